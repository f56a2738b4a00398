#!/usr/bin/env bash
# The whole test suite, as CI runs it (README's test command; .ci/run calls it through README).
#   1. release build of everything with warnings as errors (CUDA code compiled when nvcc exists),
#      the format check, and every test (GPU tests skip without a device);
#   2. an AddressSanitizer + UndefinedBehaviorSanitizer build running the CPU tests.
# Build trees: build-ci/ and build-asan/. TRIXEL_TEST_JOBS overrides the parallelism. The CUDA code is
# compiled for the oldest and the newest of the architectures the library ships by default (the same
# source for each; all six made the run nearly 30 minutes on a 2-core machine);
# TRIXEL_TEST_CUDA_ARCHITECTURES overrides them.
set -euo pipefail
cd "$(dirname "$0")/.."

jobs=${TRIXEL_TEST_JOBS:-$(nproc)}
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
# nvcc lives outside PATH in the usual toolkit install; CI must compile the CUDA code when it is there.
if ! command -v nvcc >/dev/null 2>&1 && [ -x /usr/local/cuda/bin/nvcc ]; then
  export PATH="/usr/local/cuda/bin:$PATH"
fi
cuda=AUTO
command -v nvcc >/dev/null 2>&1 && cuda=ON
cuda_args=()
[ "$cuda" = ON ] && cuda_args=(-DCMAKE_CUDA_ARCHITECTURES="${TRIXEL_TEST_CUDA_ARCHITECTURES:-75-real;90-real}")

echo "== release build (TRIXEL_CUDA=$cuda, warnings as errors)"
cmake -S . -B build-ci "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTRIXEL_WERROR=ON \
  -DTRIXEL_CUDA=$cuda "${cuda_args[@]}" -DTRIXEL_VECTORIZE=ON
cmake --build build-ci -j "$jobs"
cmake --build build-ci --target format-check

echo "== tests"
ctest --test-dir build-ci --output-on-failure --no-tests=error -j "$jobs"

echo "== AddressSanitizer + UndefinedBehaviorSanitizer build, CPU tests"
cmake -S . -B build-asan "${generator[@]}" -DCMAKE_BUILD_TYPE=Debug -DTRIXEL_WERROR=ON \
  -DTRIXEL_SANITIZE=address,undefined -DTRIXEL_CUDA=OFF -DTRIXEL_VECTORIZE=ON -DTRIXEL_BUILD_BENCHMARKS=OFF
cmake --build build-asan -j "$jobs"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp \
  ctest --test-dir build-asan --output-on-failure --no-tests=error -j "$jobs" -L cpu -LE build
echo "== all tests passed"

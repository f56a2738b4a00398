#!/usr/bin/env bash
# On a GPU machine (CUDA toolkit, CMake, a device; no image libraries needed), in one call:
# configure and build the CUDA targets, run the GPU tests (and the CPU tests of cdt), run the GPU tests
# under compute-sanitizer memcheck, run the benchmarks, and print a short table at the end.
# Logs go to $OUT (when set) or build-gpu/logs.
set -uo pipefail
cd "$(dirname "$0")/.."
logs=${OUT:-build-gpu/logs}
mkdir -p "$logs"
arch=${TRIXEL_GPU_ARCH:-90}
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
status=()

step() { # step NAME COMMAND...: runs it, logs it, records PASS/FAIL
  local name=$1; shift
  local t0 t1 r
  t0=$(date +%s%N)
  if "$@" >"$logs/$name.log" 2>&1; then r=PASS; else r=FAIL; fi
  t1=$(date +%s%N)
  status+=("| $name | $r | $(( (t1 - t0) / 1000000 )) ms |")
  echo "== $name: $r"; tail -n 25 "$logs/$name.log"
}

nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$logs/device.txt" 2>&1 || true
step configure cmake -S . -B build-gpu "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTRIXEL_CUDA=ON \
  -DCMAKE_CUDA_ARCHITECTURES="$arch" -DTRIXEL_VECTORIZE=AUTO -DTRIXEL_WERROR=ON
step build cmake --build build-gpu -j "$(nproc)"
step gpu-tests ctest --test-dir build-gpu -L gpu --output-on-failure --no-tests=error
step cdt-cpu-tests ctest --test-dir build-gpu -L cpu -LE build --output-on-failure --no-tests=error -j "$(nproc)"
if command -v compute-sanitizer >/dev/null 2>&1; then
  # Every GPU test but the million-point triangulations (minutes under the sanitizers); the mid-size
  # PSLGs with segments of TriangulateGpu.SegmentsMatchTheCpuBackend stay in.
  sanitized=--gtest_filter=-TriangulateGpu.PointsMatchTheCpuBackend
  step memcheck compute-sanitizer --tool memcheck --error-exitcode 1 build-gpu/bin/kernels_tests "$sanitized"
  step racecheck compute-sanitizer --tool racecheck --error-exitcode 1 build-gpu/bin/kernels_tests \
    "$sanitized:TriangulateGpu.ArtemOgreFilesVerify:TriangulateGpu.LatticesVerify"
fi
step bench-predicates build-gpu/bin/bench_predicates 4000000
# Phase 1 of gCD on the device (PBA and the Appendix A amendment) against the CPU executor.
step bench-voronoi build-gpu/bin/bench_voronoi_gpu --sizes 1024,2048,4096,8192 --repeat 5
# The CDT with the CPU executor alone on this machine's cores, then with the GPU backend (the digital
# Voronoi diagram on the device, the later phases on the CPU executor); the coastlines are used when
# they were carried in .carry/data (scripts/bench-cdt.sh prepares them).
coast=()
[ -s .carry/data/gshhg-high.txt ] && coast=(--coast .carry/data/gshhg-high.txt)
step bench-cdt-cpu build-gpu/bin/bench_cdt --repeat 3 --backend cpu "${coast[@]}"
step bench-cdt-gpu build-gpu/bin/bench_cdt --repeat 3 --backend gpu "${coast[@]}"
# The real vectorize pipeline, when its bundle was carried (scripts/device-bundle.sh prepares it: the
# app with libpng as its only image reader and its shared libraries): 200 Kodak-size images.
if [ -x .carry/bundle/vectorize ] && [ -d .carry/kodak ]; then
  export LD_LIBRARY_PATH=$PWD/.carry/bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  step bench-batch bash scripts/bench-batch.sh --bin .carry/bundle/vectorize --images .carry/kodak \
    -n 200 -j "1 $(nproc)" -- --backend gpu
  step bench-batch-cpu bash scripts/bench-batch.sh --bin .carry/bundle/vectorize --images .carry/kodak \
    -n 200 -j "$(nproc)" -- --backend cpu
fi

echo
echo "## device: $(cat "$logs/device.txt")"
echo "| step | result | time |"
echo "| --- | --- | --- |"
printf '%s\n' "${status[@]}"
echo
grep -h '^|' "$logs/bench-predicates.log" || true
echo
grep -h '^|' "$logs/bench-voronoi.log" || true
echo
for backend in cpu gpu; do
  grep -h -e '^backend' -e '^|' "$logs/bench-cdt-$backend.log" || true
  echo
done
for log in bench-batch bench-batch-cpu; do
  [ -f "$logs/$log.log" ] && { echo "$log:"; grep -h '^|' "$logs/$log.log" || true; }
done
grep -h -E 'tests passed|tests failed|Skipped|Not Run' "$logs/gpu-tests.log" || true
grep -q FAIL <<<"${status[*]}" && exit 1
exit 0

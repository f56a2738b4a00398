#!/usr/bin/env bash
# Prepares what the GPU machine needs to run the real vectorize pipeline, which has no OpenCV,
# OpenImageIO or Cairo there: the app built with libpng as its only image reader (TRIXEL_IMAGE_IO=png,
# so OpenImageIO's large dependency closure stays behind), its shared libraries beside it, and the
# Kodak photographs. Everything lands in .carry/ (git-ignored); pass `.carry/bundle` and `.carry/kodak`
# to the device tool's carry, and scripts/gpu-check.sh runs the batch benchmark with them.
#   scripts/device-bundle.sh [KODAK_DIR]   (default ../shared/data/images/kodak)
set -euo pipefail
cd "$(dirname "$0")/.."
kodak=${1:-../shared/data/images/kodak}
if ! command -v nvcc >/dev/null 2>&1 && [ -x /usr/local/cuda/bin/nvcc ]; then
  export PATH="/usr/local/cuda/bin:$PATH"
fi
generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
cmake -S . -B build-device "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTRIXEL_IMAGE_IO=png \
  -DCMAKE_DISABLE_FIND_PACKAGE_OpenImageIO=ON -DTRIXEL_CUDA=AUTO -DCMAKE_CUDA_ARCHITECTURES=90 \
  -DTRIXEL_BUILD_TESTS=OFF -DTRIXEL_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-device -j "$(nproc)" --target vectorize_cli
rm -rf .carry/bundle
mkdir -p .carry/bundle/lib
# The photographs are copied afresh, unless they are already what .carry/kodak holds.
same_images=0
[ -d .carry/kodak ] && [ "$(realpath "$kodak")" = "$(realpath .carry/kodak)" ] && same_images=1
if [ "$same_images" = 0 ]; then
  rm -rf .carry/kodak
  mkdir -p .carry/kodak
fi
# The binary and every shared library it needs except the C and C++ runtimes, which the GPU machine
# has in newer versions.
cp -L build-device/bin/vectorize .carry/bundle/
ldd build-device/bin/vectorize | awk '$3 ~ /^\// {print $3}' |
  grep -vE '/(libc|libm|libpthread|libdl|librt|libstdc\+\+|libgcc_s|ld-linux[^/]*)\.so' |
  while read -r lib; do cp -Ln "$lib" .carry/bundle/lib/; done
if ldd build-device/bin/vectorize | grep -q OpenImageIO; then
  echo "device-bundle: the binary links OpenImageIO; it would not fit" >&2
  exit 1
fi
[ "$same_images" = 1 ] || cp "$kodak"/*.png .carry/kodak/
du -sh .carry/bundle .carry/kodak

#!/usr/bin/env bash
# Prepares here what the GPU machine's CDT benchmark needs and lacks (scripts/gpu-check.sh cdt-cpu):
#   .carry/bin/bench_cdt_cgal    bench_cdt with CGAL, CPU executor only, linked statically (that machine
#                                has no CGAL, GMP or MPFR)
#   .carry/gshhg-high.txt.gz     the GSHHG high-resolution coastlines (scripts/bench-cdt.sh extracts
#                                them with gmt), compressed to fit the carry limit
# Then run there with: carry [".carry/bin", ".carry/gshhg-high.txt.gz"].
set -euo pipefail
cd "$(dirname "$0")/.."

as_root=()
[ "$(id -u)" -ne 0 ] && as_root=(sudo)
# gmt for the coastlines; CGAL with the static archives of GMP and MPFR for the static link.
needed=(gmt gmt-gshhg-high libcgal-dev libgmp-dev libmpfr-dev)
missing=()
for p in "${needed[@]}"; do dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  "${as_root[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi
mkdir -p .carry/data .carry/bin
coast=.carry/data/gshhg-high.txt
if [ ! -s "$coast" ]; then
  gmt coast -Rg -Dh -W -M > "$coast.tmp" && mv "$coast.tmp" "$coast"
fi
gzip -c "$coast" > .carry/gshhg-high.txt.gz.tmp && mv .carry/gshhg-high.txt.gz.tmp .carry/gshhg-high.txt.gz

generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
configured=$(cmake -S . -B build-static "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTRIXEL_CUDA=OFF \
  -DTRIXEL_VECTORIZE=OFF -DTRIXEL_WERROR=ON 2>&1) || { echo "$configured" >&2; exit 1; }
if ! grep -q 'CGAL oracle: ON' <<<"$configured"; then
  echo "device-carry: CMake did not find CGAL; the benchmark would run without it" >&2
  exit 1
fi
cmake --build build-static -j "$(nproc)" --target cdt
# CGAL's CMake configuration names the shared GMP and MPFR; a static link needs their archives.
obj=build-static/apps/bench/CMakeFiles/bench_cdt.dir/bench_cdt.cpp.o
cmake --build build-static -j "$(nproc)" --target "${obj#build-static/}" 2>/dev/null ||
  (cd build-static && ninja "${obj#build-static/}")
lib=/usr/lib/x86_64-linux-gnu
c++ -O3 -static "$obj" -o .carry/bin/bench_cdt_cgal build-static/cdt/libcdt.a \
  "$lib/libgmpxx.a" "$lib/libmpfr.a" "$lib/libgmp.a" -pthread
echo "device-carry: $(du -sh .carry/bin/bench_cdt_cgal .carry/gshhg-high.txt.gz | tr '\n' ' ')"

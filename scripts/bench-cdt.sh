#!/usr/bin/env bash
# CDT benchmark on this machine: gCD (CPU executor, all threads) against CGAL in the same run, on the
# paper's synthetic PSLGs, uniform points, and the GSHHG high-resolution coastlines.
# Installs gmt and gmt-gshhg-high (Debian) to extract the coastlines into .carry/data/ (git-ignored).
# Arguments are passed to bench_cdt (e.g. --quick, --repeat 5).
set -euo pipefail
cd "$(dirname "$0")/.."

as_root=()
[ "$(id -u)" -eq 0 ] || as_root=(sudo)
if ! command -v gmt >/dev/null 2>&1 || ! dpkg -s gmt-gshhg-high >/dev/null 2>&1; then
  "${as_root[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq gmt gmt-gshhg-high >/dev/null
fi
mkdir -p .carry/data
coast=.carry/data/gshhg-high.txt
if [ ! -s "$coast" ]; then
  gmt coast -Rg -Dh -W -M > "$coast.tmp" && mv "$coast.tmp" "$coast"
fi

generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
cmake -S . -B build-bench "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTRIXEL_BUILD_TESTS=OFF \
  -DTRIXEL_VECTORIZE=OFF -DTRIXEL_CUDA=OFF >/dev/null
cmake --build build-bench --target bench_cdt -j "$(nproc)"
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
build-bench/bin/bench_cdt --coast "$coast" "$@"

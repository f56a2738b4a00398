#!/usr/bin/env bash
# Installs the build and test dependencies on Debian 12 from Debian's packages (as root, or through
# sudo). Safe to run again: apt-get skips what is already installed.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git   # toolchain
  libopencv-dev libopenimageio-dev libcairo2-dev     # vectorize: edges, image I/O, overlays
  libpng-dev libdeflate-dev                          # vectorize: PNG reading
  libmimalloc-dev                                    # vectorize app: the allocator
  libcli11-dev                                       # command-line parsing
  libgtest-dev libcgal-dev                           # tests; CGAL is a test and benchmark oracle only
  clang-format                                       # the format check of the test suite
  chromium chromium-driver librsvg2-bin              # tests: the inspector page, SVG overlay renders
)

if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "install-deps: run as root or install sudo" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
"${as_root[@]}" apt-get update -qq
"${as_root[@]}" apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
echo "install-deps: ${#packages[@]} packages present"

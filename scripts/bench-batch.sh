#!/usr/bin/env bash
# Batch throughput of `vectorize IN... -o OUTDIR`: N copies of a set of images (default 200 copies
# cycled from the Kodak photographs), converted with each worker count given, timed end to end, with
# the peak resident memory of the whole batch process. Prints a Markdown table.
#   scripts/bench-batch.sh [--bin build-ci/bin/vectorize] [--images ../shared/data/images/kodak]
#                          [-n 200] [-j "1 2"] [-- extra vectorize options]
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build-ci/bin/vectorize
images=../shared/data/images/kodak
count=200
workers="1 2"
extra=()
while [ $# -gt 0 ]; do
  case $1 in
    --bin) bin=$2; shift 2 ;;
    --images) images=$2; shift 2 ;;
    -n) count=$2; shift 2 ;;
    -j) workers=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    *) echo "bench-batch: unknown argument $1" >&2; exit 2 ;;
  esac
done
[ -x "$bin" ] || { echo "bench-batch: no vectorize binary at $bin (build it first)" >&2; exit 1; }
mapfile -t sources < <(find "$images" -maxdepth 1 -name '*.png' | sort)
[ ${#sources[@]} -gt 0 ] || { echo "bench-batch: no PNG images in $images" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/in"
for ((k = 0; k < count; ++k)); do
  cp "${sources[k % ${#sources[@]}]}" "$work/in/$(printf 'img%04d.png' "$k")"
done

# Peak memory of the batch process through getrusage of the child (no /usr/bin/time needed).
measure() {
  if ! command -v python3 >/dev/null 2>&1; then
    local t0 t1 rc=0
    t0=$(date +%s%N)
    "$@" || rc=$?
    t1=$(date +%s%N)
    echo "$rc $(awk -v d=$((t1 - t0)) 'BEGIN {printf "%.3f", d / 1e9}') n/a"
    return
  fi
  python3 - "$@" <<'PY'
import resource, subprocess, sys, time
t0 = time.monotonic()
rc = subprocess.run(sys.argv[1:]).returncode
t1 = time.monotonic()
peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(f"{rc} {t1 - t0:.3f} {peak_kib / 1024:.0f}")
PY
}

echo "| workers (-j) | images | wall s | images/s | speed-up vs first | peak RSS MiB | exit |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
first=""
for j in $workers; do
  rm -rf "$work/out"
  read -r rc secs peak < <(measure "$bin" "$work/in" -o "$work/out" -j "$j" -q "${extra[@]}")
  rate=$(awk -v n="$count" -v s="$secs" 'BEGIN {printf "%.2f", n / s}')
  [ -z "$first" ] && first=$rate
  speedup=$(awk -v a="$rate" -v b="$first" 'BEGIN {printf "%.2fx", a / b}')
  written=$(find "$work/out" -name '*.svg' | wc -l)
  echo "| $j | $written/$count | $secs | $rate | $speedup | $peak | $rc |"
done

#!/usr/bin/env bash
# Batch throughput of two `vectorize` binaries in one call, their rounds alternating: the GPU machine's
# hosts differ by up to 25% from call to call, so only numbers from one call are compared. N copies of
# the photographs are converted by each binary in turn, ROUNDS times; each row gives the whole
# process's images per second and, from the batch's report, when the first image whose CDT was made
# on the device was done (seconds after the batch began; "-" for none) and the mean of the CDT stage
# (which includes the wait for a shared call), ms.
#   scripts/batch-compare.sh BASE_BIN NEW_BIN [--images DIR] [-n "200 1000"] [--rounds 3]
#                            [-- vectorize options]   (default options: --backend gpu)
# On the GPU machine the binaries come from scripts/device-bundle.sh (the base one built from another
# tree the same way); put the bundle's lib/ on LD_LIBRARY_PATH.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { sed -n '2,11p' "$0" >&2; exit 2; }
base=$1
new=$2
shift 2
images=.carry/kodak
counts="200 1000"
rounds=3
options=(--backend gpu)
while [ $# -gt 0 ]; do
  case $1 in
    --images) images=$2; shift 2 ;;
    -n) counts=$2; shift 2 ;;
    --rounds) rounds=$2; shift 2 ;;
    --) shift; options=("$@"); break ;;
    *) echo "batch-compare: unknown argument $1" >&2; exit 2 ;;
  esac
done
for bin in "$base" "$new"; do
  [ -x "$bin" ] || { echo "batch-compare: no binary at $bin" >&2; exit 1; }
done
command -v python3 >/dev/null 2>&1 || { echo "batch-compare: needs python3 for the reports" >&2; exit 1; }
mapfile -t sources < <(find "$images" -maxdepth 1 -name '*.png' | sort)
[ ${#sources[@]} -gt 0 ] || { echo "batch-compare: no PNG images in $images" >&2; exit 1; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# One batch: prints "IMAGES_PER_S FIRST_ON_DEVICE CDT_MEAN", or "failed".
one() {
  local bin=$1 n=$2 t0 t1
  rm -rf "$work/out"
  t0=$(date +%s%N)
  if ! "$bin" "$work/in$n" -o "$work/out" -q --report "$work/report.json" "${options[@]}" >/dev/null 2>&1; then
    echo failed
    return
  fi
  t1=$(date +%s%N)
  python3 - "$work/report.json" "$n" "$(( (t1 - t0) / 1000 ))" <<'PY'
import json, sys
report = json.load(open(sys.argv[1]))
n, micros = int(sys.argv[2]), int(sys.argv[3])
done = [i for i in report["images"] if i["status"] == "converted"]
device = [i["started"] + i["seconds"] for i in done if i["stats"]["cdt_backend"].startswith("gpu")]
cdt = sum(i["stats"]["stages_ms"].get("cdt", 0.0) for i in done) / max(1, len(done))
first = f"{min(device):.2f}" if device else "-"
print(f"{n * 1e6 / micros:.1f} {first} {cdt:.0f}")
PY
}

echo "| images | round | base images/s | new images/s | base first on device, s | new | base CDT stage, ms | new |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
for n in $counts; do
  mkdir -p "$work/in$n"
  for ((k = 0; k < n; ++k)); do
    cp "${sources[k % ${#sources[@]}]}" "$work/in$n/$(printf 'img%05d.png' "$k")"
  done
  for ((r = 1; r <= rounds; ++r)); do
    read -r b_rate b_first b_cdt <<<"$(one "$base" "$n")"
    read -r n_rate n_first n_cdt <<<"$(one "$new" "$n")"
    echo "| $n | $r | $b_rate | $n_rate | ${b_first:--} | ${n_first:--} | ${b_cdt:--} | ${n_cdt:--} |"
  done
  rm -rf "$work/in$n"
done

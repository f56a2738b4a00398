#!/usr/bin/env bash
# Vectorizer quality and speed against peers, on the same images.
#
# For each image set and each tool: convert every image to SVG (one image at a time, timed), render
# the SVG with rsvg-convert at the input's size over white and over magenta, and compare with the
# input (build target compare_images: PSNR and SSIM over white, uncovered pixels). Prints a Markdown
# table per set and writes per-image CSV rows.
#
# usage: scripts/quality.sh [options]
#   --sets LIST        comma-separated: kodak, tango (default: kodak,tango)
#   --tools LIST       comma-separated: ours, vtracer, imagetracer, potrace (default: all four)
#   --ours-args ARGS   extra arguments for ours, e.g. "--preset photo --detail 6". Repeat the option to
#                      run ours in several configurations (one table row each); "" is the defaults.
#   --kodak DIR        folder of the Kodak PNGs (default /work/shared/data/images/kodak)
#   --tango-dir DIR    Tango's scalable/ folder (default /usr/share/icons/Tango/scalable)
#   --tango-count N    how many Tango icons (default 16)
#   --tango-size PX    size of the rendered icons (default 256)
#   --potrace-colours N  palette size of the layered potrace peer (default 16)
#   --repeat R         convert each image R times and keep the median time (default 1)
#   --out DIR          output folder (default out/quality)
#   --build DIR        build folder of vectorize and compare_images (default $TRIXEL_BUILD_DIR, else
#                      build-quality); configured (-DTRIXEL_CUDA=OFF) if it does not exist yet
#   --no-build         use the binaries in the build folder as they are
#   --no-install       do not install missing packages; fail instead
#
# Peers: VTracer through @neplex/vectorizer with its Poster preset (scripts/vtracer.mjs),
# imagetracerjs with 16 colours (scripts/imagetracer.mjs), potrace in per-colour layers
# (scripts/potrace.mjs). npm packages go to .cache/npm (git-ignored).
#
# Output under --out: images/tango/*.png (the rendered icons), SET/TOOL/*.svg and *.white.png /
# *.magenta.png, SET/TOOL/results.csv (one row per image), SET.md (the table and the versions).
#
# Wall time is the whole conversion command per image (process start included, Node's for the peers),
# because that is what a user waits for. Images are taken one at a time and every tool converts each
# image in turn, so a drifting load on a shared machine weighs on all tools alike; the table gives
# each tool's time over VTracer's when VTracer runs.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
sets=kodak,tango
tools=ours,vtracer,imagetracer,potrace
ours_variants=()
kodak_dir=/work/shared/data/images/kodak
tango_dir=/usr/share/icons/Tango/scalable
tango_count=16
tango_size=256
potrace_colours=16
repeat=1
out=$repo/out/quality
build=${TRIXEL_BUILD_DIR:-$repo/build-quality}
do_build=1
do_install=1

die() {
  echo "quality.sh: $*" >&2
  exit 1
}

while (($#)); do
  case $1 in
  --sets) sets=${2:?--sets needs a value}; shift 2 ;;
  --tools) tools=${2:?--tools needs a value}; shift 2 ;;
  --ours-args) (($# >= 2)) || die "--ours-args needs a value"; ours_variants+=("$2"); shift 2 ;;
  --kodak) kodak_dir=${2:?--kodak needs a folder}; shift 2 ;;
  --tango-dir) tango_dir=${2:?--tango-dir needs a folder}; shift 2 ;;
  --tango-count) tango_count=${2:?--tango-count needs a number}; shift 2 ;;
  --tango-size) tango_size=${2:?--tango-size needs a number}; shift 2 ;;
  --potrace-colours | --potrace-colors) potrace_colours=${2:?needs a number}; shift 2 ;;
  --repeat) repeat=${2:?--repeat needs a number}; shift 2 ;;
  --out) out=${2:?--out needs a folder}; shift 2 ;;
  --build) build=${2:?--build needs a folder}; shift 2 ;;
  --no-build) do_build=0; shift ;;
  --no-install) do_install=0; shift ;;
  -h | --help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
  *) die "unknown option $1 (see --help)" ;;
  esac
done
((${#ours_variants[@]})) || ours_variants=("")
for n in "$tango_count" "$tango_size" "$potrace_colours" "$repeat"; do
  [[ $n =~ ^[1-9][0-9]*$ ]] || die "'$n' is not a positive whole number"
done
IFS=, read -r -a set_list <<<"$sets"
IFS=, read -r -a tool_list <<<"$tools"
for s in "${set_list[@]}"; do [[ $s == kodak || $s == tango ]] || die "unknown set '$s' (kodak, tango)"; done
for t in "${tool_list[@]}"; do
  [[ $t =~ ^(ours|vtracer|imagetracer|potrace)$ ]] || die "unknown tool '$t' (ours, vtracer, imagetracer, potrace)"
done
has() { [[ ,$2, == *,$1,* ]]; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
build=$(mkdir -p "$build" && cd "$build" && pwd)

# --- dependencies -------------------------------------------------------------------------------
apt_updated=0
apt_install() { # apt_install PACKAGE...
  ((do_install)) || die "missing $* (run without --no-install, or install it)"
  local sudo=()
  ((EUID == 0)) || sudo=(sudo)
  if ((!apt_updated)); then
    echo "quality.sh: apt-get update" >&2
    "${sudo[@]}" apt-get update -qq
    apt_updated=1
  fi
  echo "quality.sh: apt-get install $*" >&2
  "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}
command -v rsvg-convert >/dev/null || apt_install librsvg2-bin
if has potrace "$tools"; then command -v potrace >/dev/null || apt_install potrace; fi
if has tango "$sets" && [[ ! -d $tango_dir ]]; then
  apt_install tango-icon-theme
  [[ -d $tango_dir ]] || die "$tango_dir: not there after installing tango-icon-theme"
fi

npm_prefix=$repo/.cache/npm
export TRIXEL_NPM_PREFIX=$npm_prefix
npm_wanted=()
has vtracer "$tools" && npm_wanted+=(@neplex/vectorizer)
has imagetracer "$tools" && npm_wanted+=(imagetracerjs pngjs)
has potrace "$tools" && npm_wanted+=(pngjs)
npm_missing=()
for p in "${npm_wanted[@]}"; do
  [[ -f $npm_prefix/node_modules/$p/package.json ]] || npm_missing+=("$p")
done
if ((${#npm_wanted[@]})); then
  if ! command -v node >/dev/null || ! command -v npm >/dev/null; then apt_install nodejs npm; fi
fi
if ((${#npm_missing[@]})); then
  ((do_install)) || die "missing npm packages ${npm_missing[*]} in $npm_prefix"
  echo "quality.sh: npm install --prefix $npm_prefix ${npm_missing[*]}" >&2
  mkdir -p "$npm_prefix"
  npm install --prefix "$npm_prefix" --no-audit --no-fund --silent "${npm_missing[@]}" >&2
fi

# --- build ---------------------------------------------------------------------------------------
vectorize_bin=$build/bin/vectorize
compare_bin=$build/bin/compare_images
if ((do_build)); then
  if [[ ! -f $build/CMakeCache.txt ]]; then
    cmake -S "$repo" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTRIXEL_CUDA=OFF >&2
  fi
  targets=(compare_images)
  has ours "$tools" && targets+=(vectorize_cli)
  cmake --build "$build" -j2 --target "${targets[@]}" >&2
fi
[[ -x $compare_bin ]] || die "$compare_bin: not built (needs the vectorize dependencies: OpenCV)"
if has ours "$tools"; then [[ -x $vectorize_bin ]] || die "$vectorize_bin: not built"; fi

# --- images --------------------------------------------------------------------------------------
png_size() { # png_size FILE -> "W H" from the PNG header
  local sig
  sig=$(od -An -tx1 -N8 "$1" | tr -d ' \n')
  [[ $sig == 89504e470d0a1a0a ]] || die "$1: not a PNG file"
  od -An -tu1 -j16 -N8 "$1" | awk '{ print $1*16777216+$2*65536+$3*256+$4, $5*16777216+$6*65536+$7*256+$8 }'
}

# The Tango list: regular .svg files under scalable/ (symlinks are aliases of these), sorted by path,
# identical files kept once, the first N. Rendered once to RGBA PNG.
prepare_tango() {
  local dest=$out/images/tango list=$out/images/tango.list
  mkdir -p "$dest"
  : >"$list.tmp"
  local seen=" " n=0 rel hash name
  while IFS= read -r rel; do
    hash=$(sha256sum "$tango_dir/$rel" | cut -c1-64)
    [[ $seen == *" $hash "* ]] && continue
    seen+="$hash "
    name=${rel%.svg}
    name=${name//\//-}
    echo "$rel" >>"$list.tmp"
    [[ -s $dest/$name.png ]] ||
      rsvg-convert -w "$tango_size" -h "$tango_size" -f png -o "$dest/$name.png" "$tango_dir/$rel" ||
      die "$tango_dir/$rel: rsvg-convert failed"
    n=$((n + 1))
    ((n < tango_count)) || break
  done < <(cd "$tango_dir" && find . -type f -name '*.svg' | sed 's|^\./||' | LC_ALL=C sort)
  ((n == tango_count)) || die "$tango_dir: only $n distinct icons, $tango_count wanted"
  mv "$list.tmp" "$list"
}

images_of() { # images_of SET -> one PNG path per line
  case $1 in
  kodak)
    [[ -d $kodak_dir ]] || die "$kodak_dir: no such folder (use --kodak DIR)"
    local found
    found=$(find "$kodak_dir" -maxdepth 1 -type f -iname '*.png' | LC_ALL=C sort)
    [[ -n $found ]] || die "$kodak_dir: no PNG images"
    echo "$found"
    ;;
  tango)
    local rel name
    while IFS= read -r rel; do
      name=${rel%.svg}
      echo "$out/images/tango/${name//\//-}.png"
    done <"$out/images/tango.list"
    ;;
  esac
}

# --- tools ---------------------------------------------------------------------------------------
convert_with() { # convert_with TOOL OURS_ARGS IN OUT
  case $1 in
  ours)
    local extra=()
    [[ -n $2 ]] && read -r -a extra <<<"$2"
    "$vectorize_bin" "$3" "$4" -q "${extra[@]}"
    ;;
  vtracer) node "$repo/scripts/vtracer.mjs" "$3" "$4" ;;
  imagetracer) node "$repo/scripts/imagetracer.mjs" "$3" "$4" ;;
  potrace) node "$repo/scripts/potrace.mjs" "$3" "$4" "$potrace_colours" ;;
  esac
}

now() { date +%s.%N; }

versions() {
  echo "- machine: $(uname -srm), $(nproc) cores, $(. /etc/os-release && echo "$PRETTY_NAME")"
  local rev
  if rev=$(git -C "$repo" rev-parse --short HEAD 2>/dev/null); then
    git -C "$repo" diff --quiet HEAD -- vectorize apps/vectorize cdt kernels || rev+=" with uncommitted changes"
  else
    rev="$repo, not a git checkout"
  fi
  echo "- ours: $rev, build $build"
  has vtracer "$tools" && echo "- @neplex/vectorizer $(node -p "require('$npm_prefix/node_modules/@neplex/vectorizer/package.json').version")"
  has imagetracer "$tools" && echo "- imagetracerjs $(node -p "require('$npm_prefix/node_modules/imagetracerjs/package.json').version")"
  has potrace "$tools" && echo "- $(potrace --version | head -1)"
  echo "- $(rsvg-convert --version)"
}

csv_header="set,tool,image,status,seconds,svg_bytes,paths,$("$compare_bin" --csv-header)"

run_set() { # run_set SET
  local set=$1
  [[ $set == tango ]] && prepare_tango
  local -a images
  local listed
  listed=$(images_of "$set")
  mapfile -t images <<<"$listed"
  # The runs: one per tool, ours once per --ours-args.
  local run_tool=() run_variant=() run_label=() run_dir=() tool variant label slug
  for tool in "${tool_list[@]}"; do
    local variants=("")
    [[ $tool == ours ]] && variants=("${ours_variants[@]}")
    for variant in "${variants[@]}"; do
      label=$tool
      [[ -n $variant ]] && label="$tool ${variant//,/;}"
      slug=$(echo "$label" | tr -c 'A-Za-z0-9.=_\n' '-' | tr -s '-')
      run_tool+=("$tool")
      run_variant+=("$variant")
      run_label+=("$label")
      run_dir+=("$out/$set/$slug")
      mkdir -p "$out/$set/$slug"
      echo "$csv_header" >"$out/$set/$slug/results.csv"
    done
  done

  # Image by image, every run in turn (and every repeat in turn), so that the load of this shared
  # machine drifting over time weighs on all tools alike and the time ratios stay fair.
  local rows=() i k r img name svg size w h t0 t1 secs metrics dir
  local -A times status
  for ((i = 0; i < ${#images[@]}; ++i)); do
    img=${images[i]}
    name=$(basename "${img%.*}")
    size=$(png_size "$img")
    read -r w h <<<"$size"
    echo "quality.sh: $set: [$((i + 1))/${#images[@]}] $name" >&2
    times=()
    status=()
    for ((r = 0; r < repeat; ++r)); do
      for k in "${!run_tool[@]}"; do
        [[ ${status[$k]:-ok} == ok ]] || continue
        dir=${run_dir[k]}
        svg=$dir/$name.svg
        rm -f "$svg"
        t0=$(now)
        if ! convert_with "${run_tool[k]}" "${run_variant[k]}" "$img" "$svg" 2>"$dir/$name.log"; then
          status[$k]=failed
          echo "quality.sh: $set: ${run_label[k]}: $img failed: $(head -n 1 "$dir/$name.log")" >&2
          continue
        fi
        t1=$(now)
        times[$k]+="$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.4f", b - a }') "
      done
    done
    for k in "${!run_tool[@]}"; do
      dir=${run_dir[k]}
      svg=$dir/$name.svg
      metrics=,,,,,,,,
      if [[ ${status[$k]:-ok} == ok ]]; then
        secs=$(printf '%s\n' ${times[$k]} | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }')
        if rsvg-convert -w "$w" -h "$h" --background-color white -o "$dir/$name.white.png" "$svg" &&
          rsvg-convert -w "$w" -h "$h" --background-color magenta -o "$dir/$name.magenta.png" "$svg" &&
          metrics=$("$compare_bin" --csv "$img" "$dir/$name.white.png" "$dir/$name.magenta.png"); then
          rows+=("$set,${run_label[k]},$name,ok,$secs,$(stat -c %s "$svg"),$(grep -o '<path' "$svg" | wc -l),$metrics")
        else
          echo "quality.sh: $set: ${run_label[k]}: $svg: render or comparison failed" >&2
          rows+=("$set,${run_label[k]},$name,render-failed,,,,,,,,,,,,,")
        fi
      else
        rows+=("$set,${run_label[k]},$name,failed,,,,,,,,,,,,,")
      fi
      echo "${rows[-1]}" >>"$dir/results.csv"
    done
  done

  # One Markdown row per tool: means over the images it converted; failures counted.
  {
    echo "### $set (${#images[@]} images)"
    echo
    versions
    echo
    printf '%s\n' "${rows[@]}" | awk -F, '
      { key = $2
        if (!(key in n_all)) { order[++k] = key }
        n_all[key]++
        if ($4 != "ok") { failed[key]++; next }
        n[key]++; t[key] += $5; bytes[key] += $6; paths[key] += $7
        if ($10 == "inf") { inf[key]++ } else { psnr[key] += $10; n_psnr[key]++ }
        ssim[key] += $11
        pct = $13 > 0 ? 100 * $14 / $13 : 0
        unc[key] += pct; if (pct > uncmax[key]) uncmax[key] = pct
        holes[key] += $13 > 0 ? 100 * $15 / $13 : 0
        solid = $13 - $16 > 0 ? 100 * $17 / ($13 - $16) : 0
        if (solid > solidmax[key]) solidmax[key] = solid
        if (!($3 in translucent)) { translucent[$3] = $13 > 0 ? 100 * $16 / $13 : 0; n_tr++; sum_tr += translucent[$3] }
      }
      END {
        ref = ("vtracer" in n) ? t["vtracer"] / n["vtracer"] : ""
        printf "| tool | images | PSNR (dB) | SSIM | shape uncovered %% mean | shape uncovered %% max | opaque uncovered %% max | holes %% mean | SVG bytes | paths | time (s) |%s\n", ref != "" ? " time / VTracer |" : ""
        printf "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|%s\n", ref != "" ? "---:|" : ""
        for (i = 1; i <= k; ++i) {
          key = order[i]
          if (n[key] == 0) { printf "| %s | 0 of %d | | | | | | | | | |%s\n", key, n_all[key], ref != "" ? " |" : ""; continue }
          imgs = n[key] == n_all[key] ? n[key] : n[key] " of " n_all[key]
          p = n_psnr[key] > 0 ? sprintf("%.2f", psnr[key] / n_psnr[key]) : "inf"
          if (inf[key] > 0 && n_psnr[key] > 0) p = p " (" inf[key] " inf)"
          mt = t[key] / n[key]
          printf "| %s | %s | %s | %.3f | %.2f | %.2f | %.2f | %.3f | %.0f | %.0f | %.3f |", key, imgs, p, ssim[key] / n[key], unc[key] / n[key], uncmax[key], solidmax[key], holes[key] / n[key], bytes[key] / n[key], paths[key] / n[key], mt
          if (ref != "") printf " %.2f |", mt / ref
          printf "\n"
        }
        if (n_tr > 0 && sum_tr > 0)
          printf "\nOf the inputs\x27 shape pixels, %.2f%% (mean) are translucent (alpha < 1): a faithful render lets the background show there too.\n", sum_tr / n_tr
      }'
    echo
    echo "Means over the images. PSNR and SSIM (Gaussian 11x11, mean of R, G, B): the input over white" \
      "against the SVG rendered by rsvg-convert over white. Shape uncovered: input pixels with alpha" \
      ">= 1/2 (every pixel of an image without alpha) where the renders over white and over magenta" \
      "differ at all (the background shows through), translucent ones included; opaque uncovered: the" \
      "same among the fully opaque pixels (alpha 1), where a faithful render lets no background" \
      "through, worst image; holes: shape pixels where the renders differ by more than half. Time:" \
      "wall time of the conversion command per image$(
        ((repeat > 1)) && echo " (median of $repeat runs)")."
  } | tee "$out/$set.md"
  echo
}

for s in "${set_list[@]}"; do run_set "$s"; done
echo "quality.sh: per-image rows in $out/<set>/<tool>/results.csv" >&2

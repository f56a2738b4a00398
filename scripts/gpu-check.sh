#!/usr/bin/env bash
# On a GPU machine (CUDA toolkit, CMake, a device; no image libraries needed), in one call:
# configure and build the CUDA targets, run the GPU tests (and the CPU tests of cdt), run the GPU tests
# under compute-sanitizer memcheck and racecheck, run the benchmarks, and print a short table at the end.
# Logs go to $OUT (when set) or build-gpu/logs.
#
# usage: scripts/gpu-check.sh [PART...]   (default: all of them, in this order)
#   tests      build, GPU tests, CPU tests of cdt, compute-sanitizer memcheck and racecheck (on the
#              mid-size PSLGs with segments; TRIXEL_SANITIZE=all: on every GPU test but the largest,
#              which takes several calls' time)
#   micro      predicates and digital Voronoi benchmarks
#   cdt-gpu    the CDT benchmark matrix with the GPU backend (median of 3)
#   cdt-cpu    the same inputs on the CPU executor and CGAL (one run each: they take seconds per input);
#              with .carry/bin/bench_cdt_cgal (scripts/device-carry.sh builds it here, statically
#              linked with CGAL, which that machine lacks), else the device build without CGAL
#   batch      the vectorize batch benchmark, when its bundle was carried (scripts/device-bundle.sh),
#              and the same SVGs from the CPU and the GPU backend
#   many       cdt::triangulate_many against one call per input (bench_cdt --together N), on the
#              photographs' PSLGs in .carry/pslg/*.poly when carried (the `pslg.poly` of `vectorize
#              --debug` folders), with the GPU backend and the CPU executor
#   batch-compare (not in the default list) the batch benchmark of an earlier tree's bundle
#              (.carry/base/vectorize, built by scripts/device-bundle.sh from that tree) against this
#              one's (.carry/bundle/vectorize), rounds alternating: scripts/batch-compare.sh
#   trace      (not in the default list) the step trace (TRIXEL_CDT_TRACE=1) of the third of three runs
#              (warm) of 10M points + 1M segments and of the coastlines: the host's steps between the
#              device's phases, which the device profile does not see, and the split's sizes
#   compare    (not in the default list) an earlier tree against this one on the same machine, whose
#              timings vary 10-25% between calls: TRIXEL_BASE (default .carry/base) holds a copy of it
#              (`git archive REV | tar -x -C .carry/base`, carried); both bench_cdt builds run in turn,
#              TRIXEL_ROUNDS times (default 3), on 10M points + 1M segments and the coastlines;
#              TRIXEL_COMPARE_SIZES (POINTS:SEGMENTS pairs, default 10000000:1000000),
#              TRIXEL_COMPARE_CASE (default uniform; "" for uniform and Gaussian) and
#              TRIXEL_COMPARE_LATTICE (K, default 0: none) choose the synthetic inputs
#   batch-stall (not in the default list) the carried vectorize bundle's batch of the Kodak images with
#              the GPU backend, one process after another (TRIXEL_STALL_RUNS, TRIXEL_STALL_SECONDS as
#              below), each given 60 s: its worker threads use the device and end with the batch
#   stall      (not in the default list) 10M points + 1M segments with the GPU backend in one process
#              after another (at most TRIXEL_STALL_RUNS, default 40, within TRIXEL_STALL_SECONDS, default
#              300; TRIXEL_STALL_REPEAT runs each, default 3), each cut after 30 s: now and then one
#              does not end; bench_cdt --limit then prints its threads' states and stacks, turned into
#              functions and source lines here, and the step fails
# The CDT matrix (TRIXEL_CDT_SIZES, POINTS:SEGMENTS pairs) is the paper's synthetic design, uniform and
# Gaussian, plus a 4096 x 4096 lattice with random segments (TRIXEL_CDT_LATTICE=K for K x K, 0 for
# none) and the GSHHG coastlines when carried (.carry/gshhg-high.txt.gz). Generated inputs are cached in build-gpu/inputs for the later parts.
# TRIXEL_CDT_LIMIT (seconds, default 120) ends an input's runs that take longer.
set -uo pipefail
cd "$(dirname "$0")/.."
parts=("$@")
[ ${#parts[@]} -eq 0 ] && parts=(tests micro cdt-gpu cdt-cpu batch many)
want() { [[ " ${parts[*]} " == *" $1 "* ]]; }
logs=${OUT:-build-gpu/logs}
mkdir -p "$logs"
rm -f "$logs/0-all-steps.log"
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
  echo "== $name: $r ($(( (t1 - t0) / 1000000 )) ms)"; tail -n 25 "$logs/$name.log"
  # Every step's log in one file as well, first in name order: a caller that fetches only a few files
  # of the folder (the GPU machine's tool returns eight) still gets them all, also from a run cut short.
  { echo "== $name: $r"; cat "$logs/$name.log"; } >> "$logs/0-all-steps.log"
}

nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader > "$logs/device.txt" 2>&1 || true
# The stall part's stacks name source lines: host code with line tables then (the same machine code).
lines=()
want stall && lines=(-DCMAKE_CXX_FLAGS=-g1 -DCMAKE_CUDA_FLAGS=-Xcompiler=-g1)
step configure cmake -S . -B build-gpu "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTRIXEL_CUDA=ON \
  -DCMAKE_CUDA_ARCHITECTURES="$arch" -DTRIXEL_VECTORIZE=AUTO -DTRIXEL_WERROR=ON "${lines[@]}"
if want tests; then
  step build cmake --build build-gpu -j "$(nproc)"
  step gpu-tests ctest --test-dir build-gpu -L gpu --output-on-failure --no-tests=error
  step cdt-cpu-tests ctest --test-dir build-gpu -L cpu -LE build --output-on-failure --no-tests=error -j "$(nproc)"
  if command -v compute-sanitizer >/dev/null 2>&1; then
    if [ "${TRIXEL_SANITIZE:-mid}" = all ]; then
      # Every GPU test but the million-point triangulations (minutes under the sanitizers). Not under
      # racecheck: the tests whose cudaDeviceReset ends the process there (memcheck runs them), and the
      # lattices and files, which add minutes and no kernel of their own.
      memchecked=--gtest_filter=-TriangulateGpu.PointsMatchTheCpuBackend
      racechecked="$memchecked:TriangulateGpu.ArtemOgreFilesMatchTheCpuBackend:TriangulateGpu.LatticesMatchTheCpuBackend:TriangulateGpu.StoppedDeviceStartsAgain:TriangulateGpu.PinnedResultsAreReusedAndOutliveTheDevice"
    else
      # The default (fits one call with the benchmarks): mid-size PSLGs with segments through the whole
      # GPU backend (100K points + 10K segments; crossing segments, split on the host), the constraints
      # beside the host's split (with every piece, and without the suspects), the screen, and the output
      # started while the constraints run (800K points: the smallest mesh that starts it), and the
      # pieces beside the split made on the device (checked against the host's with TRIXEL_CUDA_SYNC).
      memchecked=--gtest_filter=TriangulateGpu.SegmentsMatchTheCpuBackend:TriangulateGpu.CrossingSegmentsMatchTheCpuBackend:TriangulateGpu.PiecesThroughPointsAndCrossingsBesideTheSplitMatchTheCpuBackend:MeshGpu.ConstraintsBesideTheHostKeepOrUndo:MeshGpu.ConstraintsBesideTheSplitWithoutTheSuspects:MeshGpu.ScreenMatchesTheCpuExecutor:MeshGpu.OutputStartedEarlyIsTheOutputMadeAtTheEnd
      # Not the pieces' test under racecheck, which takes most of the call's time already: the kernels it
      # adds (the pieces' mesh ids, their comparison) write one element a thread.
      racechecked=${memchecked/TriangulateGpu.PiecesThroughPointsAndCrossingsBesideTheSplitMatchTheCpuBackend:/}
    fi
    # TRIXEL_CUDA_SYNC=1: each launch checked where it ran, and released device blocks freed at once
    # (not kept for reuse), so a use of a released buffer is seen.
    sanitize() { # sanitize TOOL FILTER [VAR=VALUE...]: fails on a finding, and when no test ran
      local out r
      out=$(env "${@:3}" compute-sanitizer --tool "$1" --error-exitcode 1 build-gpu/bin/kernels_tests "$2" 2>&1)
      r=$?
      echo "$out"
      [ $r -eq 0 ] && grep -Eq '^\[  PASSED  \] [1-9][0-9]* tests?' <<<"$out"
    }
    step memcheck sanitize memcheck "$memchecked" TRIXEL_CUDA_SYNC=1
    step racecheck sanitize racecheck "$racechecked"
  fi
else
  step build cmake --build build-gpu -j "$(nproc)" --target bench_cdt bench_predicates bench_voronoi_gpu
fi
if want micro; then
  step bench-predicates build-gpu/bin/bench_predicates 4000000
  # Phase 1 of gCD on the device (PBA and the Appendix A amendment) against the CPU executor.
  step bench-voronoi build-gpu/bin/bench_voronoi_gpu --sizes 1024,2048,4096,8192 --repeat 5
fi
# The CDT matrix: the GPU backend, then the CPU executor and CGAL on the same inputs.
sizes=${TRIXEL_CDT_SIZES:-1000000:0,1000000:100000,10000000:0,10000000:100000,10000000:1000000}
mkdir -p build-gpu/inputs
lattice=${TRIXEL_CDT_LATTICE:-4096} # 0 leaves the lattice out
# Each input's runs end after TRIXEL_CDT_LIMIT seconds at most (default 120: the slowest input, the
# lattice on the CPU executor and CGAL, verified, takes under a minute on the H200 machine); a row then
# says TIMED OUT, with its threads' states on stderr, and the script still fits one 10-minute call.
matrix=(--sizes "$sizes" --cache build-gpu/inputs --limit "${TRIXEL_CDT_LIMIT:-120}")
[ "$lattice" != 0 ] && matrix+=(--lattice "$lattice")
if [ -s .carry/gshhg-high.txt.gz ]; then
  [ -s build-gpu/inputs/gshhg-high.txt ] || gunzip -c .carry/gshhg-high.txt.gz > build-gpu/inputs/gshhg-high.txt
  matrix+=(--coast build-gpu/inputs/gshhg-high.txt)
fi
want cdt-gpu && step bench-cdt-gpu build-gpu/bin/bench_cdt --repeat 3 --backend gpu "${matrix[@]}"
if want cdt-cpu; then
  cpu_bench=build-gpu/bin/bench_cdt
  [ -x .carry/bin/bench_cdt_cgal ] && cpu_bench=.carry/bin/bench_cdt_cgal
  step bench-cdt-cpu "$cpu_bench" --repeat 1 --backend cpu "${matrix[@]}"
fi
# The real vectorize pipeline, when its bundle was carried (scripts/device-bundle.sh prepares it: the
# app with libpng as its only image reader and its shared libraries): 200 Kodak-size images.
if want batch && [ -x .carry/bundle/vectorize ] && [ -d .carry/kodak ]; then
  export LD_LIBRARY_PATH=$PWD/.carry/bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  step bench-batch bash scripts/bench-batch.sh --bin .carry/bundle/vectorize --images .carry/kodak \
    -n 200 -j "1 $(nproc)" -- --backend gpu
  step bench-batch-cpu bash scripts/bench-batch.sh --bin .carry/bundle/vectorize --images .carry/kodak \
    -n 200 -j "$(nproc)" -- --backend cpu
  step bench-batch-own bash scripts/bench-batch.sh --bin .carry/bundle/vectorize --images .carry/kodak \
    -n 200 -j "$(nproc)" -- --backend gpu --batch-cdt own
  # The CDT is unique and the pipeline puts it in canonical order: both backends write the same bytes.
  same_svgs() {
    local dir
    dir=$(mktemp -d)
    .carry/bundle/vectorize .carry/kodak -o "$dir/cpu" -q --backend cpu &&
      .carry/bundle/vectorize .carry/kodak -o "$dir/gpu" -q --backend gpu &&
      diff -r "$dir/cpu" "$dir/gpu" && echo "the $(ls "$dir/cpu" | wc -l) SVGs are the same from both backends"
    local r=$?
    rm -rf "$dir"
    return $r
  }
  step svgs-cpu-gpu same_svgs
fi
if want batch-compare && [ -x .carry/base/vectorize ] && [ -x .carry/bundle/vectorize ]; then
  export LD_LIBRARY_PATH=$PWD/.carry/bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  step batch-compare bash scripts/batch-compare.sh .carry/base/vectorize .carry/bundle/vectorize \
    --images .carry/kodak
fi
if want many && compgen -G ".carry/pslg/*.poly" >/dev/null; then
  [ -x build-gpu/bin/bench_cdt ] || step build-bench cmake --build build-gpu -j "$(nproc)" --target bench_cdt
  files=()
  for f in .carry/pslg/*.poly; do files+=(--file "$f"); done
  many_run() {
    local backend n
    for backend in gpu cpu; do
      for n in 4 16 64; do
        echo "backend $backend:"
        build-gpu/bin/bench_cdt "${files[@]}" --sizes 100:0 --no-cgal --repeat 3 --backend "$backend" \
          --together "$n" | tail -n 1
      done
    done
  }
  step bench-many many_run
fi
if want trace; then
  trace_run() { # trace_run NAME BENCH_ARGS...: the third run's trace lines
    local name=$1
    shift
    TRIXEL_CDT_TRACE=1 build-gpu/bin/bench_cdt --repeat 3 --no-cgal --no-verify --backend gpu "$@" \
      2>"$logs/trace-$name.err" >/dev/null
    echo "== $name"
    awk '/^trace device duplicates: points up/ {run++} run == 3' "$logs/trace-$name.err"
  }
  trace_all() {
    trace_run 10m --sizes 10000000:1000000 --case uniform --cache build-gpu/inputs
    if [ -s build-gpu/inputs/gshhg-high.txt ]; then
      trace_run coast --coast build-gpu/inputs/gshhg-high.txt --case GSHHG
    fi
  }
  step trace trace_all
fi
if want stall; then
  [ -x build-gpu/bin/bench_cdt ] || step build-bench cmake --build build-gpu -j "$(nproc)" --target bench_cdt
  # The stacks that bench_cdt --limit prints, as functions and source lines (the build has line tables
  # when this part is asked for: see the configure step).
  resolve_stacks() {
    local line offset
    while IFS= read -r line; do
      if [[ $line =~ bench_cdt\(\+(0x[0-9a-f]+)\) ]]; then
        offset=$(printf '0x%x' $((BASH_REMATCH[1] - 1))) # the call, not the return address after it
        echo "    $(addr2line -f -i -C -p -e build-gpu/bin/bench_cdt "$offset" 2>&1 | cut -c1-400 | paste -sd'|')"
      else
        echo "$line"
      fi
    done
  }
  stall_hunt() {
    local r start=$SECONDS run="$logs/stall-run.txt"
    for r in $(seq 1 "${TRIXEL_STALL_RUNS:-40}"); do
      ((SECONDS - start > ${TRIXEL_STALL_SECONDS:-300})) && break
      # Written to a file as it comes, and cut by a timeout of its own: a call that ends this script
      # early still returns what the stalled process printed.
      timeout -s KILL 90 build-gpu/bin/bench_cdt --repeat "${TRIXEL_STALL_REPEAT:-3}" --no-cgal --no-verify \
        --backend gpu --cache build-gpu/inputs --sizes 10000000:1000000 --case uniform --limit 30 >"$run" 2>&1
      if grep -q 'TIMED OUT' "$run" || ! grep -q '^| s' "$run"; then
        echo "process $r did not end:"
        resolve_stacks <"$run"
        return 1
      fi
      echo "process $r:$(grep '^| s' "$run" | cut -d'|' -f5)ms"
    done
  }
  step stall stall_hunt
fi
if want batch-stall && [ -x .carry/bundle/vectorize ] && [ -d .carry/kodak ]; then
  export LD_LIBRARY_PATH=$PWD/.carry/bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
  # The batch's worker threads use the device and end with the batch: a batch after another, each
  # given 60 s; one that does not end has its threads' states printed and the step fails.
  batch_stall_hunt() {
    local r t pid task start=$SECONDS dir
    dir=$(mktemp -d)
    for r in $(seq 1 "${TRIXEL_STALL_RUNS:-40}"); do
      ((SECONDS - start > ${TRIXEL_STALL_SECONDS:-300})) && break
      rm -rf "$dir/out"
      .carry/bundle/vectorize .carry/kodak -o "$dir/out" -q --backend gpu &
      pid=$!
      for ((t = 0; t < 600; ++t)); do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
      done
      if kill -0 "$pid" 2>/dev/null; then
        echo "batch $r did not end within 60 s; its threads (tid, state, wait channel, syscall):"
        for task in /proc/"$pid"/task/*; do
          echo "  ${task##*/} $(cut -d' ' -f3 "$task/stat") $(cat "$task/wchan") $(cut -d' ' -f1 "$task/syscall")"
        done
        kill -9 "$pid"
        rm -rf "$dir"
        return 1
      fi
      if ! wait "$pid"; then
        echo "batch $r failed"
        rm -rf "$dir"
        return 1
      fi
      echo "batch $r: $(ls "$dir/out" | wc -l) SVGs"
    done
    rm -rf "$dir"
  }
  step batch-stall batch_stall_hunt
fi
if want compare; then
  base=${TRIXEL_BASE:-.carry/base}
  if [ -f "$base/CMakeLists.txt" ]; then
    step base-configure cmake -S "$base" -B build-base "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
      -DTRIXEL_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES="$arch" -DTRIXEL_VECTORIZE=OFF -DTRIXEL_BUILD_TESTS=OFF
    step base-build cmake --build build-base -j "$(nproc)" --target bench_cdt
    [ -x build-gpu/bin/bench_cdt ] || step build-bench cmake --build build-gpu -j "$(nproc)" --target bench_cdt
    one=(--repeat 3 --no-cgal --backend gpu --cache build-gpu/inputs)
    compare_case=${TRIXEL_COMPARE_CASE-uniform}
    compare_run() { # compare_run BUILD: one round on every input, lines tagged with the build
      "build-$1/bin/bench_cdt" "${one[@]}" --sizes "${TRIXEL_COMPARE_SIZES:-10000000:1000000}" \
        ${compare_case:+--case "$compare_case"} | grep '^| s' | sed "s/^/$1 /"
      [ "${TRIXEL_COMPARE_LATTICE:-0}" != 0 ] &&
        "build-$1/bin/bench_cdt" "${one[@]}" --lattice "$TRIXEL_COMPARE_LATTICE" --case lattice |
        grep '^| l' | sed "s/^/$1 /"
      [ -s build-gpu/inputs/gshhg-high.txt ] &&
        "build-$1/bin/bench_cdt" "${one[@]}" --coast build-gpu/inputs/gshhg-high.txt --case GSHHG |
        grep '^| G' | sed "s/^/$1 /"
      return 0
    }
    compare_rounds() {
      for ((r = 0; r < ${TRIXEL_ROUNDS:-3}; ++r)); do compare_run base; compare_run gpu; done
    }
    step compare compare_rounds
  else
    echo "== compare: no earlier tree in $base (git archive REV | tar -x -C $base)"
  fi
fi

echo
echo "## device: $(cat "$logs/device.txt")"
echo "| step | result | time |"
echo "| --- | --- | --- |"
printf '%s\n' "${status[@]}"
echo
for log in bench-predicates bench-voronoi bench-cdt-gpu bench-cdt-cpu; do
  [ -f "$logs/$log.log" ] && { grep -h -e '^backend' -e '^|' "$logs/$log.log" || true; echo; }
done
# The GPU backend against the CPU executor and CGAL, input by input (bench_cdt's rows: input, points,
# segments, ours ms, phases, flips, missing, verified, peak MiB, CGAL ms, ours / CGAL).
if [ -f "$logs/bench-cdt-gpu.log" ] && [ -f "$logs/bench-cdt-cpu.log" ]; then
  echo "| input | GPU ms | verified | CPU executor ms | CGAL ms | vs CPU executor | vs CGAL |"
  echo "| --- | --- | --- | --- | --- | --- | --- |"
  awk -F'|' '
    function trim(x) { gsub(/^ +| +$/, "", x); return x }
    FNR == 1 { file++ }
    $2 ~ /^ (input|---)/ || NF < 12 { next }
    file == 1 { name = trim($2); order[++n] = name; gpu[name] = trim($5); ok[name] = trim($9) }
    file == 2 { name = trim($2); cpu[name] = trim($5); cgal[name] = trim($11) }
    END {
      for (i = 1; i <= n; i++) {
        name = order[i]; g = gpu[name] + 0; c = 0; k = 0
        if (name in cpu) { c = cpu[name] + 0; k = cgal[name] + 0 }
        printf "| %s | %s | %s | %s | %s | %s | %s |\n", name, gpu[name], ok[name],
          (c > 0) ? cpu[name] : "-", (k > 0) ? cgal[name] : "-",
          (g > 0 && c > 0) ? sprintf("%.1fx", c / g) : "-", (g > 0 && k > 0) ? sprintf("%.1fx", k / g) : "-"
      }
    }' "$logs/bench-cdt-gpu.log" "$logs/bench-cdt-cpu.log"
  echo
fi
[ -f "$logs/trace.log" ] && { echo "trace (third runs):"; grep -E '^(==|trace triangulate|trace split: suspect)' "$logs/trace.log"; echo; }
[ -f "$logs/compare.log" ] && { echo "compare (base = ${TRIXEL_BASE:-.carry/base}, gpu = this tree):"; cat "$logs/compare.log"; echo; }
for log in bench-batch bench-batch-cpu bench-batch-own; do
  [ -f "$logs/$log.log" ] && { echo "$log:"; grep -h '^|' "$logs/$log.log" || true; }
done
[ -f "$logs/batch-compare.log" ] && { echo "batch-compare (base = .carry/base, new = this tree):"; grep -h '^|' "$logs/batch-compare.log" || true; }
[ -f "$logs/bench-many.log" ] && { echo "bench-many:"; grep -h -e '^backend' -e '^|' "$logs/bench-many.log" || true; }
[ -f "$logs/gpu-tests.log" ] && { grep -h -E 'tests passed|tests failed|Skipped|Not Run' "$logs/gpu-tests.log" || true; }
grep -q FAIL <<<"${status[*]}" && exit 1
exit 0

#!/usr/bin/env bash
# One benchmark sitting: every figure BENCHMARKS.md reports, measured in one go, then the table of
# figures against their targets (scripts/bench_table.py).
#
# Usage: scripts/bench-sitting.sh BUILD_DIR OUT_DIR
#   BUILD_DIR  a Release build with the targets hysid, hysid_bench_{simulator,identify,refine,
#              estimators} and hysid_python (e.g. `cmake --build build -j2`)
#   OUT_DIR    created; receives machine.txt, uptime.log (the load before and after every step),
#              gb_*.json (Google Benchmark), time_*.txt (/usr/bin/time -v), log_*.txt, cmp.txt, the
#              runs' directories, and table.md (also printed)
#
# Run it on an idle machine: nothing else running, no build, no editor indexing. Every step records
# `uptime` before and after it, and the table says which steps saw a load above 1.5.
#
# Estimated time on an idle 2-core machine (from the figures in BENCHMARKS.md): about 7 minutes,
# well inside a 15-minute sitting.
#   Google Benchmark, 51 benchmarks: the 22 with a target at 5 repetitions (≈ 3 s each: 0.5 s per
#   repetition plus the first repetition's iteration search), the other 29 at 3 (≈ 2 s each), plus
#   the refinement fixtures' simulate + identify: ≈ 2.5 min.
#   Timed CLI runs: robustness map 2 + 1 threads ≈ 17 + 33 s; efficiency study 2 + 1 threads
#   ≈ 43 + 85 s; writing the many-run data (400 `hysid simulate`) ≈ 15 s, its two identify runs
#   ≈ 2 s; paper_noise on 2 threads ≈ 21 s; the default study with its figures ≈ 16 s; merging the
#   map's tables ≈ 3 s; the Python overhead script ≈ 3 s; the Ctrl-C test ≈ 5 s: ≈ 4 min.
#   With the studies at their targets (map ≤ 12 s, efficiency ≤ 15 s on 2 threads): about 5 minutes.
#
# HYSID_SITTING_SMOKE=1 checks the script itself in under a minute or two of CPU: every benchmark at
# --benchmark_min_time=0.01 and 2 repetitions, every sweep as shard 1/50 (1/5 for the default
# study), the many-run data with 4 runs. Its figures mean nothing.
set -uo pipefail

if [[ $# -ne 2 ]]; then
  sed -n '5,10s/^# \{0,1\}//p' "$0" >&2
  exit 2
fi
repo="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)" || { echo "bench-sitting: no build directory $1" >&2; exit 2; }
mkdir -p "$2" || exit 2
out="$(cd "$2" && pwd)"
if [[ -n "$(ls -A "$out")" ]]; then
  echo "bench-sitting: $out is not empty (a sitting writes into an empty directory)" >&2
  exit 2
fi
hysid="$build/bin/hysid"
for exe in "$hysid" "$build"/bin/hysid_bench_{simulator,identify,refine,estimators}; do
  [[ -x "$exe" ]] || { echo "bench-sitting: $exe missing (build it first)" >&2; exit 2; }
done
[[ -d "$build/python" ]] || echo "bench-sitting: no $build/python (the Python figures will be missing)" >&2
[[ -x /usr/bin/time ]] || { echo "bench-sitting: /usr/bin/time missing (Debian package time)" >&2; exit 2; }
cd "$repo"

smoke="${HYSID_SITTING_SMOKE:-0}"
if [[ "$smoke" == 1 ]]; then
  min_time=0.01 reps_target=2 reps_rest=2 shard=1/50 shard_default=1/5 many_runs=4
else
  min_time=0.5 reps_target=5 reps_rest=3 shard=1/1 shard_default=1/1 many_runs=400
fi

# machine.txt: what the sitting ran on and which code.
{
  echo "date: $(date -u '+%Y-%m-%d %H:%M:%S UTC')"
  echo "commit: $(git rev-parse HEAD)"
  echo "worktree changes: $(git status --porcelain --untracked-files=no | wc -l) files"
  echo "nproc: $(nproc)"
  echo "cpu: $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | sort | uniq -c | sed 's/^ *//')"
  echo "memory: $(sed -n 's/^MemTotal:[[:space:]]*//p' /proc/meminfo)"
  echo "kernel: $(uname -sr)"
  echo "compiler: $(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt") ($(sed -n 's/^CMAKE_CXX_COMPILER_VERSION:[A-Z]*=//p' "$build/CMakeFiles"/*/CMakeCXXCompiler.cmake 2>/dev/null; "$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")" -dumpfullversion 2>/dev/null))"
  echo "build type: $(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$build/CMakeCache.txt")"
  echo "smoke: $smoke"
  echo "many runs: $many_runs"
} > "$out/machine.txt"

exec 3>&2  # the steps' progress lines, while their own output goes to log_*.txt

# step NAME COMMAND...: runs COMMAND with `uptime` before and after it in uptime.log.
step() {
  local name="$1" rc=0
  shift
  echo "$name	before	$(uptime)" >> "$out/uptime.log"
  echo "[$(date -u +%H:%M:%S)] $name" >&3
  "$@" || rc=$?
  echo "$name	after	$(uptime)" >> "$out/uptime.log"
  echo "$name	rc	$rc" >> "$out/uptime.log"
}

# timed NAME COMMAND...: a step under /usr/bin/time -v (time_NAME.txt), its output in log_NAME.txt.
timed() {
  local name="$1"
  shift
  step "$name" /usr/bin/time -v -o "$out/time_$name.txt" "$@" > "$out/log_$name.txt" 2>&1
}

# gb NAME BINARY REPETITIONS FILTER: one Google Benchmark run into gb_NAME.json.
gb() {
  step "$1" "$build/bin/hysid_bench_$2" --benchmark_filter="$4" --benchmark_repetitions="$3" \
    --benchmark_report_aggregates_only=true --benchmark_min_time="$min_time" \
    --benchmark_out="$out/gb_$1.json" --benchmark_out_format=json > "$out/log_gb_$1.txt" 2>&1
}

# same NAME A B: records whether two files are byte-identical in cmp.txt.
same() {
  local verdict=differ
  if [[ ! -f "$2" || ! -f "$3" ]]; then verdict=missing; elif cmp -s "$2" "$3"; then verdict=identical; fi
  echo "$1	$verdict	$2	$3" >> "$out/cmp.txt"
}

# Google Benchmark: the figures with a target at 5 repetitions, the rest at 3.
sim_t='^BM_SimulateImpactMsd/500$|^BM_AddMeasurementNoise$'
id_t='^BM_IdentifyStep$|^BM_IdentifyStep(FusedReference|Residual|Integral|WithHulls|Noisy|ResidualDataAccuracy|ResidualKnownSigma|ModelFile)$'
ref_t='^BM_(Plain|Sensitivity)Trajectory/|^BM_RefineSection5$|^BM_RefineDragBall/40001$|^BM_RefineWall$|^BM_RefineDriven$'
est_t='^BM_EstimatorUpdate/(gtls|frisch|frisch_growing)/2$'
gb simulator_targets simulator "$reps_target" "$sim_t"
gb identify_targets identify "$reps_target" "$id_t"
gb refine_targets refine "$reps_target" "$ref_t"
gb estimators_targets estimators "$reps_target" "$est_t"
gb simulator_rest simulator "$reps_rest" "-($sim_t)"
gb identify_rest identify "$reps_rest" "-($id_t)"
gb refine_rest refine "$reps_rest" "-($ref_t)"
gb estimators_rest estimators "$reps_rest" "-($est_t)"

# The sweeps: 2 threads then 1, the same bytes whatever the thread count.
for study in robustness_map efficiency; do
  for threads in 2 1; do
    timed "${study}_$threads" "$hysid" sweep "experiments/studies/$study.toml" --out "$out/${study}_$threads" \
      --threads "$threads" --shard "$shard" --progress none
  done
  for table in trials.csv summary.csv; do
    same "${study} $table, 1 vs 2 threads" "$out/${study}_1/$table" "$out/${study}_2/$table"
  done
  same "$study summary.csv vs results/$study" "$out/${study}_2/summary.csv" "results/$study/summary.csv"
done
if [[ "$shard" == 1/1 ]]; then  # the tables of the whole map written again (bootstrap intervals included)
  timed merge_map "$hysid" merge "$out/robustness_map_2" --out "$out/robustness_map_merged"
  same "robustness_map summary.csv, merge vs sweep" "$out/robustness_map_merged/summary.csv" \
    "$out/robustness_map_2/summary.csv"
fi
timed paper_noise_2 "$hysid" sweep experiments/studies/paper_noise.toml --out "$out/paper_noise_2" --threads 2 \
  --shard "$shard" --progress none
same "paper_noise summary.csv vs results/paper_noise" "$out/paper_noise_2/summary.csv" results/paper_noise/summary.csv

# The default study of `make run` (scripts/run-default.sh), written here instead of results/default.
timed default_study bash -c '"$1" sweep experiments/studies/default.toml --out "$2" --shard "$3" --progress none &&
  /usr/bin/python3 analysis/hysid_plots all "$2" --format png,pdf &&
  /usr/bin/python3 analysis/hysid_plots table "$2" --format md --out "$2/table.md"' default_study "$hysid" \
  "$out/default" "$shard_default"

# A many-run identify: 400 runs × 2 001 samples in one file, with and without the refinement.
step many_runs_data /usr/bin/python3 bench/many_runs.py "$hysid" "$out/many.csv" "$many_runs" > "$out/log_many_runs_data.txt" 2>&1
timed many_runs_identify "$hysid" identify --data "$out/many.csv"
timed many_runs_identify_norefine "$hysid" identify --data "$out/many.csv" --refine none
rm -f "$out/many.csv"

# The Python module against the command line, and Ctrl-C in the recursive pass.
"$hysid" simulate --sigma 0.25 --seed 3 --out "$out/noisy.csv" > /dev/null
PYTHONPATH="$build/python" step python_overhead /usr/bin/python3 bench/python_overhead.py "$hysid" "$out/noisy.csv" \
  > "$out/log_python_overhead.txt" 2>&1
HYSID_BIN="$hysid" PYTHONPATH="$build/python" step ctrl_c /usr/bin/python3 -m pytest -q -s \
  tests/python/test_hysid.py -k stops_the_recursive_pass > "$out/log_ctrl_c.txt" 2>&1

/usr/bin/python3 scripts/bench_table.py "$out" | tee "$out/table.md"

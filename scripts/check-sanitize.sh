#!/usr/bin/env bash
# `make check-sanitize`: the test suite under GCC's ASan+UBSan (build-asan/) and under clang 14's
# UBSan with float-cast-overflow (build-clang-ub/; GCC's UBSan does not check float-to-int casts),
# then the libFuzzer harnesses of tests/fuzz (build-fuzz/), each for FUZZ_RUNS executions (default
# 1 000 000) from a copy of its seed corpus in tests/fuzz/corpus/, stopped after FUZZ_SECONDS
# (default 1800) at the latest; FUZZ_HARNESSES (default "csv sample_data sweep model_file") picks
# the harnesses. Fails on any test failure, sanitizer report, or a harness that did not reach FUZZ_RUNS.
# Usage: scripts/check-sanitize.sh [asan|ub|fuzz ...]   (default: all three)
set -euo pipefail
cd "$(dirname "$0")/.."
jobs="${JOBS:-$(nproc 2>/dev/null || echo 2)}"
fuzz_runs="${FUZZ_RUNS:-1000000}"
fuzz_seconds="${FUZZ_SECONDS:-1800}"
read -r -a fuzz_harnesses <<< "${FUZZ_HARNESSES:-csv sample_data sweep model_file}"
steps=("$@")
[ ${#steps[@]} -eq 0 ] && steps=(asan ub fuzz)
launcher=()
command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# No Python module: a library built with ASan cannot be loaded into the system's python3.
common=(-G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHYSID_BUILD_BENCH=OFF -DHYSID_BUILD_PYTHON=OFF "${launcher[@]}")
# Debug information records paths below the source tree relative to it (the sanitizers' own records
# of each source stay absolute: the install test leaves a sanitized build's binaries out).
prefix_map="-ffile-prefix-map=$PWD/="
# TBB's worker threads are still alive at exit; LeakSanitizer would report their stacks.
# ASan reserves terabytes of address space for its shadow memory, so `ulimit -v` cannot bound it;
# hard_rss_limit_mb makes each process stop itself at 3 GB resident instead.
export ASAN_OPTIONS="detect_leaks=0:abort_on_error=1:strict_string_checks=1:hard_rss_limit_mb=3072"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# A sanitized test runs slower than in the Release build: a test's own TIMEOUT counts twelve times
# under ASan, eight under UBSan (the cube's refused fit: 124 s of wall time in Release, 2976 s under
# ASan beside a Release build and its tests, 1475 s under UBSan beside other tests); a test without
# one gets 4500 s, not 1500.
timeout=4500

for step in "${steps[@]}"; do
  start=$SECONDS
  case "$step" in
    asan)
      cmake -S . -B build-asan "${common[@]}" -DHYSID_TEST_TIMEOUT_SCALE=12 -DCMAKE_CXX_COMPILER=g++ \
        -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer $prefix_map"
      cmake --build build-asan -j "$jobs"
      ctest --test-dir build-asan --no-tests=error --output-on-failure --timeout "$timeout" -j "$jobs"
      ;;
    ub)
      cmake -S . -B build-clang-ub "${common[@]}" -DHYSID_TEST_TIMEOUT_SCALE=8 -DCMAKE_CXX_COMPILER=clang++-14 \
        -DCMAKE_CXX_FLAGS="-fsanitize=undefined,float-cast-overflow -fno-sanitize-recover=all -fno-omit-frame-pointer $prefix_map"
      cmake --build build-clang-ub -j "$jobs"
      ctest --test-dir build-clang-ub --no-tests=error --output-on-failure --timeout "$timeout" -j "$jobs"
      ;;
    fuzz)
      # _GLIBCXX_ASSERTIONS: libstdc++'s checks (an empty std::optional read, an index out of a vector's
      # range) abort, which no sanitizer reports.
      cmake -S . -B build-fuzz "${common[@]}" -DCMAKE_CXX_COMPILER=clang++-14 -DBUILD_TESTING=OFF -DHYSID_FUZZ=ON \
        -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address,undefined,float-cast-overflow -fno-sanitize-recover=all -D_GLIBCXX_ASSERTIONS"
      cmake --build build-fuzz -j "$jobs" --target "${fuzz_harnesses[@]/#/fuzz_}"
      for h in "${fuzz_harnesses[@]}"; do
        work="build-fuzz/corpus-$h"
        rm -rf "$work"; mkdir -p "$work"
        cp tests/fuzz/corpus/"$h"/* "$work"/
        # -rss_limit_mb: the named limits keep a 1 MiB line far below it.
        build-fuzz/bin/fuzz_"$h" "$work" -runs="$fuzz_runs" -max_total_time="$fuzz_seconds" -max_len=65536 -rss_limit_mb=2048 \
          -artifact_prefix=build-fuzz/crash-"$h"- -print_final_stats=1 2>&1 | tee build-fuzz/fuzz-"$h".log |
          grep -E "^(Done|stat::number_of_executed_units)|ERROR|SUMMARY" || true
        if grep -q -E "^(==[0-9]+==ERROR|SUMMARY: )" build-fuzz/fuzz-"$h".log; then
          echo "fuzz_$h: a finding, see build-fuzz/fuzz-$h.log" >&2; exit 1
        fi
        grep -q "^Done" build-fuzz/fuzz-"$h".log || { echo "fuzz_$h did not finish" >&2; exit 1; }
        runs=$(sed -n 's/^Done \([0-9]*\) runs.*/\1/p' build-fuzz/fuzz-"$h".log)
        if [ "${runs:-0}" -lt "$fuzz_runs" ]; then
          echo "fuzz_$h: ${runs:-0} executions in ${fuzz_seconds} s, fewer than FUZZ_RUNS=$fuzz_runs" >&2; exit 1
        fi
      done
      ;;
    *) echo "check-sanitize: unknown step '$step' (asan, ub, fuzz)" >&2; exit 2 ;;
  esac
  echo "check-sanitize: $step took $((SECONDS - start)) s"
done

#!/usr/bin/env python3
"""The identification step's regression guard: BM_IdentifyStep ÷ BM_IdentifyStepFusedReference ≤ 1.6.

Usage: check_step_ratio.py BENCH_IDENTIFY [--bound B] [--repetitions N] [--gate VAR]

Runs the two benchmarks of BENCH_IDENTIFY (the hysid_bench_identify binary) side by side, interleaved
at random, and compares the medians of their CPU times (per sample: both run the same 40 001
samples). Prints both figures and the ratio; exits 1 when the ratio is above the bound, 2 for bad
usage or a benchmark that did not run, and 77 (skipped, for ctest) when --gate names an environment
variable that is not 1. Meant for an idle machine: a compile on the other core slows BM_IdentifyStep
by up to 2× and not the reference (BENCHMARKS.md, "The machine"). Standard library only.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

STEP, REFERENCE = "BM_IdentifyStep", "BM_IdentifyStepFusedReference"
SAMPLES = 40001  # the §5 run of bench/bench_identify.cpp


def fail(message):
    print(f"check_step_ratio: {message}", file=sys.stderr)
    sys.exit(2)


def medians(binary, repetitions):
    """Median CPU time (ns per sample) of each benchmark over its repetitions."""
    command = [binary, f"--benchmark_filter=^({STEP}|{REFERENCE})$",
               f"--benchmark_repetitions={repetitions}", "--benchmark_enable_random_interleaving=true",
               "--benchmark_min_time=0.5", "--benchmark_format=json"]
    run = subprocess.run(command, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        fail(f"{' '.join(command)} exited {run.returncode}: {run.stderr.strip()}")
    times = {STEP: [], REFERENCE: []}
    for b in json.loads(run.stdout)["benchmarks"]:
        if b.get("run_type") == "iteration" and b["run_name"] in times:
            scale = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}[b["time_unit"]]
            times[b["run_name"]].append(b["cpu_time"] * scale / SAMPLES)
    for name, values in times.items():
        if not values:
            fail(f"{binary} ran no {name}")
    return {name: statistics.median(values) for name, values in times.items()}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("binary", help="the hysid_bench_identify binary")
    parser.add_argument("--bound", type=float, default=1.6, help="largest ratio that passes (default 1.6)")
    parser.add_argument("--repetitions", type=int, default=5, help="repetitions of each benchmark (default 5)")
    parser.add_argument("--gate", help="skip (exit 77) unless this environment variable is 1")
    args = parser.parse_args()
    if args.gate and os.environ.get(args.gate) != "1":
        print(f"skipped: set {args.gate}=1 to run the benchmark guard")
        return 77
    if not (args.bound > 0) or args.repetitions < 1:
        parser.error(f"--bound = {args.bound}, --repetitions = {args.repetitions}: must be > 0 and >= 1")
    m = medians(args.binary, args.repetitions)
    ratio = m[STEP] / m[REFERENCE]
    print(f"{STEP}: {m[STEP]:.2f} ns per sample, {REFERENCE}: {m[REFERENCE]:.2f} ns per sample "
          f"(medians of {args.repetitions} CPU times)")
    verdict = "met" if ratio <= args.bound else "NOT MET"
    print(f"ratio {ratio:.3f} (bound {args.bound}): {verdict}; load average {os.getloadavg()[0]:.1f}")
    return 0 if ratio <= args.bound else 1


if __name__ == "__main__":
    sys.exit(main())

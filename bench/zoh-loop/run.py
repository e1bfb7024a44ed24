#!/usr/bin/python3
"""Fit the sampled-data loop (truth.toml) from starts whose controller period T is off by a factor.

    bench/zoh-loop/run.py --hysid build/bin/hysid [--seeds 2] [--period-factors 1,1.02,1.05,1.08,1.2]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.01 --seed S` (30 s at 50 Hz, 120 ticks),
the data as a user has them (t, x, v, r); then, per factor f, `hysid identify` with its defaults from
a start file with a = 2x, K1 = 2x, K2 = 0.5x the truth and T = f x the truth, timed. Prints the wall
time, the status, T's estimate and SE, and the largest |estimate - truth| / SE over a, K1, K2, T.
"""
import argparse
import csv
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TRUTH = {"a": 0.8, "K1": 1.5, "K2": 0.6, "T": 0.25}
START = {"a": 2.0, "K1": 2.0, "K2": 0.5}


def start_file(path, factor):
    text = (HERE / "truth.toml").read_text()
    for name, value in TRUTH.items():
        start = value * (factor if name == "T" else START[name])
        text, n = re.subn(rf'(name = "{name}", value = )[0-9.]+', rf"\g<1>{start!r}", text)
        assert n == 1, name
    path.write_text(text)


def one(hysid, work, seed, factor):
    sim = work / f"sim{seed}.csv"
    if not sim.exists():
        subprocess.run([hysid, "simulate", "--model-file", str(HERE / "truth.toml"), "--sigma", "0.01",
                        "--seed", str(seed), "--out", str(sim)], check=True, capture_output=True)
    data = work / f"data{seed}.csv"
    with open(sim) as f, open(data, "w", newline="") as g:
        out = csv.writer(g)
        out.writerow(["t", "x", "v", "r"])
        for row in csv.DictReader(f):
            out.writerow([row["t"], row["x"], row["v"], row["r"]])
    start = work / f"start{factor}.toml"
    start_file(start, factor)
    result = work / f"identify{seed}-{factor}.json"
    t0 = time.perf_counter()
    run = subprocess.run([hysid, "identify", "--model-file", str(start), "--data", str(data),
                          "--json", str(result), "--progress", "none"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if not result.exists():
        return f"seed {seed}, T x{factor}: exit {run.returncode} without an estimate: {run.stderr.strip()[-200:]}"
    d = json.loads(result.read_text())
    est = dict(zip(d["names"], d["estimate"]))
    se = dict(zip(d["names"], d["standard_errors"] or [float("nan")] * len(d["names"])))
    z = max(abs(est[n] - TRUTH[n]) / se[n] for n in TRUTH if se.get(n))
    return (f"seed {seed}, T x{factor}: {wall:.2f} s wall, status {d['status']}, T = {est['T']:.5f} "
            f"± {se['T']:.2g}, max |z| {z:.3g}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--seeds", type=int, default=2, help="seeds 1, 2, ... (this many)")
    ap.add_argument("--period-factors", default="1,1.02,1.05,1.08,1.2")
    ap.add_argument("--work", help="keep the files here (default: a temporary directory)")
    args = ap.parse_args(argv)
    factors = [float(f) for f in args.period_factors.split(",")]
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.work or scratch)
        work.mkdir(parents=True, exist_ok=True)
        for seed in range(1, 1 + args.seeds):
            for factor in factors:
                print(one(args.hysid, work, seed, factor), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""Fit the oscillator with a hidden constant force (truth.toml) from starts whose F is off by a factor.

    bench/biased-wall/run.py --hysid build/bin/hysid [--seeds 2] [--force-factors 1,0.7,0.4]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.005 --seed S` (20 s at 50 Hz, about 20
impacts), the data as a user has them (t, x); then, per factor f, `hysid identify` with its defaults
from a start file with k = 1.75x, c = 0.5x and e = 0.9 (1.29x) the truth and F's start value f x the
truth, timed. Prints the wall time, the status, the start the kept fit came from, and the largest
|estimate - truth| / SE over k, c, e and x0[F].
"""
import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TRUTH = {"k": 4.0, "c": 0.3, "e": 0.7, "x0[F]": 1.0}


def start_file(path, factor):
    text = (HERE / "truth.toml").read_text()
    for old, new in (('name = "k", value = 4.0', 'name = "k", value = 7.0'),
                     ('name = "c", value = 0.3', 'name = "c", value = 0.15'),
                     ('name = "e", value = 0.7', 'name = "e", value = 0.9'),
                     ("x0 = [-0.5, 1.5, 1.0]", f"x0 = [-0.5, 0.0, {factor!r}]")):
        assert old in text, old
        text = text.replace(old, new)
    path.write_text(text)


def one(hysid, work, seed, factor):
    sim = work / f"sim{seed}.csv"
    if not sim.exists():
        subprocess.run([hysid, "simulate", "--model-file", str(HERE / "truth.toml"), "--sigma", "0.005",
                        "--seed", str(seed), "--out", str(sim)], check=True, capture_output=True)
    data = work / f"data{seed}.csv"
    with open(sim) as f, open(data, "w", newline="") as g:
        out = csv.writer(g)
        out.writerow(["t", "x"])
        for row in csv.DictReader(f):
            out.writerow([row["t"], row["x"]])
    start = work / f"start{factor}.toml"
    start_file(start, factor)
    result = work / f"identify{seed}-{factor}.json"
    t0 = time.perf_counter()
    run = subprocess.run([hysid, "identify", "--model-file", str(start), "--data", str(data),
                          "--json", str(result), "--progress", "none"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if not result.exists():
        return f"seed {seed}, F x{factor}: exit {run.returncode} without an estimate: {run.stderr.strip()[-200:]}"
    d = json.loads(result.read_text())
    est = dict(zip(d["names"], d["estimate"]))
    se = dict(zip(d["names"], d["standard_errors"] or [float("nan")] * len(d["names"])))
    z = max(abs(est[n] - TRUTH[n]) / se[n] for n in TRUTH) if d["standard_errors"] else float("nan")
    return (f"seed {seed}, F x{factor}: {wall:.2f} s wall, status {d['status']}, k = {est['k']:.4f}, "
            f"F = {est['x0[F]']:.4f}, max |z| {z:.3g}; {d['mended'] or '-'}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--seeds", type=int, default=2, help="seeds 1, 2, ... (this many)")
    ap.add_argument("--force-factors", default="1,0.7,0.4")
    ap.add_argument("--work", help="keep the files here (default: a temporary directory)")
    args = ap.parse_args(argv)
    factors = [float(f) for f in args.force_factors.split(",")]
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.work or scratch)
        work.mkdir(parents=True, exist_ok=True)
        for seed in range(1, 1 + args.seeds):
            for factor in factors:
                print(one(args.hysid, work, seed, factor), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""Time `hysid identify` with its defaults on the offset impact oscillator (truth.toml, start.toml).

    bench/offset-impact/run.py --hysid build/bin/hysid [--seeds 3] [--work DIR]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.002 --seed S` (30 s at 100 Hz, 12 impacts
for seed 3), the rows in [12, 12.6) s removed (a 0.6 s gap: two chains), the data as a user has them
(t, x, v, u); then `hysid identify --model-file start.toml` on them, timed. Prints the wall time, the
status, the route and the largest |estimate − truth| / SE over the 7 unknowns.
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
TRUTH = {"k": 6.0, "b": 0.4, "G": 2.0, "q": 0.3, "lambda": 0.75, "w": 0.35, "xe": 0.05}


def one(hysid, work, seed):
    sim = work / f"sim{seed}.csv"
    subprocess.run([hysid, "simulate", "--model-file", str(HERE / "truth.toml"), "--sigma", "0.002",
                    "--seed", str(seed), "--out", str(sim)], check=True, capture_output=True)
    data = work / f"data{seed}.csv"
    with open(sim) as f, open(data, "w", newline="") as g:
        out = csv.writer(g)
        out.writerow(["t", "x", "v", "u"])
        for row in csv.DictReader(f):
            if not 12.0 <= float(row["t"]) < 12.6 - 1e-9:
                out.writerow([row["t"], row["x"], row["v"], row["u"]])
    result = work / f"identify{seed}.json"
    t0 = time.perf_counter()
    run = subprocess.run([hysid, "identify", "--model-file", str(HERE / "start.toml"), "--data", str(data),
                          "--json", str(result), "--progress", "none"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if not result.exists():
        return f"seed {seed}: exit {run.returncode} without an estimate: {run.stderr.strip()[-200:]}"
    d = json.loads(result.read_text())
    z = max(abs(e - TRUTH[n]) / s for n, e, s in zip(d["names"], d["estimate"], d["standard_errors"])
            if n in TRUTH and s)
    return f"seed {seed}: {wall:.2f} s wall, status {d['status']}, route {d['route']}, max |z| {z:.2f}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--seeds", type=int, default=3, help="seeds 3, 4, ... (this many)")
    ap.add_argument("--work", help="keep the files here (default: a temporary directory)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.work or scratch)
        work.mkdir(parents=True, exist_ok=True)
        for seed in range(3, 3 + args.seeds):
            print(one(args.hysid, work, seed), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""Fit the stick-slip oscillator (truth.toml) from its truth and from a far start, written two ways.

    bench/stick-slip/run.py --hysid build/bin/hysid [--seeds 2]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.002 --seed S` (20 s at 50 Hz, x only),
the data as a user has them (t, x); then `hysid identify` with its defaults, timed, from the truth and
from a start with k = 2x, c = 2x, mu = 0.6x and xs = 1.3x the truth, for the model as written (the
map into stick sets v to the belt's speed) and for the same model with that map the identity
(v keeps its value into stick). Prints the wall time, the status, the start the kept fit came from
and the largest |estimate - truth| / SE.
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
TRUTH = {"k": 2.0, "c": 0.1, "mu": 0.5, "xs": 0.4}
FAR = {"k": 4.0, "c": 0.2, "mu": 0.3, "xs": 0.52}
RESET = """beta = [ { name = "keep", value = 1.0, known = true }, { name = "belt", value = 0.3, known = true } ]
psi = [["x", 0], [0, 1]]
rows = ["v"]
"""


def model_file(path, values, reset):
    text = (HERE / "truth.toml").read_text()
    for name, value in values.items():
        old = f'name = "{name}", value = {TRUTH[name]!r}'
        assert old in text, old
        text = text.replace(old, f'name = "{name}", value = {value!r}')
    if not reset:
        assert RESET in text
        text = text.replace(RESET, "")
    path.write_text(text)


def one(hysid, work, seed, start, reset):
    sim = work / f"sim{seed}.csv"
    if not sim.exists():
        subprocess.run([hysid, "simulate", "--model-file", str(HERE / "truth.toml"), "--sigma", "0.002",
                        "--seed", str(seed), "--out", str(sim)], check=True, capture_output=True)
    data = work / f"data{seed}.csv"
    with open(sim) as f, open(data, "w", newline="") as g:
        out = csv.writer(g)
        out.writerow(["t", "x"])
        for row in csv.DictReader(f):
            out.writerow([row["t"], row["x"]])
    writing = "v set to vb into stick" if reset else "identity into stick"
    path = work / f"{start}-{'reset' if reset else 'identity'}.toml"
    model_file(path, TRUTH if start == "truth" else FAR, reset)
    result = work / f"identify{seed}-{path.stem}.json"
    t0 = time.perf_counter()
    run = subprocess.run([hysid, "identify", "--model-file", str(path), "--data", str(data),
                          "--json", str(result), "--progress", "none"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    label = f"seed {seed}, {writing}, from the {start}"
    if not result.exists():
        return f"{label}: exit {run.returncode} without an estimate: {run.stderr.strip()[-200:]}"
    d = json.loads(result.read_text())
    est = dict(zip(d["names"], d["estimate"]))
    se = dict(zip(d["names"], d["standard_errors"] or []))
    z = max(abs(est[n] - TRUTH[n]) / se[n] for n in TRUTH) if se else float("nan")
    return f"{label}: {wall:.2f} s wall, status {d['status']}, max |z| {z:.3g}; {d['mended'] or '-'}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--seeds", type=int, default=2, help="seeds 1, 2, ... (this many)")
    ap.add_argument("--work", help="keep the files here (default: a temporary directory)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.work or scratch)
        work.mkdir(parents=True, exist_ok=True)
        for seed in range(1, 1 + args.seeds):
            for reset in (True, False):
                for start in ("truth", "far start"):
                    print(one(args.hysid, work, seed, start, reset), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""Support recovery of hysid's selection of jump terms over noise draws.

For each truth (a bouncing ball whose restitution map is v+ = -0.95 v, bounce_truth.toml, 37 impacts
in 15 s; and v+ = -0.95 v + 0.02 v|v|, bounce_quadratic_truth.toml, 26 impacts in 8 s) and each
sigma: `hysid simulate` of the truth with seeds 1..N, then `hysid identify --model-file
bounce_library.toml --refine none --json` (6 candidate terms of v+: v, v|v|, 1, v^3, h, sqrt|v|; the
whole pipeline: its own jump detection, the selection on the detected jumps by leave-one-jump-out
cross-validation, the bootstrap over jumps and its stability rule), and whether it chose exactly the
true support. `--select-bootstrap 0` gives cross-validation alone. The truth `maps` is a ball between
a floor and a ceiling with one [[jump]] map each (floor_ceiling_truth.toml: floor v+ = -0.98 v, ceiling
v+ = -0.9 v + 0.01 v|v|), four runs thrown up from 1 m at 14, 17, 20 and 23 m/s (3 s each, noise
trials 0-3 of the seed), identified from floor_ceiling_library.toml (5 candidate terms of v+ per map;
each map's terms chosen on its own jumps); its chosen terms are written MAP:TERM. Prints one line per
(truth, sigma) and writes the rows to --out (CSV).

Usage: jump_study.py --hysid build/bin/hysid [--draws 50] [--sigmas 0.01,0.03] [--truths linear,quadratic]
                     [--bootstrap 100] [--out results/select/jump_support.csv]
       jump_study.py --hysid build/bin/hysid --truths maps --out results/select/jump_maps_support.csv
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
# Per truth: its file, the library, the true support, and the runs' initial states (None: the file's).
TRUTHS = {
    "linear": ("bounce_truth.toml", "bounce_library.toml", ["v"], [None]),
    "quadratic": ("bounce_quadratic_truth.toml", "bounce_library.toml", ["v", "v*abs(v)"], [None]),
    "maps": ("floor_ceiling_truth.toml", "floor_ceiling_library.toml",
             ["floor:v", "ceiling:v", "ceiling:v*abs(v)"], ["1,14", "1,17", "1,20", "1,23"]),
}


def chosen_terms(jump):
    """The chosen terms of a selection's `jump`: TERM for [jump], MAP:TERM for [[jump]] maps."""
    if isinstance(jump, dict):
        return [t["term"] for t in jump["terms"] if t["chosen"]], jump["jumps"]
    return ([f"{m['map']}:{t['term']}" for m in jump for t in m["terms"] if t["chosen"]],
            sum(m["jumps"] for m in jump))


def run(args):
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(args)}: exit {p.returncode}\n{p.stdout}\n{p.stderr}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--draws", type=int, default=50)
    ap.add_argument("--sigmas", default="0.01,0.03")
    ap.add_argument("--truths", default="linear,quadratic")
    ap.add_argument("--bootstrap", type=int, default=100)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.truths.split(","):
            truth, library, support, runs = TRUTHS[name]
            for sigma in a.sigmas.split(","):
                hits = 0
                for seed in range(1, a.draws + 1):
                    data, out = [], os.path.join(tmp, "r.json")
                    for trial, x0 in enumerate(runs):
                        data += ["--data", os.path.join(tmp, f"d{trial}.csv")]
                        run([a.hysid, "simulate", "--model-file", os.path.join(HERE, truth), "--sigma", sigma,
                             "--seed", str(seed), "--out", data[-1]]
                            + (["--x0", x0, "--trial", str(trial)] if x0 else []))
                    start = time.perf_counter()
                    run([a.hysid, "identify", "--model-file", os.path.join(HERE, library), *data, "--refine",
                         "none", "--select-bootstrap", str(a.bootstrap), "--json", out])
                    seconds = time.perf_counter() - start
                    chosen, jumps = chosen_terms(json.load(open(out))["selection"]["jump"])
                    exact = sorted(chosen) == sorted(support)
                    hits += exact
                    rows.append({"truth": name, "sigma": sigma, "seed": seed, "bootstrap": a.bootstrap,
                                 "jumps": jumps, "exact": int(exact), "chosen": " ".join(chosen),
                                 "seconds": f"{seconds:.3f}"})
                print(f"{name} sigma {sigma}: exact support in {hits} of {a.draws} draws", flush=True)
    if a.out:
        with open(a.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Support recovery of hysid's candidate-term selection and of the SINDy reference, over noise draws.

For each system (the paper's Sec. 5 system, a ball with quadratic drag; analysis/select/*.toml) and
each sigma: `hysid simulate` of the truth with seeds 1..N, then on each record
  hysid:  `hysid identify --model-file LIBRARY --refine none --json` (the whole pipeline: its own jump
          detection, the selection on the integral rows with its bootstrap, which drops the chosen
          terms fewer than half of its draws chose),
  SINDy:  sindy_reference.identify_row on the same samples with the true jump times (column j),
and whether each chose exactly the true support. Prints one line per (system, sigma) and writes the
rows to --out (CSV).

Usage: support_study.py --hysid build/bin/hysid [--draws 50] [--sigmas 0.01,0.1] [--systems s5,ball]
                        [--out results/select/support.csv]
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import sindy_reference as sindy  # noqa: E402

SYSTEMS = {
    "s5": {"truth": "s5_truth.toml", "library": "s5_library.toml", "support": ["x", "v"]},
    "ball": {"truth": "ball_truth.toml", "library": "ball_library.toml", "support": ["1", "abs(v)*v"]},
}


def library_terms(path):
    with open(path, "rb") as f:
        spec = tomllib.load(f)
    (row, terms), = spec["flow"]["candidates"].items()
    return spec["states"], row, terms


def run_hysid(hysid, library, data, out_json):
    p = subprocess.run([hysid, "identify", "--model-file", library, "--data", data, "--refine", "none",
                        "--json", out_json], capture_output=True, text=True)
    if p.returncode not in (0, 1):
        raise RuntimeError(f"hysid identify failed ({p.returncode}): {p.stderr.strip()}")
    with open(out_json) as f:
        selection = json.load(f)["selection"]
    return [t["term"] for t in selection["terms"] if t["chosen"]], selection["seconds"]


def run_reference(data, states, row, terms):
    table = np.genfromtxt(data, delimiter=",", names=True)
    columns = {name: table[f"{name}_noisy"] if f"{name}_noisy" in table.dtype.names else table[name]
               for name in states}
    start = time.perf_counter()
    support, _ = sindy.identify_row(table["t"], columns, table["j"].astype(int), row, terms)
    return [term for term, chosen in zip(terms, support) if chosen], time.perf_counter() - start


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--draws", type=int, default=50)
    ap.add_argument("--sigmas", default="0.01,0.1")
    ap.add_argument("--systems", default="s5,ball")
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.systems.split(","):
            system = SYSTEMS[name]
            truth, library = (os.path.join(HERE, system[k]) for k in ("truth", "library"))
            states, row, terms = library_terms(library)
            for sigma in (float(s) for s in args.sigmas.split(",")):
                hits = {"hysid": 0, "sindy": 0}
                seconds = {"hysid": 0.0, "sindy": 0.0}
                for seed in range(1, args.draws + 1):
                    data = os.path.join(tmp, f"{name}.csv")
                    subprocess.run([args.hysid, "simulate", "--model-file", truth, "--sigma", str(sigma),
                                    "--seed", str(seed), "--out", data], check=True, capture_output=True)
                    chosen_h, sec_h = run_hysid(args.hysid, library, data, os.path.join(tmp, "id.json"))
                    chosen_s, sec_s = run_reference(data, states, row, terms)
                    for who, chosen, sec in (("hysid", chosen_h, sec_h), ("sindy", chosen_s, sec_s)):
                        exact = sorted(chosen) == sorted(system["support"])
                        hits[who] += exact
                        seconds[who] += sec
                        rows.append({"system": name, "sigma": sigma, "seed": seed, "method": who,
                                     "exact": int(exact), "chosen": " ".join(chosen), "seconds": f"{sec:.3f}"})
                print(f"{name} sigma {sigma:g}: exact support hysid {hits['hysid']}/{args.draws}, "
                      f"SINDy {hits['sindy']}/{args.draws} (mean selection time hysid "
                      f"{seconds['hysid'] / args.draws:.2f} s, SINDy {seconds['sindy'] / args.draws:.2f} s)",
                      flush=True)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()

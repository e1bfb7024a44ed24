#!/usr/bin/python3
"""Support recovery of hysid's candidate-term selection and of the SINDy reference, over noise draws.

For each system (the paper's Sec. 5 system, a ball with quadratic drag, a spring-mass hopper with
flight and stance modes, a thermostat with heater off and on; analysis/select/*.toml) and each sigma:
`hysid simulate` of the truth with seeds 1..N, then on each record
  hysid:  `hysid identify --model-file LIBRARY --refine none --json` (the whole pipeline: its own jump
          and switch detection, the selection on the integral rows of each mode with its bootstrap,
          which drops the chosen terms fewer than half of its draws chose),
  SINDy:  sindy_reference.select on the same samples with the true jump times and modes (columns j
          and q), per mode on the central differences inside that mode's flow segments,
and whether each chose exactly the true support (of every mode). With `--refine ml` hysid refines
the chosen model and drops the chosen terms the fit does not support (method `hysid+ml`, `seconds` the
whole identify's wall time). Prints one line per (system, sigma) and writes the rows to --out (CSV);
`chosen` lists MODE:TERM for the systems with modes.

Usage: support_study.py --hysid build/bin/hysid [--draws 50] [--sigmas 0.01,0.1] [--systems s5,ball]
                        [--refine none|ml] [--out results/select/support.csv]
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

# The true support per mode (None: a model without modes).
SYSTEMS = {
    "s5": {"truth": "s5_truth.toml", "library": "s5_library.toml", "support": {None: ["x", "v"]}},
    "ball": {"truth": "ball_truth.toml", "library": "ball_library.toml", "support": {None: ["1", "abs(v)*v"]}},
    "hopper": {"truth": "hopper_truth.toml", "library": "hopper_library.toml",
               "support": {"flight": ["1", "abs(v)*v"], "stance": ["1", "y"]}},
    "thermostat": {"truth": "thermostat_truth.toml", "library": "thermostat_library.toml",
                   "support": {"off": ["1", "T - 20"], "on": ["1", "T - 20"]}},
}


def library_terms(path):
    """The states, the modes (empty: none) and per mode (None without modes) its row and terms."""
    with open(path, "rb") as f:
        spec = tomllib.load(f)
    flows = spec["flow"] if isinstance(spec["flow"], list) else [spec["flow"]]
    per_mode = {}
    for flow in flows:
        if "candidates" in flow:
            (row, terms), = flow["candidates"].items()
            per_mode[flow.get("mode")] = (row, terms)
    return spec["states"], spec.get("modes", []), per_mode


def run_hysid(hysid, library, data, out_json, refine):
    start = time.perf_counter()
    p = subprocess.run([hysid, "identify", "--model-file", library, "--data", data, "--refine", refine,
                        "--json", out_json], capture_output=True, text=True)
    wall = time.perf_counter() - start
    if p.returncode not in (0, 1):
        raise RuntimeError(f"hysid identify failed ({p.returncode}): {p.stderr.strip()}")
    with open(out_json) as f:
        selection = json.load(f)["selection"]
    chosen = [(t.get("mode"), t["term"]) for t in selection["terms"] if t["chosen"]]
    return chosen, selection["seconds"] if refine == "none" else wall


def run_reference(data, states, modes, per_mode):
    """SINDy per mode on the true flow segments of that mode (split at every jump and mode change)."""
    table = np.genfromtxt(data, delimiter=",", names=True)
    columns = {name: table[f"{name}_noisy"] if f"{name}_noisy" in table.dtype.names else table[name]
               for name in states}
    q = table["q"].astype(int) if modes else np.zeros(len(table["t"]), dtype=int)
    pieces = np.concatenate([[0], np.cumsum((np.diff(table["j"]) != 0) | (np.diff(q) != 0))])
    start = time.perf_counter()
    chosen = []
    for mode, (row, terms) in per_mode.items():
        index = modes.index(mode) if mode is not None else 0
        segments = [s for s in sindy.flow_segments(pieces) if q[s[0]] == index]
        idx, dxdt, seg = sindy.central_differences(table["t"], columns[row], segments)
        theta = sindy.evaluate_terms(terms, {name: x[idx] for name, x in columns.items()})
        support, _ = sindy.select(theta, dxdt, seg)
        chosen += [(mode, term) for term, c in zip(terms, support) if c]
    return chosen, time.perf_counter() - start


def exact(chosen, support):
    return sorted((m or "", t) for m, t in chosen) == sorted((m or "", t) for m, ts in support.items() for t in ts)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--draws", type=int, default=50)
    ap.add_argument("--sigmas", default="0.01,0.1")
    ap.add_argument("--systems", default="s5,ball")
    ap.add_argument("--refine", choices=("none", "ml"), default="none")
    ap.add_argument("--out", default="")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.systems.split(","):
            system = SYSTEMS[name]
            truth, library = (os.path.join(HERE, system[k]) for k in ("truth", "library"))
            states, modes, per_mode = library_terms(library)
            for sigma in (float(s) for s in args.sigmas.split(",")):
                ours = "hysid" if args.refine == "none" else "hysid+ml"
                hits = {ours: 0, "sindy": 0}
                seconds = {ours: 0.0, "sindy": 0.0}
                for seed in range(1, args.draws + 1):
                    data = os.path.join(tmp, f"{name}.csv")
                    subprocess.run([args.hysid, "simulate", "--model-file", truth, "--sigma", str(sigma),
                                    "--seed", str(seed), "--out", data], check=True, capture_output=True)
                    chosen_h, sec_h = run_hysid(args.hysid, library, data, os.path.join(tmp, "id.json"), args.refine)
                    chosen_s, sec_s = run_reference(data, states, modes, per_mode)
                    for who, chosen, sec in ((ours, chosen_h, sec_h), ("sindy", chosen_s, sec_s)):
                        hit = exact(chosen, system["support"])
                        hits[who] += hit
                        seconds[who] += sec
                        text = " ".join(f"{m}:{t}" if m else t for m, t in chosen)
                        rows.append({"system": name, "sigma": sigma, "seed": seed, "method": who,
                                     "exact": int(hit), "chosen": text, "seconds": f"{sec:.3f}"})
                print(f"{name} sigma {sigma:g}: exact support {ours} {hits[ours]}/{args.draws}, "
                      f"SINDy {hits['sindy']}/{args.draws} (mean time {ours} "
                      f"{seconds[ours] / args.draws:.2f} s, SINDy {seconds['sindy'] / args.draws:.2f} s)",
                      flush=True)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()

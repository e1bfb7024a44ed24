#!/usr/bin/env python3
"""What knowing the structure buys: the floor-ceiling ball (two jump maps, e_floor and e_ceiling)
identified with its own model and with the one-map model (one restitution e for both walls,
experiments/studies/floor-ceiling-one-map.toml) on the same simulated data, in units of the two-map
Cramér–Rao sd.

Usage: scripts/one_map_baseline.py HYSID [OUT_DIR] [--seeds N] [--sigma S,S,...]
  OUT_DIR (default results/floor-ceiling-baseline) gets trials.csv (one row per seed, σ and model)
  and summary.csv (per σ: the two-map CRLB sd of g, e_floor, e_ceiling; per model the fits whose
  status is ok, and the mean |θ̂ − θ| / sd of g, of the floor's and of the ceiling's restitution,
  where the one-map model's single ê stands for both). Every run: `hysid simulate --seed s --sigma σ`
  of examples/floor-ceiling/model.toml (its defaults: ξ0 = (1, 15), 5 s at 1 ms), then
  `hysid identify --refine ml --json` with each model file; a fit that is not ok keeps the recursive
  estimate (its status is in trials.csv and counted in summary.csv).
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TWO = os.path.join(ROOT, "examples/floor-ceiling/model.toml")
ONE = os.path.join(ROOT, "experiments/studies/floor-ceiling-one-map.toml")
TRUTH = {"g": 9.81, "e_floor": 0.9, "e_ceiling": 0.7}


def run(cmd):
    return subprocess.run(cmd, check=False, capture_output=True, text=True)


def crlb_sd(hysid, sigma):
    """The two-map model's CRLB sd of g, e_floor, e_ceiling at σ (hysid crlb's lines 'NAME = v sd s')."""
    out = run([hysid, "crlb", "--model-file", TWO, "--sigma", str(sigma)])
    if out.returncode != 0:
        sys.exit(f"hysid crlb failed: {out.stdout}{out.stderr}")
    sd = {}
    for name in TRUTH:
        m = re.search(rf"^\s+{name}\s+=\s+\S+\s+sd (\S+)", out.stdout, re.M)
        sd[name] = float(m.group(1))
    return sd


def identify(hysid, model, data, tmp):
    js = os.path.join(tmp, "fit.json")
    out = run([hysid, "identify", "--model-file", model, "--data", data, "--refine", "ml", "--json", js])
    if out.returncode not in (0, 1):
        return "error", {}
    j = json.load(open(js))
    return j["status"], dict(zip(j["names"], j["estimate"]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("hysid")
    ap.add_argument("out", nargs="?", default=os.path.join(ROOT, "results/floor-ceiling-baseline"))
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--sigma", default="1e-3,1e-2,2e-2")
    a = ap.parse_args()
    a.hysid = os.path.abspath(a.hysid)
    os.makedirs(a.out, exist_ok=True)
    rows, summary = [], []
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "sim.csv")
        for sigma in [float(s) for s in a.sigma.split(",")]:
            sd = crlb_sd(a.hysid, sigma)
            errs = {"two-map": [], "one-map": []}
            for seed in range(1, a.seeds + 1):
                sim = run([a.hysid, "simulate", "--model-file", TWO, "--sigma", str(sigma), "--seed", str(seed),
                           "--out", data])
                if sim.returncode != 0:
                    sys.exit(f"hysid simulate failed: {sim.stdout}{sim.stderr}")
                for label, model in (("two-map", TWO), ("one-map", ONE)):
                    status, est = identify(a.hysid, model, data, tmp)
                    floor = est.get("e_floor", est.get("e"))
                    ceiling = est.get("e_ceiling", est.get("e"))
                    g = est.get("g")
                    rows.append([sigma, seed, label, status, g, floor, ceiling])
                    if None not in (g, floor, ceiling):
                        errs[label].append((status == "ok", abs(g - TRUTH["g"]) / sd["g"],
                                            abs(floor - TRUTH["e_floor"]) / sd["e_floor"],
                                            abs(ceiling - TRUTH["e_ceiling"]) / sd["e_ceiling"]))
            for label, e in errs.items():
                n = len(e)
                mean = [sum(x[i] for x in e) / n if n else float("nan") for i in (1, 2, 3)]
                summary.append([sigma, label, a.seeds, n, sum(x[0] for x in e), sd["g"], sd["e_floor"],
                                sd["e_ceiling"]] + mean)
    with open(os.path.join(a.out, "trials.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["sigma", "seed", "model", "status", "g_hat", "e_floor_hat", "e_ceiling_hat"])
        w.writerows([[repr(x) if isinstance(x, float) else x for x in r] for r in rows])
    with open(os.path.join(a.out, "summary.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["sigma", "model", "seeds", "estimates", "fits_ok", "crlb_sd_g", "crlb_sd_e_floor",
                    "crlb_sd_e_ceiling", "g_err_sd_mean", "e_floor_err_sd_mean", "e_ceiling_err_sd_mean"])
        w.writerows([[repr(x) if isinstance(x, float) else x for x in r] for r in summary])
    print(f"wrote {a.out}/trials.csv, summary.csv")


if __name__ == "__main__":
    main()

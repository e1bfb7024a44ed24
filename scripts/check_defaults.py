#!/usr/bin/python3
"""`hysid identify` with its defaults on simulated data of every built-in model, against the
Cramér–Rao bound: for each model and seed, `hysid simulate --sigma SIGMA --seed S`, then
`hysid identify --json` (residual detector + ML refinement, no tuning flags). Per estimate: the
error in CRLB standard deviations (|θ̂ − θ| / sd, truth from the simulation's sidecar) and the
printed standard error over the CRLB sd. Fails (exit 1) when a fit is not ok, an error exceeds
MAX_SD sd, or a standard error is off the bound's by more than SE_TOL.

Usage: scripts/check_defaults.py HYSID [--seeds N] [--sigma S] [--max-sd 4] [--se-tol 0.2]
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

MODELS = ["impact-msd", "bouncing-ball", "impact-pendulum"]


def truth_of(name, names, sidecar):
    """A parameter's true value, or x0's: the x0[...] names come in state order."""
    if name.startswith("x0["):
        return sidecar["x0"][[n for n in names if n.startswith("x0[")].index(name)]
    return sidecar["parameters"][name]


def one(hysid, model, seed, sigma, work):
    data = work / f"{model}-{seed}.csv"
    fit = work / f"{model}-{seed}.fit.json"
    subprocess.run([hysid, "simulate", "--model", model, "--sigma", str(sigma), "--seed", str(seed),
                    "--out", str(data)], check=True, capture_output=True)
    subprocess.run([hysid, "identify", "--model", model, "--data", str(data), "--json", str(fit)],
                   capture_output=True)
    sidecar = json.loads(data.with_suffix(".json").read_text())
    f = json.loads(fit.read_text())
    rows = []
    for i, name in enumerate(f["names"]):
        sd = f["crlb_sd"][i] if f.get("crlb_sd") else float("nan")
        err = abs(f["estimate"][i] - truth_of(name, f["names"], sidecar)) / sd
        se = f["standard_errors"][i] / sd if f.get("standard_errors") else float("nan")
        rows.append((name, err, se))
    return f["status"], rows


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("hysid")
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--sigma", type=float, default=0.01)
    p.add_argument("--max-sd", type=float, default=4.0)
    p.add_argument("--se-tol", type=float, default=0.2)
    a = p.parse_args()
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        for model in MODELS:
            ok, worst, se_lo, se_hi = 0, 0.0, float("inf"), 0.0
            for seed in range(1, a.seeds + 1):
                status, rows = one(a.hysid, model, seed, a.sigma, Path(tmp))
                ok += status == "ok"
                for name, err, se in rows:
                    worst, se_lo, se_hi = max(worst, err), min(se_lo, se), max(se_hi, se)
                    if not err <= a.max_sd or not abs(se - 1.0) <= a.se_tol:
                        print(f"  {model} seed {seed} {name}: error {err:.2f} sd, se/sd {se:.3f}")
                if status != "ok":
                    print(f"  {model} seed {seed}: status {status}")
            print(f"{model}: {ok}/{a.seeds} ok, worst error {worst:.2f} CRLB sd, "
                  f"se/CRLB sd {se_lo:.3f}-{se_hi:.3f}")
            failed |= ok < a.seeds or worst > a.max_sd or max(abs(se_lo - 1), abs(se_hi - 1)) > a.se_tol
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

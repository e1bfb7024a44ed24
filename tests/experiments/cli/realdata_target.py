#!/usr/bin/env python3
"""Real-world data target: the §5 system (impact-msd) measured in 3 runs at irregular times (each sample
off its grid point by up to ±1 % of δt), with 10 rows of missing values, in RFC 4180 files (one with a
quoted header and CRLF line ends, one holding two runs in a `run` column), identified by `hysid identify`
with its defaults (residual detector, rls, maximum-likelihood refinement). Every estimate of α and β must
lie within 4 standard errors of the truth, and the refinement's status must be ok.

The states at the irregular times are exact: `hysid simulate` (noise-free, rtol 1e-12) gives the
trajectory on the grid and its jumps; each irregular sample is the exact linear flow
ξ' = [[0, 1], [-a, -b]]ξ carried from the grid point or jump of its own segment (a Taylor series of the
matrix exponential over at most 1 % of δt). Gaussian noise σ = 0.01 is added with a fixed seed.

Usage: realdata_target.py HYSID WORKDIR [SEED]   (SEED: the noise, jitter and gap draw; default 2026)
"""
import csv
import json
import math
import os
import random
import subprocess
import sys

A, B, LAMBDA, MU = 5.0, 0.1, 0.99, 0.0
DT, JITTER, SIGMA = 5e-4, 0.01, 0.01
X0S = [(20.0, 0.0), (15.0, 5.0), (10.0, -10.0)]
MISSING = 10


def flow(x, tau):
    """exp(A tau) x for A = [[0, 1], [-a, -b]], |tau| ≤ 1e-5 (Taylor to order 8)."""
    out, term = list(x), list(x)
    for k in range(1, 9):
        term = [term[1] * tau / k, (-A * term[0] - B * term[1]) * tau / k]
        out = [out[0] + term[0], out[1] + term[1]]
    return out


def simulate(hysid, d, r, x0):
    traj, jumps = os.path.join(d, f"grid{r}.csv"), os.path.join(d, f"jumps{r}.csv")
    subprocess.run([hysid, "simulate", "--x0", f"{x0[0]},{x0[1]}", "--out", traj, "--jumps-out", jumps],
                   check=True, capture_output=True)
    with open(traj) as f:
        rows = [(float(r["t"]), int(r["j"]), float(r["true_x"]), float(r["true_v"])) for r in csv.DictReader(f)]
    with open(jumps) as f:
        events = [(float(r["t_jump"]), (float(r["pre_x"]), float(r["pre_v"])),
                   (float(r["post_x"]), float(r["post_v"]))) for r in csv.DictReader(f)]
    return rows, events


def state_at(t, k, rows, events):
    """ξ at time t near grid sample k, on the segment t belongs to (jumps at t_j: after, the post state)."""
    tk, jk, x1, x2 = rows[k]
    seg = sum(1 for e in events if e[0] <= t)
    if seg == jk:
        return flow((x1, x2), t - tk)
    if seg > jk:  # a jump in (t_k, t]: from its post state
        te, _, post = events[seg - 1]
        return flow(post, t - te)
    te, pre, _ = events[seg]  # a jump in (t, t_k]: back from its pre state
    return flow(pre, t - te)


def measured(rows, events, rng):
    out = []
    for k, (tk, _, _, _) in enumerate(rows):
        t = tk + (rng.uniform(-JITTER, JITTER) * DT if k > 0 else 0.0)
        x = state_at(t, k, rows, events)
        out.append([t, x[0] + rng.gauss(0.0, SIGMA), x[1] + rng.gauss(0.0, SIGMA)])
    return out


def cell(v):
    return repr(v)


def write_files(d, runs, rng):
    # 10 missing rows, away from the first samples: empty, nan, NA, one state only.
    spots = sorted(rng.sample(range(100, len(runs[0]) - 100), MISSING))
    kinds = ["", "nan", "NA", "NaN"]
    for i, k in enumerate(spots):
        run = runs[i % 3]
        run[k][1 + (i % 2)] = kinds[i % 4]
    a = os.path.join(d, "run_a.csv")
    with open(a, "w", newline="") as f:  # quoted header, CRLF
        f.write('"time","pos","vel"\r\n')
        for t, x, v in runs[0]:
            f.write(f"{cell(t)},{cell(x) if x != '' else ''},{cell(v) if v != '' else ''}\r\n".replace("'", ""))
    bc = os.path.join(d, "runs_bc.csv")
    with open(bc, "w", newline="") as f:  # two runs in a run column, quoted cells
        f.write("run,time,pos,vel\n")
        for r in (1, 2):
            for t, x, v in runs[r]:
                f.write(f'{r},{cell(t)},"{x}",{v}\n')
    return a, bc


def main():
    hysid, d = sys.argv[1], sys.argv[2]
    os.makedirs(d, exist_ok=True)
    rng = random.Random(int(sys.argv[3]) if len(sys.argv) > 3 else 2026)
    runs = [measured(*simulate(hysid, d, r, x0), rng) for r, x0 in enumerate(X0S)]
    a, bc = write_files(d, runs, rng)
    out = os.path.join(d, "fit.json")
    p = subprocess.run([hysid, "identify", "--data", a, "--data", bc, "--columns", "t=time,pos,vel",
                        "--json", out], capture_output=True, text=True)
    print(p.stdout)
    print(p.stderr, file=sys.stderr)
    if p.returncode != 0:
        sys.exit(f"hysid identify exited {p.returncode}")
    fit = json.load(open(out))
    truth = {"a": A, "b": B, "lambda": LAMBDA, "mu": MU}
    worst = 0.0
    for name, est, se in zip(fit["names"], fit["estimate"], fit["standard_errors"]):
        if name not in truth:  # the first chain's initial state
            continue
        z = abs(est - truth[name]) / se
        worst = max(worst, z)
        print(f"{name}: {est:.10g} ± {se:.3g}, truth {truth[name]}: |error|/se = {z:.2f}")
    print(f"max |error|/se = {worst:.2f} over the {len(truth)} estimates of alpha and beta; "
          f"chains {fit['chains_used']}")
    if sum(fit["chain_samples_used"]) != fit["samples_used"] or \
            len(fit["chain_samples_used"]) != len(fit["chain_x0"]):
        sys.exit("FAILED: the per-chain sample counts do not add up to samples_used")
    if fit["status"] != "ok" or worst > 4.0 or not set(truth) <= set(fit["names"]):
        sys.exit("FAILED: status not ok or an estimate beyond 4 standard errors")


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The hold-out by chain of `hysid compare` (ctest compare.chains_*).

--case hand: three runs of x = x0_c + a t + noise, candidates drift.toml (x' = a) and drift-decay.toml.
  drift.toml's held-out forecast is computed here independently: for each chain c, the linear least
  squares of the other chains and chain c's head (its first max(ceil(0.1 n_c), 5) samples) for a and
  each chain's x0, then x0_c + a t over the rest of chain c; the RMSE and score (RMSE / sd of the
  scored samples) pooled over the chains must equal the report's to 1e-4 relative, with the folds,
  chains and scored-sample count. (The refinement stops at a relative cost decrease of 1e-9, its
  estimates here within 4e-6 of the least squares, the RMSE within 1e-5; a head one sample longer or
  shorter moves the RMSE by 0.2-1 %.)
--case thermostat: three runs of the 2-mode thermostat from different temperatures; candidates with 1
  and 2 modes. The true file ranks first by the chain hold-out, the 1-mode file's held-out error is
  larger (by 2x or more), the true file's RMSE is within 1.5 sigma, and the --csv carries the --json's
  score and hold-out kind.

    /usr/bin/python3 tests/compare/chains.py --hysid build/bin/hysid --work DIR --case hand
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def write(path, t, x, name):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", name])
        for a, b in zip(t, x):
            w.writerow([repr(float(a)), repr(float(b))])


def compare(hysid, work, files, data, extra=()):
    report, table = os.path.join(work, "compare.json"), os.path.join(work, "compare.csv")
    cmd = [hysid, "compare", *files, "--holdout-by", "chain", "--json", report, "--csv", table, *extra]
    for d in data:
        cmd += ["--data", d]
    p = subprocess.run(cmd, capture_output=True, text=True)
    print(p.stdout + p.stderr)
    if p.returncode != 0:
        raise SystemExit(f"hysid compare exited {p.returncode}")
    with open(report) as f, open(table) as g:
        return json.load(f), list(csv.DictReader(g))


def hand_forecast(t, y, head_fraction=0.1, min_samples=5):
    """drift.toml's chain hold-out by hand: per fold the least squares of [a, x0_1..x0_C], pooled errors."""
    errors, scored_y = [], []
    for c in range(len(t)):
        head = max(math.ceil(head_fraction * len(t[c])), min_samples)
        rows, values = [], []
        for d in range(len(t)):
            n = head if d == c else len(t[d])
            for k in range(n):
                row = np.zeros(1 + len(t))
                row[0], row[1 + d] = t[d][k] - t[d][0], 1.0
                rows.append(row)
                values.append(y[d][k])
        theta = np.linalg.lstsq(np.array(rows), np.array(values), rcond=None)[0]
        rest = slice(head, len(t[c]))
        predicted = theta[1 + c] + theta[0] * (t[c][rest] - t[c][0])
        errors.extend(y[c][rest] - predicted)
        scored_y.extend(y[c][rest])
    errors, scored_y = np.array(errors), np.array(scored_y)
    rmse = math.sqrt(np.mean(errors ** 2))
    return rmse, rmse / np.std(scored_y), len(errors)


def case_hand(hysid, work):
    rng = np.random.default_rng(7)
    t = [np.arange(0.0, n) for n in (101, 81, 121)]
    y = [x0 + 0.05 * tc + 0.05 * rng.standard_normal(tc.size) for x0, tc in zip((1.0, 2.0, 3.0), t)]
    data = [os.path.join(work, f"run{c + 1}.csv") for c in range(3)]
    for path, tc, yc in zip(data, t, y):
        write(path, tc, yc, "x")
    files = [os.path.join(HERE, "drift.toml"), os.path.join(HERE, "drift-decay.toml")]
    report, _ = compare(hysid, work, files, data)
    h = report["models"][0]["holdout"]
    rmse, score, scored = hand_forecast(t, y)
    print(f"by hand: rmse {rmse!r}, score {score!r}, {scored} samples; hysid: {h}")
    ok = (h["done"] and h["by"] == "chain" and h["fits"] == 3 and h["chains_held"] == [1, 2, 3]
          and h["samples"] == scored and math.isclose(h["rmse"][0], rmse, rel_tol=1e-4)
          and math.isclose(h["score"], score, rel_tol=1e-4) and report["holdout_by"] == "chain")
    return ok


def case_thermostat(hysid, work):
    truth = os.path.join(HERE, "thermostat-2.toml")
    data = []
    for i, x0 in enumerate(("20", "19.7", "20.3"), start=1):
        sim = os.path.join(work, f"sim{i}.csv")
        subprocess.run([hysid, "simulate", "--model-file", truth, "--sigma", "0.05", "--seed", str(i), "--x0", x0,
                        "--t-end", "300", "--out", sim], check=True, capture_output=True)
        with open(sim) as f:
            rows = list(csv.DictReader(f))
        data.append(os.path.join(work, f"run{i}.csv"))
        write(data[-1], [float(r["t"]) for r in rows], [float(r["T"]) for r in rows], "T")
    files = [os.path.join(HERE, "thermostat-1.toml"), truth]
    report, table = compare(hysid, work, files, data)
    one, two = (m["holdout"] for m in report["models"])
    print(f"held-out score: 1 mode {one['score']}, 2 modes {two['score']}; rmse {one['rmse']}, {two['rmse']}")
    ok = report["best"]["holdout"] == truth and two["rank"] == 1 and one["rank"] == 2
    ok = ok and one["rmse"][0] > 2.0 * two["rmse"][0] and two["rmse"][0] < 1.5 * 0.05
    ok = ok and two["fits"] == 3 and two["chains_held"] == [1, 2, 3]
    for row, m in zip(table, report["models"]):
        ok = ok and row["holdout_by"] == "chain" and math.isclose(float(row["holdout_score"]), m["holdout"]["score"],
                                                                  rel_tol=1e-15)
        ok = ok and int(row["holdout_rank"]) == m["holdout"]["rank"]
    return ok


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--case", required=True, choices=["hand", "thermostat"])
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    ok = (case_hand if a.case == "hand" else case_thermostat)(a.hysid, a.work)
    print("ok" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

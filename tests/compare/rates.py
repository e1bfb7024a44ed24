#!/usr/bin/python3
"""How often `hysid compare` picks the true mode count, over noise draws.

For each system (thermostat, hopper) the 2-mode file is the truth: draw d is
`hysid simulate --model-file SYSTEM-2.toml --sigma S --seed d`, of which the data keep the time and the
measured states. `hysid compare SYSTEM-1.toml SYSTEM-2.toml SYSTEM-3.toml --data draw.csv --json ...` then
ranks the three candidates; a criterion picks the true count when SYSTEM-2 is its best.
With --chains C (C >= 2) a draw is C runs, one data file each: run i (1-based) simulated from the i-th
initial state of the system's list below with seed 1000 d + i; --holdout-by chain then leaves each run
out in turn (--holdout-by tail, the default, holds out each run's tail).

    /usr/bin/python3 tests/compare/rates.py --hysid build/bin/hysid --work /tmp/compare-rates --draws 50

prints one row per system and criterion (picks of 1, 2, 3 modes, none) and writes DIR/draws.csv
(one row per draw) and DIR/rates.csv. --check exits 1 unless BIC picks the true count in at least
--target of the draws of every system.
"""
import argparse
import concurrent.futures
import csv
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SYSTEMS = {  # name: (noise sd of the measured states, measured columns)
    "thermostat": (0.05, ["T"]),
    "hopper": (0.002, ["y"]),
}
X0 = {  # name: the initial state of run i of a draw with --chains (the first is the file's default)
    "thermostat": ["20", "19.7", "20.3", "19.85", "20.15"],
    "hopper": ["1.3,0", "1.2,0", "1.4,0", "1.25,0", "1.35,0"],
}
CRITERIA = ["aic", "bic", "holdout"]


def model(system, modes):
    return os.path.join(HERE, f"{system}-{modes}.toml")


def simulate(hysid, out, system, seed, x0, name):
    """One run of the true file as a data file of time and the measured columns."""
    sigma, measured = SYSTEMS[system]
    sim = os.path.join(out, f"sim{name}.csv")
    cmd = [hysid, "simulate", "--model-file", model(system, 2), "--sigma", str(sigma), "--seed", str(seed),
           "--out", sim]
    subprocess.run(cmd + (["--x0", x0] if x0 else []), check=True, capture_output=True)
    with open(sim) as f:
        rows = list(csv.DictReader(f))
    data = os.path.join(out, f"data{name}.csv")
    with open(data, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t"] + measured)
        for r in rows:
            w.writerow([r["t"]] + [r[c] for c in measured])
    return data


def run_draw(hysid, work, system, draw, a):
    out = os.path.join(work, system, f"draw{draw:02d}")
    report = os.path.join(out, "compare.json")
    if a.resume and os.path.exists(report):
        return summarise(system, draw, 0, report)
    os.makedirs(out, exist_ok=True)
    if a.chains <= 1:
        files = [simulate(hysid, out, system, draw, None, "")]
    else:
        files = [simulate(hysid, out, system, 1000 * draw + i, X0[system][i - 1], str(i)) for i in range(1, a.chains + 1)]
    cmd = [hysid, "compare"] + [model(system, m) for m in (1, 2, 3)] + ["--holdout", str(a.holdout),
                                                                         "--holdout-by", a.holdout_by,
                                                                         "--json", report]
    for f in files:
        cmd += ["--data", f]
    p = subprocess.run(cmd, capture_output=True, text=True)
    with open(os.path.join(out, "compare.txt"), "w") as f:
        f.write(p.stdout + p.stderr)
    if p.returncode not in (0, 1) or not os.path.exists(report):
        return {"system": system, "draw": draw, "exit": p.returncode}
    return summarise(system, draw, p.returncode, report)


def summarise(system, draw, code, report):
    """One draw's row from its compare.json: each criterion's pick (1, 2, 3 modes; 0: none)."""
    with open(report) as f:
        j = json.load(f)
    row = {"system": system, "draw": draw, "exit": code}
    for c in CRITERIA:
        best = j["best"][c]
        row[c] = 0 if best is None else int(os.path.basename(best).split("-")[-1].split(".")[0])
    for m in j["models"]:
        n = int(os.path.basename(m["file"]).split("-")[-1].split(".")[0])
        row[f"status{n}"] = m["status"]
        row[f"ranked{n}"] = int(m["ranked"])
        row[f"delta_aic{n}"] = m["delta_aic"]
        row[f"delta_bic{n}"] = m["delta_bic"]
        row[f"holdout_score{n}"] = m["holdout"]["score"]
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--draws", type=int, default=50)
    ap.add_argument("--first", type=int, default=1, help="the first draw's seed")
    ap.add_argument("--systems", default=",".join(SYSTEMS))
    ap.add_argument("--holdout", type=float, default=0.25)
    ap.add_argument("--holdout-by", default="tail", choices=["tail", "chain"])
    ap.add_argument("--chains", type=int, default=1, choices=range(1, 6), metavar="1..5",
                    help="runs per draw (data files), each from its own initial state")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--resume", action="store_true", help="reuse the draws whose compare.json exists")
    ap.add_argument("--target", type=float, default=0.95)
    ap.add_argument("--gate", help="skip (exit 77) unless this environment variable is 1")
    a = ap.parse_args()
    if a.gate and os.environ.get(a.gate) != "1":
        print(f"skipped: set {a.gate}=1 to run")
        return 77
    os.makedirs(a.work, exist_ok=True)
    systems = a.systems.split(",")
    tasks = [(s, d) for s in systems for d in range(a.first, a.first + a.draws)]
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        rows = list(pool.map(lambda t: run_draw(a.hysid, a.work, t[0], t[1], a), tasks))
    keys = sorted({k for r in rows for k in r}, key=lambda k: (k not in ("system", "draw", "exit"), k))
    with open(os.path.join(a.work, "draws.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    ok = True
    print(f"{'system':<11} {'criterion':<9} {'draws':>5} {'1 mode':>6} {'2 modes':>7} {'3 modes':>7} {'none':>5} "
          f"{'true':>6}")
    rates = []
    for s in systems:
        mine = [r for r in rows if r["system"] == s]
        for c in CRITERIA:
            picks = [r.get(c, 0) for r in mine]
            count = {m: picks.count(m) for m in (1, 2, 3, 0)}
            share = count[2] / len(mine)
            rates.append({"system": s, "criterion": c, "draws": len(mine), "pick1": count[1], "pick2": count[2],
                          "pick3": count[3], "none": count[0], "true_share": share})
            print(f"{s:<11} {c:<9} {len(mine):>5} {count[1]:>6} {count[2]:>7} {count[3]:>7} {count[0]:>5} "
                  f"{share:>6.0%}")
            if c == "bic" and share < a.target:
                ok = False
        for n in (1, 2, 3):
            statuses = {}
            for r in mine:
                statuses[r.get(f"status{n}", "no report")] = statuses.get(r.get(f"status{n}", "no report"), 0) + 1
            print(f"  {s}-{n}: " + "; ".join(f"{k} x{v}" for k, v in sorted(statuses.items())))
    with open(os.path.join(a.work, "rates.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rates[0]))
        w.writeheader()
        w.writerows(rates)
    if a.check and not ok:
        print(f"FAILED: BIC picks the true mode count in fewer than {a.target:.0%} of the draws")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

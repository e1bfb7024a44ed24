#!/usr/bin/python3
"""The hopper's air drag against its bound over noise draws (truth.toml; results/hopper-drag).

    bench/hopper-drag/run.py --hysid build/bin/hysid [--seeds 20] [--csv results/hopper-drag/draws.csv]

Per seed: `hysid simulate --model-file truth.toml --sigma 1e-4 --seed S` (10 s at 1 kHz, 10 001
samples, 15 hops), `hysid identify` with its defaults from the truth's values, and `hysid crlb` on
the same samples. The drag c is told by each flight's drift from the drag-free parabola, over more
samples than a segment of the multiple shooting by time. Writes one row per seed and parameter
(status, estimate, SE, the CRLB sd) to --csv, and prints per parameter the spread of the estimates
and their mean SE, each over the CRLB sd.
"""
import csv
import re
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from own_system import identify, run_seeds, user_data  # noqa: E402

SIGMA = 1e-4
TRUTH = {"g": 9.81, "w2": 400.0, "c": 0.1, "L0": 1.0, "x0[y]": 1.5, "x0[v]": 0.0}
CRLB_LINE = re.compile(r"^\s+(\S+)\s+=\s+\S+\s+sd\s+(\S+)")
rows = []


def each(hysid, work, seed, args):
    data = user_data(hysid, HERE / "truth.toml", SIGMA, seed, ["t", "y", "v"], work)
    crlb = subprocess.run([hysid, "crlb", "--model-file", str(HERE / "truth.toml"), "--sigma", str(SIGMA),
                           "--times", str(data)], check=True, capture_output=True, text=True).stdout
    sd = {m.group(1): float(m.group(2)) for m in map(CRLB_LINE.match, crlb.splitlines()) if m}
    wall, d, error = identify(hysid, HERE / "truth.toml", data, work / f"identify{seed}.json")
    if d is None:
        yield f"seed {seed}: {error}"
        return
    se = dict(zip(d["names"], d["standard_errors"] or [float("nan")] * len(d["names"])))
    est = dict(zip(d["names"], d["estimate"]))
    for name in TRUTH:
        rows.append({"seed": seed, "status": d["status"], "parameter": name, "estimate": repr(est[name]),
                     "se": repr(se[name]), "crlb_sd": repr(sd[name])})
    yield (f"seed {seed}: {wall:.2f} s wall, status {d['status']}, c = {est['c']:.9f} +- {se['c']:.3g} "
           f"(CRLB sd {sd['c']:.3g})")


def summary(args):
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            out = csv.DictWriter(f, ["seed", "status", "parameter", "estimate", "se", "crlb_sd"])
            out.writeheader()
            out.writerows(rows)
    ok = sorted({r["seed"] for r in rows if r["status"] == "ok"})
    print(f"{len(ok)} of {len({r['seed'] for r in rows})} fits ok; over them, per parameter:")
    for name, truth in TRUTH.items():
        mine = [r for r in rows if r["parameter"] == name and r["seed"] in ok]
        if len(mine) < 2:
            continue
        bound = statistics.mean(float(r["crlb_sd"]) for r in mine)
        errors = [float(r["estimate"]) - truth for r in mine]
        rms = statistics.fmean(e * e for e in errors) ** 0.5
        print(f"  {name:6s} spread {statistics.stdev(float(r['estimate']) for r in mine) / bound:.3f}, "
              f"RMS error {rms / bound:.3f}, mean SE {statistics.mean(float(r['se']) for r in mine) / bound:.3f}, "
              f"max |z| {max(abs(e) / float(r['se']) for e, r in zip(errors, mine)):.2f} (x the CRLB sd)")


if __name__ == "__main__":
    sys.exit(run_seeds(__doc__, 1, 20, each, [("--csv", None, "write the rows here")], after=summary))

#!/usr/bin/python3
"""Evaluate `hysid identify` (defaults) on the user systems' noise draws (README.md here).

    evaluate.py --hysid build/bin/hysid --work DIR [--draws 20] [--systems ball,...]
                [--start draw|truth] [--csv FILE] [--check] [--fresh] [--gate VAR]

Draws missing from DIR are generated first (generate.py). Per draw: `hysid identify --model-file
start.toml --data data.csv --json id-draw.json`, nothing else: the defaults, from start values off by
up to 2.5x (`--start truth`: the true model file instead), timed; and the bound on the samples in
data.csv (systems.crlb). Writes one CSV row per draw (WORK/hysid-START.csv) and prints a table per
system: fits with status ok; ok with every unknown within 4 reported SE of the truth; ok beyond 4 SE
(confident and wrong); ok fits with every SE within 25 % of the CRLB sd; the range of SE / CRLB sd;
wall and CPU time per fit. --check exits 1 unless every system meets the targets: ok within 4 SE in all but
N//20 draws, never ok beyond 4 SE, every SE of an ok fit within 25 % of the CRLB sd.
"""
import argparse
import csv
import json
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import systems

Z = 4.0            # the "within 4 SE"
SE_TOLERANCE = 0.25


def identify(hysid, draw_path, model_file, tag):
    out = Path(draw_path) / f"id-{tag}.json"
    out.unlink(missing_ok=True)
    cmd = [str(hysid), "identify", "--model-file", str(model_file),
           "--data", str(Path(draw_path) / "data.csv"), "--json", str(out)]
    t0, c0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    run = subprocess.run(cmd, capture_output=True, text=True)
    wall, c1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
    (Path(draw_path) / f"id-{tag}.txt").write_text(run.stdout + run.stderr)
    if not out.exists():
        lines = (run.stderr or run.stdout).strip().splitlines()
        reason = (lines[-1] if lines else "").replace(str(Path(draw_path)) + "/", "")
        return {"exit": run.returncode, "wall": wall, "cpu": cpu, "status": "error", "reason": reason}
    result = json.loads(out.read_text())
    result.update(exit=run.returncode, wall=wall, cpu=cpu)
    return result


def judge(names, estimate, se, truth, crlb_sd):
    """|θ̂ − θ| / SE and SE / CRLB sd per unknown (None where a value is missing)."""
    z, ratio = {}, {}
    for i, n in enumerate(names):
        e = estimate[i] - truth[n]
        s = se[i] if se and i < len(se) and se[i] is not None else None
        z[n] = abs(e) / s if s and s > 0 else math.inf
        ratio[n] = s / crlb_sd[n] if s and n in crlb_sd else None
    return z, ratio


def initial_truth(draw_path, result, truth):
    """The truth with x0[STATE] at the first fitted chain's first sample (the time the reported x0
    holds: later than t = 0 when the first rows are missing), from the draw's truth.csv."""
    chains = [c for c, x0 in zip(result.get("chains", []), result.get("chain_x0", [])) if x0]
    if not chains or chains[0]["t_first"] == 0.0:
        return truth
    with open(Path(draw_path) / "truth.csv") as f:
        rows = list(csv.DictReader(f))
    t_first = chains[0]["t_first"]
    row = min(rows, key=lambda r: abs(float(r["t"]) - t_first))
    shifted = dict(truth)
    for name in truth:
        if name.startswith("x0["):
            shifted[name] = float(row["true_" + name[3:-1]])
    return shifted


def evaluate_draw(hysid, sys_, draw_path, start):
    spec = sys_.spec()
    truth = systems.truth(spec)
    bound = systems.crlb(hysid, sys_, draw_path)
    model_file = sys_.path if start == "truth" else Path(draw_path) / "start.toml"
    r = identify(hysid, draw_path, model_file, start)
    row = {"system": sys_.name, "draw": Path(draw_path).name, "start": start, "status": r["status"],
           "exit": r["exit"], "wall_s": round(r["wall"], 4), "cpu_s": round(r["cpu"], 4),
           "reason": (r.get("reason") or "").replace("\n", " ")[:300],
           "samples": r.get("samples", ""), "samples_used": r.get("samples_used", ""),
           "crlb_source": bound["source"]}
    ok = r["status"] == "ok"
    z, ratio = ({}, {})
    if ok:
        missing = [n for n in r["names"] if n not in truth]
        if missing:
            raise RuntimeError(f"{draw_path}: unknowns {missing} not in the truth")
        z, ratio = judge(r["names"], r["estimate"], r.get("standard_errors"), initial_truth(draw_path, r, truth),
                         bound["sd"])
    row["within_4se"] = int(ok and all(v <= Z for v in z.values()))
    row["ok_beyond_4se"] = int(ok and not row["within_4se"])
    row["max_err_in_se"] = round(max(z.values()), 3) if z else ""
    good = [v for v in ratio.values() if v is not None]
    row["se_over_crlb_min"] = round(min(good), 4) if good else ""
    row["se_over_crlb_max"] = round(max(good), 4) if good else ""
    row["se_within_25pc"] = int(bool(good) and len(good) == len(ratio)
                                and all(abs(v - 1) <= SE_TOLERANCE for v in good))
    for n in truth:
        row[f"err_in_se_{n}"] = round(z[n], 3) if n in z else ""
        row[f"se_over_crlb_{n}"] = round(ratio[n], 4) if ratio.get(n) is not None else ""
    return row


def summarize(rows):
    n = len(rows)
    ok = [r for r in rows if r["status"] == "ok"]
    lo = [r["se_over_crlb_min"] for r in ok if r["se_over_crlb_min"] != ""]
    hi = [r["se_over_crlb_max"] for r in ok if r["se_over_crlb_max"] != ""]
    walls = sorted(r["wall_s"] for r in rows)
    cpus = sorted(r["cpu_s"] for r in rows)
    statuses = {}
    for r in rows:
        key = r["status"] if r["status"] != "error" else "error: " + r["reason"][:90]
        statuses[key] = statuses.get(key, 0) + 1
    return {"system": rows[0]["system"], "draws": n, "ok": len(ok),
            "ok_within_4se": sum(r["within_4se"] for r in rows),
            "ok_beyond_4se": sum(r["ok_beyond_4se"] for r in rows),
            "se_within_25pc": sum(r["se_within_25pc"] for r in ok),
            "se_over_crlb": f"{min(lo):.3g}-{max(hi):.3g}" if lo else "-",
            "wall_median_s": statistics.median(walls), "wall_max_s": walls[-1],
            "cpu_median_s": statistics.median(cpus), "cpu_max_s": cpus[-1],
            "statuses": "; ".join(f"{k} x{v}" for k, v in sorted(statuses.items()))}


def meets_targets(s):
    need = s["draws"] - s["draws"] // 20
    return (s["ok_within_4se"] >= need and s["ok_beyond_4se"] == 0
            and s["se_within_25pc"] == s["ok"])


def print_table(summaries, out=sys.stdout):
    head = f"{'system':<11} {'draws':>5} {'ok':>3} {'ok<=4SE':>7} {'ok>4SE':>6} {'SE~CRLB':>7} " \
           f"{'SE/CRLB':>11} {'wall med':>8} {'max':>6} {'cpu med':>7} {'max':>6}  target"
    print(head, file=out)
    for s in summaries:
        print(f"{s['system']:<11} {s['draws']:>5} {s['ok']:>3} {s['ok_within_4se']:>7} "
              f"{s['ok_beyond_4se']:>6} {s['se_within_25pc']:>7} {s['se_over_crlb']:>11} "
              f"{s['wall_median_s']:>8.3f} {s['wall_max_s']:>6.2f} {s['cpu_median_s']:>7.3f} "
              f"{s['cpu_max_s']:>6.2f}  "
              f"{'met' if meets_targets(s) else 'NOT met'}", file=out)
    for s in summaries:
        print(f"  {s['system']}: {s['statuses']}", file=out)


def write_csv(rows, path):
    fields = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)


def ensure_draws(hysid, work, sys_index, sys_, draws):
    for d in range(draws):
        if not (systems.draw_dir(work, sys_, d) / "draw.json").exists():
            systems.generate_draw(hysid, work, sys_index, sys_, d)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True, help="path of the hysid binary")
    ap.add_argument("--work", required=True, help="directory of the draws (generated when missing)")
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--systems", default=",".join(s.name for s in systems.SYSTEMS))
    ap.add_argument("--csv", help="per-draw CSV (default WORK/hysid.csv)")
    ap.add_argument("--check", action="store_true", help="exit 1 unless every system meets the targets")
    ap.add_argument("--start", choices=["draw", "truth"], default="draw",
                    help="the model file identify gets: the draw's start.toml (default) or the truth's")
    ap.add_argument("--fresh", action="store_true", help="remove WORK first (new draws, new bounds)")
    ap.add_argument("--gate", metavar="VAR", help="exit 77 (skipped) unless the environment sets VAR=1")
    args = ap.parse_args(argv)
    if args.gate and os.environ.get(args.gate) != "1":
        print(f"usersys: skipped (set {args.gate}=1, or run `make check-usersys`)")
        return 77
    if args.fresh:
        shutil.rmtree(args.work, ignore_errors=True)
    hysid = Path(args.hysid).resolve()
    names = args.systems.split(",")
    rows, summaries = [], []
    for i, s in enumerate(systems.SYSTEMS):
        if s.name not in names:
            continue
        ensure_draws(hysid, args.work, i, s, args.draws)
        mine = [evaluate_draw(hysid, s, systems.draw_dir(args.work, s, d), args.start)
                for d in range(args.draws)]
        rows += mine
        summaries.append(summarize(mine))
    write_csv(rows, args.csv or Path(args.work) / f"hysid-{args.start}.csv")
    print_table(summaries)
    if args.check and not all(meets_targets(s) for s in summaries):
        print("usersys: the targets are not met (status ok and within 4 SE in all but N//20 draws, "
              "never ok beyond 4 SE, SE within 25 % of the CRLB sd)")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

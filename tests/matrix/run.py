#!/usr/bin/python3
"""Identify every cell of the combination matrix on simulated data (README.md here).

    run.py --hysid build/bin/hysid --work DIR [--cells NAME,NAME,...] [--check] [--csv FILE]

Per cell, in DIR/CELL/: truth.toml (the cell's model file at the truth), start.toml (the same with
every unknown moved off the truth, cells.start_values), `hysid simulate --model-file truth.toml
--sigma SIGMA --seed INDEX+1` (truth.csv, jumps.csv), data.csv (what a user has: t, the measured
states, u; the gap's rows removed), then `hysid identify --model-file start.toml --data data.csv
--json id.json`, timed. A cell is ok when its status is ok and every unknown (α, β, γ, x0) is within
4 reported SE of the truth. Before the fit the data are checked against the cell's design: every
wall hit at least twice and both modes entered, outside the gap. Prints one line per cell and the
total CPU; --check exits 1 unless every cell asked for is ok.
"""
import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import cells

Z = 4.0


def run(cmd):
    t0, c0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run([str(c) for c in cmd], capture_output=True, text=True)
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    done.cpu = (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)
    done.wall = time.perf_counter() - t0
    return done


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def in_gap(cell, t):
    return cell.gap and cells.GAP_FROM <= t < cells.GAP_TO


def generate(hysid, cell, out):
    """Write the cell's model files, simulate it and write data.csv; returns the design problems."""
    out.mkdir(parents=True, exist_ok=True)
    values, x0 = cells.truth_values(cell)
    (out / "truth.toml").write_text(cells.model_text(cell, values, x0))
    (out / "start.toml").write_text(cells.model_text(cell, *cells.start_values(cell)))
    sim = run([hysid, "simulate", "--model-file", out / "truth.toml", "--sigma", repr(cells.SIGMA),
               "--seed", cell.index + 1, "--out", out / "truth.csv", "--jumps-out", out / "jumps.csv"])
    if sim.returncode != 0:
        raise RuntimeError(f"{cell.name}: hysid simulate: exit {sim.returncode}: {sim.stderr.strip()}")
    cols = ["t", "x"] + ([] if cell.hidden else ["v"]) + (["u"] if cell.input else [])
    rows = [r for r in read_csv(out / "truth.csv") if not in_gap(cell, float(r["t"]))]
    with open(out / "data.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(cols)
        w.writerows([r[c] for c in cols] for r in rows)
    return design_problems(cell, out, rows)


def design_problems(cell, out, rows):
    """What the data must show for the cell to be identifiable: each wall hit twice, each mode entered."""
    jumps = [j for j in read_csv(out / "jumps.csv") if not in_gap(cell, float(j["t_jump"]))]
    walls = ["right", "left"] if cell.jumps2 else ["right"]
    problems = []
    for wall in walls:
        hits = sum(1 for j in jumps if j.get("map", "right") == wall)
        if hits < 2:
            problems.append(f"wall '{wall}' hit {hits} time(s) outside the gap")
    if cell.modes2:
        for mode in ("0", "1"):
            if not any(r["q"] == mode for r in rows):
                problems.append(f"mode {mode} never entered in the data")
    return problems


def truth_at(cell, out, result):
    """The true θ with x0 at the first fitted chain's first sample (the time the reported x0 holds)."""
    values, x0 = cells.truth_values(cell)
    theta = dict(values, **{"x0[x]": x0[0], "x0[v]": x0[1]})
    chains = result.get("chains") or []
    if chains and chains[0]["t_first"] > 0.0:
        row = min(read_csv(out / "truth.csv"), key=lambda r: abs(float(r["t"]) - chains[0]["t_first"]))
        theta.update({"x0[x]": float(row["true_x"]), "x0[v]": float(row["true_v"])})
    return theta


def identify(hysid, cell, out):
    (out / "id.json").unlink(missing_ok=True)
    fit = run([hysid, "identify", "--model-file", out / "start.toml", "--data", out / "data.csv",
               "--json", out / "id.json"])
    (out / "id.txt").write_text(fit.stdout + fit.stderr)
    row = {"cell": cell.name, "exit": fit.returncode, "cpu_s": round(fit.cpu, 3), "wall_s": round(fit.wall, 3)}
    if not (out / "id.json").exists():
        lines = (fit.stderr or fit.stdout).strip().splitlines()
        return dict(row, status="error", reason=(lines[-1] if lines else "")[:200], worst_z=math.inf)
    result = json.loads((out / "id.json").read_text())
    row.update(status=result["status"], reason=str(result.get("reason", ""))[:200],
               route=result.get("route", ""), samples_used=result.get("samples_used", ""))
    theta = truth_at(cell, out, result)
    missing = [n for n in theta if n not in result["names"]]
    if missing:
        return dict(row, status=row["status"] + f" (unknowns {missing} not reported)", worst_z=math.inf)
    z = {}
    for name, est, se in zip(result["names"], result["estimate"], result.get("standard_errors") or []):
        z[name] = abs(est - theta[name]) / se if se and se > 0 else math.inf
    worst = max(z, key=z.get) if z else ""
    row.update(worst_z=z.get(worst, math.inf), worst=worst, z=json.dumps({k: round(v, 2) for k, v in z.items()}))
    return row


def evaluate(hysid, cell, work):
    out = Path(work) / cell.name
    problems = generate(hysid, cell, out)
    if problems:
        return {"cell": cell.name, "status": "design", "reason": "; ".join(problems), "worst_z": math.inf,
                "cpu_s": 0.0, "wall_s": 0.0, "exit": ""}
    row = identify(hysid, cell, out)
    row["ok"] = int(row["status"] == "ok" and row["worst_z"] <= Z)
    return row


def print_row(r, out=sys.stdout):
    z = f"{r['worst_z']:.2f} ({r.get('worst', '')})" if math.isfinite(r["worst_z"]) else "-"
    verdict = "ok" if r.get("ok") else ("KNOWN" if r["cell"] in cells.known_failures() else "FAIL")
    print(f"{r['cell']:<37} {verdict:<5} {r['status']:<22} {z:<16} {r['cpu_s']:>7.3f}"
          + (f"  {r['reason']}" if r["status"] != "ok" else ""), file=out, flush=True)


def write_markdown(rows, path):
    known = cells.known_failures()
    with open(path, "w") as f:
        f.write("| cell | ok | status | worst \\|error\\|/SE | identify CPU s | known failure |\n|---|---|---|---|---|---|\n")
        for r in rows:
            z = f"{r['worst_z']:.2f} ({r.get('worst', '')})" if math.isfinite(r["worst_z"]) else "–"
            f.write(f"| {r['cell']} | {'yes' if r.get('ok') else 'NO'} | {r['status']} | {z} | {r['cpu_s']:.2f} | "
                    f"{'yes' if r['cell'] in known else ''} |\n")
        f.write(f"\n{sum(r.get('ok', 0) for r in rows)} of {len(rows)} cells ok; identify CPU total "
                f"{sum(r['cpu_s'] for r in rows):.1f} s\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True, help="path of the hysid binary")
    ap.add_argument("--work", required=True, help="directory of the cells' files")
    ap.add_argument("--cells", help="comma-separated cell names (default: all 64)")
    ap.add_argument("--csv", help="one row per cell")
    ap.add_argument("--markdown", help="the table as Markdown (README.md's)")
    ap.add_argument("--check", action="store_true", help="exit 1 unless every cell is ok")
    ap.add_argument("--gate", metavar="VAR", help="exit 77 (skipped) unless the environment sets VAR=1")
    args = ap.parse_args(argv)
    if args.gate and os.environ.get(args.gate) != "1":
        print(f"matrix: skipped (set {args.gate}=1, or run `make check-matrix`)")
        return 77
    chosen = [cells.cell_by_name(n) for n in args.cells.split(",")] if args.cells else cells.all_cells()
    hysid = Path(args.hysid).resolve()
    print(f"{'cell':<37} {'ok':<5} {'status':<22} {'worst |err|/SE':<16} {'cpu s':>7}")
    rows = []
    for cell in chosen:
        rows.append(evaluate(hysid, cell, args.work))
        print_row(rows[-1])
    print(f"{sum(r.get('ok', 0) for r in rows)} of {len(rows)} cells ok; identify CPU total "
          f"{sum(r['cpu_s'] for r in rows):.2f} s")
    if args.csv:
        fields = []
        for r in rows:
            fields += [k for k in r if k not in fields]
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields)
            w.writeheader()
            w.writerows(rows)
    if args.markdown:
        write_markdown(rows, args.markdown)
    return 1 if args.check and not all(r.get("ok") for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())

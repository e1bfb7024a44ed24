#!/usr/bin/env python3
"""`hysid identify`'s files carry what its text report shows, and `simulate` names its columns.

1. --json: every number the text report prints (stdout) is in the JSON with the same value, to the
   digits printed, over cases that print every kind of line: simulated data with its truth and the
   refinement's CRLB comparison; two runs with a gap and missing rows; gtls with --localize and
   --second-pass; frisch boxes; the paper detector's options; a bouncing ball fitted on a shorter span.
   The JSON's detections, chains and truth agree with the trace and the data.
2. --trace: one row per data row on a two-run file with a gap and missing rows: the same count, each
   row's run, line and time those of its data row (times restart in run 2), missing = 1 exactly on
   the rows with a missing cell, chains restarting at the gap and at the run.
3. simulate: the columns are t, j, true_STATE.., STATE.. and pre_/post_STATE.. after the model's state
   names; identify reads them, reads the older x1.., y1.. names alike, and --columns overrides both.

Usage: report_outputs.py HYSID WORKDIR (a scratch directory; hysid runs in it on relative names)
"""
import csv
import json
import math
import os
import re
import shutil
import subprocess
import sys

HYSID, WORK = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
FAILURES = []

# A number as printed: not part of a name (x0[x], lag-1, 2nd) and not a file name's digits.
NUMBER = re.compile(r"(?<![\w.\[\]-])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w\[.])")


def check(ok, what):
    if not ok:
        FAILURES.append(what)
        print("FAILED:", what)


def hysid(*args, codes=(0,)):
    p = subprocess.run([HYSID, *map(str, args)], cwd=WORK, capture_output=True, text=True)
    if p.returncode not in codes:
        sys.exit(f"hysid {' '.join(map(str, args))}: exit {p.returncode}\n{p.stdout}\n{p.stderr}")
    return p.stdout


def half_unit(token):
    """Half a unit in the last printed place of `token` (the rounding the text applied)."""
    mantissa, _, exponent = token.lower().lstrip("+-").partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals)


def json_numbers(node, out):
    """Every number in the JSON, and every number inside its strings (reasons, names)."""
    if isinstance(node, dict):
        for v in node.values():
            json_numbers(v, out)
    elif isinstance(node, list):
        for v in node:
            json_numbers(v, out)
    elif isinstance(node, bool) or node is None:
        pass
    elif isinstance(node, (int, float)):
        out.append(float(node))
    elif isinstance(node, str):
        out.extend(float(t) for t in NUMBER.findall(node))
    return out


def text_in_json(case, text, report):
    values = json_numbers(report, [])
    for line in text.splitlines():
        if line.startswith("wrote "):  # the file names; the counts are checked below
            line = line.split("(", 1)[1] if "(" in line else ""
        for token in NUMBER.findall(line):
            x, tol = float(token), half_unit(token) * (1 + 1e-9)
            if not any(abs(v - x) <= tol for v in values if math.isfinite(v)):
                check(False, f"{case}: '{token}' in the text line '{line.strip()}' is not in the JSON")


def identify(case, data, *flags, codes=(0, 1)):
    out = f"{case}.report.json"
    text = hysid("identify", *data, "--json", out, *flags, codes=codes)
    report = json.load(open(os.path.join(WORK, out)))
    text_in_json(case, text, report)
    return text, report


def read_csv(name):
    with open(os.path.join(WORK, name), newline="") as f:
        return list(csv.DictReader(f))


def two_runs():
    """run,t,j,x,v: a simulated trajectory cut into two runs (times restarting at 0), a 10 ms gap in
    run 1, and missing cells (empty, nan, NA) in both runs."""
    hysid("simulate", "--sigma", "0.01", "--seed", "4", "--t-end", "8", "--out", "whole.csv")
    rows = read_csv("whole.csv")
    half = len(rows) // 2
    out, missing = [], set()
    for k, r in enumerate(rows):
        if 3000 <= k < 3020:  # the gap
            continue
        run, t = (1, float(r["t"])) if k < half else (2, float(r["t"]) - float(rows[half]["t"]))
        x, v = r["x"], r["v"]
        if k in (500, 501, 4000, half, half + 700):
            x = ["", "nan", "NA", "", "nan"][[500, 501, 4000, half, half + 700].index(k)]
            missing.add(len(out))
        out.append([run, repr(t), r["j"], x, v])
    with open(os.path.join(WORK, "runs.csv"), "w", newline="") as f:
        f.write("run,t,j,x,v\n")
        f.writelines(",".join(map(str, row)) + "\n" for row in out)
    return out, missing


def check_trace(data, missing, report):
    trace = read_csv("runs.trace.csv")
    check(len(trace) == len(data), f"trace: {len(trace)} rows for {len(data)} data rows")
    for i, (row, d) in enumerate(zip(trace, data)):
        if int(row["run"]) != d[0] or int(row["line"]) != i + 2 or float(row["t"]) != float(d[1]):
            check(False, f"trace row {i + 1}: run, line, t {row['run']}, {row['line']}, {row['t']} for data "
                         f"row run {d[0]}, line {i + 2}, t {d[1]}")
            break
    flagged = {i for i, row in enumerate(trace) if row["missing"] == "1"}
    check(flagged == missing, f"trace: missing = 1 on rows {sorted(flagged)}, the data's are {sorted(missing)}")
    check(all(trace[i]["gamma"] == "nan" for i in flagged), "trace: a missing row has a gamma")
    restart = [i for i in range(1, len(trace)) if float(trace[i]["t"]) < float(trace[i - 1]["t"])]
    check(len(restart) == 1 and trace[restart[0]]["run"] == "2" and trace[restart[0] - 1]["run"] == "1",
          f"trace: time restarts at rows {restart}, not once where run 1 turns into run 2")
    samples = [row for row in trace if row["missing"] == "0"]
    starts = [int(row["line"]) for i, row in enumerate(samples) if i == 0 or row["chain"] != samples[i - 1]["chain"]]
    check([c["first_line"] for c in report["chains"]] == starts and len(starts) == 3,
          f"chains: JSON first lines {[c['first_line'] for c in report['chains']]}, trace {starts} (3 expected)")
    for c in report["chains"]:
        rows = [row for row in samples if int(row["chain"]) == c["chain"]]
        jumps = sum(row["gamma"] == "1" for row in rows)
        check(c["samples"] == len(rows) and c["jumps"] == jumps and c["jump_updates"] == jumps and
              c["flow_updates"] == len(rows) - 1 - jumps and all(int(r["run"]) == c["run"] for r in rows),
              f"chain {c['chain']}: JSON counts {c} against the trace's {len(rows)} samples, {jumps} jumps")
    lines = [int(row["line"]) for row in samples if row["gamma"] == "1"]
    check([d["line"] for d in report["detections"]] == lines, "detections: JSON lines differ from the trace's")
    check(all(float(samples[d["sample"]]["t"]) == d["t"] for d in report["detections"]),
          "detections: a JSON sample index or time differs from the trace's")
    truth = report["truth"]
    true_jumps = sum(row["true_jump"] == "1" for row in samples)
    check(truth["true_jumps"] == true_jumps and truth["tp"] + truth["fp"] == len(lines),
          f"truth: {truth['true_jumps']} true jumps, TP + FP {truth['tp'] + truth['fp']}; the trace has "
          f"{true_jumps} and {len(lines)}")


def simulate_columns():
    text = hysid("simulate", "--sigma", "0.01", "--t-end", "4", "--out", "named.csv", "--jumps-out", "named-jumps.csv")
    with open(os.path.join(WORK, "named.csv")) as f:
        header = f.readline().strip()
    with open(os.path.join(WORK, "named-jumps.csv")) as f:
        jumps = f.readline().strip()
    check(header == "t,j,true_x,true_v,x,v", f"simulate: header {header}")
    check(jumps == "j,t_jump,pre_x,pre_v,post_x,post_v", f"simulate --jumps-out: header {jumps}")
    check("columns:" not in text, "simulate: generic columns announced for impact-msd")
    ball = hysid("simulate", "--model", "bouncing-ball", "--t-end", "1", "--out", "ball-named.csv")
    with open(os.path.join(WORK, "ball-named.csv")) as f:
        check(f.readline().strip() == "t,j,true_h,true_v,h,v", "simulate: the ball's header")
    check("wrote" in ball, "simulate: the ball's run")
    # A state named j clashes with the jump counter: generic names, said so, and read as y1, y2.
    with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "models",
                           "impact-msd.toml")) as f:
        clash = re.sub(r"\bv\b", "j", f.read())
    with open(os.path.join(WORK, "msd-j.toml"), "w") as f:
        f.write(clash)
    said = hysid("simulate", "--model-file", "msd-j.toml", "--t-end", "4", "--out", "clash.csv",
                 "--jumps-out", "clash-jumps.csv")
    with open(os.path.join(WORK, "clash.csv")) as f, open(os.path.join(WORK, "clash-jumps.csv")) as g:
        check(f.readline().strip() == "t,j,x1,x2,y1,y2" and g.readline().strip() == "j,t_jump,pre_x1,pre_x2,post_x1,post_x2"
              and "columns: x1..x2 (true state), y1..y2 (measured)" in said, "simulate: a state named j")
    check("(y1,y2)" in hysid("identify", "--model-file", "msd-j.toml", "--refine", "none", "--data", "clash.csv"),
          "identify: the generic columns of a model with a state named j")
    # The older names: the same file with x1, x2, y1, y2 identifies alike, and --columns overrides.
    with open(os.path.join(WORK, "named.csv")) as f, open(os.path.join(WORK, "generic.csv"), "w") as g:
        g.write("t,j,x1,x2,y1,y2\n" + "".join(f.readlines()[1:]))
    shutil.copy(os.path.join(WORK, "named.json"), os.path.join(WORK, "generic.json"))
    named = hysid("identify", "--refine", "none", "--data", "named.csv")
    generic = hysid("identify", "--refine", "none", "--data", "generic.csv")
    check("(x,v)" in named and "(y1,y2)" in generic, "identify: the measured columns chosen by name")
    body = lambda t: [l for l in t.splitlines()[1:] if ".json" not in l]
    check(body(named) == body(generic), "identify: the named and generic files give different reports")
    forced = hysid("identify", "--refine", "none", "--columns", " t = t , true_x , true_v ", "--data", "named.csv")
    check("(true_x,true_v)" in forced, "identify: --columns (with spaces) does not override the names")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    hysid("simulate", "--sigma", "0.01", "--seed", "1", "--t-end", "6", "--out", "msd.csv")
    identify("msd", ["--data", "msd.csv"], "--trace", "msd.trace.csv", "--hulls", "msd.hulls.csv")
    data, missing = two_runs()
    _, report = identify("runs", ["--data", "runs.csv"], "--trace", "runs.trace.csv")
    check_trace(data, missing, report)
    identify("gtls", ["--data", "msd.csv"], "--estimator", "gtls", "--localize", "--second-pass", "--refine", "none")
    identify("frisch", ["--data", "msd.csv"], "--estimator", "frisch", "--refine", "none")
    identify("paper", ["--data", "msd.csv"], "--detector", "paper", "--refine", "none")
    hysid("simulate", "--model", "bouncing-ball", "--sigma", "0.01", "--seed", "3", "--out", "ball.csv")
    text, _ = identify("ball", ["--data", "ball.csv"], "--model", "bouncing-ball")
    check("fitted the first" in text, "ball: the text has no shorter span to compare")
    simulate_columns()
    if FAILURES:
        sys.exit(f"{len(FAILURES)} failures")
    print("all checks passed")


if __name__ == "__main__":
    main()

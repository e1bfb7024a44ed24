#!/usr/bin/python3
"""run.sh's glue between hysid's files and the benchmark's.

    hysid_io.py params IDENTIFY_JSON OUT     identify --json's estimate as NAME=VALUE lines, then
                                             x0=H1,Y (the fitted initial state)
    hysid_io.py test-simulation SIM_CSV OUT  simulate's noise-free output true_y as t,y (1024 rows)
    hysid_io.py rmse TEST_CSV VALIDATION_CSV the RMS error between the two files' y columns
"""

import csv
import json
import math
import sys


def params_file(identify_json, out):
    report = json.load(open(identify_json))
    estimate = dict(zip(report["names"], report["estimate"]))
    x0 = [estimate.pop("x0[h1]"), estimate.pop("x0[y]")]
    lines = [f"{k}={v:.17g}" for k, v in estimate.items()] + [f"x0={x0[0]:.17g},{x0[1]:.17g}"]
    open(out, "w").write("\n".join(lines) + "\n")
    print(f"identify status: {report.get('status')} {report.get('reason', '')}".rstrip())


def read_column(path, name):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(row for row in f if not row.startswith("#")))
    return [float(r["t"]) for r in rows], [float(r[name]) for r in rows]


def test_simulation(sim_csv, out):
    t, y = read_column(sim_csv, "true_y")
    if len(t) != 1024:
        raise SystemExit(f"hysid_io.py: error: {sim_csv}: {len(t)} rows, expected 1024")
    with open(out, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["t", "y"])
        w.writerows([[repr(a), repr(b)] for a, b in zip(t, y)])


def rmse(test_csv, validation_csv):
    _, a = read_column(test_csv, "y")
    _, b = read_column(validation_csv, "y")
    if len(a) != len(b):
        raise SystemExit(f"hysid_io.py: error: {test_csv} has {len(a)} rows, {validation_csv} {len(b)}")
    print(f"test RMSE {math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)) / len(a)):.4f} V")


def main(argv):
    commands = {"params": (params_file, 2), "test-simulation": (test_simulation, 2), "rmse": (rmse, 2)}
    if len(argv) < 2 or argv[1] not in commands or len(argv) - 2 != commands[argv[1]][1]:
        raise SystemExit(__doc__)
    commands[argv[1]][0](*argv[2:])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

#!/usr/bin/python3
"""The benchmark's CSV (data/dataBenchmark.csv) as hysid's data and input files.

    /usr/bin/python3 examples/cascaded-tanks/convert.py OUTDIR

writes into OUTDIR
    estimation.csv        t,y,u   the estimation record (identify --data: y measured, u the input)
    validation.csv        t,y,u   the test record (for scoring only: the fit never reads it)
    validation_input.csv  t,u     the test input alone (simulate --inputs)
with t = 4k s, k = 0..1023, every number as the benchmark file writes it (no rounding).
"""

import csv
import pathlib
import sys

TS = 4
SOURCE = pathlib.Path(__file__).resolve().parent / "data" / "dataBenchmark.csv"


def read_columns(path):
    """The benchmark's columns uEst, uVal, yEst, yVal as lists of strings (the text as written)."""
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r]
    header = rows[0]
    columns = {}
    for name in ("uEst", "uVal", "yEst", "yVal"):
        if name not in header:
            raise SystemExit(f"convert.py: error: {path}:1: no column {name!r} (header {header})")
        i = header.index(name)
        columns[name] = [r[i] for r in rows[1:]]
    lengths = {len(c) for c in columns.values()}
    if lengths != {1024}:
        raise SystemExit(f"convert.py: error: {path}: expected 1024 rows per column, got {lengths}")
    return columns


def write(path, header, columns):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(header)
        for k, values in enumerate(zip(*columns)):
            writer.writerow([TS * k, *values])


def main(argv):
    if len(argv) != 2:
        raise SystemExit("usage: convert.py OUTDIR")
    out = pathlib.Path(argv[1])
    out.mkdir(parents=True, exist_ok=True)
    c = read_columns(SOURCE)
    write(out / "estimation.csv", ["t", "y", "u"], [c["yEst"], c["uEst"]])
    write(out / "validation.csv", ["t", "y", "u"], [c["yVal"], c["uVal"]])
    write(out / "validation_input.csv", ["t", "u"], [c["uVal"]])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

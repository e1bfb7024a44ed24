#!/usr/bin/env python3
"""A parameter read through its effect accumulated over many shooting segments, at the bound.

bench/hopper-drag/truth.toml: a spring-mass hopper whose flight has air drag c|v|v. The drag is told by
how each flight's velocity and height drift from the drag-free parabola over the whole flight, longer
than a segment of the multiple shooting (10 001 samples at sigma 1e-4, 48 segments). Per seed:
`hysid simulate` of the truth, then `hysid identify` with the defaults from the truth's values.
Asserts status ok, the route by time, every unknown within 4 reported standard errors of the truth,
and every standard error within 25 % of `hysid crlb`'s sd on the same samples: the covariance is the
fit's with its continuity exact, not the one its soft continuity rows would give (c's standard error
then well above the bound's).

Usage: accumulated_drag.py HYSID MODEL_FILE
"""
import json
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hysid_run import run  # noqa: E402

HYSID, TRUTH_FILE = sys.argv[1], sys.argv[2]
SIGMA = 1e-4
TRUTH = {"g": 9.81, "w2": 400.0, "c": 0.1, "L0": 1.0, "x0[y]": 1.5, "x0[v]": 0.0}
CRLB_LINE = re.compile(r"^\s+(\S+)\s+=\s+\S+\s+sd\s+(\S+)")


def main():
    failures = []
    with tempfile.TemporaryDirectory() as d:
        for seed in (1, 2):
            data, out = os.path.join(d, f"data{seed}.csv"), os.path.join(d, f"id{seed}.json")
            run(HYSID, "simulate", "--model-file", TRUTH_FILE, "--sigma", str(SIGMA), "--seed", str(seed),
                "--out", data)
            crlb = {m.group(1): float(m.group(2))
                    for m in map(CRLB_LINE.match, run(HYSID, "crlb", "--model-file", TRUTH_FILE, "--sigma", str(SIGMA),
                                                      "--times", data).splitlines()) if m}
            if set(crlb) != set(TRUTH):
                sys.exit(f"hysid crlb gave sd for {sorted(crlb)}, expected {sorted(TRUTH)}")
            run(HYSID, "identify", "--model-file", TRUTH_FILE, "--data", data, "--json", out, "--progress", "none",
                codes=(0, 1))
            with open(out) as f:
                r = json.load(f)
            if r["status"] != "ok":
                failures.append(f"seed {seed}: status {r['status']}: {r['reason']}")
                continue
            if r["route"] != "multiple shooting by time":
                failures.append(f"seed {seed}: route {r['route']}, not multiple shooting by time")
            for name, value, se in zip(r["names"], r["estimate"], r["standard_errors"]):
                z = abs(value - TRUTH[name]) / se
                ratio = se / crlb[name]
                print(f"seed {seed}: {name} = {value:.9g} +- {se:.3g} (|z| {z:.2f}, se/crlb {ratio:.3f})")
                if z > 4.0:
                    failures.append(f"seed {seed}: {name} = {value} is {z:.2f} SE from {TRUTH[name]}")
                if not 0.75 <= ratio <= 1.25:
                    failures.append(f"seed {seed}: {name}: se {se:.4g} is {ratio:.3f} x the CRLB sd {crlb[name]:.4g}")
    if failures:
        sys.exit("\n".join(failures))
    print("accumulated drag: ok on both seeds, at the bound")


main()

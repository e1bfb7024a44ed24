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
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hysid_run import at_the_bound, crlb_sd, run  # noqa: E402

HYSID, TRUTH_FILE = sys.argv[1], sys.argv[2]
SIGMA = 1e-4
TRUTH = {"g": 9.81, "w2": 400.0, "c": 0.1, "L0": 1.0, "x0[y]": 1.5, "x0[v]": 0.0}


def main():
    failures = []
    with tempfile.TemporaryDirectory() as d:
        for seed in (1, 2):
            data, out = os.path.join(d, f"data{seed}.csv"), os.path.join(d, f"id{seed}.json")
            run(HYSID, "simulate", "--model-file", TRUTH_FILE, "--sigma", str(SIGMA), "--seed", str(seed),
                "--out", data)
            crlb = crlb_sd(HYSID, "crlb", "--model-file", TRUTH_FILE, "--sigma", str(SIGMA), "--times", data)
            if set(crlb) != set(TRUTH):
                sys.exit(f"hysid crlb gave sd for {sorted(crlb)}, expected {sorted(TRUTH)}")
            run(HYSID, "identify", "--model-file", TRUTH_FILE, "--data", data, "--json", out, "--progress", "none",
                codes=(0, 1))
            with open(out) as f:
                r = json.load(f)
            if r["status"] == "ok" and r["route"] != "multiple shooting by time":
                failures.append(f"seed {seed}: route {r['route']}, not multiple shooting by time")
            failures += at_the_bound(f"seed {seed}", r, TRUTH, crlb)
    if failures:
        sys.exit("\n".join(failures))
    print("accumulated drag: ok on both seeds, at the bound")


main()

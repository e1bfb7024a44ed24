#!/usr/bin/env python3
"""A hidden state the model keeps constant, identified with the defaults from far start values.

tests/data/lif_hidden_drive.toml: a leaky integrate-and-fire neuron v' = -g v + I whose drive I is a
state that is not measured and does not change. Per seed: `hysid simulate` of the truth (sigma 0.01,
601 samples, 16 spikes), the data as a user has them (t, v), and `hysid identify` from a start file
with g 2.2x, th 1.3x and I's start 0.5x the truth. Asserts status ok, every unknown within 4
reported standard errors of the truth, and every standard error within 25 % of `hysid crlb`'s sd at
the truth.

Usage: hidden_constant.py HYSID MODEL_FILE
"""
import json
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "..", "..", "bench")]
from hysid_run import at_the_bound, crlb_sd, run, start_file  # noqa: E402
from own_system import user_data  # noqa: E402

HYSID, TRUTH_FILE = sys.argv[1], sys.argv[2]
SIGMA = 0.01
TRUTH = {"g": 0.5, "th": 1.0, "x0[v]": 0.0, "x0[I]": 0.8}
START = (('name = "g", value = 0.5', 'name = "g", value = 1.1'),
         ('name = "th", value = 1.0', 'name = "th", value = 1.3'),
         ("x0 = [0.0, 0.8]", "x0 = [0.0, 0.4]"))


def main():
    failures = []
    crlb = crlb_sd(HYSID, "crlb", "--model-file", TRUTH_FILE, "--sigma", str(SIGMA))
    if set(crlb) != set(TRUTH):
        sys.exit(f"hysid crlb gave sd for {sorted(crlb)}, expected {sorted(TRUTH)}")
    with tempfile.TemporaryDirectory() as d:
        start = os.path.join(d, "start.toml")
        start_file(TRUTH_FILE, START, start)
        for seed in (1, 2):
            data = str(user_data(HYSID, TRUTH_FILE, SIGMA, seed, ["t", "v"], d))
            out = os.path.join(d, f"id{seed}.json")
            run(HYSID, "identify", "--model-file", start, "--data", data, "--json", out, "--progress", "none",
                codes=(0, 1))
            with open(out) as f:
                r = json.load(f)
            failures += at_the_bound(f"seed {seed}", r, TRUTH, crlb)
    if failures:
        sys.exit("\n".join(failures))
    print("hidden constant: ok on both seeds, at the bound")


main()

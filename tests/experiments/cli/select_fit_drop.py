#!/usr/bin/python3
"""hysid identify drops a chosen candidate that the refined fit does not support (docs/method.md,
"Which model: candidate terms of a jump", rounds and refinement).

The spring-mass hopper of analysis/select/hopper_truth.toml with a touchdown that keeps 0.9 of the
velocity (v+ = 0.9 v; the truth written from hopper_truth.toml), sigma = 1e-4, seed 1, identified from
five candidate terms of v+ in the touchdown map (v, v|v|, 1, v^3, y). On this record the selection
chooses v and 1: the sample before a touchdown lies up to a step before it, and the constant takes up
the velocity gained in between. The refined fit holds the constant at z^2 below the chi-square(1)
quantile at 0.99, so it is dropped and the chosen model refit without it. Checked: `dropped_by_fit`
names touchdown_v_3 with z^2 below its threshold, the final chosen terms are [touchdown_v_1], the status
is ok and the refined coefficient is within 4 standard errors of 0.9; the --chosen-model file has no
touchdown_v_3 and is taken as it is by identify (its estimates within 0.1 standard errors), simulate and
crlb.

Usage: select_fit_drop.py HYSID SOURCE_DIR WORK_DIR
"""
import json
import os
import sys

from hysid_run import chosen_model_taken, run, start_file

TOUCHDOWN = '''[[jump]]
name = "touchdown"
from = "flight"
to = "stance"
guard = "touch"
'''


def main():
    hysid, source, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    hopper = os.path.join(source, "analysis", "select", "hopper_truth.toml")
    truth, library, data = (os.path.join(work, f) for f in ("truth.toml", "library.toml", "data.csv"))
    start_file(hopper, [(TOUCHDOWN, TOUCHDOWN + '''beta = [ { name = "keep", value = 1.0, known = true },
         { name = "touchdown_v_1", value = 0.9 } ]
psi = [["y", 0], [0, "v"]]
rows = ["v"]
''')], truth)
    start_file(hopper, [(TOUCHDOWN, TOUCHDOWN + '''beta = [ { name = "keep", value = 1.0, known = true } ]
psi = [["y"], [0]]
rows = ["v"]
candidates = { v = ["v", "v*abs(v)", "1", "v^3", "y"] }
''')], library)
    run(hysid, "simulate", "--model-file", truth, "--sigma", "1e-4", "--seed", "1", "--out", data)
    chosen, out = os.path.join(work, "chosen.toml"), os.path.join(work, "report.json")
    text = run(hysid, "identify", "--model-file", library, "--data", data, "--chosen-model", chosen, "--json", out)
    report = json.load(open(out))
    sel = report["selection"]
    bad = []
    drops = sel["dropped_by_fit"]
    if [d["name"] for d in drops] != ["touchdown_v_3"] or not drops[0]["z2"] < drops[0]["threshold"]:
        bad.append(f"dropped_by_fit {drops}, expected touchdown_v_3 below its threshold")
    if "dropped after the refinement: touchdown_v_3" not in text:
        bad.append("the report does not say touchdown_v_3 was dropped after the refinement")
    if sel["chosen"] != ["touchdown_v_1"]:
        bad.append(f"chosen {sel['chosen']}, expected ['touchdown_v_1']")
    est = dict(zip(report["names"], report["estimate"]))
    se = dict(zip(report["names"], report["standard_errors"]))
    if report["status"] != "ok" or abs(est["touchdown_v_1"] - 0.9) > 4 * se["touchdown_v_1"]:
        bad.append(f"status {report['status']}, touchdown_v_1 = {est.get('touchdown_v_1')} ± "
                   f"{se.get('touchdown_v_1')}: more than 4 se from 0.9")
    if "touchdown_v_3" in open(chosen).read():
        bad.append(f"{chosen} keeps touchdown_v_3")
    # Refit from its own refined values the chosen model lands within a tenth of a standard error.
    bad += chosen_model_taken(hysid, chosen, ["--data", data], est, "1e-4", work, rel=0.1, se=se)[0]
    if bad:
        sys.exit("\n".join(bad))
    print("ok: dropped", drops, "estimate", est["touchdown_v_1"], "±", se["touchdown_v_1"])


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""hysid identify on a model file with candidate terms of the jump's row, end to end
(docs/model-files.md#candidate-terms-of-a-jump).

A bouncing ball (analysis/select/bounce_truth.toml: v+ = -0.95 v, 37 impacts) simulated at sigma = 0.01,
identified from 6 candidate terms of v+ (analysis/select/bounce_library.toml): the selection must choose
exactly v (jump_v_1), the bootstrap over the jumps must choose it in at least 90 % of its draws, the
refined coefficient must lie within 5 standard errors of -0.95; the model written by --chosen-model has
no candidates and keeps jump_v_1 as a plain beta entry, and `identify` on it gives the same refined
estimates (relative 1e-6), `simulate` and `crlb` accept it. Then the ball whose map is
v+ = -0.95 v + 0.02 v|v| (bounce_quadratic_truth.toml, 26 impacts): v and v|v| are chosen
(jump_v_1, jump_v_2), each within 5 standard errors of its truth after the refinement. Last, a file
with candidates of v' (1, v, |v|v, h) and of v+: 1 and v are chosen (v_1, jump_v_1).

Usage: select_jump.py HYSID SOURCE_DIR WORK_DIR
"""
import json
import os
import sys

from hysid_run import chosen_model_taken, run


def identify(hysid, select, work, truth, tag, bad):
    """Simulates `truth`, identifies from the library; returns the report and the chosen model's path."""
    data, chosen, out = (os.path.join(work, f"{tag}{ext}") for ext in (".csv", ".chosen.toml", ".report.json"))
    run(hysid, "simulate", "--model-file", os.path.join(select, truth), "--sigma", "0.01", "--seed", "1",
        "--out", data)
    text = run(hysid, "identify", "--model-file", os.path.join(select, "bounce_library.toml"), "--data", data,
               "--chosen-model", chosen, "--json", out, "--select-bootstrap", "50")
    if "selection of jump terms" not in text or "jump_v_1 v+ term v" not in text:
        bad.append(f"{tag}: the report lists no jump candidates:\n{text}")
    return json.load(open(out)), data, chosen


def within(report, expected, tag, bad):
    est = dict(zip(report["names"], report["estimate"]))
    se = dict(zip(report["names"], report["standard_errors"]))
    for name, truth in expected.items():
        if abs(est[name] - truth) > 5 * se[name]:
            bad.append(f"{tag}: {name} = {est[name]} ± {se[name]}: more than 5 se from {truth}")
    return est


def main():
    hysid, source, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    select = os.path.join(source, "analysis", "select")
    bad = []
    report, data, chosen = identify(hysid, select, work, "bounce_truth.toml", "linear", bad)
    jump = report["selection"]["jump"]
    if jump["chosen"] != ["jump_v_1"] or report["selection"]["chosen"] != ["jump_v_1"]:
        bad.append(f"linear: chosen {jump['chosen']}, expected ['jump_v_1'] (v)")
    if jump["jumps"] != 37:
        bad.append(f"linear: {jump['jumps']} jumps summed, the simulation has 37")
    freq = {t["name"]: t["bootstrap_frequency"] for t in jump["terms"]}
    if len(freq) != 6 or freq["jump_v_1"] < 0.9:
        bad.append(f"linear: bootstrap frequencies {freq}: v below 0.9 (or not 6 terms)")
    est = within(report, {"jump_v_1": -0.95}, "linear", bad)
    text = open(chosen).read()
    if "candidates" in text or "jump_v_2" in text or "'jump_v_1'" not in text:
        bad.append(f"{chosen} still lists candidates, or lacks jump_v_1:\n{text}")
    taken, again = chosen_model_taken(hysid, chosen, ["--data", data], est, "0.01", work)
    bad += taken
    if sorted(again["names"]) != sorted(est):
        bad.append(f"the chosen model's parameters {again['names']}, the selection's {list(est)}")

    report, _, _ = identify(hysid, select, work, "bounce_quadratic_truth.toml", "quadratic", bad)
    if report["selection"]["jump"]["chosen"] != ["jump_v_1", "jump_v_2"]:
        bad.append(f"quadratic: chosen {report['selection']['jump']['chosen']}, expected v and v*abs(v)")
    else:
        within(report, {"jump_v_1": -0.95, "jump_v_2": 0.02}, "quadratic", bad)
    # Candidates of the flow's v' and of v+ in one file: each chosen on its own rows.
    library = open(os.path.join(select, "bounce_library.toml")).read()
    both = os.path.join(work, "both.toml")
    with open(both, "w") as f:
        f.write(library.replace('{ name = "g", value = 9.81 } ]', "]").replace(
            'phi = [["v", 0], [0, -1]]', 'phi = [["v"], [0]]\ncandidates = { v = ["1", "v", "abs(v)*v", "h"] }'))
    out = os.path.join(work, "both.report.json")
    run(hysid, "identify", "--model-file", both, "--data", data, "--refine", "none", "--json", out,
        "--select-bootstrap", "20")
    if json.load(open(out))["selection"]["chosen"] != ["v_1", "jump_v_1"]:
        bad.append(f"flow and jump candidates: chosen {json.load(open(out))['selection']['chosen']}, expected "
                   "['v_1', 'jump_v_1'] (1 in v', v in v+)")
    if bad:
        sys.exit("\n".join(bad))
    print("ok: chosen", jump["chosen"], "then", report["selection"]["jump"]["chosen"])


if __name__ == "__main__":
    main()

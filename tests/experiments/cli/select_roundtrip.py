#!/usr/bin/python3
"""hysid identify on a model file with candidate terms, end to end (docs/model-files.md#candidate-terms).

The paper's Sec. 5 system (a = 5, b = 0.1) simulated at sigma = 0.03, identified from a library of 20
terms of v' (analysis/select/s5_library.toml): the selection must choose exactly x and v (v_2, v_3),
the bootstrap must choose each in at least 90 % of its draws and the exact support in at least 80 %,
the refined a and b must lie within 5 standard errors of the truth (-5, -0.1); the model written by
--chosen-model has no candidates, reloads, and `identify` on it gives the same refined estimates
(relative 1e-6), `simulate` and `crlb` accept it.

Usage: select_roundtrip.py HYSID SOURCE_DIR WORK_DIR
"""
import json
import os
import sys

from hysid_run import chosen_model_taken, run


def main():
    hysid, source, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    select = os.path.join(source, "analysis", "select")
    data, chosen = os.path.join(work, "s5.csv"), os.path.join(work, "chosen.toml")
    first = os.path.join(work, "first.json")
    run(hysid, "simulate", "--model-file", os.path.join(select, "s5_truth.toml"), "--sigma", "0.03", "--seed", "1",
        "--out", data)
    run(hysid, "identify", "--model-file", os.path.join(select, "s5_library.toml"), "--data", data,
        "--chosen-model", chosen, "--json", first, "--select-bootstrap", "50")
    report = json.load(open(first))
    sel = report["selection"]
    bad = []
    if sel["chosen"] != ["v_2", "v_3"]:
        bad.append(f"chosen {sel['chosen']}, expected ['v_2', 'v_3'] (x and v)")
    freq = {t["name"]: t["bootstrap_frequency"] for t in sel["terms"]}
    if min(freq["v_2"], freq["v_3"]) < 0.9:
        bad.append(f"bootstrap frequencies of x and v {freq['v_2']}, {freq['v_3']}: below 0.9")
    if sel["bootstrap_support_matches"] < 0.8 * sel["bootstrap_draws"]:
        bad.append(f"the exact support in {sel['bootstrap_support_matches']} of {sel['bootstrap_draws']} draws")
    est = dict(zip(report["names"], report["estimate"]))
    se = dict(zip(report["names"], report["standard_errors"]))
    for name, truth in (("v_2", -5.0), ("v_3", -0.1)):
        if abs(est[name] - truth) > 5 * se[name]:
            bad.append(f"{name} = {est[name]} ± {se[name]}: more than 5 se from {truth}")
    text = open(chosen).read()
    if "candidates" in text:
        bad.append(f"{chosen} still lists candidates")
    bad += chosen_model_taken(hysid, chosen, ["--data", data], est, "0.03", work)[0]
    if bad:
        sys.exit("\n".join(bad))
    print("ok: chosen", sel["chosen"], "estimates", {k: est[k] for k in ("v_2", "v_3")})


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""hysid identify on a model file with candidate terms per mode, end to end (docs/model-files.md#candidate-terms).

A spring-mass hopper (flight with air drag: v' = -9.81 - 0.1|v|v; stance: v' = 390.19 - 400 y)
simulated at sigma = 3e-4, identified from 20 terms of v' in each mode
(analysis/select/hopper_library.toml): each mode's selection must choose exactly its true terms
(flight_v_1, flight_v_11: 1 and |v|v; stance_v_1, stance_v_2: 1 and y), every term of the report must
name its mode, the recursive estimates of the chosen model must lie within 1 % of the truth (the
refinement is left out: on this record it takes about 10 s); the model written by --chosen-model has
no candidates, keeps each term in its mode, and `identify` on it gives the same recursive estimates
(relative 1e-9); `simulate` and `crlb` accept it.

Usage: select_modes.py HYSID SOURCE_DIR WORK_DIR
"""
import json
import os
import sys

from hysid_run import chosen_model_taken, run

TRUTH = {"flight_v_1": -9.81, "flight_v_11": -0.1, "stance_v_1": 390.19, "stance_v_2": -400.0}


def main():
    hysid, source, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    select = os.path.join(source, "analysis", "select")
    data, chosen = os.path.join(work, "hopper.csv"), os.path.join(work, "chosen.toml")
    first = os.path.join(work, "first.json")
    run(hysid, "simulate", "--model-file", os.path.join(select, "hopper_truth.toml"), "--sigma", "3e-4", "--seed",
        "1", "--out", data)
    run(hysid, "identify", "--model-file", os.path.join(select, "hopper_library.toml"), "--data", data,
        "--chosen-model", chosen, "--json", first, "--select-bootstrap", "20", "--refine", "none")
    report = json.load(open(first))
    sel = report["selection"]
    bad = []
    if sorted(sel["chosen"]) != sorted(TRUTH):
        bad.append(f"chosen {sel['chosen']}, expected {sorted(TRUTH)}")
    if [m["mode"] for m in sel["modes"]] != ["flight", "stance"]:
        bad.append(f"selections in modes {[m['mode'] for m in sel['modes']]}, expected flight, stance")
    for t in sel["terms"]:
        if t["mode"] != t["name"].split("_")[0]:
            bad.append(f"{t['name']}: mode {t['mode']}")
    est = dict(zip(report["names"], report["estimate"]))
    for name, truth in TRUTH.items():
        if name not in est or abs(est[name] - truth) > 0.01 * abs(truth):
            bad.append(f"{name} = {est.get(name)}: more than 1 % from {truth}")
    text = open(chosen).read()
    if "candidates" in text:
        bad.append(f"{chosen} still lists candidates")
    taken, again = chosen_model_taken(hysid, chosen, ["--data", data], est, "3e-4", work, ("--refine", "none"),
                                      rel=1e-9, floor=0.0)
    bad += taken
    if sorted(n for n in again["names"] if n in TRUTH) != sorted(TRUTH):
        bad.append(f"the chosen model's parameters {again['names']}")
    if bad:
        sys.exit("\n".join(bad))
    print("ok: chosen", sel["chosen"], "estimates", {k: est[k] for k in TRUTH})


if __name__ == "__main__":
    main()

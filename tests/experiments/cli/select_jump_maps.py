#!/usr/bin/python3
"""hysid identify on a model file with candidate terms in two [[jump]] maps, end to end
(docs/model-files.md#candidate-terms-of-a-jump, "Per map").

A ball between a floor and a ceiling (analysis/select/floor_ceiling_truth.toml: floor v+ = -0.98 v,
ceiling v+ = -0.9 v + 0.01 v|v|), four runs thrown up at 14, 17, 20 and 23 m/s, sigma = 0.01, identified
from five candidate terms of v+ per map (analysis/select/floor_ceiling_library.toml): each map's
selection must sum only its own jumps (as many as the simulations' jumps of that map) and choose exactly
its true terms (floor_v_1; ceiling_v_1 and ceiling_v_2), the bootstrap must choose each true term in at
least 90 % of its draws, and the refined coefficients must lie within 5 standard errors of the truth.
The model written by --chosen-model has no candidates and keeps the chosen terms in their maps;
`identify` on it gives the same refined estimates (relative 1e-6), `simulate` and `crlb` accept it.

Usage: select_jump_maps.py HYSID SOURCE_DIR WORK_DIR
"""
import csv
import json
import os
import sys

from hysid_run import chosen_model_taken, run

TRUTH = {"floor_v_1": -0.98, "ceiling_v_1": -0.9, "ceiling_v_2": 0.01}
CHOSEN = {"floor": ["floor_v_1"], "ceiling": ["ceiling_v_1", "ceiling_v_2"]}


def main():
    hysid, source, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    select = os.path.join(source, "analysis", "select")
    bad = []
    data, jumps = [], {"floor": 0, "ceiling": 0}
    for i, v0 in enumerate((14, 17, 20, 23)):
        out, events = (os.path.join(work, f"run{i}{ext}") for ext in (".csv", ".jumps.csv"))
        run(hysid, "simulate", "--model-file", os.path.join(select, "floor_ceiling_truth.toml"), "--x0", f"1,{v0}",
            "--sigma", "0.01", "--seed", "1", "--trial", str(i), "--out", out, "--jumps-out", events)
        data += ["--data", out]
        for row in csv.DictReader(open(events)):
            jumps[row["map"]] += 1
    chosen, report_path = os.path.join(work, "chosen.toml"), os.path.join(work, "report.json")
    text = run(hysid, "identify", "--model-file", os.path.join(select, "floor_ceiling_library.toml"), *data,
               "--chosen-model", chosen, "--json", report_path, "--select-bootstrap", "50")
    for name in ("floor", "ceiling"):
        if f"selection of jump terms of map {name}" not in text:
            bad.append(f"the report has no selection of map {name}:\n{text}")
    report = json.load(open(report_path))
    maps = report["selection"]["jump"]
    if [m["map"] for m in maps] != ["floor", "ceiling"]:
        sys.exit(f"selection.jump: {maps}, expected one object per map (floor, ceiling)")
    for m in maps:
        name = m["map"]
        if m["chosen"] != CHOSEN[name]:
            bad.append(f"{name}: chosen {m['chosen']}, expected {CHOSEN[name]}")
        if m["jumps"] != jumps[name]:
            bad.append(f"{name}: {m['jumps']} jumps summed, the simulations have {jumps[name]}")
        freq = {t["name"]: t["bootstrap_frequency"] for t in m["terms"]}
        if len(freq) != 5 or any(freq[t] < 0.9 for t in CHOSEN[name]):
            bad.append(f"{name}: bootstrap frequencies {freq}: a true term below 0.9 (or not 5 terms)")
    if report["selection"]["chosen"] != CHOSEN["floor"] + CHOSEN["ceiling"]:
        bad.append(f"chosen {report['selection']['chosen']}")
    if report["status"] != "ok":
        bad.append(f"the chosen model's refinement: {report['status']} ({report.get('reason')})")
    est = dict(zip(report["names"], report["estimate"]))
    se = dict(zip(report["names"], report["standard_errors"]))
    for name, truth in TRUTH.items():
        if name not in est or abs(est[name] - truth) > 5 * se[name]:
            bad.append(f"{name} = {est.get(name)} ± {se.get(name)}: more than 5 se from {truth}")
    model = open(chosen).read()
    if "candidates" in model or "floor_v_2" in model or "'ceiling_v_2'" not in model:
        bad.append(f"{chosen} still lists candidates, or lacks ceiling_v_2:\n{model}")
    bad += chosen_model_taken(hysid, chosen, data, est, "0.01", work)[0]
    if bad:
        sys.exit("\n".join(bad))
    print("ok:", {m["map"]: m["chosen"] for m in maps}, {n: (est[n], se[n]) for n in TRUTH})


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The term selection of examples/cube/README.md ("Which terms?"), checked on the shipped free flight:

  check_selection.py HYSID EXAMPLE_DIR OUT_DIR

1. After checking the data files' SHA-256, `hysid identify` on free-flight-library.toml (g and 20
   candidate terms of vz') over all 533 tosses with the README's --sigma and --refine none (the
   selection and its bootstrap take under a second): no candidate chosen, in each of the 100
   bootstrap draws too, over the 533 tosses' flow segments.
2. The model it writes (--chosen-model OUT_DIR/chosen.toml) is free-flight.toml: the same unknowns
   and the same phi, no candidates left.
3. That model refined on the tosses numbered below 200 (194 tosses, OUT_DIR/first_200.csv; 3 s;
   all 533 take about 50 s, and their fit is examples.cube.free_flight's, of the same model) gives
   g within two of its standard errors (0.0049 m/s²) of the README's 9.6429 m/s².
A chosen drag term fails step 1 and step 2 (the quadratic-drag model refined on the same 194 tosses
gives g = 9.6656 ± 0.0130: its g is correlated with k, so step 3 alone would not see it).
"""
import json
import os
import subprocess
import sys
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import check_recording as cr  # noqa: E402

SIGMA = ["--sigma", "3.75e-5", "0.00614"]
CANDIDATES, DRAWS, FIRST_TOSSES = 20, 100, 200


def select(hysid, example, data, out):
    chosen, out_json = os.path.join(out, "chosen.toml"), os.path.join(out, "selection.json")
    run = cr.identify(hysid, example, data, SIGMA + ["--refine", "none", "--chosen-model", chosen,
                                                      "--json", out_json], model="free-flight-library")
    if run.returncode != 0:
        return {f"selection exit 0 (got {run.returncode})": False}, chosen
    with open(out_json, encoding="utf-8") as f:
        s = json.load(f)["selection"]
    often = [t["term"] for t in s["terms"] if t["bootstrap_frequency"] > 0.1]
    return {
        f"{CANDIDATES} candidate terms": len(s["terms"]) == CANDIDATES,
        f"{cr.TOSSES} flow segments": s["segments"] == cr.TOSSES,
        f"no candidate chosen (chosen: {s['chosen']})": s["chosen"] == [],
        f"no term in more than 10% of the draws (more: {often})": not often,
        f"the chosen support in all {DRAWS} draws": s["bootstrap_draws"] == DRAWS
        and s["bootstrap_support_matches"] == DRAWS,
    }, chosen


def same_model(example, chosen):
    with open(chosen, "rb") as f:
        c = tomllib.load(f)
    with open(os.path.join(example, "free-flight.toml"), "rb") as f:
        known = tomllib.load(f)
    names = lambda m: [(p["name"], p.get("known", False)) for p in m["alpha"]]  # noqa: E731
    return {
        "the chosen model's alpha is free-flight.toml's": names(c) == names(known),
        "its phi is free-flight.toml's": c["flow"]["phi"] == known["flow"]["phi"],
        "no candidates left": "candidates" not in c["flow"],
    }


def first_tosses(data, out):
    """free_flight.csv cut to its runs below FIRST_TOSSES (194 tosses: some numbers are left out),
    written to OUT_DIR; returns its path."""
    path = os.path.join(out, f"first_{FIRST_TOSSES}.csv")
    with open(os.path.join(data, "free_flight.csv"), encoding="utf-8") as f, open(path, "w") as w:
        for line in f:
            if line.startswith("#") or line.startswith("run,") or int(line.split(",")[0]) < FIRST_TOSSES:
                w.write(line)
    return path


def refine_chosen(hysid, chosen, subset, out):
    out_json = os.path.join(out, "chosen_first.json")
    command = [hysid, "identify", "--model-file", chosen, "--data", subset, "--columns",
               "t=t,z,vz,run=run", "--json", out_json] + SIGMA
    run = subprocess.run(command, capture_output=True, text=True)
    print(run.stdout + run.stderr)
    with open(out_json, encoding="utf-8") as f:
        result = json.load(f)
    g, se = result["estimate"][0], result["standard_errors"][0]
    print(f"chosen model on the first {FIRST_TOSSES} tosses: g = {g:.6f} +- {se:.6f} (README {cr.DOCUMENTED_G})")
    return {
        "the refined estimate reported": result["reported"] is True,
        f"g within 2 se of {cr.DOCUMENTED_G}": abs(g - cr.DOCUMENTED_G) < 2 * se,
    }


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    hysid, example, out = argv
    data = os.path.join(example, "data")
    os.makedirs(out, exist_ok=True)
    if cr.report(cr.digest_checks(data)):
        return 1
    checks, chosen = select(hysid, example, data, out)
    if all(checks.values()):
        checks.update(same_model(example, chosen))
        checks.update(refine_chosen(hysid, chosen, first_tosses(data, out), out))
    return cr.report(checks)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/env python3
"""examples/drag-ball: simulate the ball, keep its height only, identify it with the defaults.

Usage: check_drag_ball.py HYSID EXAMPLE_DIR WORK_DIR SEEDS

For each seed: `hysid simulate` (σ = 1 mm) writes every state; a copy with the columns t and h alone
(the camera's data) is identified with the defaults (only the model file and the data). The fit must
be ok, g, k and e within 3 standard errors of the truth, every standard error within 20 % of the
CRLB sd of height-only samples (identify's own bound for data with a simulate sidecar), the velocity
reported as reconstructed, and the same estimate from simulate's file (all columns: h picked by name).
"""
import csv
import json
import os
import subprocess
import sys


def run(argv, ok_codes=(0,)):
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode not in ok_codes:
        sys.exit(f"{' '.join(argv)}: exit {p.returncode}\n{p.stdout}\n{p.stderr}")
    return p.stdout


def height_only(src, dst):
    """t, the true jump counter j (for the bound only) and h (simulate's measured h column)."""
    with open(src, newline="") as f, open(dst, "w", newline="") as g:
        rows = csv.DictReader(f)
        w = csv.writer(g)
        w.writerow(["t", "j", "h"])
        for r in rows:
            w.writerow([r["t"], r["j"], r["h"]])


def main():
    hysid, example, work, seeds = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    model = os.path.join(example, "drag-ball.toml")
    os.makedirs(work, exist_ok=True)
    failures = []
    for seed in range(1, seeds + 1):
        full = os.path.join(work, f"ball{seed}.csv")
        run([hysid, "simulate", "--model-file", model, "--sigma", "0.001", "--seed", str(seed), "--out", full])
        camera = os.path.join(work, f"camera{seed}.csv")
        height_only(full, camera)
        os.replace(full.replace(".csv", ".json"), camera.replace(".csv", ".json"))  # the truth, for the bound
        out = os.path.join(work, f"camera{seed}.fit.json")
        text = run([hysid, "identify", "--model-file", model, "--data", camera, "--json", out])
        fit = json.load(open(out))
        if fit["status"] != "ok":
            failures.append(f"seed {seed}: status {fit['status']}: {fit['reason']}")
            continue
        if fit["reconstructed"] != ["v"] or fit["measured"] != ["h"]:
            failures.append(f"seed {seed}: measured {fit['measured']}, reconstructed {fit['reconstructed']}")
        if "reconstructed: v from dh/dt" not in text:
            failures.append(f"seed {seed}: the text does not say v is reconstructed")
        truth = {"g": 9.81, "k": 0.05, "e": 0.85}
        for i, name in enumerate(fit["names"]):
            est, se, sd = fit["estimate"][i], fit["standard_errors"][i], fit["crlb_sd"][i]
            if name in truth and abs(est - truth[name]) > 3 * se:
                failures.append(f"seed {seed}: {name} = {est} is {abs(est - truth[name]) / se:.2f} se from {truth[name]}")
            if abs(se / sd - 1) > 0.2:
                failures.append(f"seed {seed}: {name} se {se} against CRLB sd {sd}")
        # simulate's own file (t, j, true_h, true_v, h, v): h by name, the same fit.
        os.replace(camera.replace(".csv", ".json"), full.replace(".csv", ".json"))
        out_full = os.path.join(work, f"ball{seed}.fit.json")
        run([hysid, "identify", "--model-file", model, "--data", full, "--json", out_full])
        same = json.load(open(out_full))
        if same["estimate"] != fit["estimate"]:
            failures.append(f"seed {seed}: simulate's file gives {same['estimate']}, the camera's {fit['estimate']}")
        print(f"seed {seed}: " + ", ".join(f"{n} {e:.6g} ± {s:.3g} (CRLB {c:.3g})" for n, e, s, c in
                                            zip(fit["names"], fit["estimate"], fit["standard_errors"], fit["crlb_sd"])))
    if failures:
        sys.exit("\n".join(failures))


if __name__ == "__main__":
    main()

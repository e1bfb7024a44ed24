#!/usr/bin/env python3
"""examples/thrown-ball: simulate the ball, keep the camera's frames of its position, identify it from far.

Usage: check_thrown_ball.py HYSID EXAMPLE_DIR WORK_DIR SEEDS

For each seed: `hysid simulate` (σ = 2 mm on x and z, one per measured state) writes every state; the
camera's file keeps t, x and z, without the frames in a 0.2 s dropout (its place drawn per seed) and
every 20th frame. It is identified with the defaults from a copy of the model file whose g, c, e, mu are
2.0–2.5× off the truth (the file's values). The fit must be ok on every frame kept, every unknown
(g, c, e, mu and the initial state) within 4 standard errors of the truth, and each standard error of
g, c, e, mu within 0.9–1.1× the CRLB sd of the frames kept (`hysid crlb --times`).
"""
import csv
import json
import os
import random
import re
import subprocess
import sys

TRUTH = {"g": 9.81, "c": 0.03, "e": 0.8, "mu": 0.9, "x0[x]": 0.0, "x0[z]": 1.5, "x0[vx]": 1.2, "x0[vz]": 0.0}
FAR = {"g": 4.0, "c": 0.075, "e": 0.35, "mu": 0.4}


def run(argv):
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(argv)}: exit {p.returncode}\n{p.stdout}\n{p.stderr}")
    return p.stdout


def far_model(model, path):
    """The model file with the unknowns' values replaced by FAR (a user's rough start values)."""
    text = open(model).read()
    for name, value in FAR.items():
        text, count = re.subn(rf'(name = "{name}", value = )[0-9.]+', rf"\g<1>{value}", text)
        assert count == 1, name
    open(path, "w").write(text)


def camera(src, dst, seed):
    """t, x, z without a 0.2 s dropout and every 20th frame; the number of frames kept."""
    start = random.Random(seed).uniform(0.5, 2.8)
    kept = 0
    with open(src, newline="") as f, open(dst, "w", newline="") as g:
        w = csv.writer(g)
        w.writerow(["t", "x", "z"])
        for k, r in enumerate(csv.DictReader(f)):
            if start <= float(r["t"]) < start + 0.2 or k % 20 == 7:
                continue
            w.writerow([r["t"], r["x"], r["z"]])
            kept += 1
    return kept


def main():
    hysid, example, work, seeds = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    model = os.path.join(example, "model.toml")
    os.makedirs(work, exist_ok=True)
    start = os.path.join(work, "start.toml")
    far_model(model, start)
    failures = []
    for seed in range(1, seeds + 1):
        full = os.path.join(work, f"ball{seed}.csv")
        run([hysid, "simulate", "--model-file", model, "--sigma", "0.002,0.002", "--seed", str(seed), "--out", full])
        frames = os.path.join(work, f"camera{seed}.csv")
        kept = camera(full, frames, seed)
        out = os.path.join(work, f"camera{seed}.fit.json")
        run([hysid, "identify", "--model-file", start, "--data", frames, "--json", out])
        fit = json.load(open(out))
        text = run([hysid, "crlb", "--model-file", model, "--sigma", "0.002,0.002", "--times", frames])
        crlb = {m[1]: float(m[2]) for m in re.finditer(r"^ +(\S+) += \S+ +sd (\S+)", text, re.M)}
        assert set(crlb) == set(TRUTH) and f"({kept} of 351 samples" in text, text
        if fit["status"] != "ok" or fit["samples_used"] != kept:
            failures.append(f"seed {seed}: status {fit['status']} on {fit['samples_used']} of {kept}: {fit['reason']}")
            continue
        for name, est, se in zip(fit["names"], fit["estimate"], fit["standard_errors"]):
            if abs(est - TRUTH[name]) > 4 * se:
                failures.append(f"seed {seed}: {name} = {est} is {abs(est - TRUTH[name]) / se:.2f} se from {TRUTH[name]}")
            if name in FAR and not 0.9 <= se / crlb[name] <= 1.1:
                failures.append(f"seed {seed}: {name} se {se} against the CRLB sd {crlb[name]} of its frames")
        print(f"seed {seed}: " + ", ".join(f"{n} {e:.6g} ± {s:.3g}" for n, e, s in
                                            zip(fit["names"], fit["estimate"], fit["standard_errors"])))
    if failures:
        sys.exit("\n".join(failures))


if __name__ == "__main__":
    main()

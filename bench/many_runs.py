#!/usr/bin/env python3
"""Writes the many-run data set of BENCHMARKS.md ("Memory of a many-run identify"): RUNS runs of the
§5 system (impact-msd, its default parameters), each SAMPLES samples at δt = 0.5 ms, from initial
states spread over x0 ∈ [5, 20], v0 ∈ [-20, 0] (a fixed pattern, no randomness), measured with
σ = 0.25 (noise seed = run index + 1), as one CSV with a leading run column (run, t, j, x, v).

Usage: many_runs.py HYSID OUT.csv [RUNS [SAMPLES]]   (defaults: 400 runs, 2001 samples)
"""
import csv
import os
import subprocess
import sys
import tempfile


def main(argv):
    if len(argv) < 3:
        sys.exit(__doc__)
    hysid, out = argv[1], argv[2]
    runs = int(argv[3]) if len(argv) > 3 else 400
    samples = int(argv[4]) if len(argv) > 4 else 2001
    dt = 5e-4
    t_end = (samples - 1) * dt
    with tempfile.TemporaryDirectory() as tmp, open(out, "w", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(["run", "t", "j", "x", "v"])
        for r in range(runs):
            x0 = 5.0 + 15.0 * ((r * 37) % 101) / 100.0
            v0 = -20.0 * ((r * 53) % 103) / 102.0
            path = os.path.join(tmp, "run.csv")
            subprocess.run([hysid, "simulate", "--t-end", repr(t_end), "--dt", repr(dt), "--x0",
                            f"{x0!r},{v0!r}", "--sigma", "0.25", "--seed", str(r + 1), "--out", path],
                           check=True, stdout=subprocess.DEVNULL)
            with open(path, newline="") as run:
                reader = csv.DictReader(run)
                for row in reader:
                    writer.writerow([r, row["t"], row["j"], row["x"], row["v"]])


if __name__ == "__main__":
    main(sys.argv)

#!/usr/bin/python3
"""Time `hysid identify` with its defaults on the offset impact oscillator (truth.toml, start.toml).

    bench/offset-impact/run.py --hysid build/bin/hysid [--seeds 3] [--work DIR]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.002 --seed S` (30 s at 100 Hz, 12 impacts
for seed 3), the rows in [12, 12.6) s removed (a 0.6 s gap: two chains), the data as a user has them
(t, x, v, u); then `hysid identify --model-file start.toml` on them, timed. Prints the wall time, the
status, the route and the largest |estimate − truth| / SE over the 7 unknowns.
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from own_system import identify, max_z, run_seeds, user_data  # noqa: E402

TRUTH = {"k": 6.0, "b": 0.4, "G": 2.0, "q": 0.3, "lambda": 0.75, "w": 0.35, "xe": 0.05}


def each(hysid, work, seed, args):
    data = user_data(hysid, HERE / "truth.toml", 0.002, seed, ["t", "x", "v", "u"], work,
                     keep=lambda row: not 12.0 <= float(row["t"]) < 12.6 - 1e-9)
    wall, d, error = identify(hysid, HERE / "start.toml", data, work / f"identify{seed}.json")
    if d is None:
        yield f"seed {seed}: {error}"
        return
    yield f"seed {seed}: {wall:.2f} s wall, status {d['status']}, route {d['route']}, max |z| {max_z(d, TRUTH):.2f}"


if __name__ == "__main__":
    sys.exit(run_seeds(__doc__, 3, 3, each))

#!/usr/bin/python3
"""Fit the sampled-data loop (truth.toml) from starts whose controller period T is off by a factor.

    bench/zoh-loop/run.py --hysid build/bin/hysid [--seeds 2] [--period-factors 1,1.02,1.05,1.08,1.2]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.01 --seed S` (30 s at 50 Hz, 120 ticks),
the data as a user has them (t, x, v, r); then, per factor f, `hysid identify` with its defaults from
a start file with a = 2x, K1 = 2x, K2 = 0.5x the truth and T = f x the truth, timed. Prints the wall
time, the status, T's estimate and SE, and the largest |estimate - truth| / SE over a, K1, K2, T.
"""
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from own_system import identify, max_z, run_seeds, user_data  # noqa: E402

TRUTH = {"a": 0.8, "K1": 1.5, "K2": 0.6, "T": 0.25}
START = {"a": 2.0, "K1": 2.0, "K2": 0.5}


def start_file(path, factor):
    text = (HERE / "truth.toml").read_text()
    for name, value in TRUTH.items():
        start = value * (factor if name == "T" else START[name])
        text, n = re.subn(rf'(name = "{name}", value = )[0-9.]+', rf"\g<1>{start!r}", text)
        assert n == 1, name
    path.write_text(text)


def each(hysid, work, seed, args):
    data = user_data(hysid, HERE / "truth.toml", 0.01, seed, ["t", "x", "v", "r"], work)
    for factor in (float(f) for f in args.period_factors.split(",")):
        start = work / f"start{factor}.toml"
        start_file(start, factor)
        wall, d, error = identify(hysid, start, data, work / f"identify{seed}-{factor}.json")
        if d is None:
            yield f"seed {seed}, T x{factor}: {error}"
            continue
        est = dict(zip(d["names"], d["estimate"]))
        se = dict(zip(d["names"], d["standard_errors"] or [float("nan")] * len(d["names"])))
        yield (f"seed {seed}, T x{factor}: {wall:.2f} s wall, status {d['status']}, T = {est['T']:.5f} "
               f"± {se['T']:.2g}, max |z| {max_z(d, TRUTH):.3g}")


if __name__ == "__main__":
    sys.exit(run_seeds(__doc__, 1, 2, each, [("--period-factors", "1,1.02,1.05,1.08,1.2", "factors of T's start")]))

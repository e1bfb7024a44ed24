#!/usr/bin/python3
"""Fit the oscillator with a hidden constant force (truth.toml) from starts whose F is off by a factor.

    bench/biased-wall/run.py --hysid build/bin/hysid [--seeds 2] [--force-factors 1,0.7,0.4]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.005 --seed S` (20 s at 50 Hz, about 20
impacts), the data as a user has them (t, x); then, per factor f, `hysid identify` with its defaults
from a start file with k = 1.75x, c = 0.5x and e = 0.9 (1.29x) the truth and F's start value f x the
truth, timed. Prints the wall time, the status, the start the kept fit came from, and the largest
|estimate - truth| / SE over k, c, e and x0[F].
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from own_system import identify, max_z, run_seeds, user_data  # noqa: E402

TRUTH = {"k": 4.0, "c": 0.3, "e": 0.7, "x0[F]": 1.0}


def start_file(path, factor):
    text = (HERE / "truth.toml").read_text()
    for old, new in (('name = "k", value = 4.0', 'name = "k", value = 7.0'),
                     ('name = "c", value = 0.3', 'name = "c", value = 0.15'),
                     ('name = "e", value = 0.7', 'name = "e", value = 0.9'),
                     ("x0 = [-0.5, 1.5, 1.0]", f"x0 = [-0.5, 0.0, {factor!r}]")):
        assert old in text, old
        text = text.replace(old, new)
    path.write_text(text)


def each(hysid, work, seed, args):
    data = user_data(hysid, HERE / "truth.toml", 0.005, seed, ["t", "x"], work)
    for factor in (float(f) for f in args.force_factors.split(",")):
        start = work / f"start{factor}.toml"
        start_file(start, factor)
        wall, d, error = identify(hysid, start, data, work / f"identify{seed}-{factor}.json")
        if d is None:
            yield f"seed {seed}, F x{factor}: {error}"
            continue
        est = dict(zip(d["names"], d["estimate"]))
        yield (f"seed {seed}, F x{factor}: {wall:.2f} s wall, status {d['status']}, k = {est['k']:.4f}, "
               f"F = {est['x0[F]']:.4f}, max |z| {max_z(d, TRUTH):.3g}; {d['mended'] or '-'}")


if __name__ == "__main__":
    sys.exit(run_seeds(__doc__, 1, 2, each, [("--force-factors", "1,0.7,0.4", "factors of F's start")]))

#!/usr/bin/python3
"""Fit the stick-slip oscillator (truth.toml) from its truth and from a far start, written two ways.

    bench/stick-slip/run.py --hysid build/bin/hysid [--seeds 2]

Per seed: `hysid simulate --model-file truth.toml --sigma 0.002 --seed S` (20 s at 50 Hz, x only),
the data as a user has them (t, x); then `hysid identify` with its defaults, timed, from the truth and
from a start with k = 2x, c = 2x, mu = 0.6x and xs = 1.3x the truth, for the model as written (the
map into stick sets v to the belt's speed) and for the same model with that map the identity
(v keeps its value into stick). Prints the wall time, the status, the start the kept fit came from
and the largest |estimate - truth| / SE.
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from own_system import identify, max_z, run_seeds, user_data  # noqa: E402

TRUTH = {"k": 2.0, "c": 0.1, "mu": 0.5, "xs": 0.4}
FAR = {"k": 4.0, "c": 0.2, "mu": 0.3, "xs": 0.52}
RESET = """beta = [ { name = "keep", value = 1.0, known = true }, { name = "belt", value = 0.3, known = true } ]
psi = [["x", 0], [0, 1]]
rows = ["v"]
"""


def model_file(path, values, reset):
    text = (HERE / "truth.toml").read_text()
    for name, value in values.items():
        old = f'name = "{name}", value = {TRUTH[name]!r}'
        assert old in text, old
        text = text.replace(old, f'name = "{name}", value = {value!r}')
    if not reset:
        assert RESET in text
        text = text.replace(RESET, "")
    path.write_text(text)


def each(hysid, work, seed, args):
    data = user_data(hysid, HERE / "truth.toml", 0.002, seed, ["t", "x"], work)
    for reset in (True, False):
        for start in ("truth", "far start"):
            path = work / f"{start.replace(' ', '-')}-{'reset' if reset else 'identity'}.toml"
            model_file(path, TRUTH if start == "truth" else FAR, reset)
            wall, d, error = identify(hysid, path, data, work / f"identify{seed}-{path.stem}.json")
            label = f"seed {seed}, {'v set to vb into stick' if reset else 'identity into stick'}, from the {start}"
            if d is None:
                yield f"{label}: {error}"
                continue
            yield f"{label}: {wall:.2f} s wall, status {d['status']}, max |z| {max_z(d, TRUTH):.3g}; {d['mended'] or '-'}"


if __name__ == "__main__":
    sys.exit(run_seeds(__doc__, 1, 2, each))

"""The combination matrix's family of systems (README.md here): one impact oscillator whose variants
switch on each feature of a model file, the cells, the start values and the gaps.

The base: a unit mass on a spring, x' = v, v' = -k x - b v, hitting a wall at x = w = 0.3 (rising) where
v+ = -lam v. The features:
  hidden   `measured = ["x"]`: v is not in the data (it enters x' = v, so x shows it);
  input    `inputs = ["u"]`: v' gains + G u, u a measured two-tone signal (a column of the data);
  gparam   the wall's position w is an unknown guard parameter (else the number 0.3 in the file);
  modes2   a bilinear spring: mode "soft" (x < 0, stiffness k_soft) and "stiff" (x > 0, k_stiff),
           switched by identity maps at x = 0 (both modes are visited every half period);
  jumps2   a second wall on the left at x = -0.4 (falling), v+ = -mu v: two state-resetting jump
           maps, each with its own restitution (both walls are hit);
  gap      the rows in [GAP_FROM, GAP_TO) removed from the data.
"""

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FEATURES = ("hidden", "input", "gparam", "modes2", "jumps2", "gap")
START_FACTOR = 1.5           # every unknown starts off the truth by a factor up to this
SIGMA = 5e-3                 # noise sd of the measured states
T_END, DT = 10.0, 0.02       # 501 samples
GAP_FROM, GAP_TO = 6.0, 7.0  # 50 rows removed
WALL, LEFT_WALL = 0.3, 0.4
INPUT_EXPR = "1.5*sin(1.9*t) + 0.8*sin(3.1*t + 1)"


@dataclass(frozen=True)
class Cell:
    hidden: bool = False
    input: bool = False
    gparam: bool = False
    modes2: bool = False
    jumps2: bool = False
    gap: bool = False

    @property
    def name(self):
        on = [f for f in FEATURES if getattr(self, f)]
        return "-".join(on) if on else "base"

    @property
    def index(self):
        return sum(1 << i for i, f in enumerate(FEATURES) if getattr(self, f))


def all_cells():
    return [Cell(*bits[::-1]) for bits in itertools.product((False, True), repeat=len(FEATURES))]


def known_failures():
    """known_failures.txt: {cell name: cause} of the cells expected to fail today."""
    out = {}
    for line in (Path(__file__).resolve().parent / "known_failures.txt").read_text().splitlines():
        if line and not line.startswith("#"):
            name, _, cause = line.partition(" ")
            out[name] = cause.strip()
    return out


def cell_by_name(name):
    for c in all_cells():
        if c.name == name:
            return c
    raise KeyError(f"unknown cell '{name}'")


def _param(name, value, bounds=None, known=False):
    text = f'{{ name = "{name}", value = {value!r}'
    if known:
        text += ", known = true"
    if bounds:
        text += f", bounds = [{bounds[0]!r}, {bounds[1]!r}]"
    return text + " }"


def truth_values(cell):
    """The true unknowns (α, β, γ by name) and x0 = (x, v)."""
    values = {}
    if cell.modes2:
        values.update(k_soft=3.0, k_stiff=8.0)
    else:
        values["k"] = 5.0
    values["b"] = 0.1
    if cell.input:
        values["G"] = 2.0
    values["lam"] = 0.8
    if cell.jumps2:
        values["mu"] = 0.7
    if cell.gparam:
        values["w"] = WALL
    return values, [0.2, -3.5]


BOUNDS = {"k": (0.0, 100.0), "k_soft": (0.0, 100.0), "k_stiff": (0.0, 100.0), "b": (0.0, 10.0),
          "G": (0.0, 50.0), "lam": (0.0, 1.0), "mu": (0.0, 1.0), "w": (0.1, 2.0)}


def model_text(cell, values, x0):
    """The model file of a cell with the given values of the unknowns and x0."""
    w = "w" if cell.gparam else repr(WALL)
    lines = [f"# The combination matrix's cell '{cell.name}' (tests/matrix/README.md).",
             f'name = "matrix-{cell.name}"',
             'states = ["x", "v"]']
    if cell.hidden:
        lines.append('measured = ["x"]')
    if cell.input:
        lines += ['inputs = ["u"]', f'input_defaults = {{ u = "{INPUT_EXPR}" }}']
    # α: the known 1 of x' = v, the stiffness (one, or one per mode), b, G.
    alpha = [("one", 1.0, True)]
    alpha += [(n, values[n], False) for n in (("k_soft", "k_stiff") if cell.modes2 else ("k",))]
    alpha.append(("b", values["b"], False))
    if cell.input:
        alpha.append(("G", values["G"], False))
    lines.append("alpha = [")
    lines += [f"  {_param(n, v, None if known else BOUNDS[n], known)}," for n, v, known in alpha]
    lines.append("]")
    if cell.gparam:
        lines.append(f"guard_params = [ {_param('w', values['w'], BOUNDS['w'])} ]")
    automaton = cell.modes2 or cell.jumps2
    if not automaton:  # one [jump] map over the top-level β
        lines.append(f"beta = [ {_param('one_x', 1.0, known=True)}, {_param('lam', values['lam'], BOUNDS['lam'])} ]")

    def v_row(stiff_column):
        row = ["0"] * len(alpha)
        names = [a[0] for a in alpha]
        row[names.index(stiff_column)] = '"-x"'
        row[names.index("b")] = '"-v"'
        if cell.input:
            row[names.index("G")] = '"u"'
        return "[" + ", ".join(row) + "]"

    x_row = "[" + ", ".join(['"v"'] + ["0"] * (len(alpha) - 1)) + "]"
    if cell.modes2:
        lines.append('modes = ["soft", "stiff"]')
        for mode, col in (("soft", "k_soft"), ("stiff", "k_stiff")):
            lines += ["", "[[flow]]", f'mode = "{mode}"', f"phi = [{x_row}, {v_row(col)}]", 'rows = ["v"]',
                      "jacobian_constant = true"]
    else:
        lines += ["", "[flow]", f"phi = [{x_row}, {v_row('k')}]", 'rows = ["v"]', "jacobian_constant = true"]

    def wall_map(name, guard, beta, mode):
        out = ["", "[[jump]]", f'name = "{name}"', f'guard = "{guard}"']
        if mode:
            out += [f'from = "{mode}"']
        out += [f'beta = [ {_param("one_" + name, 1.0, known=True)},',
                f'         {_param(beta, values[beta], BOUNDS[beta])} ]',
                'psi = [["x", 0], [0, "-v"]]', 'rows = ["v"]']
        return out

    if not automaton:
        lines += ["", "[jump]", 'psi = [["x", 0], [0, "-v"]]', 'rows = ["v"]']
    else:
        lines += wall_map("right", "right", "lam", "stiff" if cell.modes2 else None)
        if cell.jumps2:
            lines += wall_map("left", "left", "mu", "soft" if cell.modes2 else None)
        if cell.modes2:
            lines += ["", "[[jump]]", 'name = "to-stiff"', 'guard = "up"', 'from = "soft"', 'to = "stiff"',
                      "", "[[jump]]", 'name = "to-soft"', 'guard = "down"', 'from = "stiff"', 'to = "soft"']
    lines += ["", "[[guard]]", 'name = "right"', f'h = "x - {w}"', 'direction = "rising"',
              f'project = {{ x = "{w}" }}']
    if cell.jumps2:
        lines += ["", "[[guard]]", 'name = "left"', f'h = "x + {LEFT_WALL!r}"', 'direction = "falling"',
                  f'project = {{ x = "-{LEFT_WALL!r}" }}']
    if cell.modes2:
        lines += ["", "[[guard]]", 'name = "up"', 'h = "x"', 'direction = "rising"',
                  "", "[[guard]]", 'name = "down"', 'h = "x"', 'direction = "falling"']
    if not automaton:
        lines += ["", "[sets]", f'C = "x < {w} || (x == {w} && v <= 0)"', f'D = "x == {w} && v >= 0"']
    lines += ["", "[defaults]", f"x0 = [{x0[0]!r}, {x0[1]!r}]"]
    if cell.modes2:
        lines.append(f'mode = "{"stiff" if x0[0] > 0 or (x0[0] == 0 and x0[1] > 0) else "soft"}"')
    lines += [f"t_end = {T_END!r}", f"dt = {DT!r}", ""]
    return "\n".join(lines)


def start_values(cell):
    """Every unknown and the unmeasured v0 moved off the truth by START_FACTOR^s, s uniform in
    [-1, 1] from numpy's generator seeded with the cell's index; kept 1 % of the range inside the
    bounds."""
    values, x0 = truth_values(cell)
    rng = np.random.default_rng([45, cell.index])
    start = {}
    for name, v in values.items():
        s = v * START_FACTOR ** rng.uniform(-1.0, 1.0)
        lo, hi = BOUNDS[name]
        start[name] = min(max(s, lo + 0.01 * (hi - lo)), hi - 0.01 * (hi - lo))
    x0 = list(x0)
    if cell.hidden:
        x0[1] *= START_FACTOR ** rng.uniform(-1.0, 1.0)
    return start, x0

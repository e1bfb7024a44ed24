"""The four user systems of the evaluation (README.md here): model files, noise, inputs, gaps, starts.

Each system is a model file in this folder whose parameter values and default x0 are the truth. A draw
d (0-based) of a system is `hysid simulate` with seed d + 1, post-processed into the file a user has
(time, the measured states, the inputs; rows missing or removed), and a start file: the model file
with every unknown parameter and every unmeasured x0 component moved off the truth by up to a factor
2.5 (rules below), from numpy's generator seeded with (system index, draw).
"""

import csv
import json
import math
import re
import subprocess
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
START_FACTOR = 2.5


@dataclass
class System:
    name: str
    model: str                      # model file in this folder
    sigma: float                    # noise sd of the measured states
    start_rules: dict = field(default_factory=dict)  # unknown -> rule (default "factor")
    dropout: tuple = ()             # (t_from, t_to): rows removed (a camera dropout)
    missing_share: float = 0.0      # share of the other rows whose measured cells are NaN
    input_expr: str = ""            # u(t, phases) for the per-draw input file (numpy expression)
    input_dt: float = 0.0

    @property
    def path(self):
        return HERE / self.model

    def spec(self):
        with open(self.path, "rb") as f:
            return tomllib.load(f)


SYSTEMS = [
    System("ball", "ball.toml", sigma=2e-3, dropout=(1.95, 2.25), missing_share=0.05),
    System("impact", "impact.toml", sigma=2e-3,
           input_expr="1.2*np.sin(1.7*t + p[0]) + 0.8*np.sin(2.9*t + p[1]) + 0.5*np.sin(4.3*t + p[2])",
           input_dt=0.01),
    System("tanks", "tanks.toml", sigma=2e-2,
           input_expr="4.3 + 1.2*np.sin(0.0209*t + p[0]) + 0.6*np.sin(0.0571*t + p[1])",
           input_dt=2.0),
    System("thermostat", "thermostat.toml", sigma=5e-2,
           start_rules={"T_lo": "band", "T_hi": "band"}),
]


def system(name):
    for s in SYSTEMS:
        if s.name == name:
            return s
    raise KeyError(f"unknown system '{name}' (known: {', '.join(s.name for s in SYSTEMS)})")


def parameters(spec):
    """Every parameter of a model spec as (name, value, known, bounds)."""
    out = []
    for key in ("alpha", "beta", "guard_params"):
        for p in spec.get(key, []):
            out.append((p["name"], float(p["value"]), bool(p.get("known", False)),
                        tuple(p.get("bounds", (-math.inf, math.inf)))))
    for jump in spec.get("jump", []) if isinstance(spec.get("jump"), list) else []:
        for p in jump.get("beta", []):
            out.append((p["name"], float(p["value"]), bool(p.get("known", False)),
                        tuple(p.get("bounds", (-math.inf, math.inf)))))
    return out


def truth(spec):
    """The true θ by name: unknown α, β, γ, then x0[STATE] for every state."""
    theta = {n: v for n, v, known, _ in parameters(spec) if not known}
    for s, v in zip(spec["states"], spec["defaults"]["x0"]):
        theta[f"x0[{s}]"] = float(v)
    return theta


def measured(spec):
    return list(spec.get("measured", spec["states"]))


def _inside(value, bounds):
    """A start outside the file's bounds (e > 1, a rim above its bound) is put 1 % of the range inside."""
    lo, hi = bounds
    if value >= hi:
        return hi - 0.01 * (hi - lo) if math.isfinite(lo) else hi - 0.01 * abs(hi)
    if value <= lo:
        return lo + 0.01 * (hi - lo) if math.isfinite(hi) else lo + 0.01 * abs(lo)
    return value


def start_values(sys_index, sys, draw):
    """The start of a draw: every unknown off the truth (README.md, "Start values")."""
    spec = sys.spec()
    rng = np.random.default_rng([sys_index, draw])
    start = {}
    band = [n for n, r in sys.start_rules.items() if r == "band"]
    for name, value, known, bounds in parameters(spec):
        if known or name in band:
            continue
        factor = START_FACTOR ** rng.uniform(-1.0, 1.0)
        start[name] = _inside(value * factor, bounds)
    if band:  # thresholds: the band's width off by up to 2.5x, its centre by up to half the band
        lo, hi = sorted((dict((n, v) for n, v, *_ in parameters(spec))[b], b) for b in band)
        centre, width = 0.5 * (lo[0] + hi[0]), hi[0] - lo[0]
        width *= START_FACTOR ** rng.uniform(-1.0, 1.0)
        centre += rng.uniform(-0.5, 0.5) * (hi[0] - lo[0])
        start[lo[1]], start[hi[1]] = centre - 0.5 * width, centre + 0.5 * width
    x0 = [float(v) for v in spec["defaults"]["x0"]]
    for i, s in enumerate(spec["states"]):
        if s not in measured(spec):
            x0[i] *= START_FACTOR ** rng.uniform(-1.0, 1.0)
    return start, x0


def write_start_file(sys, start, x0, path):
    """The model file with the start values in place of the truth (text substitution, comments kept)."""
    text = sys.path.read_text()
    for name, value in start.items():
        pattern = re.compile(r'(\{ name = "' + re.escape(name) + r'", value = )([^,}]+)')
        text, count = pattern.subn(lambda m: m.group(1) + repr(float(value)), text)
        if count != 1:
            raise RuntimeError(f"{sys.model}: parameter {name} found {count} times")
    text, count = re.subn(r"(?m)^x0 = \[[^\]]*\]", "x0 = [" + ", ".join(repr(v) for v in x0) + "]",
                          text)
    if count != 1:
        raise RuntimeError(f"{sys.model}: [defaults] x0 found {count} times")
    Path(path).write_text(text)


def write_inputs(sys, draw, spec, path):
    rng = np.random.default_rng([99, draw])
    p = rng.uniform(0.0, 2.0 * math.pi, 3)
    t_end = float(spec["defaults"]["t_end"])
    t = np.arange(0.0, t_end + 0.5 * sys.input_dt, sys.input_dt)
    u = eval(sys.input_expr, {"np": np, "t": t, "p": p})
    np.savetxt(path, np.column_stack([t, u]), delimiter=",", header="t,u", comments="", fmt="%.17g")


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return rows


def draw_dir(root, sys, draw):
    return Path(root) / sys.name / f"draw{draw + 1:02d}"


def generate_draw(hysid, root, sys_index, sys, draw):
    """Simulate one draw and write truth.csv (+ sidecar), data.csv, start.toml, inputs.csv, draw.json."""
    spec = sys.spec()
    out = draw_dir(root, sys, draw)
    out.mkdir(parents=True, exist_ok=True)
    cmd = [str(hysid), "simulate", "--model-file", str(sys.path), "--sigma", repr(sys.sigma),
           "--seed", str(draw + 1), "--out", str(out / "truth.csv"), "--jumps-out", str(out / "jumps.csv")]
    if sys.input_expr:
        write_inputs(sys, draw, spec, out / "inputs.csv")
        cmd += ["--inputs", str(out / "inputs.csv")]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {run.returncode}: {run.stderr.strip()}")
    rows = read_csv(out / "truth.csv")
    rng = np.random.default_rng([sys_index, draw, 7])
    keep, cols = [], ["t"] + measured(spec) + list(spec.get("inputs", []))
    for r in rows:
        t = float(r["t"])
        if sys.dropout and sys.dropout[0] <= t < sys.dropout[1]:
            continue
        keep.append({c: r[c] for c in cols})
    n_missing = int(round(sys.missing_share * len(keep)))
    for i in rng.choice(len(keep), size=n_missing, replace=False) if n_missing else []:
        for s in measured(spec):
            keep[i][s] = "nan"
    with open(out / "data.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        w.writerows(keep)
    start, x0 = start_values(sys_index, sys, draw)
    write_start_file(sys, start, x0, out / "start.toml")
    info = {"system": sys.name, "draw": draw + 1, "seed": draw + 1, "sigma": sys.sigma,
            "truth": truth(spec), "start": start, "start_x0": x0, "rows": len(rows),
            "rows_kept": len(keep), "rows_missing": n_missing, "dropout": list(sys.dropout)}
    (out / "draw.json").write_text(json.dumps(info, indent=1))
    return out


def data_samples(draw_path, spec):
    """The sample times and measured values present in data.csv (missing cells left out)."""
    rows = read_csv(Path(draw_path) / "data.csv")
    ms = measured(spec)
    t, y = [], []
    for r in rows:
        vals = [float(r[s]) for s in ms]
        if all(math.isfinite(v) for v in vals):
            t.append(float(r["t"]))
            y.append(vals)
    return np.array(t), np.array(y)


def _simulate_true(hysid, sys, draw_path, theta, out):
    """The noise-free measured states of the true model file at θ (α, β, γ by name, x0[...])."""
    spec = sys.spec()
    params = [f"{n}={v!r}" for n, v in theta.items() if not n.startswith("x0[")]
    x0 = ",".join(repr(theta[f"x0[{s}]"]) for s in spec["states"])
    cmd = [str(hysid), "simulate", "--model-file", str(sys.path), "--sigma", "0", "--x0", x0,
           "--out", str(out)] + (["--param"] + params if params else [])
    if (Path(draw_path) / "inputs.csv").exists():
        cmd += ["--inputs", str(Path(draw_path) / "inputs.csv")]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {run.returncode}: {run.stderr.strip()}")
    rows = read_csv(out)
    return {r["t"]: [float(r["true_" + s]) for s in measured(spec)] for r in rows}


def fd_crlb(hysid, sys, draw_path, times_text, rel=1e-6):
    """CRLB sd of every unknown on the given sample times: the Fisher information SᵀS/σ² with the
    sensitivities S by central differences of noise-free `hysid simulate` runs (step rel·|θ|)."""
    spec = sys.spec()
    theta = truth(spec)
    tmp = Path(draw_path) / f"fd{rel:g}.csv"
    columns = []
    for name, value in theta.items():
        step = rel * max(abs(value), 1e-2)
        plus = _simulate_true(hysid, sys, draw_path, {**theta, name: value + step}, tmp)
        minus = _simulate_true(hysid, sys, draw_path, {**theta, name: value - step}, tmp)
        columns.append(np.concatenate([(np.array(plus[t]) - np.array(minus[t])) / (2 * step)
                                       for t in times_text]))
    tmp.unlink()
    tmp.with_suffix(".json").unlink()
    s = np.column_stack(columns) / sys.sigma
    cov = np.linalg.inv(s.T @ s)
    return dict(zip(theta, np.sqrt(np.diag(cov)).tolist()))


CRLB_LINE = re.compile(r"^\s+(\S+)\s+=\s+\S+\s+sd\s+(\S+)")


def hysid_crlb(hysid, sys, draw_path):
    """`hysid crlb` at the truth on the model's full sample grid: {name: sd}, or the failure text."""
    cmd = [str(hysid), "crlb", "--model-file", str(sys.path), "--sigma", repr(sys.sigma)]
    if (Path(draw_path) / "inputs.csv").exists():
        cmd += ["--inputs", str(Path(draw_path) / "inputs.csv")]
    run = subprocess.run(cmd, capture_output=True, text=True)
    sd = {m.group(1): float(m.group(2)) for m in map(CRLB_LINE.match, run.stdout.splitlines()) if m}
    if run.returncode != 0 or not sd:
        return None, (run.stdout + run.stderr).strip().splitlines()[-1]
    return sd, ""


def crlb(hysid, sys, draw_path):
    """The bound on the samples the data hold (cached in draw_path/crlb.json): `hysid crlb` where the
    data are the model's whole grid and it runs; else the finite-difference Fisher information on the
    data's sample times. Both are recorded with their source."""
    cache = Path(draw_path) / "crlb.json"
    if cache.exists():
        return json.loads(cache.read_text())
    spec = sys.spec()
    rows = read_csv(Path(draw_path) / "data.csv")
    present = [r["t"] for r in rows if all(math.isfinite(float(r[s])) for s in measured(spec))]
    info = json.loads((Path(draw_path) / "draw.json").read_text())
    full = len(present) == info["rows"]
    sd, why = hysid_crlb(hysid, sys, draw_path)
    result = {"hysid_crlb_full_grid": sd, "hysid_crlb_failure": why}
    if full and sd is not None:
        result.update(sd=sd, source="hysid crlb")
    else:
        result.update(sd=fd_crlb(hysid, sys, draw_path, present),
                      source=f"finite differences of hysid simulate on the {len(present)} samples"
                             + ("" if full else f" present of {info['rows']}"))
    cache.write_text(json.dumps(result, indent=1))
    return result

#!/usr/bin/python3
"""The scipy output-error peer of tests/usersys/scipy_oe.py on the stick-slip oscillator (truth.toml).

    bench/stick-slip/scipy_peer.py --hysid build/bin/hysid [--seeds 2]

The same data and starts as run.py (the model as written: v set to the belt's speed into stick):
scipy.optimize.least_squares (trf, finite-difference Jacobian, at most 100 evaluations) around
scipy_oe.simulate (solve_ivp, DOP853, terminal events for the guards, the switch applied at each),
from the truth and from k 2x, c 2x, mu 0.6x, xs 1.3x; x0 = (the first sample, 0). A fit succeeds as
in scipy_oe.py: converged, residual RMS below 1.25 sigma, every unknown within 4 of its own standard
error (central differences at the optimum). Prints the wall time, the outcome and the largest error.
"""
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent.parent / "tests" / "usersys"))
from own_system import run_seeds, user_data  # noqa: E402
from scipy_oe import FAILED_RESIDUAL, MAX_NFEV, RMS_LIMIT, Z, central_jacobian, simulate  # noqa: E402

SIGMA = 0.002
VB = 0.3
TRUTH = {"k": 2.0, "c": 0.1, "mu": 0.5, "xs": 0.4}
FAR = {"k": 4.0, "c": 0.2, "mu": 0.3, "xs": 0.52}
BOUNDS = {"k": (0.0, 50.0), "c": (0.0, 10.0), "mu": (0.0, 10.0), "xs": (0.0, 5.0)}


class StickSlip:
    def rhs(self, t, x, q, p, u):
        if q == "stick":
            return [VB, 0.0]
        return [x[1], -p["k"] * x[0] - p["c"] * x[1] + p["mu"]]

    def events(self, q, p, u):
        if q == "stick":
            return [(lambda t, x, *_: x[0] - p["xs"], +1)]
        return [(lambda t, x, *_: x[1] - VB, +1)]

    def reset(self, i, t, x, q, p, u):
        if q == "stick":
            return np.array(x), "slip"
        return np.array([x[0], VB]), "stick"


def fit(t, y, start):
    names = list(TRUTH) + ["x0[x]", "x0[v]"]
    theta0 = np.array([start[n] for n in TRUTH] + [y[0], 0.0])
    lo = np.array([BOUNDS[n][0] for n in TRUTH] + [-np.inf, -np.inf])
    hi = np.array([BOUNDS[n][1] for n in TRUTH] + [np.inf, np.inf])
    model = StickSlip()

    def residuals(theta):
        p = dict(zip(names, theta))
        try:
            ym = simulate(model, p, [p["x0[x]"], p["x0[v]"]], "slip", t, None, [0])[:, 0]
        except (ValueError, OverflowError, ZeroDivisionError):
            ym = np.full_like(y, np.nan)
        r = (ym - y) / SIGMA
        return np.where(np.isfinite(r), r, FAILED_RESIDUAL)

    res = least_squares(residuals, theta0, bounds=(lo, hi), method="trf", x_scale="jac", diff_step=1e-6,
                        max_nfev=MAX_NFEV)
    s2 = 2.0 * res.cost / max(res.fun.size - len(names), 1)
    jac = central_jacobian(residuals, res.x)
    try:
        se = np.sqrt(np.diag(np.linalg.inv(jac.T @ jac) * s2))
    except np.linalg.LinAlgError:
        se = np.full(len(names), np.nan)
    return names, res, se


def each(hysid, work, seed, args):
    data = user_data(hysid, HERE / "truth.toml", SIGMA, seed, ["t", "x"], work)
    rows = np.loadtxt(data, delimiter=",", skiprows=1)
    t, y = rows[:, 0], rows[:, 1]
    np.seterr(invalid="ignore")
    for label, start in (("truth", TRUTH), ("far start", FAR)):
        t0 = time.perf_counter()
        names, res, se = fit(t, y, start)
        wall = time.perf_counter() - t0
        rms = math.sqrt(2 * res.cost / res.fun.size)
        z = max(abs(res.x[i] - TRUTH[n]) / se[i] for i, n in enumerate(TRUTH))
        ok = bool(res.success) and rms < RMS_LIMIT and z <= Z
        yield (f"seed {seed}, scipy from the {label}: {wall:.2f} s wall, {'success' if ok else 'failed'} "
               f"(converged {bool(res.success)}, rms {rms:.3g} sigma, max |z| {z:.3g}, "
               f"k = {res.x[0]:.4f}, xs = {res.x[3]:.4f}, {res.nfev} evaluations)")


if __name__ == "__main__":
    sys.exit(run_seeds(__doc__, 1, 2, each))

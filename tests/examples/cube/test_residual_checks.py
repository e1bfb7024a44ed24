"""examples/cube/residual_checks.py: its weighted least-squares refit reproduces hysid's free-flight ĝ and
white-noise standard error (README "Identification"), and its toss-clustered standard error is the
scatter of ĝ when each toss has its own acceleration error (Monte Carlo), the white-noise one when not.
Its fit with quadratic drag (linearised in k) reproduces hysid's nonlinear fit of
free-flight-quadratic-drag.toml (README "Which terms?") and recovers k of simulated tosses."""
import importlib.util
import os

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
CUBE = os.path.join(HERE, "..", "..", "..", "examples", "cube")
spec = importlib.util.spec_from_file_location("residual_checks", os.path.join(CUBE, "residual_checks.py"))
rc = importlib.util.module_from_spec(spec)
spec.loader.exec_module(rc)


def test_refit_reproduces_hysids_free_flight_fit():
    f = rc.fit(rc.read(os.path.join(CUBE, "data", "free_flight.csv")), True)
    # `hysid identify ... --sigma 3.75e-5 0.00614`: g = 9.642935873 ± 0.001046, lag-1 0.144. Its solves
    # end at a cost change of 1e-3, a move of at most 0.045 standard errors (kCostResolution).
    assert abs(f["g"] - 9.642935873) < 0.045 * 0.001046 and abs(f["se_white"] / 0.001046 - 1) < 1e-3
    assert round(f["lag1_pooled"], 3) == 0.144 and f["tosses"] == 533


def tosses(rng, n, offset_sd):
    t = np.arange(13) * rc.DT
    out = []
    for _ in range(n):
        g = 9.8 + rng.normal(0, offset_sd)
        z = 0.2 + 0.5 * t - g * (t * t / 2 + rc.DT / 2 * t) + rng.normal(0, rc.SIGMA[0], t.size)
        v = 0.5 - g * t + rng.normal(0, rc.SIGMA[1], t.size)
        out.append((t, z, v))
    return out


def test_clustered_standard_error_is_the_scatter_of_g():
    rng = np.random.default_rng(5)
    for offset in (0.0, 0.3):
        fits = [rc.fit(tosses(rng, 100, offset), True) for _ in range(60)]
        sd = np.std([f["g"] for f in fits], ddof=1)
        clustered = np.mean([f["se_clustered"] for f in fits])
        assert abs(clustered / sd - 1) < 0.25, (offset, clustered, sd)
        white = np.mean([f["se_white"] for f in fits])
        if offset == 0.0:
            assert abs(white / sd - 1) < 0.25
        else:
            assert sd > 4 * white  # the white-noise se understates when tosses differ


def test_drag_fit_reproduces_hysids_quadratic_drag_fit():
    d = rc.drag_fit(rc.read(os.path.join(CUBE, "data", "free_flight.csv")))
    # `hysid identify --model-file examples/cube/free-flight-quadratic-drag.toml ... --sigma 3.75e-5
    # 0.00614` (the nonlinear fit): g = 9.662667676, k = 0.05520099704 ± 0.01271 (Newey-West).
    assert abs(d["g"] - 9.662667676) < 5e-4 and abs(d["k"] - 0.05520099704) < 1e-3
    assert d["se_white"][1] < 0.01271 < d["se_clustered"][1]


def drag_tosses(rng, n, k):
    """Tosses of vz' = -g - k |vz| vz, z' = vz - (dt/2) g (classical Runge-Kutta, 10 steps a frame)."""
    g, h = 9.8, rc.DT / 10

    def rate(x):
        return np.array([x[1] - rc.DT / 2 * g, -g - k * abs(x[1]) * x[1]])

    out = []
    for _ in range(n):
        x, rows = np.array([0.2, rng.uniform(-0.5, 1.0)]), []
        for _ in range(13):
            rows.append(x.copy())
            for _ in range(10):
                k1 = rate(x)
                k2 = rate(x + h / 2 * k1)
                k3 = rate(x + h / 2 * k2)
                x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + rate(x + h * k3))
        rows = np.array(rows)
        out.append((np.arange(13) * rc.DT, rows[:, 0] + rng.normal(0, rc.SIGMA[0], 13),
                    rows[:, 1] + rng.normal(0, rc.SIGMA[1], 13)))
    return out


def test_drag_fit_recovers_k_of_simulated_tosses():
    rng = np.random.default_rng(7)
    for k in (0.0, 0.5):
        d = rc.drag_fit(drag_tosses(rng, 200, k))
        assert abs(d["k"] - k) < 3 * d["se_white"][1], (k, d)
        assert abs(d["g"] - 9.8) < 3 * d["se_white"][0], (k, d)

"""examples/cube/residual_checks.py: its weighted least-squares refit reproduces hysid's free-flight ĝ and
white-noise standard error (README "Identification"), and its toss-clustered standard error is the
scatter of ĝ when each toss has its own acceleration error (Monte Carlo), the white-noise one when not."""
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
    # `hysid identify ... --sigma 3.75e-5 0.00614`: g = 9.642912011 ± 0.001046, lag-1 0.144.
    assert abs(f["g"] - 9.642912011) < 1e-6 and abs(f["se_white"] / 0.001046 - 1) < 1e-3
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

"""The SINDy reference (analysis/select/sindy_reference.py) against cases with a known answer."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "analysis", "select"))
import sindy_reference as sindy  # noqa: E402


def test_sparsify_dynamics_recovers_a_sparse_vector_from_exact_data():
    rng = np.random.default_rng(1)
    theta = rng.normal(size=(400, 6))
    xi = np.array([0.0, 2.0, 0.0, -0.5, 0.0, 0.0])
    got = sindy.sparsify_dynamics(theta, theta @ xi, lam=0.1)
    assert np.array_equal(got != 0, xi != 0)
    assert np.allclose(got, xi, atol=1e-12)


def test_an_oscillator_with_exact_samples_gives_its_two_terms():
    # x' = v, v' = -4 x - 0.2 v sampled finely without noise, one segment: v' from 5 terms is -4 x - 0.2 v.
    t = np.linspace(0.0, 10.0, 20001)
    w = np.sqrt(4.0 - 0.01)
    x = np.exp(-0.1 * t) * np.cos(w * t)
    v = np.exp(-0.1 * t) * (-0.1 * np.cos(w * t) - w * np.sin(w * t))
    support, coef = sindy.identify_row(t, {"x": x, "v": v}, np.zeros(len(t), int), "v",
                                       ["1", "x", "v", "x^2", "abs(v)*v"], rule="bic")
    assert list(support) == [False, True, True, False, False]
    assert abs(coef[1] + 4.0) < 1e-4 and abs(coef[2] + 0.2) < 1e-4


def test_flow_segments_split_at_the_jump_counter():
    assert sindy.flow_segments([0, 0, 0, 0, 1, 1, 1, 2, 2]) == [(0, 4), (4, 7)]

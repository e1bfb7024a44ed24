"""Intervals, number formatting and axis-scale rules against independent computations."""
import math

import numpy as np
import pytest

from hysid_plots import stats, style


def binomial_quantile(n, p, q):
    """Smallest k with P(Binomial(n, p) <= k) >= q, by summing the probabilities."""
    acc = 0.0
    for k in range(n + 1):
        acc += math.comb(n, k) * p ** k * (1 - p) ** (n - k)
        if acc >= q:
            return k
    return n


def test_bootstrap_of_a_two_point_sample_matches_the_binomial_quantiles():
    # The bootstrap mean of 10 ones and 40 zeros is Binomial(50, 0.2) / 50: its 2.5 % and 97.5 %
    # quantiles are the exact interval; 2000 resamples land within one step (1/50) of them.
    values = np.array([1.0] * 10 + [0.0] * 40)
    est, lo, hi = stats.bootstrap(values, "mean", cell=7)
    assert est == 0.2
    assert abs(lo - binomial_quantile(50, 0.2, 0.025) / 50) <= 1 / 50 + 1e-12
    assert abs(hi - binomial_quantile(50, 0.2, 0.975) / 50) <= 1 / 50 + 1e-12


def test_bootstrap_is_deterministic_and_depends_on_the_cell():
    v = np.random.default_rng(1).lognormal(size=30)
    assert stats.bootstrap(v, "mean", 3) == stats.bootstrap(v, "mean", 3)
    assert stats.bootstrap(v, "mean", 3) != stats.bootstrap(v, "mean", 4)


@pytest.mark.parametrize("stat", ["mean", "median"])
def test_bootstrap_of_skewed_non_negative_data_stays_above_zero(stat):
    # Mostly zeros and one large value: mean ± 1.96 sd/√n would go below 0; the percentile interval cannot.
    v = np.array([0.0] * 19 + [0.0134])
    est, lo, hi = stats.bootstrap(v, stat, 0)
    assert np.mean(v) - 1.96 * np.std(v, ddof=1) / math.sqrt(v.size) < 0
    assert 0.0 <= lo <= est <= hi


def test_bootstrap_of_constant_data_is_a_point():
    assert stats.bootstrap(np.full(5, 2.5), "mean", 0) == (2.5, 2.5, 2.5)


@pytest.mark.parametrize("x,d,text", [(0.0071234, 2, "0.0071"), (4.5671e-7, 2, "4.6e-7"), (0.0, 2, "0"),
                                      (1234.5, 3, "1230"), (123456.0, 2, "1.2e5"), (0.25, 3, "0.250"),
                                      (math.nan, 2, "–")])
def test_significant_digits(x, d, text):
    assert stats.sig(x, d) == text


def test_digits_follow_the_interval_width():
    assert stats.digits_for(0.0071, 0.0065, 0.0078) == 2   # width 1.3e-3 on 7.1e-3
    assert stats.digits_for(5.00186, 5.0017, 5.0020) == 6  # width 3e-4: down to 1e-5
    assert stats.digits_for(1.0, 1.0, 1.0) == 2


@pytest.mark.parametrize("grid,spread", [([0, 0.25, 0.5, 0.75, 1.0], False), ([0.0, 0.05, 0.2], False),
                                         ([0, 0.05, 0.1, 0.25, 0.5], True), ([1e-3, 2e-3, 4e-3], True),
                                         ([0.01, 0.1, 1.0], True), ([0.1, 0.2, 0.3], False), ([0.5], False)])
def test_grid_axis_is_log_for_spread_or_log_spaced_grids(grid, spread):
    assert style.is_spread(grid) == spread
    fig, ax = style.figure("single")
    ax = ax[0][0]
    ax.plot(grid, [1] * len(grid))
    want = ("symlog" if min(grid) == 0 else "log") if spread else "linear"
    assert style.set_grid_axis(ax, grid) == want
    assert ax.get_xscale() == want


@pytest.mark.parametrize("values,scale", [([1e-6, 1e-2, 0.5], "log"), ([0.0, 1e-5, 1e-3], "symlog"),
                                          ([0.0, 0.0], "linear"), ([-1.0, 2.0], "linear")])
def test_value_axis(values, scale):
    fig, ax = style.figure("single")
    assert style.set_value_axis(ax[0][0], values) == scale
    if scale == "symlog":
        assert ax[0][0].yaxis.get_transform().linthresh == 1e-5


@pytest.mark.parametrize("est,lo,hi,text", [(1.95771, 1.95569, 1.95991, "1.9577 [1.9557, 1.9599]"),
                                            (0.001043, 0.000741, 0.001352, "0.00104 [7.4e-4, 0.00135]"),
                                            (4.6e-7, 4.6e-7, 4.6e-7, "4.6e-7"),
                                            (1.5e-6, 0.0, 4.5e-6, "1.5e-6 [0, 4.5e-6]")])
def test_interval_text_rounds_the_bounds_at_the_estimates_last_digit(est, lo, hi, text):
    assert stats.interval_text(est, lo, hi) == text


def test_grid_labels_of_a_log_range_round_to_what_tells_neighbours_apart():
    # { from = 0.01, to = 1, count = 5, log = true }: the ends as written, the generated values to 2 digits.
    grid = list(np.logspace(-2, 0, 5))
    assert grid[1] == pytest.approx(0.0316227766)
    labels = stats.grid_labels(grid)
    assert [labels[v] for v in grid] == ["0.01", "0.032", "0.1", "0.32", "1"]
    # A value as written (≤ 4 significant digits) keeps every digit, even when fewer would tell it apart.
    assert stats.grid_labels([0.25, 0.5, 1.0, 1e-08, 0.0005]) == {0.25: "0.25", 0.5: "0.5", 1.0: "1",
                                                                   1e-08: "1e-08", 0.0005: "0.0005"}
    # Close generated neighbours get the digits that separate them; labels stay distinct.
    tight = list(np.geomspace(1.0, 1.01, 4))
    texts = [stats.grid_labels(tight)[v] for v in tight]
    assert len(set(texts)) == 4 and texts[0] == "1" and texts[-1] == "1.01"
    for v, t in zip(tight, texts):
        assert abs(float(t) - v) <= 0.5 * 10 ** (math.floor(math.log10(v)) - len(t.replace(".", "")) + 2)
    assert stats.grid_label(grid, grid[3]) == "0.32" and stats.grid_label(grid, "rls") == "rls"


def test_grid_axis_ticks_use_the_grid_labels():
    fig, axes = style.figure("single")
    ax = axes[0][0]
    grid = list(np.logspace(-2, 0, 5))
    ax.plot(grid, grid)
    style.set_grid_axis(ax, grid)
    fmt = ax.xaxis.get_major_formatter()
    assert [fmt(v, i) for i, v in enumerate(grid)] == ["0.01", "0.032", "0.1", "0.32", "1"]

"""Intervals and number formatting.

The interval of a cell's mean (or median) is the percentile bootstrap over its trials (trials.csv):
B = 2000 resamples drawn with a generator seeded by (SEED, cell), so the same data give the same
bounds on every run. A percentile interval lies inside the range of the data: it is never below 0 for
a non-negative metric. Without trials.csv the summary's interval is used (docs/figures.md: a rate's Wilson
score interval at the effective sample size, a non-negative metric's percentile bootstrap; both inside the
metric's range), clipped at 0 for a non-negative metric in case the summary.csv is older; captions name
which one a figure shows.
"""
import math

import numpy as np

from . import data

SEED = 20201123
RESAMPLES = 2000
LEVEL = 0.95


def bootstrap(values, stat, cell):
    """(estimate, lo, hi) of `stat` ('mean' or 'median') of `values` with its percentile interval."""
    values = np.asarray(values, dtype=float)
    n = values.size
    if n == 0:
        return math.nan, math.nan, math.nan
    f = np.mean if stat == "mean" else np.median
    est = float(f(values))
    if n == 1 or np.all(values == values[0]):
        return est, est, est
    rng = np.random.default_rng([SEED, int(cell)])
    idx = rng.integers(0, n, size=(RESAMPLES, n))
    boot = f(values[idx], axis=1)
    a = (1 - LEVEL) / 2
    lo, hi = np.quantile(boot, [a, 1 - a])
    return est, float(lo), float(hi)


class Intervals:
    """Point estimate and 95 % interval of a metric per summary row, from trials.csv when present."""

    def __init__(self, run, stat="mean"):
        if stat not in ("mean", "median"):
            raise data.DataError(f"--stat = '{stat}': must be mean or median")
        self.run = run
        self.stat = stat
        self.bootstrapped = run.trials is not None
        self._cache = {}

    def of(self, row, metric, scale=1.0):
        """(estimate, lo, hi, n) of `metric` in summary row `row`, each divided by `scale`."""
        key = (row["_line"], metric, self.stat)
        if key not in self._cache:
            self._cache[key] = self._compute(row, metric)
        est, lo, hi, n = self._cache[key]
        return est / scale, lo / scale, hi / scale, n

    def values(self, row, column):
        return self.run.trials.column(row["cell"], column)

    def of_values(self, row, values, tag):
        """(estimate, lo, hi, n) of derived per-trial `values` of row's cell (cached under `tag`)."""
        key = (row["_line"], tag, self.stat)
        if key not in self._cache:
            est, lo, hi = bootstrap(values, self.stat, row["cell"])
            self._cache[key] = (est, lo, hi, len(values))
        return self._cache[key]

    def _compute(self, row, metric):
        if self.bootstrapped:
            v = self.run.trials.column(row["cell"], metric)
            est, lo, hi = bootstrap(v, self.stat, row["cell"])
            return est, lo, hi, v.size
        if self.stat == "median":
            med = row.get(f"{metric}_median", math.nan)
            return med, math.nan, math.nan, int(row.get("trials", 0) - row.get("failures", 0))
        lo, hi = self.run.summary.interval(row, metric)
        if metric in data.NON_NEGATIVE:
            lo = max(lo, 0.0)
        n = row.get("trials", math.nan) - (row.get("failures", 0) or 0)
        return row[f"{metric}_mean"], lo, hi, int(n) if math.isfinite(n) else 0

    def method(self):
        """The interval method, for captions and table notes."""
        if self.bootstrapped:
            return (f"{self.stat} over the trials of each cell with its 95 % percentile bootstrap interval "
                    f"({RESAMPLES} resamples, seed {SEED}; from trials.csv)")
        if self.stat == "median":
            return "median over the trials of each cell (summary.csv; no interval without trials.csv)"
        return ("mean over the trials of each cell with the 95 % interval of summary.csv (trials.csv absent): "
                "for a rate the Wilson score interval at the effective sample size, for a non-negative error or "
                f"count the percentile bootstrap ({RESAMPLES} resamples); clipped at 0")


def crn_note(summary):
    """The caption's sentence on common random numbers (docs/architecture.md): the cells of one model and
    δt see the same noise draws in trial i, so their intervals are not independent."""
    where = ("summary.csv's *_diff_mean, *_diff_ci95_lo, *_diff_ci95_hi columns (each cell minus its baseline "
             "cell over the same trials)" if summary.has("e_alpha_diff_mean") else
             "summary.csv's *_diff_* columns once the sweep file sets [summary] baseline")
    return ("Common random numbers: every cell of one model and δt sees the same noise draws in trial i (σ "
            "scales them), so the intervals of different points are not independent; overlapping intervals do "
            "not show that two cells are alike, and the interval of a difference is not read off two of them: "
            f"the paired differences are in {where}. ")


WRITTEN_DIGITS = 4  # a grid value with at most this many significant digits is shown as written
LABEL_DIGITS = 2  # the fewest significant digits of a generated grid value's label


def significant_digits(x):
    """The significant digits of x's shortest round-trip decimal (repr): 0.01 → 1, 0.0310723… → 17."""
    mantissa = repr(abs(float(x))).split("e")[0].replace(".", "").lstrip("0").rstrip("0")
    return max(1, len(mantissa))


def grid_labels(values):
    """{value: label} of a grid axis (σ, δt, r, ...). A value with at most WRITTEN_DIGITS significant
    digits (one written in the sweep file or summary.csv, e.g. 0.05, 2.5e-4) is shown as written; a
    generated one (a `{ from, to, count, log = true }` range: 0.0310723…) is rounded to the fewest
    significant digits, at least LABEL_DIGITS, that tell it apart from both neighbours on the grid."""
    grid = sorted({float(v) for v in values if isinstance(v, (int, float)) and math.isfinite(v)})
    labels = {}
    for i, v in enumerate(grid):
        if significant_digits(v) <= WRITTEN_DIGITS:
            labels[v] = f"{v:g}"
            continue
        neighbours = grid[max(i - 1, 0):i] + grid[i + 1:i + 2]
        d = LABEL_DIGITS
        while d < 17 and any(float(f"{v:.{d}g}") == float(f"{u:.{d}g}") for u in neighbours):
            d += 1
        labels[v] = f"{v:.{d}g}"
    return labels


def grid_label(grid, v):
    """The label of value v of a grid axis whose values are `grid` (grid_labels); strings as they are."""
    if isinstance(v, str):
        return v
    return grid_labels(list(grid) + [v]).get(float(v), f"{v:g}")


def sig(x, digits=2):
    """x with `digits` significant digits, plain or in e-notation as shorter; '–' for NaN."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if x == 0:
        return "0"
    e = math.floor(math.log10(abs(x)))
    if -3 <= e < 5:
        return f"{round(x, digits - 1 - e):.{max(digits - 1 - e, 0)}f}"
    return f"{x:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e")


def digits_for(est, lo, hi):
    """Significant digits for `est` so that the interval's width shows in its last one or two digits."""
    if not all(map(math.isfinite, (est, lo, hi))) or est == 0 or hi <= lo:
        return 2
    width = hi - lo
    return int(min(6, max(2, math.floor(math.log10(abs(est))) - math.floor(math.log10(width)) + 2)))


def sig_at(x, place):
    """x rounded at the decimal place 10**place (the last digit of the estimate it goes with)."""
    if not math.isfinite(x) or x == 0:
        return sig(x)
    return sig(x, max(1, math.floor(math.log10(abs(x))) - place + 1))


def interval_parts(est, lo, hi):
    """(est, lo, hi) as text: est with the digits its interval supports, the bounds to est's last digit."""
    d = digits_for(est, lo, hi)
    if not (math.isfinite(lo) and math.isfinite(hi)) or (est == 0 and hi <= 0):
        return sig(est, d), sig(lo), sig(hi)
    place = math.floor(math.log10(abs(est))) - d + 1 if est != 0 else math.floor(math.log10(hi)) - 1
    return sig(est, d), sig_at(lo, place), sig_at(hi, place)


def interval_text(est, lo, hi):
    """'est [lo, hi]'; just 'est' for a point interval or none."""
    e, lo_t, hi_t = interval_parts(est, lo, hi)
    if math.isfinite(lo) and (lo != est or hi != est):
        return f"{e} [{lo_t}, {hi_t}]"
    return e

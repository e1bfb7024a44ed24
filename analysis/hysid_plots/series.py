"""Splitting a summary into figures and the series (lines) of a figure, in numeric order."""
import math

from . import data, stats

FIGURE_KEYS = ("model", "dt")      # one figure per value of these (when they vary)
NOT_SERIES = ("model", "dt", "sigma")


def fmt_key(key, v, grid=None):
    """A key's value as text: a grid value as labelled on its axis (stats.grid_labels) when the axis's
    values `grid` are given, else with up to 6 significant digits."""
    if isinstance(v, str):
        return v
    return stats.grid_label(grid, v) if grid is not None else f"{v:g}"


def figure_groups(summary, keys=FIGURE_KEYS):
    """[(dict of the figure's key values, rows)] in numeric order of the keys."""
    keys = [k for k in keys if k in summary.keys]
    order = [summary.values(k) for k in keys]
    groups = {}
    for r in summary.rows:
        idx = tuple(index_of(order[i], r[k]) for i, k in enumerate(keys))
        groups.setdefault(idx, []).append(r)
    return [({k: order[i][j] for i, (k, j) in enumerate(zip(keys, idx))}, groups[idx]) for idx in sorted(groups)]


def index_of(values, v):
    for i, s in enumerate(values):
        if data.same(s, v):
            return i
    raise KeyError(v)


class Series:
    def __init__(self, label, rows, group, sub, index):
        self.label, self.rows, self.group, self.sub, self.index = label, rows, group, sub, index


def detector_text(row, summary=None):
    """'paper r = 220', 'residual p = 1e-08' (the detector and its setting; r and p labelled as on their
    grid when the summary is given)."""
    text = row.get("detector", "")
    for key, sym in (("r", "r"), ("false_alarm", "p")):
        if math.isfinite(row.get(key, math.nan)):
            grid = summary.values(key) if summary is not None and key in summary.keys else None
            text += f" {sym} = {fmt_key(key, row[key], grid)}"
    return text.strip()


def series(summary, rows, x="sigma"):
    """The lines of one figure: one per combination of the other keys, ordered by estimator (grid
    order), detector, then r and p numerically; rows of a line sorted by x. Colour group = estimator,
    dash group = detector setting."""
    keys = [k for k in summary.keys if k not in NOT_SERIES and k != x]
    order = {k: summary.values(k) for k in keys}
    lines = {}
    for r in rows:
        idx = tuple(index_of(order[k], r[k]) for k in keys)
        lines.setdefault(idx, []).append(r)
    varying = [k for k in keys if len({index_of(order[k], r[k]) for r in rows}) > 1]
    estimators = order.get("estimator", [None])
    det_settings = []
    out = []
    # Detector before estimator in the sort when both vary: lines of one detector setting stay together.
    sort_keys = sorted(range(len(keys)), key=lambda i: 0 if keys[i] == "detector" else 1)
    for n, idx in enumerate(sorted(lines, key=lambda t: [t[i] for i in sort_keys])):
        rs = sorted(lines[idx], key=lambda r: r[x])
        r0 = rs[0]
        parts = []
        if "estimator" in varying:
            parts.append(r0["estimator"])
        if any(k in varying for k in ("detector", "r", "false_alarm")):
            parts.append(detector_text(r0, summary))
        parts += [f"{k} = {fmt_key(k, r0[k], order[k])}" for k in varying if k not in ("estimator", "detector", "r",
                                                                             "false_alarm")]
        setting = detector_text(r0, summary)
        if setting not in det_settings:
            det_settings.append(setting)
        group = estimators.index(r0["estimator"]) if "estimator" in varying else n
        out.append(Series(", ".join(parts) or "all", rs, group, det_settings.index(setting), n))
    return out


def title_of(fixed, summary=None):
    """'impact-msd, δt = 0.0005 s' from a figure's key values (labelled as on their grid when the summary
    is given)."""
    parts = []
    for k, v in fixed.items():
        text = fmt_key(k, v, summary.values(k) if summary is not None and k in summary.keys else None)
        parts.append(v if k == "model" else (f"δt = {text} s" if k == "dt" else f"{k} = {text}"))
    return ", ".join(parts)


def slug(fixed):
    out = []
    for k, v in fixed.items():
        out.append(v if k == "model" else f"{k}{fmt_key(k, v)}".replace("-", "m").replace("+", ""))
    return "_".join(out)

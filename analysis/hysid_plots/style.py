"""The look shared by every figure: hysid.mplstyle, the two column widths, the series styles, the
axis scales chosen from the data, and saving a figure with its caption file."""
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker as mticker  # noqa: E402
import numpy as np  # noqa: E402

from . import stats  # noqa: E402

STYLE = os.path.join(os.path.dirname(__file__), "hysid.mplstyle")
# Heat-map cell labels (pt): readable at one column's width; a map whose cells are too narrow for them
# at this size shows the colour bar only.
CELL_LABEL_PT = 8
WIDTHS = {"single": 3.5, "double": 7.16}  # inches: one column / the full page of a two-column paper
FORMATS = ("pdf", "svg", "png")
DPI = 300  # of PNG files (--dpi)
# Okabe-Ito colours (distinct for colour-blind readers; wine instead of its yellow, faint on white);
# markers and dashes tell series apart in grey.
COLORS = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#882255"]
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "<", ">", "p", "h", "*"]
DASHES = ["-", "--", ":", "-."]

plt.style.use(STYLE)


def figure(width, rows=1, cols=1, height=None, **kw):
    """A figure `width` ('single' or 'double') wide; `height` in inches (default: panels of 0.62 × their
    width for one column, 0.75 for several)."""
    w = WIDTHS[width]
    if height is None:
        height = rows * (w / cols) * (0.62 if cols == 1 else 0.75)
    return plt.subplots(rows, cols, figsize=(w, height), squeeze=False, **kw)


def series_style(i, group, sub):
    """Line style of series i: colour from `group` (e.g. the estimator), dashes from `sub` (e.g. the
    detector setting), a hollow marker of its own (coinciding series show both markers)."""
    return {"color": COLORS[group % len(COLORS)], "linestyle": DASHES[sub % len(DASHES)],
            "marker": MARKERS[i % len(MARKERS)], "markerfacecolor": "none", "markeredgewidth": 0.8}


def panels(width, n, legend_entries=0, panel_height=None, cols=None, title_lines=0):
    """A figure of n panels (one column for a single-width figure of up to 3, else up to 4 a row) and,
    when legend_entries > 0, a row below them holding the legend (it never covers data; title_lines more
    lines of it for the legend's title).
    Returns (fig, list of panel axes, legend axes or None, legend columns)."""
    cols = cols or ((1 if n <= 3 else 2) if width == "single" else min(n, 4))
    rows = math.ceil(n / cols)
    w = WIDTHS[width]
    ph = panel_height or (1.45 if cols == 1 else 0.75 * w / cols)
    ncol = 2 if width == "single" else 4
    leg_h = 0.0 if legend_entries == 0 else 0.16 * (math.ceil(legend_entries / ncol) + title_lines) + 0.08
    fig = plt.figure(figsize=(w, rows * ph + leg_h), constrained_layout=True)
    gs = fig.add_gridspec(rows + (1 if leg_h else 0), cols,
                          height_ratios=[ph] * rows + ([leg_h] if leg_h else []))
    axes = [fig.add_subplot(gs[i // cols, i % cols]) for i in range(n)]
    leg = None
    if leg_h:
        leg = fig.add_subplot(gs[rows, :])
        leg.axis("off")
    return fig, axes, leg, ncol


def is_spread(values):
    """True when positive grid values span a decade or more, or grow by a constant ratio (a log grid)."""
    pos = np.array(sorted(v for v in values if v > 0))
    if pos.size < 2:
        return False
    steps = np.diff(np.concatenate(([0.0], pos)) if len(pos) < len(values) else pos)
    if np.allclose(steps, steps[0], rtol=1e-6):
        return False  # evenly spaced (including from 0): a linear grid
    ratios = pos[1:] / pos[:-1]
    return pos[-1] / pos[0] >= 10 or (pos.size >= 3 and np.allclose(ratios, ratios[0], rtol=1e-6))


def set_grid_axis(ax, values, axis="x"):
    """Scale of a grid axis (σ, δt, ...): log for a spread positive grid, symlog when 0 is in it too (the
    stretch from 0 to the smallest positive value drawn linear), else linear. Returns the scale."""
    values = [v for v in values if math.isfinite(v)]
    setter = ax.set_xscale if axis == "x" else ax.set_yscale
    if not is_spread(values):
        return "linear"
    minpos = min(v for v in values if v > 0)
    which = ax.xaxis if axis == "x" else ax.yaxis
    if min(values) <= 0:
        setter("symlog", linthresh=minpos, linscale=0.4)
        scale = "symlog"
    else:
        setter("log")
        scale = "log"
    # Limits in the scaled space (call after drawing): a margin of 3 % of the decades spanned.
    margin = 10 ** (0.03 * math.log10(max(values) / minpos) + 0.01)
    (ax.set_xlim if axis == "x" else ax.set_ylim)(-0.1 * minpos if scale == "symlog" else minpos / margin,
                                                  max(values) * margin)
    which.set_major_locator(mticker.FixedLocator(sorted(set(values))))  # thinned by space_ticks on saving
    labels = stats.grid_labels(values)
    which.set_major_formatter(mticker.FuncFormatter(lambda v, _: labels.get(float(v), f"{v:g}")))
    which.set_minor_locator(mticker.NullLocator())
    ax.hysid_grid_ticks = (sorted(set(values)), axis)
    return scale


def space_ticks(fig):
    """After the layout: drops grid ticks whose labels would touch (see spaced_ticks)."""
    marked = [ax for ax in fig.axes if hasattr(ax, "hysid_grid_ticks")]
    if not marked:
        return
    engine = fig.get_layout_engine()
    if engine is not None:
        engine.execute(fig)
    for ax in marked:
        grid, axis = ax.hysid_grid_ticks
        (ax.xaxis if axis == "x" else ax.yaxis).set_major_locator(mticker.FixedLocator(spaced_ticks(ax, grid,
                                                                                                    axis)))


def spaced_ticks(ax, grid, axis):
    """The grid values as ticks, without those whose labels would touch a neighbour's (the largest is
    kept; labels ~0.62 em a character at 8 pt plus 5 pt)."""
    fig = ax.figure
    pos = ax.get_position()
    length_pt = (pos.width if axis == "x" else pos.height) * fig.get_size_inches()[0 if axis == "x" else 1] * 72
    tr = (ax.xaxis if axis == "x" else ax.yaxis).get_transform()
    lim = ax.get_xlim() if axis == "x" else ax.get_ylim()
    lo, hi = tr.transform(np.array(lim, dtype=float))
    at = (tr.transform(np.array(grid, dtype=float)) - lo) / (hi - lo) * length_pt
    labels = stats.grid_labels(grid)
    need = [(len(labels[float(v)]) * 0.62 * 8 if axis == "x" else 8) + 5 for v in grid]
    kept = [len(grid) - 1]
    for i in range(len(grid) - 2, -1, -1):
        if at[kept[-1]] - at[i] >= (need[i] + need[kept[-1]]) / 2:
            kept.append(i)
    return [grid[i] for i in sorted(kept)]


def power_label(v, _):
    if v == 0:
        return "0"
    k = math.log10(abs(v))
    return f"$10^{{{int(round(k))}}}$" if abs(k - round(k)) < 1e-9 else f"{v:g}"


def set_value_axis(ax, values, axis="y"):
    """Scale of a value axis (errors, rates): log when every drawn value is > 0; symlog with its linear
    part below the smallest positive value when some are 0; linear when none is > 0."""
    v = np.asarray([x for x in values if math.isfinite(x)])
    setter = ax.set_yscale if axis == "y" else ax.set_xscale
    pos = v[v > 0]
    if np.any(v < 0):
        return "linear"
    if pos.size == 0:
        (ax.set_ylim if axis == "y" else ax.set_xlim)(0, 1)  # nothing above 0 (e.g. no misclassification)
        return "linear"
    if pos.size == v.size:
        setter("log")
        return "log"
    lo = math.floor(math.log10(pos.min()))
    hi = math.ceil(math.log10(pos.max()))
    setter("symlog", linthresh=10.0 ** lo, linscale=1.0)  # 0 sits one decade below the smallest value
    which = ax.yaxis if axis == "y" else ax.xaxis
    stride = max(1, math.ceil((hi - lo) / 5))
    which.set_major_locator(mticker.FixedLocator([0.0] + [10.0 ** k for k in range(hi, lo - 1, -stride)]))
    which.set_major_formatter(mticker.FuncFormatter(power_label))
    which.set_minor_locator(mticker.NullLocator())
    return "symlog"


def save(fig, out_dir, stem, formats, caption):
    """Writes out_dir/stem.FMT for each of `formats` and the caption out_dir/stem.txt; returns the
    figure paths."""
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise ValueError(f"--format = '{','.join(formats)}': must be one or more of {', '.join(FORMATS)}")
    os.makedirs(out_dir, exist_ok=True)
    space_ticks(fig)
    paths = []
    for fmt in formats:
        path = os.path.join(out_dir, f"{stem}.{fmt}")
        meta = {"pdf": {"CreationDate": None, "ModDate": None}, "svg": {"Date": None}, "png": {}}[fmt]
        fig.savefig(path, format=fmt, metadata=meta, dpi=DPI)
        paths.append(path)
    plt.close(fig)
    with open(os.path.join(out_dir, f"{stem}.txt"), "w") as f:
        f.write(caption.strip() + "\n")
    return paths


def is_bottom(ax, axes):
    """True when no panel of `axes` lies below `ax` in its column (it carries the x label)."""
    spec = ax.get_subplotspec()
    col, row = spec.colspan.start, spec.rowspan.start
    return not any(a.get_subplotspec().colspan.start == col and a.get_subplotspec().rowspan.start > row
                   for a in axes)

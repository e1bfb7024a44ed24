"""Figures of a sweep run directory: error vs σ, efficiency against the CRLB, per-parameter relative
error, misclassification over δt × r. Each function returns the paths it wrote."""
import math

import matplotlib.lines
import matplotlib.transforms
import numpy as np

from . import data, series, stats, style

ERROR_PANELS = [("e_alpha", r"$e_\alpha = \|\hat\alpha - \alpha\|$"),
                ("e_beta", r"$e_\beta = \|\hat\beta - \beta\|$"),
                ("misclassification", "misclassification rate")]
SIGMA_LABEL = r"noise $\sigma$"
# What the CRLB-implied errors include (docs/method.md, sensitivities): the bound of the unknown α, β
# and ξ0 from the sensitivities at a fixed jump count, so the information in the jump times is left out.
BOUND_NOTE = ("The bound (summary.csv's crlb_e_alpha, crlb_e_beta) is that of the unknown α, β and ξ0 with "
              "the jump times held fixed: it leaves out the information the jump times carry, so an estimator "
              "that uses it can lie below the line (a ratio below 1 is not below the bound of the full problem). ")
# The short form shown in the figure (the legend's title).
# The legend title's second line in a figure with a CRLB line or ratio: what the bound leaves out.
BOUND_MARK = "CRLB-implied: jump times held fixed"
CRN_MARK = "cells share noise draws: intervals not independent"
FAILED_LABEL = "every trial failed"
# The caption's sentence on failed trials (when some cell has any).
FAILED_NOTE = ("A number beside a point counts that cell's failed trials (summary.csv's failures: a simulation, "
               "identification or refinement that did not succeed), left out of its point; × at the foot of a "
               "panel marks a cell every trial of which failed, with its count. ")


def crlb_column(summary, metric):
    """The summary's CRLB-implied value of `metric` (crlb_e_alpha or e_alpha_crlb), or None."""
    for c in (f"crlb_{metric}", f"{metric}_crlb"):
        if summary.has(c):
            return c
    return None


def failures(row):
    """The failed trials of a summary row (0 when the summary has no failures column)."""
    f = row.get("failures", 0.0)
    return int(f) if isinstance(f, float) and math.isfinite(f) else 0


def all_failed(row):
    """True when every trial of the row's cell failed (it has trials and no ok one)."""
    n = row.get("trials", math.nan)
    return isinstance(n, float) and math.isfinite(n) and n > 0 and failures(row) >= n


def fit_column(summary, metric):
    """The summary's CRLB-implied value of `metric` over the samples each estimate used
    (crlb_fit_e_alpha, ...), or None."""
    c = f"crlb_fit_{metric}"
    return c if summary.has(c) else None


FIT_DIFFERS = 0.01  # the relative difference from which both bounds are drawn


def fit_differs(rows, metric):
    """True when some row's bound over the samples fit differs from its whole record's by more than
    FIT_DIFFERS (relative); then error-vs-sigma draws both."""
    whole, fit = f"crlb_{metric}", f"crlb_fit_{metric}"
    return any(math.isfinite(r.get(fit, math.nan)) and math.isfinite(r.get(whole, math.nan)) and
               abs(r[fit] - r[whole]) > FIT_DIFFERS * abs(r[whole]) for r in rows)


def draw_fit_bounds(ax, lines, col):
    """Per series, its cells' bound over the samples each fit used (summary column `col`) as a dotted
    line in the series' colour, gid 'crlb_fit'. Returns the drawn values."""
    ys = []
    for s in lines:
        pts = [(r["sigma"], r[col]) for r in s.rows if math.isfinite(r.get(col, math.nan)) and r[col] > 0]
        if not pts:
            continue
        x, y = zip(*pts)
        ax.plot(x, y, color=getattr(s, "color", "black"), lw=0.9, ls=":", gid="crlb_fit")
        ys += list(y)
    return ys


FIT_LABEL = "CRLB-implied over the samples fit (dotted, series colour)"


def draw_series(ax, lines, point):
    """Draws each line of `lines` with its interval band; point(row) -> (est, lo, hi, n); then marks the
    failed trials (mark_failures). Returns (handles, every drawn value, every x, the largest and smallest
    n)."""
    handles, ys, xs, ns = [], [], [], []
    for s in lines:
        pts = [(r["sigma"],) + tuple(point(r)) for r in s.rows]
        pts = [p for p in pts if math.isfinite(p[1])]
        xs += [r["sigma"] for r in s.rows if all_failed(r)]
        if not pts:
            continue
        x, y, lo, hi, n = (np.array(v) for v in zip(*pts))
        (h,) = ax.plot(x, y, label=s.label, **style.series_style(s.index, s.group, s.sub))
        s.color = h.get_color()
        ok = np.isfinite(lo) & np.isfinite(hi)
        if ok.any():
            ax.fill_between(x[ok], lo[ok], hi[ok], color=h.get_color(), alpha=0.15, lw=0)
        handles.append(h)
        ys += list(y) + list(lo[ok]) + list(hi[ok])
        xs += list(x)
        ns += list(n)
    mark_failures(ax, lines, point)
    return handles, ys, xs, ns


def mark_failures(ax, lines, point):
    """Marks each cell with failed trials: its count beside its point (gid 'failures'), and for a cell
    every trial of which failed (no point) an × at the foot of the panel at its σ with its count above
    (one line of gid 'failed' per series, stacked when several series fail at one σ). Returns whether
    any cell had failures."""
    stack = {}
    any_failed = False
    for s in lines:
        color = getattr(s, "color", style.COLORS[s.group % len(style.COLORS)])
        gone = []
        for r in s.rows:
            f = failures(r)
            if f == 0:
                continue
            any_failed = True
            est = point(r)[0]
            if math.isfinite(est) and not all_failed(r):
                ax.annotate(str(f), (r["sigma"], est), xytext=(3, 3), textcoords="offset points", fontsize=8,
                            color=color, gid="failures", in_layout=False, annotation_clip=False)
            elif all_failed(r):
                gone.append(r)
        if not gone:
            continue
        trans = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
        ys = []
        for r in gone:
            level = stack.get(r["sigma"], 0)
            stack[r["sigma"]] = level + 1
            ys.append(0.05 + 0.14 * level)
            ax.text(r["sigma"], ys[-1] + 0.04, str(failures(r)), transform=trans, ha="center", va="bottom",
                    fontsize=8, color=color, gid="failures", in_layout=False)
        ax.plot([r["sigma"] for r in gone], ys, transform=trans, ls="none", marker="x", ms=5, mew=1.2,
                color=color, gid="failed", label=FAILED_LABEL, clip_on=False)
    return any_failed


def failed_handle(lines):
    """A legend entry for the × of an all-failed cell, or nothing when no cell of `lines` failed so."""
    if not any(all_failed(r) for s in lines for r in s.rows):
        return []
    return [matplotlib.lines.Line2D([], [], ls="none", marker="x", ms=5, mew=1.2, color="black",
                                    label=FAILED_LABEL)]


def failed_note(rows):
    return FAILED_NOTE if any(failures(r) for r in rows) else ""


def finish_panel(ax, axes, ylabel, xs, ys):
    """Axis scales from the drawn data, the y label, and the σ label on the bottom panels only."""
    style.set_value_axis(ax, ys)
    style.set_grid_axis(ax, xs)
    ax.set_ylabel(ylabel)
    if style.is_bottom(ax, axes):
        ax.set_xlabel(SIGMA_LABEL)
    else:
        ax.tick_params(labelbottom=False)


def legend(leg, handles, ncol, extra=(), bound=False):
    """The legend below the panels, titled with the common-random-numbers mark (CRN_MARK) and, with
    `bound`, what the CRLB leaves out (BOUND_MARK)."""
    if leg is not None:
        hs = list(handles) + list(extra)
        leg.legend(hs, [h.get_label() for h in hs], loc="center", ncol=min(ncol, len(hs)), borderaxespad=0,
                   title=CRN_MARK + ("\n" + BOUND_MARK if bound else ""), title_fontsize="small")


def n_text(ns):
    ns = [int(n) for n in ns if n == n]
    if not ns:
        return "n = ?"
    return f"n = {min(ns)}" if min(ns) == max(ns) else f"n = {min(ns)}–{max(ns)}"


def caption(what, iv, ns, run, extra=""):
    return (f"{what} Points: {iv.method()}; {n_text(ns)} trials per point. {extra}{stats.crn_note(run.summary)}"
            f"Data: {run.source()}.")


def error_vs_sigma(run, out_dir, formats, width, stat="mean"):
    """e_α, e_β and the misclassification rate against σ, one figure per model and δt; the CRLB-implied
    e_α, e_β as a black line where summary.csv carries it."""
    s = run.summary
    iv = stats.Intervals(run, stat)
    panels = [(m, lab) for m, lab in ERROR_PANELS if s.has(f"{m}_mean")]
    written = []
    for fixed, rows in series.figure_groups(s):
        lines = series.series(s, rows)
        if len({r["sigma"] for r in rows}) < 2:
            continue
        bound = any(crlb_column(s, m) for m, _ in panels)
        both = any(fit_column(s, m) and fit_differs(rows, m) for m, _ in panels)
        entries = len(lines) + 1 + both + len(failed_handle(lines))
        fig, axes, leg, ncol = style.panels(width, len(panels), entries, title_lines=1 + bound)
        handles, all_ns = [], []
        extra = {}  # legend entries of the bounds: whole record, samples fit
        for ax, (metric, ylabel) in zip(axes, panels):
            h, ys, xs, ns = draw_series(ax, lines, lambda r, m=metric: iv.of(r, m))
            handles = handles or h
            all_ns += ns
            col = crlb_column(s, metric)
            if col:
                pts = sorted({(r["sigma"], r[col]) for r in rows if math.isfinite(r[col]) and r[col] > 0})
                if pts:
                    (extra["whole"],) = ax.plot(*zip(*pts), color="black", lw=1.4, ls=(0, (6, 2)),
                                                label="CRLB-implied, whole record" if both else "CRLB-implied")
                    ys += [p[1] for p in pts]
                if both and fit_column(s, metric):
                    ys += draw_fit_bounds(ax, lines, fit_column(s, metric))
                    extra["fit"] = matplotlib.lines.Line2D([], [], color="0.3", lw=0.9, ls=":", label=FIT_LABEL)
            finish_panel(ax, axes, ylabel, xs, ys)
        extra = list(extra.values())
        legend(leg, handles, ncol, extra + failed_handle(lines), bound=bool(extra))
        if width == "double":  # a single-column figure leaves its title to the caption
            fig.suptitle(series.title_of(fixed, s))
        stem = f"error_vs_sigma_{series.slug(fixed)}"
        what = (f"{series.title_of(fixed, s)}: identification errors e_α, e_β and the misclassification rate "
                f"against the noise σ.{' The dashed black line is the CRLB-implied mean error' if extra else ''}"
                f"{' of the whole record; a dotted line in a series colour that over the samples each of its fits used (summary.csv crlb_fit_*: the mean over its ok trials)' if len(extra) > 1 else ''}"
                f"{'.' if extra else ''}")
        note = failed_note(rows) + (BOUND_NOTE if extra else "")
        written += style.save(fig, out_dir, stem, formats, caption(what, iv, all_ns, run, note))
    return written


def efficiency(run, out_dir, formats, width, stat="mean"):
    """The ratio of the mean e_α (e_β) to its CRLB-implied value against σ (1 = efficient): the bound
    over the samples each estimate used (crlb_fit_*) when summary.csv has it, else the whole record's."""
    s = run.summary
    cols = [(m, fit_column(s, m) or crlb_column(s, m)) for m in ("e_alpha", "e_beta")]
    cols = [(m, c) for m, c in cols if c]
    used = any(c.startswith("crlb_fit_") for _, c in cols)
    if not cols:
        raise data.DataError(f"{s.path}: no CRLB column (crlb_e_alpha, crlb_e_beta): the efficiency figure "
                             "needs a sweep that computes the CRLB")
    iv = stats.Intervals(run, stat)
    written = []
    sym = {"e_alpha": r"\alpha", "e_beta": r"\beta"}
    for fixed, rows in series.figure_groups(s):
        lines = series.series(s, rows)
        fig, axes, leg, ncol = style.panels(width, len(cols), len(lines) + 1 + len(failed_handle(lines)),
                                            title_lines=2)
        handles, all_ns, one = [], [], None
        for ax, (metric, col) in zip(axes, cols):
            def ratio(r, m=metric, c=col):
                if not (math.isfinite(r[c]) and r[c] > 0):
                    return math.nan, math.nan, math.nan, 0
                return iv.of(r, m, scale=r[c])
            h, ys, xs, ns = draw_series(ax, lines, ratio)
            handles = handles or h
            all_ns += ns
            one = ax.axhline(1.0, color="black", lw=0.9, ls=(0, (6, 2)), label="CRLB-implied (ratio 1)")
            finish_panel(ax, axes, rf"$e_{sym[metric]}$ / CRLB-implied $e_{sym[metric]}$", xs, ys + [1.0])
        legend(leg, handles, ncol, [one] + failed_handle(lines), bound=True)
        stem = f"efficiency_{series.slug(fixed)}"
        over = (" The bound of each cell is over the samples its estimates used (summary.csv's crlb_fit_e_alpha, "
                "crlb_fit_e_beta: the mean over its ok trials of the bound over the samples each fit used; a "
                "refinement may leave out the end of a record, the recursive estimators use every sample); "
                "the whole record's bound is crlb_e_alpha, crlb_e_beta." if used else
                " The bound is that of the whole record (summary.csv's crlb_e_alpha, crlb_e_beta).")
        what = (f"{series.title_of(fixed, s)}: {stat} error over its CRLB-implied value against σ "
                f"(1 = at the CRLB-implied error; σ = 0 has no bound and is left out).{over}")
        written += style.save(fig, out_dir, stem, formats,
                              caption(what, iv, all_ns, run, failed_note(rows) + BOUND_NOTE))
    return written


def unknown_params(run):
    """[(column in trials.csv, 'alpha'|'beta', name)] of the estimated parameters."""
    if run.trials is None:
        raise data.DataError(f"{run.dir}: no trials.csv: per-parameter errors need the per-trial table "
                             f"(rerun: hysid sweep {run.meta.get('source', 'SWEEP.toml')} --out {run.dir})")
    out = []
    for h in run.trials.header:
        for kind in ("alpha", "beta"):
            if h.startswith(f"{kind}_hat_"):
                out.append((h, kind, h[len(kind) + 5:]))
    if not out:
        raise data.DataError(f"{run.trials.path}: no alpha_hat_* / beta_hat_* column")
    return out


def greek(name):
    g = {"lambda": r"\lambda", "mu": r"\mu", "alpha": r"\alpha", "beta": r"\beta", "gamma": r"\gamma",
         "omega": r"\omega", "zeta": r"\zeta", "theta": r"\theta", "epsilon": r"\epsilon"}
    return g.get(name, name if len(name) == 1 else rf"\mathrm{{{name}}}")


def relative_error(run, out_dir, formats, width, stat="mean"):
    """One panel per unknown parameter θ_i: |θ̂_i − θ_i| / |θ_i| against σ (|θ̂_i − θ_i| when θ_i = 0),
    from trials.csv and the true values in run.json."""
    params = unknown_params(run)
    s = run.summary
    iv = stats.Intervals(run, stat)
    written = []
    for fixed, rows in series.figure_groups(s):
        model = rows[0].get("model")
        truth = run.true_params(model)
        mine = [p for p in params if p[2] in truth and run.trials.column(rows[0]["cell"], p[0]).size]
        lines = series.series(s, rows)
        fig, axes, leg, ncol = style.panels(width, len(mine), len(lines) + len(failed_handle(lines)), title_lines=1)
        handles, all_ns, absolute = [], [], []
        for ax, (col, kind, name) in zip(axes, mine):
            true = truth[name]
            scale = abs(true) if true != 0 else 1.0

            # The sweep's own rel_err_NAME column when trials.csv has it (rel_err_beta_NAME for a β
            # parameter that shares an α parameter's name), else computed from the estimate column.
            rel = f"rel_err_beta_{name}" if f"rel_err_beta_{name}" in run.trials.header and kind == "beta" \
                else f"rel_err_{name}"
            rel = rel if rel in run.trials.header else None

            def point(r, col=col, true=true, scale=scale, rel=rel):
                if rel is not None:
                    return iv.of_values(r, run.trials.column(r["cell"], rel), col)
                v = np.abs(run.trials.column(r["cell"], col) - true) / scale
                return iv.of_values(r, v, col)
            h, ys, xs, ns = draw_series(ax, lines, point)
            handles = handles or h
            all_ns += ns
            g = greek(name)
            if true != 0:
                label = rf"$|\hat{{{g}}} - {g}|\,/\,|{g}|$"
            else:
                label = rf"$|\hat{{{g}}} - {g}|$ (${g}$ = 0)"
                absolute.append(name)
            finish_panel(ax, axes, label, xs, ys)
            ax.set_title(rf"${g}$ = {true:g}")
        legend(leg, handles, ncol, failed_handle(lines))
        stem = f"relative_error_{series.slug(fixed)}"
        note = (f" A parameter whose true value is 0 ({', '.join(absolute)}) shows the absolute error."
                if absolute else "")
        what = (f"{series.title_of(fixed, s)}: relative error of each estimated parameter against σ, "
                f"true values from {'--truth' if run.truth else 'run.json'}.{note}")
        written += style.save(fig, out_dir, stem, formats, caption(what, iv, all_ns, run, failed_note(rows)))
    return written


COVERAGE_LEVEL = 0.95


def coverage_params(summary):
    """[(summary column stem cover_NAME, NAME)] of the coverage columns of summary.csv."""
    return [(c[:-5], c[len("cover_"):-5]) for c in summary.columns if c.startswith("cover_") and c.endswith("_mean")]


def coverage(run, out_dir, formats, width, stat="mean"):
    """Per unknown parameter, the share of trials whose reported 95 % interval θ̂ ± 1.96·se covers the
    truth against σ, with its Wilson score interval (summary.csv's cover_NAME_*), and the nominal 0.95."""
    s = run.summary
    params = coverage_params(s)
    if not params:
        raise data.DataError(f"{s.path}: no cover_*_mean column: the coverage figure needs a sweep with a refine "
                             "axis (its trials report standard errors)")
    written = []
    for fixed, rows in series.figure_groups(s):
        lines = [ln for ln in series.series(s, rows)
                 if any(r.get(f"{c}_n", 0) > 0 or all_failed(r) for c, _ in params for r in ln.rows)]
        if not lines:
            continue
        fig, axes, leg, ncol = style.panels(width, len(params), len(lines) + 1 + len(failed_handle(lines)),
                                            title_lines=1)
        handles, all_ns, nominal = [], [], None
        for ax, (col, name) in zip(axes, params):
            def point(r, c=col):
                return r[f"{c}_mean"], r[f"{c}_ci95_lo"], r[f"{c}_ci95_hi"], r.get(f"{c}_n", 0)
            h, ys, xs, ns = draw_series(ax, lines, point)
            handles = handles or h
            all_ns += ns
            nominal = ax.axhline(COVERAGE_LEVEL, color="black", lw=0.9, ls=(0, (6, 2)),
                                 label=f"nominal {COVERAGE_LEVEL:g}")
            lo = min([y for y in ys if math.isfinite(y)] + [COVERAGE_LEVEL])
            ax.set_ylim(max(0.0, lo - 0.05 * (1.0 - lo) - 0.01), 1.0 + 0.02 * (1.0 - lo) + 0.005)
            style.set_grid_axis(ax, xs)
            ax.set_ylabel(rf"coverage of ${greek(name)}$")
            if style.is_bottom(ax, axes):
                ax.set_xlabel(SIGMA_LABEL)
            else:
                ax.tick_params(labelbottom=False)
        legend(leg, handles, ncol, [nominal] + failed_handle(lines))
        stem = f"coverage_{series.slug(fixed)}"
        what = (f"{series.title_of(fixed, s)}: share of the trials whose reported 95 % interval θ̂ ± 1.96·se "
                "(the refinement's standard error) covers the true value, per unknown parameter, against σ; "
                "dashed: the nominal 0.95. Cells without standard errors (no refinement) are not drawn.")
        cap = (f"{what} Points: the share over the trials of each cell with a standard error, with its Wilson "
               f"score interval (z = 1.96; summary.csv's cover_*); {n_text(all_ns)} trials per point. "
               f"{failed_note(rows)}{stats.crn_note(s)}Data: {run.source()}.")
        written += style.save(fig, out_dir, stem, formats, cap)
    return written

"""Figures of a sweep run directory: error vs σ, efficiency against the CRLB, per-parameter relative
error, misclassification over δt × r. Each function returns the paths it wrote."""
import math

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


def crlb_column(summary, metric):
    """The summary's CRLB-implied value of `metric` (crlb_e_alpha or e_alpha_crlb), or None."""
    for c in (f"crlb_{metric}", f"{metric}_crlb"):
        if summary.has(c):
            return c
    return None


def draw_series(ax, lines, point):
    """Draws each line of `lines` with its interval band; point(row) -> (est, lo, hi, n).
    Returns (handles, every drawn value, every x, the largest and smallest n)."""
    handles, ys, xs, ns = [], [], [], []
    for s in lines:
        pts = [(r["sigma"],) + tuple(point(r)) for r in s.rows]
        pts = [p for p in pts if math.isfinite(p[1])]
        if not pts:
            continue
        x, y, lo, hi, n = (np.array(v) for v in zip(*pts))
        (h,) = ax.plot(x, y, label=s.label, **style.series_style(s.index, s.group, s.sub))
        ok = np.isfinite(lo) & np.isfinite(hi)
        if ok.any():
            ax.fill_between(x[ok], lo[ok], hi[ok], color=h.get_color(), alpha=0.15, lw=0)
        handles.append(h)
        ys += list(y) + list(lo[ok]) + list(hi[ok])
        xs += list(x)
        ns += list(n)
    return handles, ys, xs, ns


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
        fig, axes, leg, ncol = style.panels(width, len(panels), len(lines) + 1, title_lines=1 + bound)
        handles, extra, all_ns = [], [], []
        for ax, (metric, ylabel) in zip(axes, panels):
            h, ys, xs, ns = draw_series(ax, lines, lambda r, m=metric: iv.of(r, m))
            handles = handles or h
            all_ns += ns
            col = crlb_column(s, metric)
            if col:
                pts = sorted({(r["sigma"], r[col]) for r in rows if math.isfinite(r[col]) and r[col] > 0})
                if pts:
                    (c,) = ax.plot(*zip(*pts), color="black", lw=1.4, ls=(0, (6, 2)), label="CRLB-implied")
                    extra = [c]
                    ys += [p[1] for p in pts]
            finish_panel(ax, axes, ylabel, xs, ys)
        legend(leg, handles, ncol, extra, bound=bool(extra))
        if width == "double":  # a single-column figure leaves its title to the caption
            fig.suptitle(series.title_of(fixed, s))
        stem = f"error_vs_sigma_{series.slug(fixed)}"
        what = (f"{series.title_of(fixed, s)}: identification errors e_α, e_β and the misclassification rate "
                f"against the noise σ.{' The dashed black line is the CRLB-implied mean error.' if extra else ''}")
        written += style.save(fig, out_dir, stem, formats, caption(what, iv, all_ns, run, BOUND_NOTE if extra else ""))
    return written


def efficiency(run, out_dir, formats, width, stat="mean"):
    """The ratio of the mean e_α (e_β) to its CRLB-implied value against σ (1 = efficient)."""
    s = run.summary
    cols = [(m, crlb_column(s, m)) for m in ("e_alpha", "e_beta")]
    cols = [(m, c) for m, c in cols if c]
    if not cols:
        raise data.DataError(f"{s.path}: no CRLB column (crlb_e_alpha, crlb_e_beta): the efficiency figure "
                             "needs a sweep that computes the CRLB")
    iv = stats.Intervals(run, stat)
    written = []
    sym = {"e_alpha": r"\alpha", "e_beta": r"\beta"}
    for fixed, rows in series.figure_groups(s):
        lines = series.series(s, rows)
        fig, axes, leg, ncol = style.panels(width, len(cols), len(lines) + 1, title_lines=2)
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
        legend(leg, handles, ncol, [one], bound=True)
        stem = f"efficiency_{series.slug(fixed)}"
        what = (f"{series.title_of(fixed, s)}: {stat} error over its CRLB-implied value against σ "
                "(1 = at the CRLB-implied error; σ = 0 has no bound and is left out).")
        written += style.save(fig, out_dir, stem, formats, caption(what, iv, all_ns, run, BOUND_NOTE))
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
        fig, axes, leg, ncol = style.panels(width, len(mine), len(lines), title_lines=1)
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
        legend(leg, handles, ncol)
        stem = f"relative_error_{series.slug(fixed)}"
        note = (f" A parameter whose true value is 0 ({', '.join(absolute)}) shows the absolute error."
                if absolute else "")
        what = (f"{series.title_of(fixed, s)}: relative error of each estimated parameter against σ, "
                f"true values from {'--truth' if run.truth else 'run.json'}.{note}")
        written += style.save(fig, out_dir, stem, formats, caption(what, iv, all_ns, run))
    return written

"""Heat maps over two grid axes: the misclassification map (δt × r, one panel per σ) and the detector
comparison (σ × δt: the best r of the paper detector in hindsight against the residual detector)."""
import csv
import math
import os

import matplotlib
import matplotlib.colors
import matplotlib.patches
import numpy as np
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import TextToPath

from . import data, stats, style

RATE_LABEL = "mean misclassification rate"
TO_PATH = TextToPath()


def rate_norm(values):
    """Log colours from the smallest positive rate (rounded down to a decade, at least 1e-8) to the
    largest (rounded up); a rate of 0 is drawn white and the caption says so."""
    pos = [v for v in values if v > 0 and math.isfinite(v)]
    lo = 10.0 ** max(-8, math.floor(math.log10(min(pos)))) if pos else 1e-6
    hi = 10.0 ** math.ceil(math.log10(max(pos))) if pos else 1.0
    return matplotlib.colors.LogNorm(vmin=lo, vmax=max(hi, 10 * lo), clip=True)


def heat(ax, m, xs, ys, norm):
    """Draws matrix m (rows = ys, columns = xs) with exact zeros white; labels come from label_cells."""
    cmap = matplotlib.colormaps["viridis"].copy()
    cmap.set_bad("white")
    shown = np.where(m > 0, m, np.nan)
    im = ax.imshow(shown, origin="lower", aspect="auto", cmap=cmap, norm=norm, interpolation="nearest")
    ax.grid(False)
    xl, yl = stats.grid_labels(xs), stats.grid_labels(ys)
    ax.hysid_xlabels = [xl[float(v)] for v in xs]
    ax.set_xticks(range(len(xs)), ax.hysid_xlabels)
    ax.set_yticks(range(len(ys)), [yl[float(v)] for v in ys])
    ax.tick_params(length=0)
    return im


def failure_matrix(rows, shape, index):
    """(failed trials, every trial failed) per cell of a map: index(row) -> (i, j) or None."""
    f = np.zeros(shape)
    gone = np.zeros(shape, bool)
    for r in rows:
        ij = index(r)
        if ij is None:
            continue
        n, k = r.get("trials", math.nan), r.get("failures", 0.0)
        k = k if math.isfinite(k) else 0.0
        f[ij] = k
        gone[ij] = math.isfinite(n) and n > 0 and k >= n
    return f, gone


def mark_failed_cells(ax, failed, gone, label):
    """A cell every trial of which failed: grey and hatched (a patch of gid 'failed'), never the white of a
    rate of 0; with `label`, each cell with failed trials shows their count in its upper left corner (gid
    'failures')."""
    for (a, b), k in np.ndenumerate(failed):
        if gone[a, b]:
            ax.add_patch(matplotlib.patches.Rectangle((b - 0.5, a - 0.5), 1, 1, facecolor="0.7", edgecolor="0.35",
                                                      hatch="xx", lw=0, gid="failed"))
        if k > 0 and label:
            ax.text(b - 0.45, a + 0.45, f"{int(k)}×", ha="left", va="top", fontsize=style.CELL_LABEL_PT,
                    color="#882255", gid="failures")


def failed_caption(failed, gone):
    if not failed.any():
        return ""
    return (f" Grey, hatched: a cell every trial of which failed ({int(gone.sum())} cells); "
            f"{int((failed > 0).sum())} cells have failed trials ({int(failed.sum())} in all; with cell labels, "
            "'k×' in a cell's corner counts them), left out of its rate.")


def cell_text(v):
    """A rate in at most 4 characters: 0, 0.08, 1, 4e-3."""
    if v == 0:
        return "0"
    if v >= 0.0095:
        return f"{v:.1g}"
    m, e = f"{v:.0e}".split("e")
    return f"{m}e{int(e)}"


def text_width(text, size):
    """Width in points of `text` at `size` pt in the style's font."""
    w, _, _ = TO_PATH.get_text_width_height_descent(text, FontProperties(size=size), ismath=False)
    return w


def label_cells(fig, panels, norm, size=style.CELL_LABEL_PT):
    """After one layout pass: x tick labels turned vertical where upright ones would run together, and
    each cell labelled with its rate where the widest label fits with 1 pt either side.
    panels: [(ax, matrix)]. Returns whether the cells were labelled."""
    engine = fig.get_layout_engine()
    if engine is not None:
        engine.execute(fig)
    ax0, m0 = panels[0]
    cell_pt = ax0.get_position().width * fig.get_size_inches()[0] * 72 / m0.shape[1]
    ticks = max(text_width(t, 8) for t in ax0.hysid_xlabels)
    widest = max((text_width(cell_text(v), size) for _, m in panels for v in m.ravel() if math.isfinite(v)),
                 default=0)
    annotate = cell_pt >= widest + 2
    for ax, m in panels:
        if ticks + 2 > cell_pt:
            ax.tick_params(axis="x", labelrotation=90)
        if not annotate:
            continue
        for (a, b), v in np.ndenumerate(m):
            if math.isfinite(v):
                dark = v > 0 and norm(v) < 0.6
                ax.text(b, a, cell_text(v), ha="center", va="center", fontsize=size,
                        color="white" if dark else "black")
    return annotate


def map_groups(summary):
    """{(model, estimator, detector): rows} for detector settings with r over ≥ 2 dt and ≥ 2 r."""
    groups = {}
    for r in summary.rows:
        if math.isfinite(r.get("r", math.nan)):
            groups.setdefault((r.get("model", ""), r.get("estimator", ""), r.get("detector", "")), []).append(r)
    return {k: rs for k, rs in groups.items()
            if len({r["dt"] for r in rs}) >= 2 and len({r["r"] for r in rs}) >= 2}


def misclassification_map(run, out_dir, formats, width, stat="mean"):
    """Mean misclassification over δt × r, one panel per σ, per model, estimator and detector."""
    s = run.summary
    if not all(s.has(c) for c in ("dt", "r", "misclassification_mean")):
        raise data.DataError(f"{s.path}: the map needs columns dt, r and misclassification_mean")
    written = []
    for (model, est, det), rows in sorted(map_groups(s).items()):
        dts = sorted({r["dt"] for r in rows})
        rs = sorted({r["r"] for r in rows})
        sigmas = sorted({r["sigma"] for r in rows})
        cols = min(len(sigmas), 2 if width == "single" else 3)
        nrows = math.ceil(len(sigmas) / cols)
        pw = (style.WIDTHS[width] - 0.3) / cols
        fig, axes = style.figure(width, nrows, cols, height=nrows * pw * 0.7 + 0.8, constrained_layout=True)
        mats, fails = {}, {}
        for sg in sigmas:
            m = np.full((len(dts), len(rs)), np.nan)
            for r in rows:
                if r["sigma"] == sg:
                    m[dts.index(r["dt"]), rs.index(r["r"])] = r[f"misclassification_{stat}"]
            mats[sg] = m
            fails[sg] = failure_matrix(rows, m.shape, lambda r, sg=sg: (dts.index(r["dt"]), rs.index(r["r"]))
                                       if r["sigma"] == sg else None)
        norm = rate_norm([v for m in mats.values() for v in m.ravel()])
        im = None
        for i, sg in enumerate(sigmas):
            ax = axes[i // cols][i % cols]
            im = heat(ax, mats[sg], rs, dts, norm)
            ax.set_title(rf"$\sigma$ = {stats.grid_label(sigmas, sg)}")
            ax.set_ylabel(r"$\delta t$ [s]")
        for j in range(len(sigmas), nrows * cols):
            axes[j // cols][j % cols].axis("off")
        shown = [ax for ax in axes.ravel() if ax.axison]
        for ax in shown:
            if style.is_bottom(ax, shown):
                ax.set_xlabel("bound scale r")
        fig.colorbar(im, ax=axes.ravel().tolist(), label=f"{stat} misclassification rate", shrink=0.9,
                     location="bottom", aspect=30 if width == "single" else 45)
        annotate = label_cells(fig, [(axes[i // cols][i % cols], mats[sg]) for i, sg in enumerate(sigmas)], norm)
        for i, sg in enumerate(sigmas):
            mark_failed_cells(axes[i // cols][i % cols], *fails[sg], annotate)
        failed_all = np.concatenate([fails[sg][0].ravel() for sg in sigmas])
        gone_all = np.concatenate([fails[sg][1].ravel() for sg in sigmas])
        stem = f"misclassification_map_{model}_{est}_{det}"
        n = sorted({int(r["trials"] - r["failures"]) for r in rows})
        cap = (f"{model}, {est} estimator, {det} detector: {stat} misclassification rate (false and missed "
               f"jumps over all samples) over the sample time δt and the bound scale r, one panel per noise σ; "
               f"log colour scale, white = 0 (no misclassified sample in any trial)"
               f"{'; cell labels: the rate to 1 significant digit (4e-3 = 4·10⁻³)' if annotate else ''}."
               f"{failed_caption(failed_all, gone_all)} "
               f"{'n = ' + str(n[0]) if len(n) == 1 else f'n = {n[0]}–{n[-1]}'} trials per cell "
               f"(summary.csv). Data: {run.source()}.")
        written += style.save(fig, out_dir, stem, formats, cap)
    return written


def compare(run, p, iv):
    """Cells (model, estimator, σ, δt) with the paper detector and the residual detector at p."""
    cells = {}
    for r in run.summary.rows:
        key = (r.get("model", ""), r.get("estimator", ""), r["sigma"], r["dt"])
        c = cells.setdefault(key, {"paper": {}, "residual": None, "rows": {}})
        if r["detector"] == "paper":
            c["paper"][r["r"]] = r["misclassification_mean"]
            c["rows"][r["r"]] = r
        elif r["detector"] == "residual" and r.get("false_alarm") == p:
            c["residual"] = iv.of(r, "misclassification")
            c["residual_row"] = r
    out = []
    for key in sorted(cells):
        c = cells[key]
        if not c["paper"] or c["residual"] is None:
            continue
        # A setting every trial of which failed has no rate and is never the best.
        best_r = min(c["paper"], key=lambda r: (not math.isfinite(c["paper"][r]), c["paper"][r], r))
        best = c["paper"][best_r]
        res, lo, hi, n = c["residual"]
        tied = res == best or (math.isfinite(lo) and lo <= best <= hi)
        out.append({"model": key[0], "estimator": key[1], "sigma": key[2], "dt": key[3], "p": p,
                    "paper": c["paper"], "best_r": best_r, "best": best, "residual": res, "lo": lo, "hi": hi,
                    "n": n, "match_or_beat": res <= best, "tied": tied,
                    "best_row": c["rows"][best_r], "residual_row": c["residual_row"]})
    return out


def comparison_table(cmp, iv):
    """Markdown lines of one false-alarm probability's comparison, and its one-line verdict."""
    rs = sorted(cmp[0]["paper"])
    n = len(cmp)
    wins = sum(c["match_or_beat"] for c in cmp)
    ties = sum(c["match_or_beat"] or c["tied"] for c in cmp)
    worst = {r: max(c["paper"][r] for c in cmp) for r in rs}
    worst_res = max(c["residual"] for c in cmp)
    # The model and estimator columns only when they vary.
    who = [k for k in ("model", "estimator") if len({c[k] for c in cmp}) > 1]
    # Grid values as labelled on their axes (stats.grid_labels).
    sl, dl = (stats.grid_labels([c[k] for c in cmp]) for k in ("sigma", "dt"))
    rl = stats.grid_labels(rs)
    lines = [f"### residual detector at p = {cmp[0]['p']:g}", "",
             "| " + "".join(f"{k} | " for k in who) + "σ | δt | " + " | ".join(f"r = {rl[r]}" for r in rs) +
             " | best r | residual [95 % interval] | ≤ best | tied |", "|" + "---|" * (len(who) + len(rs) + 6)]
    for c in cmp:
        lines.append("| " + "".join(f"{c[k]} | " for k in who) + f"{sl[c['sigma']]} | {dl[c['dt']]} | " +
                     " | ".join(stats.sig(c["paper"][r]) for r in rs) +
                     f" | {rl[c['best_r']]} | {stats.interval_text(c['residual'], c['lo'], c['hi'])}"
                     f" | {'yes' if c['match_or_beat'] else 'no'} | {'yes' if c['tied'] else 'no'} |")
    lines.append("| worst cell | " + "| " * (len(who) + 1) + " | ".join(stats.sig(worst[r]) for r in rs) +
                 f" | | {stats.sig(worst_res)} | | |")
    verdict = (f"p = {cmp[0]['p']:g}: residual detector ≤ best paper r in {wins} of {n} cells "
               f"({100 * wins / n:.0f} %); ≤ or within its 95 % interval in {ties} of {n} "
               f"({100 * ties / n:.0f} %); worst cell {stats.sig(worst_res)}.")
    return lines + ["", verdict, ""], verdict


def write_comparison_tables(run, cmps, iv):
    """RUN_DIR/detector_comparison.csv and .md; returns the verdicts."""
    rs = sorted(cmps[0][0]["paper"])
    with open(os.path.join(run.dir, "detector_comparison.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["model", "estimator", "sigma", "dt"] + [f"paper_r{r:g}" for r in rs] +
                   ["best_r", "best_paper", "false_alarm", "residual", "residual_lo", "residual_hi",
                    "residual_le_best", "tied_within_interval"])
        for cmp in cmps:
            for c in cmp:
                w.writerow([c["model"], c["estimator"], repr(c["sigma"]), repr(c["dt"])] +
                           [repr(c["paper"].get(r, math.nan)) for r in rs] +
                           [repr(c["best_r"]), repr(c["best"]), repr(c["p"]), repr(c["residual"]),
                            repr(c["lo"]), repr(c["hi"]), int(c["match_or_beat"]), int(c["tied"])])
    md = [f"Mean misclassification rate per cell; residual detector's interval: {iv.method()}. "
          f"{stats.crn_note(run.summary)}Data: {run.source()}.", ""]
    verdicts = []
    for cmp in cmps:
        lines, verdict = comparison_table(cmp, iv)
        md += lines
        verdicts.append(verdict)
    with open(os.path.join(run.dir, "detector_comparison.md"), "w") as fh:
        fh.write("\n".join(md))
    return verdicts


def detector_comparison(run, out_dir, formats, width, stat="mean", tables=True):
    """Best r of the paper detector per (σ, δt) cell in hindsight against the residual detector at each
    false-alarm probability, as heat maps over σ × δt; with `tables`, also the .csv and .md tables."""
    s = run.summary
    if not all(s.has(c) for c in ("detector", "false_alarm", "r", "dt")):
        raise data.DataError(f"{s.path}: the comparison needs columns detector, false_alarm, r and dt")
    iv = stats.Intervals(run, "mean")
    ps = [p for p in s.values("false_alarm") if math.isfinite(p)]
    cmps = [c for c in (compare(run, p, iv) for p in ps) if c]
    if not cmps:
        raise data.DataError(f"{s.path}: no cell has both the paper and the residual detector")
    written = []
    pairs = sorted({(c["model"], c["estimator"]) for c in cmps[0]})
    for model, est in pairs:
        mine = [[c for c in cmp if (c["model"], c["estimator"]) == (model, est)] for cmp in cmps]
        sigmas = sorted({c["sigma"] for c in mine[0]})
        dts = sorted({c["dt"] for c in mine[0]})
        npanel = 1 + len(mine)
        cols = 1 if width == "single" else npanel
        pw = (style.WIDTHS[width] - 0.3) / cols
        fig, axes = style.figure(width, math.ceil(npanel / cols), cols, sharex=True, sharey=True,
                                 height=math.ceil(npanel / cols) * pw * (0.5 if width == "single" else 0.9) + 0.8,
                                 constrained_layout=True)
        axes = axes.ravel()
        mats = []
        for cmp, key in [(mine[0], "best")] + [(c, "residual") for c in mine]:
            m = np.full((len(sigmas), len(dts)), np.nan)
            for c in cmp:
                m[sigmas.index(c["sigma"]), dts.index(c["dt"])] = c[key]
            mats.append(m)
        norm = rate_norm([v for m in mats for v in m.ravel()])
        fails = [failure_matrix([c[row] for c in cmp], (len(sigmas), len(dts)),
                                lambda r: (sigmas.index(r["sigma"]), dts.index(r["dt"])))
                 for cmp, row in [(mine[0], "best_row")] + [(c, "residual_row") for c in mine]]
        titles = ["paper detector, best r per cell"] + [f"residual detector, p = {c[0]['p']:g}" for c in mine]
        for ax, m, title in zip(axes, mats, titles):
            im = heat(ax, m, dts, sigmas, norm)
            ax.set_title(title)
            ax.set_ylabel(r"noise $\sigma$")
            ax.set_xlabel(r"$\delta t$ [s]")
        fig.colorbar(im, ax=axes.tolist(), label=RATE_LABEL, shrink=0.9,
                     location="bottom", aspect=30 if width == "single" else 45)
        annotate = label_cells(fig, list(zip(axes, mats)), norm)
        for ax, (failed, gone) in zip(axes, fails):
            mark_failed_cells(ax, failed, gone, annotate)
        n = sorted({c["n"] for cmp in mine for c in cmp})
        cap = (f"{model}, {est} estimator: mean misclassification rate per (σ, δt) cell of the paper detector "
               f"with the r that is best in that cell (chosen in hindsight) and of the residual detector "
               f"(nothing tuned) at each false-alarm probability p; log colour scale, white = 0. "
               f"n = {n[0] if len(n) == 1 else f'{n[0]}–{n[-1]}'} trials per cell. Both detectors and every r see "
               f"the same noisy samples (common random numbers)."
               f"{failed_caption(np.concatenate([f.ravel() for f, _ in fails]), np.concatenate([g.ravel() for _, g in fails]))}"
               f" Data: {run.source()}.")
        stem = "detector_comparison" if len(pairs) == 1 else f"detector_comparison_{model}_{est}"
        written += style.save(fig, out_dir, stem, formats, cap)
    if tables:
        for v in write_comparison_tables(run, cmps, iv):
            print(v)
        written += [os.path.join(run.dir, "detector_comparison.csv"), os.path.join(run.dir, "detector_comparison.md")]
    return written

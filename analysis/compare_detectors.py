#!/usr/bin/python3
"""Paper detector (each r) vs the tuning-free residual detector, cell by cell, from a sweep's summary.csv.

Usage: /usr/bin/python3 analysis/compare_detectors.py RUN_DIR   (e.g. results/robustness_map)

For each (model, estimator, sigma, dt) cell: the mean misclassification rate of the paper detector at
every r, the best r in hindsight, and the residual detector's rate with its 95 % CI. The residual
detector "matches or beats" the best r when its mean is <= the best r's mean; "statistically tied" when
the best r's mean lies inside the residual detector's 95 % confidence interval.
Writes RUN_DIR/detector_comparison.csv, RUN_DIR/detector_comparison.md (a Markdown table) and
RUN_DIR/figures/detector_comparison.png (best paper r vs residual over sigma x dt).
"""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read(run_dir):
    with open(os.path.join(run_dir, "summary.csv"), newline="") as f:
        return list(csv.DictReader(f))


def f(text):
    return float(text) if text else math.nan


def false_alarms(rows):
    return sorted({f(r.get("false_alarm", "")) for r in rows if r["detector"] == "residual"})


def compare(rows, p):
    """Cells with the paper detector and the residual detector at false-alarm probability p."""
    cells = {}
    for r in rows:
        key = (r["model"], r["estimator"], f(r["sigma"]), f(r["dt"]))
        c = cells.setdefault(key, {"paper": {}, "residual": {}})
        m = f(r["misclassification_mean"])
        if r["detector"] == "paper":
            c["paper"][f(r["r"])] = m
        elif r["detector"] == "residual":
            c["residual"][f(r.get("false_alarm", ""))] = (
                m, f(r["misclassification_ci95_lo"]), f(r["misclassification_ci95_hi"]))
    out = []
    for key in sorted(cells):
        c = cells[key]
        if not c["paper"] or p not in c["residual"]:
            continue
        best_r = min(c["paper"], key=lambda r: (c["paper"][r], r))
        best = c["paper"][best_r]
        res, lo, hi = c["residual"][p]
        tied = (not math.isnan(lo)) and lo <= best <= hi or res == best
        out.append({"model": key[0], "estimator": key[1], "sigma": key[2], "dt": key[3], "p": p,
                    "paper": c["paper"], "best_r": best_r, "best": best, "residual": res,
                    "residual_ci_lo": lo, "residual_ci_hi": hi,
                    "match_or_beat": res <= best, "tied": tied})
    return out


def table(cmp):
    rs = sorted(cmp[0]["paper"])
    n = len(cmp)
    wins = sum(c["match_or_beat"] for c in cmp)
    ties = sum(c["match_or_beat"] or c["tied"] for c in cmp)
    worst = {r: max(c["paper"][r] for c in cmp) for r in rs}
    worst_res = max(c["residual"] for c in cmp)
    lines = [f"### residual detector at p = {cmp[0]['p']:g}", "",
             "| σ | δt | " + " | ".join(f"r = {r:g}" for r in rs) + " | best r | residual (95 % CI) | ≤ best | tied |",
             "|" + "---|" * (len(rs) + 6)]
    for c in cmp:
        lines.append(f"| {c['sigma']:g} | {c['dt']:g} | " +
                     " | ".join(f"{c['paper'][r]:.2g}" for r in rs) +
                     f" | {c['best_r']:g} | {c['residual']:.2g} ({max(c['residual_ci_lo'], 0):.1g}–"
                     f"{c['residual_ci_hi']:.1g}) | {'yes' if c['match_or_beat'] else 'no'} | "
                     f"{'yes' if c['tied'] else 'no'} |")
    lines.append("| worst cell | | " + " | ".join(f"{worst[r]:.2g}" for r in rs) + f" | | {worst_res:.2g} | | |")
    lines.append("")
    verdict = (f"p = {cmp[0]['p']:g}: residual detector ≤ best paper r in {wins} of {n} cells "
               f"({100 * wins / n:.0f} %); ≤ or within its 95 % CI in {ties} of {n} ({100 * ties / n:.0f} %); "
               f"worst cell {worst_res:.2g}.")
    lines.append(verdict)
    lines.append("")
    return lines, verdict


def heat(ax, cmp, key, title, norm, cmap):
    sigmas = sorted({c["sigma"] for c in cmp})
    dts = sorted({c["dt"] for c in cmp})
    m = np.full((len(sigmas), len(dts)), np.nan)
    for c in cmp:
        m[sigmas.index(c["sigma"]), dts.index(c["dt"])] = c[key]
    im = ax.imshow(m, origin="lower", aspect="auto", cmap=cmap, norm=norm)
    for a in range(len(sigmas)):
        for b in range(len(dts)):
            v = m[a, b]
            ax.text(b, a, "0" if v == 0 else f"{v:.0e}", ha="center", va="center", fontsize=7,
                    color="white" if v < 1e-4 else "black")
    ax.set_xticks(range(len(dts)), [f"{v:g}" for v in dts])
    ax.set_yticks(range(len(sigmas)), [f"{v:g}" for v in sigmas])
    ax.set_xlabel(r"$\delta t$ [s]")
    ax.set_title(title, fontsize=9)
    return im, m


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    run = sys.argv[1]
    rows = read(run)
    ps = false_alarms(rows)
    cmps = [c for c in (compare(rows, p) for p in ps) if c]
    if not cmps:
        sys.exit(f"{run}/summary.csv: no cell has both the paper and the residual detector")
    rs = sorted(cmps[0][0]["paper"])
    with open(os.path.join(run, "detector_comparison.csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["model", "estimator", "sigma", "dt"] + [f"paper_r{r:g}" for r in rs] +
                   ["best_r", "best_paper", "false_alarm", "residual", "residual_ci95_lo", "residual_ci95_hi",
                    "residual_le_best", "tied_within_ci"])
        for cmp in cmps:
            for c in cmp:
                w.writerow([c["model"], c["estimator"], repr(c["sigma"]), repr(c["dt"])] +
                           [repr(c["paper"].get(r, math.nan)) for r in rs] +
                           [repr(c["best_r"]), repr(c["best"]), repr(c["p"]), repr(c["residual"]),
                            repr(c["residual_ci_lo"]), repr(c["residual_ci_hi"]), int(c["match_or_beat"]),
                            int(c["tied"])])
    md, verdicts = [], []
    for cmp in cmps:
        lines, verdict = table(cmp)
        md += lines
        verdicts.append(verdict)
    with open(os.path.join(run, "detector_comparison.md"), "w") as fh:
        fh.write("\n".join(md))

    fig, axes = plt.subplots(1, 1 + len(cmps), figsize=(5 * (1 + len(cmps)), 4), constrained_layout=True,
                             sharey=True, squeeze=False)
    axes = axes[0]
    cmap = matplotlib.colormaps["viridis"].copy()
    cmap.set_bad(cmap(0.0))
    norm = matplotlib.colors.LogNorm(vmin=1e-7, vmax=1e-3, clip=True)
    im, _ = heat(axes[0], cmps[0], "best", "paper detector, best r per cell (hindsight)", norm, cmap)
    for ax, cmp in zip(axes[1:], cmps):
        heat(ax, cmp, "residual", f"residual detector, p = {cmp[0]['p']:g} (nothing tuned)", norm, cmap)
    axes[0].set_ylabel(r"noise $\sigma$")
    fig.colorbar(im, ax=axes.tolist(), label="mean misclassification rate (log)")
    os.makedirs(os.path.join(run, "figures"), exist_ok=True)
    fig.savefig(os.path.join(run, "figures", "detector_comparison.png"), dpi=110)
    for v in verdicts:
        print(v)
    print("wrote", os.path.join(run, "detector_comparison.md"), "and .csv, figures/detector_comparison.png")


if __name__ == "__main__":
    main()

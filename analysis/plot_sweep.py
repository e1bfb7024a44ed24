#!/usr/bin/python3
"""Every figure of a sweep run directory, from its summary.csv alone.

Usage: /usr/bin/python3 analysis/plot_sweep.py RUN_DIR [--out DIR]   (default DIR: RUN_DIR/figures)

Writes
  error_vs_sigma_<model>_dt<dt>.png   for each model and dt with at least two sigma values: e_alpha,
      e_beta and the misclassification rate against sigma, one line per (estimator, detector, r), the
      mean with its 95 % confidence band (the summary's ci95_lo..ci95_hi, clipped at 0);
  misclassification_map_<model>_<estimator>_<detector>.png   for each model, estimator and detector
      with at least two dt and two r values: the mean misclassification rate over dt x r, one panel
      per sigma.
Needs Debian's python3-matplotlib and python3-numpy (run with /usr/bin/python3).
"""
import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

KEYS = ["model", "dt", "sigma", "r", "false_alarm", "estimator", "detector"]
ERROR_PANELS = [("e_alpha", r"$e_\alpha = \|\alpha - \hat\alpha\|$"),
                ("e_beta", r"$e_\beta = \|\beta - \hat\beta\|$"),
                ("misclassification", "misclassification rate")]


def num(text):
    return float(text) if text != "" else math.nan


def read_summary(run_dir):
    """The rows of RUN_DIR/summary.csv as dicts; numbers as floats (NaN for empty cells)."""
    path = os.path.join(run_dir, "summary.csv")
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        rows = []
        for line, row in enumerate(reader, start=2):
            out = {}
            for k, v in row.items():
                if k in ("model", "estimator", "detector"):
                    out[k] = v
                else:
                    try:
                        out[k] = num(v)
                    except ValueError:
                        sys.exit(f"{path}:{line}: column '{k}': '{v}' is not a number")
            rows.append(out)
    if not rows:
        sys.exit(f"{path}: no cells")
    return rows


def same(a, b):
    return (math.isnan(a) and math.isnan(b)) or a == b


def line_label(row):
    label = f"{row['estimator']}, {row['detector']}"
    if not math.isnan(row["r"]):
        label += f", r={row['r']:g}"
    if not math.isnan(row.get("false_alarm", math.nan)):
        label += f", p={row['false_alarm']:g}"
    return label


def error_vs_sigma(rows):
    """{(model, dt): {label: [rows sorted by sigma]}} for groups with at least two sigma values."""
    groups = {}
    for row in rows:
        key = (row["model"], row["dt"])
        groups.setdefault(key, {}).setdefault(line_label(row), []).append(row)
    out = {}
    for key, lines in groups.items():
        for label in lines:
            lines[label].sort(key=lambda r: r["sigma"])
        if max(len(v) for v in lines.values()) >= 2:
            out[key] = lines
    return out


def plot_error_vs_sigma(lines, title):
    """One figure; returns it. Axis i holds ERROR_PANELS[i]; each line's x = sigma, y = mean."""
    fig, axes = plt.subplots(1, len(ERROR_PANELS), figsize=(5 * len(ERROR_PANELS), 4))
    for ax, (metric, ylabel) in zip(axes, ERROR_PANELS):
        means = np.array([r[metric + "_mean"] for rs in lines.values() for r in rs])
        means = means[~np.isnan(means)]
        log = metric != "misclassification" and means.size > 0 and bool(np.all(means > 0))
        # On a log axis a CI reaching 0 or below is drawn down to half the smallest mean.
        floor = 0.5 * float(means.min()) if log else 0.0
        for label, rs in sorted(lines.items()):
            x = np.array([r["sigma"] for r in rs])
            y = np.array([r[metric + "_mean"] for r in rs])
            lo = np.array([max(r[metric + "_ci95_lo"], floor) for r in rs])
            hi = np.array([r[metric + "_ci95_hi"] for r in rs])
            (ln,) = ax.plot(x, y, "o-", ms=3, label=label)
            ok = ~(np.isnan(lo) | np.isnan(hi))
            if ok.any():
                ax.fill_between(x[ok], lo[ok], hi[ok], color=ln.get_color(), alpha=0.2, lw=0)
        if log:
            ax.set_yscale("log")
        ax.set_xlabel(r"noise $\sigma$")
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def misclassification_maps(rows):
    """{(model, estimator, detector): {sigma: (dts, rs, matrix[dt][r] of means)}} for dt x r grids."""
    groups = {}
    for row in rows:
        if math.isnan(row["r"]):
            continue
        groups.setdefault((row["model"], row["estimator"], row["detector"]), []).append(row)
    out = {}
    for key, rs in groups.items():
        dts = sorted({r["dt"] for r in rs})
        rvals = sorted({r["r"] for r in rs})
        if len(dts) < 2 or len(rvals) < 2:
            continue
        maps = {}
        for sigma in sorted({r["sigma"] for r in rs}):
            m = np.full((len(dts), len(rvals)), np.nan)
            for r in rs:
                if r["sigma"] == sigma:
                    m[dts.index(r["dt"]), rvals.index(r["r"])] = r["misclassification_mean"]
            maps[sigma] = (dts, rvals, m)
        out[key] = maps
    return out


def plot_misclassification_map(maps, title):
    """One panel per sigma; each panel's image array is the dt x r matrix of mean misclassification.

    Colours are logarithmic from 1e-6 to 1 (a rate of 0 gets the darkest colour); each cell is labelled
    with its value."""
    sigmas = sorted(maps)
    cols = min(4, len(sigmas))
    nrows = (len(sigmas) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(3.4 * cols + 1.2, 3.0 * nrows + 0.6), squeeze=False,
                             sharex=True, sharey=True, constrained_layout=True)
    cmap = matplotlib.colormaps["viridis"].copy()
    cmap.set_bad(cmap(0.0))
    norm = matplotlib.colors.LogNorm(vmin=1e-6, vmax=1.0, clip=True)
    im = None
    for i, sigma in enumerate(sigmas):
        ax = axes[i // cols][i % cols]
        dts, rvals, m = maps[sigma]
        im = ax.imshow(m, origin="lower", aspect="auto", cmap=cmap, norm=norm)
        for a in range(len(dts)):
            for b in range(len(rvals)):
                v = m[a, b]
                text = "0" if v == 0 else f"{v:.0e}" if v < 0.01 else f"{v:.2f}"
                ax.text(b, a, text, ha="center", va="center", fontsize=6,
                        color="white" if not (v >= 1e-2) else "black")
        ax.set_xticks(range(len(rvals)), [f"{v:g}" for v in rvals], fontsize=7)
        ax.set_yticks(range(len(dts)), [f"{v:g}" for v in dts], fontsize=7)
        if i // cols == nrows - 1 or i + cols >= len(sigmas):
            ax.set_xlabel("r")
        if i % cols == 0:
            ax.set_ylabel(r"$\delta t$ [s]")
        ax.set_title(rf"$\sigma$ = {sigma:g}", fontsize=9)
    for j in range(len(sigmas), nrows * cols):
        axes[j // cols][j % cols].axis("off")
    fig.colorbar(im, ax=axes.ravel().tolist(), label="mean misclassification rate (log)")
    fig.suptitle(title)
    return fig


def slug(x):
    return f"{x:g}".replace("-", "m").replace("+", "")


def plot_run(run_dir, out_dir=None):
    """Writes every figure of RUN_DIR; returns the list of files written."""
    rows = read_summary(run_dir)
    out_dir = out_dir or os.path.join(run_dir, "figures")
    os.makedirs(out_dir, exist_ok=True)
    written = []
    for (model, dt), lines in sorted(error_vs_sigma(rows).items()):
        fig = plot_error_vs_sigma(lines, f"{model}, δt = {dt:g} s: errors vs noise (mean, 95 % CI)")
        path = os.path.join(out_dir, f"error_vs_sigma_{model}_dt{slug(dt)}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    for (model, est, det), maps in sorted(misclassification_maps(rows).items()):
        fig = plot_misclassification_map(maps, f"{model}, {est}, {det} detector: misclassification over δt × r")
        path = os.path.join(out_dir, f"misclassification_map_{model}_{est}_{det}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--out", default=None, help="output directory (default RUN_DIR/figures)")
    args = ap.parse_args()
    for path in plot_run(args.run_dir, args.out):
        print("wrote", path)


if __name__ == "__main__":
    main()

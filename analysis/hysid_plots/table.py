"""A run's summary as a paper table: one row per cell (the grid keys that vary), one column per metric
holding the mean (or median) and its 95 % interval, with as many significant digits as the interval
supports."""
import csv
import io
import re

from . import data, series, stats

DEFAULT_METRICS = ("e_alpha", "e_beta", "misclassification")
HEADERS = {"e_alpha": ("e_α", r"$e_\alpha$"), "e_beta": ("e_β", r"$e_\beta$"),
           "misclassification": ("misclassification", "misclass."), "sigma": ("σ", r"$\sigma$"),
           "dt": ("δt [s]", r"$\delta t$ [s]"), "estimator": ("estimator", "estimator"),
           "detector": ("detector", "detector"), "model": ("model", "model")}


def cell_order(summary):
    """Rows sorted by model, detector setting, estimator, δt, σ (numeric)."""
    keys = [k for k in ("model", "detector", "r", "false_alarm", "estimator", "dt", "sigma") if k in summary.keys]
    keys += [k for k in summary.keys if k not in keys]
    order = {k: summary.values(k) for k in keys}
    return sorted(summary.rows, key=lambda r: [series.index_of(order[k], r[k]) for k in keys])


def columns(summary):
    """The key columns shown: those that vary, the detector's r and p folded into 'detector'."""
    shown = [k for k in ("model", "detector", "estimator", "dt", "sigma") if len(summary.values(k) if
                                                                                k in summary.keys else []) > 1]
    if "detector" not in shown and any(len(summary.values(k)) > 1 for k in ("r", "false_alarm")
                                       if k in summary.keys):
        shown.insert(0, "detector")
    shown += [k for k in summary.keys if k not in ("model", "detector", "estimator", "dt", "sigma", "r",
                                                   "false_alarm") and len(summary.values(k)) > 1]
    return shown


def key_text(row, k, summary):
    """The text of key k in row: a grid value as labelled on its axis (stats.grid_labels)."""
    if k == "detector":
        return series.detector_text(row, summary)
    return series.fmt_key(k, row[k], summary.values(k))


def cells(run, metrics, stat):
    """[(key texts, [(est, lo, hi) per metric], n)] in table order."""
    iv = stats.Intervals(run, stat)
    keys = columns(run.summary)
    out = []
    for r in cell_order(run.summary):
        vals = [iv.of(r, m)[:3] for m in metrics]
        n = min(iv.of(r, m)[3] for m in metrics)
        out.append(([key_text(r, k, run.summary) for k in keys], vals, n))
    return keys, out, iv


def latex_num(text):
    m = re.fullmatch(r"(-?[0-9.]+)e(-?)0*([0-9]+)", text)
    return rf"{m.group(1)}\cdot10^{{{m.group(2)}{m.group(3)}}}" if m else text


def render(run, fmt, metrics=None, stat="mean"):
    """The table as text in `fmt` ('md', 'latex' or 'csv')."""
    metrics = metrics or [m for m in DEFAULT_METRICS if run.summary.has(f"{m}_mean")]
    for m in metrics:
        if not run.summary.has(f"{m}_mean"):
            raise data.DataError(f"{run.summary.path}: no column '{m}_mean' (--metrics {','.join(metrics)})")
    keys, rows, iv = cells(run, metrics, stat)
    note = (f"{stat[0].upper() + stat[1:]} [95 % interval] per cell: {iv.method()}. "
            f"{stats.crn_note(run.summary)}Data: {run.source()}.")
    if fmt == "csv":
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(keys + [f"{m}_{s}" for m in metrics for s in (stat, "lo", "hi")] + ["n"])
        for ks, vals, n in rows:
            w.writerow(ks + [text for t in vals for text in stats.interval_parts(*t)] + [n])
        return buf.getvalue()
    texts = []
    for ks, vals, n in rows:
        cellv = []
        for est, lo, hi in vals:
            cellv.append(stats.interval_text(est, lo, hi))
        texts.append(ks + cellv + [str(n)])
    names = [HEADERS.get(k, (k, k)) for k in keys + metrics] + [("n", "n")]
    if fmt == "md":
        lines = ["| " + " | ".join(h[0] for h in names) + " |", "|" + "---|" * len(names)]
        lines += ["| " + " | ".join(t) + " |" for t in texts]
        return "\n".join(lines) + f"\n\n{note}\n"
    if fmt == "latex":
        body = [" & ".join(latex_cell(c) for c in t) + r" \\" for t in texts]
        return "\n".join([r"% " + note, r"\begin{tabular}{" + "l" * len(keys) + "r" * (len(metrics) + 1) + "}",
                          r"\hline", " & ".join(h[1] for h in names) + r" \\", r"\hline"] + body +
                         [r"\hline", r"\end{tabular}"]) + "\n"
    raise data.DataError(f"--format = '{fmt}': must be md, latex or csv")


def latex_cell(text):
    parts = re.split(r"([-0-9.]+e-?[0-9]+)", text)
    out = "".join(f"${latex_num(p)}$" if re.fullmatch(r"[-0-9.]+e-?[0-9]+", p) else p for p in parts)
    return out.replace("_", r"\_").replace("–", "--")

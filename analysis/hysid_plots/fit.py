"""The figure of one identification (`hysid identify --json REPORT.json --trace TRACE.csv`): per run of
the data, the measured outputs with the fitted model's output, the detected jumps and the fitted
event times with their standard errors, the mode sequence of an automaton, the detector's statistic
against its threshold, and the fit's residuals: against time, their autocorrelation with the band
±1.96/√N, and a normal quantile plot.

What each part reads:
- measured outputs: the data files named in the report (`data.path`, `data.state_columns`), one row
  per trace row (the trace holds every data row, in file order);
- detections: the report's `detections` (`t`, `run`); fitted events: `automaton.events` (`time_fitted`,
  `time_fitted_se`); modes: `automaton.modes`; the detector: the trace's `z`, `q` (residual detector) or
  `D`, `tau_hat` (paper detector);
- the fitted model and its residuals: the trace's `fit_STATE` (the fitted model's output at the row,
  each chain run from its fitted initial state; NaN where not fitted) and `residual_STATE`
  (y − fit over the fitted samples, NaN elsewhere). A trace without them gives a figure of the
  data, events and detector only, and the caption says which columns were missing.
"""
import csv
import json
import math
import os

import matplotlib.patches
import matplotlib.transforms
import numpy as np
from scipy import stats as sps

from . import data, style

ACF_LAGS = 20


def read_report(path):
    if not os.path.exists(path):
        raise data.DataError(f"{path}: no such file (written by hysid identify --json {path})")
    with open(path) as f:
        try:
            return json.load(f)
        except json.JSONDecodeError as e:
            raise data.DataError(f"{path}:{e.lineno}: {e.msg}") from None


def read_trace(path):
    """{column: array of floats}; text cells NaN."""
    header, rows = data.read_csv(path)
    out = {}
    for i, h in enumerate(header):
        col = []
        for r in rows:
            try:
                col.append(float(r[i]))
            except ValueError:
                col.append(math.nan)
        out[h] = np.array(col)
    return out


def read_measured(report, base):
    """The measured state columns of the report's data files, one row per data row (files in order),
    as a (rows × states) array; names the file and column when they cannot be read."""
    d = report.get("data", {})
    names = d.get("state_columns") or []
    files = [p.strip() for p in str(d.get("path", "")).split(", ") if p.strip()]
    if not files or not names:
        raise data.DataError("the report has no data.path or data.state_columns")
    out = []
    for path in files:
        full = path if os.path.isabs(path) or os.path.exists(path) else os.path.join(base, path)
        if not os.path.exists(full):
            raise data.DataError(f"{path}: the report's data file is not found (from the current directory or "
                                 f"{base})")
        with open(full, newline="") as f:
            rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
        header = rows[0]
        for n in names:
            if n not in header:
                raise data.DataError(f"{full}: no column '{n}' (the report's data.state_columns)")
        idx = [header.index(n) for n in names]
        for r in rows[1:]:
            out.append([data.number(r[i], full) if r[i].strip().lower() not in ("", "nan", "na") else math.nan
                        for i in idx])
    return np.array(out, dtype=float), names


def resolve(run):
    """(report path, trace path) from RUN: a report REPORT.json (the trace beside it: REPORT.csv or
    REPORT_trace.csv), or a prefix P (P.json and P.csv or P_trace.csv)."""
    stem = run[:-5] if run.endswith(".json") else run
    report = stem + ".json"
    for trace in (stem + ".csv", stem + "_trace.csv", stem + ".trace.csv"):
        if os.path.exists(trace):
            return report, trace
    raise data.DataError(f"{stem}.csv: no such file (the trace: hysid identify --trace {stem}.csv)")


class Fit:
    """One identification's outputs: the report, the trace and the measured outputs."""

    def __init__(self, report_path, trace_path):
        self.report_path, self.trace_path = report_path, trace_path
        self.report = read_report(report_path)
        self.trace = read_trace(trace_path)
        for need in ("run", "chain", "t", "missing"):
            if need not in self.trace:
                raise data.DataError(f"{trace_path}: no column '{need}' (not a trace of hysid identify)")
        self.y, self.names = read_measured(self.report, os.path.dirname(os.path.abspath(report_path)))
        if self.y.shape[0] != self.trace["t"].size:
            raise data.DataError(f"{trace_path}: {self.trace['t'].size} rows, the data files "
                                 f"{self.y.shape[0]}: not the trace of this report")
        self.missing_columns = [c for n in self.names for c in (f"fit_{n}", f"residual_{n}")
                                if c not in self.trace]

    def runs(self):
        return sorted({int(r) for r in self.trace["run"] if math.isfinite(r)})

    def rows(self, run):
        """The sample rows of `run` (not missing)."""
        return np.flatnonzero((self.trace["run"] == run) & (self.trace["missing"] == 0))

    def sigma(self, i):
        s = self.report.get("sigma") or []
        return float(s[i]) if i < len(s) and s[i] is not None and float(s[i]) > 0 else math.nan

    def detections(self, run):
        return np.array([d["t"] for d in self.report.get("detections") or [] if d.get("run") == run])

    def fitted_events(self, run, rows):
        """[(time, se)] of the automaton's events with a fitted time inside the run's time span."""
        auto = self.report.get("automaton") or {}
        lo, hi = self.trace["t"][rows].min(), self.trace["t"][rows].max()
        runs = self.trace["run"]
        out = []
        for e in auto.get("events") or []:
            tf = e.get("time_fitted")
            k = e.get("sample")
            if tf is None or k is None or k >= runs.size or runs[self.sample_row(k)] != run:
                continue
            if lo <= tf <= hi:
                out.append((float(tf), float(e.get("time_fitted_se") or 0.0)))
        return out

    def sample_row(self, k):
        """The trace row of sample index k (samples count the rows without a missing value)."""
        if not hasattr(self, "_samples"):
            self._samples = np.flatnonzero(self.trace["missing"] == 0)
        return self._samples[min(k, self._samples.size - 1)]

    def modes(self, run, rows):
        """[(t_start, t_end, mode)] of the automaton's runs of equal mode inside the run."""
        auto = self.report.get("automaton") or {}
        spans = auto.get("modes") or []
        t = self.trace["t"]
        out = []
        for i, m in enumerate(spans):
            k = m.get("first_sample", 0)
            if self.trace["run"][self.sample_row(k)] != run:
                continue
            end = spans[i + 1]["t"] if i + 1 < len(spans) else t[rows].max()
            out.append((float(m["t"]), float(min(end, t[rows].max())), m.get("mode")))
        return out

    def residuals(self, rows):
        """Normalised residuals r/σ per measured state over `rows` (NaN where not fitted), or None."""
        if any(f"residual_{n}" not in self.trace for n in self.names):
            return None
        out = []
        for i, n in enumerate(self.names):
            s = self.sigma(i)
            out.append(self.trace[f"residual_{n}"][rows] / (s if math.isfinite(s) else 1.0))
        return np.array(out)


def autocorrelation(r, lags):
    """Lag-k autocorrelation of the finite entries of r, pooled as the refinement's check pools it:
    Σ r_k r_{k−l} / Σ r_k² over pairs with both finite (not mean-centred)."""
    r = np.asarray(r, dtype=float)
    z = np.where(np.isfinite(r), r, 0.0)
    den = np.sum(z * z)
    return np.array([np.sum(z[l:] * z[:len(z) - l]) / den if den > 0 else math.nan for l in range(1, lags + 1)])


def draw_run(fit, run, width):
    rows = fit.rows(run)
    t = fit.trace["t"][rows]
    n = len(fit.names)
    res = fit.residuals(rows)
    det = "z" if "z" in fit.trace else ("D" if "D" in fit.trace else None)
    modes = fit.modes(run, rows)
    top = n + (det is not None) + (res is not None)
    fig = style.plt.figure(figsize=(style.WIDTHS[width], 1.1 * top + (1.5 if res is not None else 0) + 0.3),
                           constrained_layout=True)
    gs = fig.add_gridspec(top + (res is not None), 2, height_ratios=[1.0] * top + ([1.3] if res is not None else []))
    axes = []
    for i in range(top):
        axes.append(fig.add_subplot(gs[i, :], sharex=axes[0] if axes else None))
    dets = fit.detections(run)
    events = fit.fitted_events(run, rows)
    for i, name in enumerate(fit.names):
        ax = axes[i]
        ax.plot(t, fit.y[rows, i], ls="none", marker=".", ms=1.5, color="0.45", label="measured", gid="measured")
        col = f"fit_{name}"
        if col in fit.trace:
            ax.plot(t, fit.trace[col][rows], color=style.COLORS[0], lw=0.9, label="fitted model", gid="fit")
        mark_events(ax, dets, events)
        if modes and i == 0:
            mode_ribbon(ax, modes)
        ax.set_ylabel(name)
    k = n
    if det is not None:
        ax = axes[k]
        thr = "q" if det == "z" else "tau_hat"
        stat, limit = fit.trace[det][rows], fit.trace[thr][rows]
        # Log axis: a statistic or threshold of 0 (a chain's first samples) is not drawn.
        ax.plot(t, np.where(stat > 0, stat, np.nan), color="0.35", lw=0.6, label="statistic", gid="statistic")
        ax.plot(t, np.where(limit > 0, limit, np.nan), color=style.COLORS[1], lw=0.9, ls="--", label="threshold",
                gid="threshold")
        if np.any(np.r_[stat, limit] > 0):
            ax.set_yscale("log")
        mark_events(ax, dets, events)
        ax.set_ylabel(r"max $|z|$, $q$" if det == "z" else r"$D_{\delta t}\xi$, $\hat\tau$")
        k += 1
    if res is not None:
        ax = axes[k]
        for i, name in enumerate(fit.names):
            ax.plot(t, res[i], ls="none", marker=".", ms=1.5, color=style.COLORS[i % len(style.COLORS)],
                    label=name, gid=f"residual_{name}")
        ax.axhline(0, color="black", lw=0.6)
        mark_events(ax, dets, events)
        ax.set_ylabel("residual / σ" if any(math.isfinite(fit.sigma(i)) for i in range(n)) else "residual")
        draw_diagnostics(fig.add_subplot(gs[top, 0]), fig.add_subplot(gs[top, 1]), res, fit.names)
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel("t")
    handles = [h for h in axes[0].get_lines() if h.get_gid() in ("measured", "fit")]
    axes[0].legend(handles, [h.get_label() for h in handles], loc="upper right", fontsize=7, markerscale=4)
    return fig


def mark_events(ax, dets, events):
    """Detected jumps: dotted grey vertical lines (gid 'detections'); fitted event times: a line with a
    band of ± its standard error (gid 'fitted_events')."""
    if len(dets):
        trans = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
        xs = np.repeat(dets, 3)
        ys = np.tile([0.0, 1.0, np.nan], len(dets))
        ax.plot(xs, ys, transform=trans, color="0.55", lw=0.6, ls=":", gid="detections")
    for tf, se in events:
        ax.axvline(tf, color=style.COLORS[2], lw=0.8, gid="fitted_events")
        if se > 0:
            ax.axvspan(tf - se, tf + se, color=style.COLORS[2], alpha=0.25, lw=0)


def mode_ribbon(ax, modes):
    """The mode sequence as a coloured ribbon along the top of the panel."""
    names = []
    for _, _, m in modes:
        if m not in names:
            names.append(m)
    trans = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
    for t0, t1, m in modes:
        ax.add_patch(matplotlib.patches.Rectangle((t0, 0.95), t1 - t0, 0.05, transform=trans, lw=0,
                                                  color=style.COLORS[3 + names.index(m) % 4], gid="mode",
                                                  label=str(m)))


def draw_diagnostics(ax_acf, ax_qq, res, names):
    """Autocorrelation of each state's normalised residuals (lags 1 … ACF_LAGS) with the band
    ±1.96/√N, and the normal quantile plot of all of them pooled."""
    n = 0
    for i, name in enumerate(names):
        r = res[i]
        m = int(np.isfinite(r).sum())
        if m < ACF_LAGS + 2:
            continue
        n = max(n, m)
        acf = autocorrelation(r, ACF_LAGS)
        ax_acf.plot(np.arange(1, ACF_LAGS + 1), acf, marker=style.MARKERS[i], mfc="none", lw=0.8, ms=3,
                    color=style.COLORS[i % len(style.COLORS)], label=name, gid=f"acf_{name}")
    if n:
        band = 1.96 / math.sqrt(n)
        ax_acf.axhspan(-band, band, color="0.8", alpha=0.6, lw=0, gid="acf_band")
    ax_acf.axhline(0, color="black", lw=0.6)
    ax_acf.set_xlabel("lag (samples)")
    ax_acf.set_ylabel("autocorrelation")
    ax_acf.legend(fontsize=7)
    pooled = np.sort(np.concatenate([r[np.isfinite(r)] for r in res]))
    if pooled.size:
        q = sps.norm.ppf((np.arange(1, pooled.size + 1) - 0.5) / pooled.size)
        ax_qq.plot(q, pooled, ls="none", marker=".", ms=2, color="0.3", gid="qq")
        lim = [q.min(), q.max()]
        ax_qq.plot(lim, lim, color=style.COLORS[1], lw=0.8, ls="--", gid="qq_line")
    ax_qq.set_xlabel("normal quantile")
    ax_qq.set_ylabel("residual / σ, sorted")


def fit_figures(run, out_dir, formats, width, runs=None):
    """The fit figure of each chosen run of the identification RUN (resolve); `runs`: run numbers
    (default: the first 3). Returns the written paths."""
    report, trace = resolve(run)
    fit = Fit(report, trace)
    chosen = runs or fit.runs()[:3]
    bad = [r for r in chosen if r not in fit.runs()]
    if bad:
        raise data.DataError(f"--runs {','.join(map(str, bad))}: not a run of {trace} (runs 1–{len(fit.runs())})")
    out_dir = out_dir or os.path.dirname(os.path.abspath(report))
    stem0 = os.path.basename(report)[:-5]
    written = []
    for r in chosen:
        fig = draw_run(fit, r, width)
        stem = f"{stem0}_fit" + (f"_run{r}" if len(fit.runs()) > 1 else "")
        written += style.save(fig, out_dir, stem, formats, caption(fit, r))
    return written


def caption(fit, run):
    rep = fit.report
    names = ", ".join(fit.names)
    est = ", ".join(f"{n} = {v:.6g}" + (f" ± {se:.2g}" if se is not None else "")
                    for n, v, se in zip(rep.get("names") or [], rep.get("estimate") or [],
                                        (rep.get("standard_errors") or []) + [None] * 99)
                    if not str(n).startswith("x0"))
    text = f"{rep.get('model', '?')}, run {run} of {len(fit.runs())}: the measured {names} (grey dots)"
    if not fit.missing_columns:
        text += " with the fitted model's output (line), each chain run from its fitted initial state"
    thr = "q" if "z" in fit.trace else "τ̂"
    text += (f"; dotted grey: the detected jumps; green: the fitted event times with ± their standard error; "
             f"below them the detector's statistic (grey) against its threshold {thr} (dashed), log axis, zeros "
             "not drawn")
    text = text + (f". Refinement: {rep.get('status')}" + (f" ({rep.get('reason')})" if rep.get("reason")
                                                                     else "") + f"; {est}.")
    if not fit.missing_columns:
        text += (f" Below: the normalised residuals r/σ against time, their autocorrelation at lags 1–{ACF_LAGS} "
                 "with the band ±1.96/√N of white noise, and their normal quantile plot (pooled over the states); "
                 f"the refinement's lag-1 check value {rep.get('lag1')}.")
    else:
        text += (" The trace has no " + ", ".join(fit.missing_columns) +
                 ": the fitted model's output and the residual diagnostics are not drawn.")
    return text + f" Data: {fit.report_path}, {fit.trace_path}."

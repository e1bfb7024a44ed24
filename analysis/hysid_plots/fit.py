"""The figure of one identification (`hysid identify --json REPORT.json --trace TRACE.csv`, or the dict
`hysid.identify` returns): per run of the data, the measured outputs with the fitted model run over
the whole record (and the recursive estimate's run when it differs), the detected jumps and the
fitted model's own events with their standard errors, the mode sequence of an automaton as a ribbon,
the hidden states with their band, the detector's statistic against its threshold, and the fit's
residuals: against time, their autocorrelation with the band of the refinement's lag-1 test, and a
normal quantile plot.

What each part reads (docs/outputs.md):
- measured outputs: the data files named in the report (`data.path`, `data.state_columns`), one row
  per trace row (the trace holds every data row, in file order); they are the report's `measured`
  states, in order;
- the fitted model: the trace's `fit_STATE` with the band ±1.96 `sd_STATE`, `recursive_STATE`, and
  `residual_STATE` (y − fit) with `in_fit` (the samples the fit used: only they enter the
  autocorrelation and the quantile plot; the others are drawn grey);
- detections: the report's `detections` (`t`, `run`); the fitted events: `fitted_events.jumps` (`t`,
  `se`, `chain`); modes: `fitted_events.modes` (the fitted run's), else `automaton.modes` (the
  detected sequence); the detector: the trace's `z`, `q` (residual detector) or `D`, `tau_hat`.
A trace without the fitted model's columns gives a figure of the data, events and detector only, and
the caption says which columns were missing.
"""
import csv
import json
import math
import os

import matplotlib.patches
import matplotlib.ticker
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

    def __init__(self, report, trace, y, report_path="", trace_path=""):
        self.report_path, self.trace_path = report_path, trace_path
        self.report, self.trace, self.y = report, trace, y
        for need in ("run", "chain", "t", "missing"):
            if need not in self.trace:
                raise data.DataError(f"{trace_path}: no column '{need}' (not a trace of hysid identify)")
        columns = report.get("data", {}).get("state_columns") or []
        self.names = list(report.get("measured") or columns)  # the model's names of the measured states
        if len(self.names) != y.shape[1]:
            raise data.DataError(f"{report_path}: measured {self.names}, but {y.shape[1]} data columns")
        if self.y.shape[0] != self.trace["t"].size:
            raise data.DataError(f"{trace_path}: {self.trace['t'].size} rows, the data files "
                                 f"{self.y.shape[0]}: not the trace of this report")
        self.states = [c[4:] for c in self.trace if c.startswith("fit_")]  # every state, model order
        self.hidden = [s for s in self.states if s not in self.names]
        self.missing_columns = [c for n in self.names for c in (f"fit_{n}", f"residual_{n}")
                                if c not in self.trace]
        # A refinement that reported no fit: its columns are nan throughout (fitted_events.reason says why).
        self.no_fit = not self.missing_columns and not any(np.any(np.isfinite(self.trace[f"fit_{n}"]))
                                                           for n in self.names)
        self._samples = np.flatnonzero(self.trace["missing"] == 0)

    @classmethod
    def from_files(cls, report_path, trace_path):
        report = read_report(report_path)
        trace = read_trace(trace_path)
        y, _ = read_measured(report, os.path.dirname(os.path.abspath(report_path)))
        return cls(report, trace, y, report_path, trace_path)

    @classmethod
    def from_result(cls, result):
        """From the dict `hysid.identify(...)` returns: its `report` and `fit_trace`."""
        if "fit_trace" not in result or "report" not in result:
            raise data.DataError("the result has no 'fit_trace' or 'report' (a dict of hysid.identify)")
        trace = {k: np.asarray(v, dtype=float) for k, v in result["fit_trace"].items() if k != "measured"}
        return cls(result["report"], trace, np.asarray(result["fit_trace"]["measured"], dtype=float),
                   "hysid.identify result", "result['fit_trace']")

    def runs(self):
        return sorted({int(r) for r in self.trace["run"] if math.isfinite(r)})

    def rows(self, run):
        """The sample rows of `run` (not missing)."""
        return np.flatnonzero((self.trace["run"] == run) & (self.trace["missing"] == 0))

    def state_index(self, name):
        return self.states.index(name) if name in self.states else self.names.index(name)

    def sigma(self, name):
        s = self.report.get("sigma") or []
        i = self.state_index(name)
        return float(s[i]) if i < len(s) and s[i] is not None and float(s[i]) > 0 else math.nan

    def detections(self, run):
        return np.array([d["t"] for d in self.report.get("detections") or [] if d.get("run") == run])

    def fitted_events(self, run, rows):
        """[(time, se)] of the fitted model's jumps in the chains of `run` (fitted_events.jumps), else
        the automaton's events with a fitted time in the run's span."""
        chains = {int(c) for c in self.trace["chain"][rows] if math.isfinite(c)}
        fe = self.report.get("fitted_events")
        if fe is not None:
            return [(float(j["t"]), float(j["se"]) if j.get("se") is not None else 0.0)
                    for j in fe.get("jumps") or [] if j.get("chain") in chains]
        auto = self.report.get("automaton") or {}
        lo, hi = self.trace["t"][rows].min(), self.trace["t"][rows].max()
        out = []
        for e in auto.get("events") or []:
            tf, k = e.get("time_fitted"), e.get("sample")
            if tf is None or k is None or self.trace["run"][self.sample_row(k)] != run:
                continue
            if lo <= tf <= hi:
                out.append((float(tf), float(e.get("time_fitted_se") or 0.0)))
        return out

    def detector(self):
        """The trace's detector statistic column ('z' or 'D'), or None when it has none or it is never
        positive (a hybrid automaton's events come from the slope-change statistic, not in the trace)."""
        for stat, thr in (("z", "q"), ("D", "tau_hat")):
            if stat in self.trace and np.any(np.r_[self.trace[stat], self.trace[thr]] > 0):
                return stat
        return None

    def sample_rows(self):
        """Every sample row (all runs)."""
        return self._samples

    def sample_row(self, k):
        """The trace row of sample index k (samples count the rows without a missing value)."""
        return self._samples[min(k, self._samples.size - 1)]

    def modes(self, run, rows):
        """([(t_start, t_end, mode)] of the runs of equal mode inside the run, 'fitted' or 'detected'):
        the fitted run's (fitted_events.modes), else the detected sequence (automaton.modes); none for a
        model with one mode."""
        fe = self.report.get("fitted_events") or {}
        spans, which = fe.get("modes"), "fitted"
        if not spans:
            spans, which = (self.report.get("automaton") or {}).get("modes") or [], "detected"
        if len({m.get("mode") for m in spans}) < 2:  # one mode (jump maps only): no sequence to show
            return [], which
        t = self.trace["t"]
        t_end = t[rows].max()
        out = []
        for i, m in enumerate(spans):
            row = self.sample_row(m.get("first_sample", 0))
            if self.trace["run"][row] != run:
                continue
            nxt = spans[i + 1] if i + 1 < len(spans) else None
            end = nxt["t"] if nxt is not None and self.trace["run"][self.sample_row(nxt["first_sample"])] == run else t_end
            out.append((float(m["t"]), float(end), m.get("mode")))
        return out, which

    def residuals(self, rows):
        """Normalised residuals r/σ per measured state over `rows` (NaN where not fitted), or None
        (no residual columns, or no fit)."""
        if self.missing_columns or self.no_fit:
            return None
        out = []
        for n in self.names:
            s = self.sigma(n)
            out.append(self.trace[f"residual_{n}"][rows] / (s if math.isfinite(s) else 1.0))
        return np.array(out)

    def in_fit(self, rows):
        """1 where the sample is one the fit used (all when the trace has no in_fit column)."""
        return self.trace["in_fit"][rows] == 1 if "in_fit" in self.trace else np.ones(rows.size, bool)

    def lag1_band(self, n):
        """The half-width of the refinement's lag-1 test on n samples: z/√n, z the normal quantile at
        the test's size split over the measured states (checks.lag1.test_size; 1.96 without it)."""
        size = ((self.report.get("checks") or {}).get("lag1") or {}).get("test_size")
        z = sps.norm.isf(size / (2 * len(self.names))) if size else 1.96
        return z / math.sqrt(n), z


def autocorrelation(r, lags, chain=None):
    """Lag-l autocorrelation of the finite entries of r, as the refinement's check computes it:
    Σ r_k r_{k−l} / Σ r_k² over pairs with both finite and in the same chain (not mean-centred)."""
    r = np.asarray(r, dtype=float)
    z = np.where(np.isfinite(r), r, 0.0)
    den = np.sum(z * z)
    out = []
    for l in range(1, lags + 1):
        pair = z[l:] * z[:len(z) - l]
        if chain is not None:
            pair = pair * (np.asarray(chain[l:]) == np.asarray(chain[:len(z) - l]))
        out.append(np.sum(pair) / den if den > 0 else math.nan)
    return np.array(out)


def draw_run(fit, run, width):
    """The figure of one run: a panel per measured then hidden state, the detector's, the residuals'
    and below them the autocorrelation and the normal quantiles."""
    rows = fit.rows(run)
    res = fit.residuals(rows)
    det = fit.detector()
    shown = fit.names + fit.hidden
    top = len(shown) + (det is not None) + (res is not None)
    fig = style.plt.figure(figsize=(style.WIDTHS[width], 1.05 * top + (1.6 if res is not None else 0) + 0.3),
                           constrained_layout=True)
    gs = fig.add_gridspec(top + (res is not None), 2, height_ratios=[1.0] * top + ([1.4] if res is not None else []))
    axes = []
    for i in range(top):
        axes.append(fig.add_subplot(gs[i, :], sharex=axes[0] if axes else None))
    marks = (fit.detections(run), fit.fitted_events(run, rows))
    mode_handles = draw_states(axes[:len(shown)], fit, run, rows, shown, marks)
    k = len(shown)
    if det is not None:
        draw_detector(axes[k], fit, rows, det, marks)
        k += 1
    if res is not None:
        draw_residuals(axes[k], fit, rows, res, marks)
        every = fit.sample_rows()  # the diagnostics pool every run, as the refinement's tests do
        draw_diagnostics(fig.add_subplot(gs[top, 0]), fig.add_subplot(gs[top, 1]), fit, every, fit.residuals(every))
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel("t")
    handles = [h for h in axes[0].get_lines() if h.get_gid() in ("measured", "fit", "recursive")] + mode_handles
    axes[0].legend(handles, [h.get_label() for h in handles], loc="lower left", bbox_to_anchor=(0.0, 0.98),
                   fontsize=6, markerscale=4, ncol=min(len(handles), 3), borderaxespad=0.0, handlelength=1.8)
    return fig


def draw_states(axes, fit, run, rows, shown, marks):
    """Each state's panel: the measured samples, the models' runs, the events; the mode ribbon on the
    first. Returns the ribbon's legend handles."""
    t = fit.trace["t"][rows]
    modes, _ = fit.modes(run, rows)
    handles = []
    for i, name in enumerate(shown):
        ax = axes[i]
        if name in fit.names:
            ax.plot(t, fit.y[rows, fit.names.index(name)], ls="none", marker=".", ms=1.5, color="0.55",
                    label="measured", gid="measured")
        draw_model(ax, fit, name, rows, t)
        mark_events(ax, *marks)
        if modes and i == 0:
            handles = mode_ribbon(ax, modes)
        ax.set_ylabel(name if name in fit.names else f"{name} (hidden)")
    return handles


def draw_detector(ax, fit, rows, det, marks):
    """The detector's statistic against its threshold (log axis: a 0 of a chain's first samples is not
    drawn)."""
    t = fit.trace["t"][rows]
    thr = "q" if det == "z" else "tau_hat"
    stat, limit = fit.trace[det][rows], fit.trace[thr][rows]
    ax.plot(t, np.where(stat > 0, stat, np.nan), color="0.35", lw=0.6, label="statistic", gid="statistic")
    ax.plot(t, np.where(limit > 0, limit, np.nan), color=style.COLORS[1], lw=0.9, ls="--", label="threshold",
            gid="threshold")
    ax.set_yscale("log")
    mark_events(ax, *marks)
    ax.set_ylabel(r"max $|z|$, $q$" if det == "z" else r"$D_{\delta t}\xi$, $\hat\tau$")


def draw_residuals(ax, fit, rows, res, marks):
    """The normalised residuals against time: coloured where the fit used the sample, grey elsewhere."""
    t = fit.trace["t"][rows]
    used = fit.in_fit(rows)
    for i, name in enumerate(fit.names):
        color = style.COLORS[i % len(style.COLORS)]
        ax.plot(t, np.where(used, res[i], np.nan), ls="none", marker=".", ms=1.0, alpha=0.6, color=color,
                label=name, gid=f"residual_{name}")
        if not used.all():
            ax.plot(t, np.where(used, np.nan, res[i]), ls="none", marker=".", ms=1.0, color="0.7",
                    gid=f"residual_unfitted_{name}")
    ax.axhline(0, color="black", lw=0.6)
    mark_events(ax, *marks)
    ax.set_ylabel("residual / σ" if any(math.isfinite(fit.sigma(n)) for n in fit.names) else "residual")
    if len(fit.names) > 1:
        ax.legend(loc="lower right", bbox_to_anchor=(1.0, 0.98), fontsize=6, markerscale=5, ncol=len(fit.names),
                  borderaxespad=0.0, handletextpad=0.1)


def draw_model(ax, fit, name, rows, t):
    """The fitted model's run (gid 'fit') with its band ±1.96 sd (gid 'fit_band'), and the recursive
    estimate's run (gid 'recursive') when it differs from it."""
    col = f"fit_{name}"
    if col not in fit.trace:
        return
    x = fit.trace[col][rows]
    ax.plot(t, x, color=style.COLORS[0], lw=0.9, label="fitted model", gid="fit", zorder=3)
    sd = fit.trace.get(f"sd_{name}")
    if sd is not None and np.any(np.isfinite(sd[rows])):
        ax.fill_between(t, x - 1.96 * sd[rows], x + 1.96 * sd[rows], color=style.COLORS[0], alpha=0.25, lw=0,
                        gid="fit_band")
    rec = fit.trace.get(f"recursive_{name}")
    if rec is not None and recursive_differs(rec[rows], x, fit.sigma(name)):
        ax.plot(t, rec[rows], color=style.COLORS[1], lw=0.7, ls="--", label="recursive estimate",
                gid="recursive", zorder=2)


def recursive_differs(rec, x, sigma):
    """True when the recursive estimate's run is drawn: it runs where the fit does not, or it differs
    from the fit somewhere by more than σ/2 (1e-3 of the fit's range without σ)."""
    if not np.any(np.isfinite(rec)):
        return False
    both = np.isfinite(rec) & np.isfinite(x)
    if not both.any():
        return True
    tol = sigma / 2 if math.isfinite(sigma) else 1e-3 * (np.ptp(x[both]) or 1.0)
    return bool(np.max(np.abs(rec[both] - x[both])) > tol)


def mark_events(ax, dets, events):
    """Detected jumps: dotted grey vertical lines (gid 'detections'); the fitted model's events: a line
    with a band of ± its standard error (gid 'fitted_events')."""
    if len(dets):
        trans = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
        xs = np.repeat(dets, 3)
        ys = np.tile([0.0, 1.0, np.nan], len(dets))
        ax.plot(xs, ys, transform=trans, color="0.55", lw=0.6, ls=":", gid="detections")
    for tf, se in events:
        ax.axvline(tf, color=style.COLORS[2], lw=0.7, gid="fitted_events")
        if se > 0:
            ax.axvspan(tf - se, tf + se, color=style.COLORS[2], alpha=0.3, lw=0, gid="fitted_event_se")


def mode_ribbon(ax, modes):
    """The mode sequence as a coloured ribbon along the top of the panel; returns a legend handle per mode."""
    names = []
    for _, _, m in modes:
        if m not in names:
            names.append(m)
    trans = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
    for t0, t1, m in modes:
        ax.add_patch(matplotlib.patches.Rectangle((t0, 0.93), t1 - t0, 0.07, transform=trans, lw=0,
                                                  color=style.COLORS[3 + names.index(m) % 4], gid="mode",
                                                  label=str(m)))
    return [matplotlib.patches.Patch(color=style.COLORS[3 + i % 4], label=f"mode {m}") for i, m in enumerate(names)]


def draw_diagnostics(ax_acf, ax_qq, fit, rows, res):
    """Autocorrelation of each state's normalised residuals over the fitted samples among `rows` (every
    run: the refinement's tests pool them; lags 1 … ACF_LAGS, pairs within a chain) with the band of the
    refinement's lag-1 test, and the normal quantile plot of all of them pooled."""
    used = fit.in_fit(rows)
    chain = fit.trace["chain"][rows][used]
    n = 0
    for i, name in enumerate(fit.names):
        r = res[i][used]
        m = int(np.isfinite(r).sum())
        if m < ACF_LAGS + 2:
            continue
        n = max(n, m)
        acf = autocorrelation(r, ACF_LAGS, chain)
        ax_acf.plot(np.arange(1, ACF_LAGS + 1), acf, marker=style.MARKERS[i], mfc="none", lw=0.8, ms=3,
                    color=style.COLORS[i % len(style.COLORS)], label=name, gid=f"acf_{name}")
    if n:
        band, _ = fit.lag1_band(n)
        ax_acf.axhspan(-band, band, color="0.8", alpha=0.6, lw=0, gid="acf_band")
    ax_acf.axhline(0, color="black", lw=0.6)
    ax_acf.set_xlabel("lag (samples)")
    ax_acf.set_ylabel("autocorrelation")
    ax_acf.legend(fontsize=6)
    pooled = np.sort(np.concatenate([r[used][np.isfinite(r[used])] for r in res]))
    if pooled.size:
        q = sps.norm.ppf((np.arange(1, pooled.size + 1) - 0.5) / pooled.size)
        ax_qq.plot(q, pooled, ls="none", marker=".", ms=2, color="0.3", gid="qq")
        lim = [q.min(), q.max()]
        ax_qq.plot(lim, lim, color=style.COLORS[1], lw=0.8, ls="--", gid="qq_line")
    ax_qq.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(5, integer=True))
    ax_qq.set_xlabel("normal quantile")
    ax_qq.set_ylabel("residual / σ, sorted")


def fit_figures(run, out_dir, formats, width, runs=None):
    """The fit figure of each chosen run of the identification RUN (resolve); `runs`: run numbers
    (default: the first 3). Returns the written paths."""
    report, trace = resolve(run)
    fit = Fit.from_files(report, trace)
    out_dir = out_dir or os.path.dirname(os.path.abspath(report))
    return save_figures(fit, runs, out_dir, os.path.basename(report)[:-5], formats, width)


def plot_fit(result, out_dir=None, formats=("png",), width="single", runs=None, stem="identify"):
    """The fit figure from the dict `hysid.identify(...)` returns (its `report` and `fit_trace`): the
    figures of the chosen runs (default: the first 3) as out_dir/STEM_fit[_runR].FMT when `out_dir` is
    given (returns their paths), else the figure of the first chosen run (a matplotlib Figure)."""
    fit = Fit.from_result(result)
    if out_dir is None:
        return draw_run(fit, (runs or fit.runs())[0], width)
    return save_figures(fit, runs, out_dir, stem, list(formats), width)


def save_figures(fit, runs, out_dir, stem0, formats, width):
    chosen = runs or fit.runs()[:3]
    bad = [r for r in chosen if r not in fit.runs()]
    if bad:
        raise data.DataError(f"--runs {','.join(map(str, bad))}: not a run of {fit.trace_path} "
                             f"(runs 1–{len(fit.runs())})")
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
    if not fit.missing_columns and not fit.no_fit:
        text += (" with the fitted model run on its own over the whole record from each chain's fitted initial "
                 "state (blue line, band ±1.96 sd from the fit's covariance) and the recursive "
                 "estimate's run (dashed orange, where it differs)")
    elif fit.no_fit:
        text += " with the recursive estimate's run from each chain's first sample (dashed orange)"
    if fit.hidden and not fit.no_fit:
        text += f"; the hidden {', '.join(fit.hidden)} as the fitted model estimates them, with the same band"
    elif fit.hidden:
        text += f"; the hidden {', '.join(fit.hidden)} as the recursive estimate's run has them"
    rows = fit.rows(run)
    _, which = fit.modes(run, rows)
    if fit.modes(run, rows)[0]:
        text += f"; the ribbon on top: the {which} mode sequence"
    text += ("; dotted grey: the detected jumps; green: the fitted model's events with ± their standard error "
             "(shaded; often narrower than the line)")
    if fit.detector() is not None:
        thr = "q" if fit.detector() == "z" else "τ̂"
        text += f"; the detector's statistic (grey) against its threshold {thr} (dashed), log axis, zeros not drawn"
    reason = (rep.get("fitted_events") or {}).get("reason")
    text = text + (f". Refinement: {rep.get('status')}" + (f" ({rep.get('reason')})" if rep.get("reason")
                                                                     else "") + f"; {est}.")
    if reason and not fit.no_fit:
        text += f" The fitted model's run: {reason}."
    if fit.no_fit:
        text += " No fitted model, no residuals: the refinement reported no fit."
    elif not fit.missing_columns:
        n = int(fit.in_fit(fit.sample_rows()).sum())
        _, z = fit.lag1_band(max(n, 1))
        every = f" of all {len(fit.runs())} runs" if len(fit.runs()) > 1 else ""
        text += (f" Below: the normalised residuals r/σ = (y − fit)/σ against time (grey: samples the fit left out); "
                 f"over the {n} fitted samples{every}, their autocorrelation at lags 1–{ACF_LAGS} (pairs within a "
                 f"chain) with the band ±{z:.3g}/√N of the refinement's lag-1 test, and their normal quantile plot "
                 f"(pooled over the states); the refinement's lag-1 value: {rep.get('lag1')}.")
    else:
        text += (" The trace has no " + ", ".join(fit.missing_columns) +
                 ": the fitted model's output and the residual diagnostics are not drawn.")
    return text + f" Data: {fit.report_path}, {fit.trace_path}."

"""Every figure kind rendered from the committed summaries and from a small sweep, in PDF and PNG:
axis scales, labels, legend order, interval bounds and plotted values checked against the CSVs."""
import csv
import math
import os
import shutil

import numpy as np
import pytest
from matplotlib.collections import PolyCollection

from hysid_plots import cli, data, maps, series, stats, style, sweep_figs

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))

NON_NEG_PANELS = ("e_", "misclassification", "/", "|")


def render(argv):
    assert cli.main(argv) == 0


def data_axes(fig):
    """Panels and colour bars (not the legend row, which is switched off)."""
    return [ax for ax in fig.axes if ax.axison]


def legend_texts(fig):
    for ax in fig.axes:
        if not ax.axison and ax.get_legend() is not None:
            return [t.get_text() for t in ax.get_legend().get_texts()]
    return []


def check_files(out, stems, formats=("pdf", "png"), n=True):
    magic = {"pdf": b"%PDF", "png": b"\x89PNG"}
    for stem in stems:
        for fmt in formats:
            with open(os.path.join(out, f"{stem}.{fmt}"), "rb") as f:
                assert f.read(4) == magic[fmt], (stem, fmt)
        with open(os.path.join(out, f"{stem}.txt")) as f:
            cap = f.read()
        assert "Data:" in cap and ("n = " in cap or not n), cap


def check_figure(fig):
    """Every panel has a y label; series are told apart by marker and dashes; no band below 0."""
    for ax in data_axes(fig):
        if ax.get_label() == "<colorbar>":  # labelled along its length (x when below the panels)
            assert (ax.get_xlabel() + ax.get_ylabel()).strip()
            continue
        assert ax.get_ylabel().strip(), [a.get_title() for a in fig.axes]
        styles = [(ln.get_marker(), ln.get_linestyle()) for ln in ax.get_lines() if ln.get_marker() != "None"]
        assert len(styles) == len(set(styles)), styles
        for coll in ax.collections:
            if isinstance(coll, PolyCollection) and coll.get_paths():  # interval bands
                assert min(p.vertices[:, 1].min() for p in coll.get_paths()) >= 0.0


@pytest.mark.parametrize("rel", ["results/paper_noise", "results/robustness_map", "results/eiv/oracle",
                                 "results/eiv/detector", "results/eiv/bbrf_plain_oracle"])
def test_every_figure_of_a_committed_summary(committed_figs, rel):
    out, figs = committed_figs[rel]
    stems = sorted({stem for _, stem, _ in figs})
    assert any(s.startswith("error_vs_sigma") for s in stems)
    if rel == "results/robustness_map":
        assert "misclassification_map_impact-msd_rls_paper" in stems and "detector_comparison" in stems
    check_files(out, stems)
    for fig, stem, caption in figs:
        check_figure(fig)
        assert abs(fig.get_size_inches()[0] - style.WIDTHS["single"]) < 1e-9
        assert "clipped at 0" in caption or stem.startswith(("misclassification_map", "detector_comparison"))


def test_double_width_svg(committed, captured, tmp_path):
    render(["error-vs-sigma", committed["results/paper_noise"], "--format", "svg", "--width", "double",
            "--out", str(tmp_path)])
    fig, stem, _ = captured.figs[0]
    assert abs(fig.get_size_inches()[0] - 7.16) < 1e-9
    assert len(data_axes(fig)) == 3 and len({ax.get_position().y0 for ax in data_axes(fig)}) == 1  # one row
    with open(tmp_path / f"{stem}.svg") as f:
        assert "<svg" in f.read(2000)


def test_error_vs_sigma_axes_and_legend_order(committed_figs):
    figs = [f for f in committed_figs["results/robustness_map"][1] if f[1].startswith("error_vs_sigma")]
    assert len(figs) == 5  # one per dt (each saved as PDF and PNG)
    for fig, stem, _ in figs:
        panels = data_axes(fig)
        assert [ax.get_xscale() for ax in panels] == ["symlog"] * 3  # sigma 0, 0.01 ... 0.5
        assert all(ax.get_yscale() in ("log", "symlog") for ax in panels)
        assert legend_texts(fig) == ["paper r = 5", "paper r = 20", "paper r = 50", "paper r = 220",
                                     "paper r = 500", "paper r = 1000", "residual p = 1e-08", "residual p = 1e-06"]
        assert [t.get_text() for t in panels[-1].get_xticklabels()] == ["0", "0.01", "0.02", "0.05", "0.1",
                                                                         "0.25", "0.5"]
        assert [ax.get_xlabel() for ax in panels] == ["", "", r"noise $\sigma$"]  # one column, shared σ


def test_committed_summary_intervals_stay_in_the_metrics_range():
    # Every committed summary.csv: the interval of a non-negative metric (every metric of the summary:
    # rates, counts, errors, distances) is never below 0, a rate's never above 1, and each contains its
    # mean. The paired differences (*_diff_ci95_*) can be negative and are not checked.
    rates = ("misclassification", "precision", "recall", "flow_outside_share")
    checked = 0
    for rel in ["results/paper_noise", "results/robustness_map", "results/eiv/oracle", "results/eiv/detector",
                "results/eiv/bbrf_plain_oracle", "results/efficiency", "results/paper"]:
        rows = list(csv.DictReader(open(os.path.join(ROOT, rel, "summary.csv"))))
        for r in rows:
            for col, lo in r.items():
                if not col.endswith("_ci95_lo") or "_diff_" in col or lo == "":
                    continue
                metric = col[:-len("_ci95_lo")]
                lo, hi, mean = float(lo), float(r[f"{metric}_ci95_hi"]), float(r[f"{metric}_mean"])
                assert lo >= 0.0, (rel, r["cell"], col, lo)
                assert lo <= mean * (1 + 1e-12) and mean <= hi * (1 + 1e-12), (rel, r["cell"], metric)
                if metric in rates:
                    assert hi <= 1.0, (rel, r["cell"], metric, hi)
                checked += 1
    assert checked > 1000


def test_summary_intervals_are_drawn_as_written(committed):
    run = data.Run(committed["results/robustness_map"])
    iv = stats.Intervals(run)
    assert not iv.bootstrapped
    assert "Wilson" in iv.method() and "bootstrap" in iv.method()
    for r in run.summary.rows:
        for m in ("misclassification", "e_alpha", "e_beta", "fp", "fn"):
            est, lo, hi, n = iv.of(r, m)
            assert (lo, hi) == run.summary.interval(r, m)
            assert not lo < 0.0
            assert n == 100


def test_small_sweep_every_kind_pdf_png(small_run, captured, tmp_path):
    run_dir = str(tmp_path / "run")
    shutil.copytree(small_run, run_dir)
    out = str(tmp_path / "fig")
    render(["all", run_dir, "--format", "pdf,png", "--width", "single", "--dpi", "60", "--out", out])
    stems = sorted({stem for _, stem, _ in captured.figs})
    assert stems == ["detector_comparison", "error_vs_sigma_impact-msd_dt0.001", "error_vs_sigma_impact-msd_dt0.002",
                     "misclassification_map_impact-msd_rls_paper", "relative_error_impact-msd_dt0.001",
                     "relative_error_impact-msd_dt0.002"]
    check_files(out, stems)
    for fig, stem, caption in captured.figs:
        check_figure(fig)
        if not stem.startswith(("misclassification_map", "detector")):
            assert "percentile bootstrap" in caption and "n = 5 trials" in caption
    assert os.path.exists(os.path.join(run_dir, "detector_comparison.md"))


def test_small_sweep_plotted_means_equal_the_summary(small_run, captured, tmp_path):
    render(["error-vs-sigma", small_run, "--out", str(tmp_path)])
    rows = list(csv.DictReader(open(os.path.join(small_run, "summary.csv"))))
    for fig, stem, _ in captured.figs:
        dt = stem.rsplit("_dt", 1)[1]
        assert legend_texts(fig) == ["paper r = 20", "paper r = 100", "residual p = 1e-08"]
        for ax, metric in zip(data_axes(fig), ["e_alpha", "e_beta", "misclassification"]):
            for ln, label in zip(ax.get_lines(), legend_texts(fig)):
                det, _, _, val = label.split(" ")
                for x, y in zip(ln.get_xdata(), ln.get_ydata()):
                    hit = [r for r in rows if r["dt"] == dt and float(r["sigma"]) == x and r["detector"] == det and
                           (r["r"] if det == "paper" else r["false_alarm"]) == val]
                    assert len(hit) == 1
                    assert y == pytest.approx(float(hit[0][f"{metric}_mean"]), rel=1e-12, abs=1e-300)


def test_relative_error_is_computed_from_trials_and_run_json(small_run, captured, tmp_path):
    render(["relative-error", small_run, "--out", str(tmp_path)])
    trials = list(csv.DictReader(open(os.path.join(small_run, "trials.csv"))))
    fig, stem, caption = captured.figs[0]
    assert stem == "relative_error_impact-msd_dt0.001"
    panels = data_axes(fig)
    assert [ax.get_title() for ax in panels] == ["$a$ = 5", "$b$ = 0.1", r"$\lambda$ = 0.99", r"$\mu$ = 0"]
    assert "(mu) shows the absolute error" in caption
    truth = {"alpha_hat_a": 5.0, "beta_hat_mu": 0.0}
    for ax, col in [(panels[0], "alpha_hat_a"), (panels[3], "beta_hat_mu")]:
        ln = ax.get_lines()[0]  # paper r = 20
        for x, y in zip(ln.get_xdata(), ln.get_ydata()):
            v = [abs(float(t[col]) - truth[col]) / (abs(truth[col]) or 1.0) for t in trials
                 if t["dt"] == "0.001" and float(t["sigma"]) == x and t["detector"] == "paper" and t["r"] == "20"]
            assert len(v) == 5 and y == pytest.approx(sum(v) / 5, rel=1e-12)


def test_relative_error_without_trials_names_what_is_missing(committed, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(["relative-error", committed["results/paper_noise"]])
    assert "no trials.csv: per-parameter errors need the per-trial table" in str(e.value)


def with_crlb(src, dst):
    """src's summary with crlb_e_alpha = 9.12e-4 σ and crlb_e_beta = 8.80e-3 σ (the §5 system's values)."""
    os.makedirs(dst)
    shutil.copy(os.path.join(src, "run.json"), dst)
    rows = list(csv.reader(open(os.path.join(src, "summary.csv"))))
    si = rows[0].index("sigma")
    with open(os.path.join(dst, "summary.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(rows[0] + ["crlb_e_alpha", "crlb_e_beta"])
        for r in rows[1:]:
            w.writerow(r + [repr(9.12e-4 * float(r[si])), repr(8.80e-3 * float(r[si]))])
    return dst


def test_crlb_line_and_efficiency(committed, captured, tmp_path):
    run_dir = with_crlb(committed["results/paper_noise"], str(tmp_path / "run"))
    render(["error-vs-sigma", run_dir, "--out", str(tmp_path / "f"), "--format", "pdf"])
    fig, _, caption = captured.figs[0]
    crlb = [ln for ln in data_axes(fig)[0].get_lines() if ln.get_label() == "CRLB-implied"]
    assert len(crlb) == 1 and "CRLB-implied" in caption
    np.testing.assert_allclose(crlb[0].get_ydata(), 9.12e-4 * np.asarray(crlb[0].get_xdata()))
    assert "CRLB-implied" in legend_texts(fig)
    # The bound's caption says what it leaves out; every sweep figure says its cells share noise draws.
    assert "leaves out the information the jump times carry" in caption
    assert "Common random numbers" in caption and "not independent" in caption
    titles = [a.get_legend().get_title().get_text() for a in fig.axes if a.get_legend() is not None]
    assert titles == [f"{sweep_figs.CRN_MARK}\n{sweep_figs.BOUND_MARK}"]
    render(["efficiency", run_dir, "--out", str(tmp_path / "f"), "--format", "pdf,png"])
    fig, stem, caption = captured.figs[-1]
    assert "leaves out the information the jump times carry" in caption
    assert "*_diff_* columns once the sweep file sets [summary] baseline" not in caption  # paper_noise has one
    assert stem == "efficiency_impact-msd_dt0.0005"
    rows = data.Summary(os.path.join(run_dir, "summary.csv")).rows
    ax = data_axes(fig)[0]
    ln = ax.get_lines()[0]  # rls, paper r = 220
    for x, y in zip(ln.get_xdata(), ln.get_ydata()):
        hit = [r for r in rows if r["sigma"] == x and r["estimator"] == "rls" and r["detector"] == "paper"]
        assert x > 0 and y == pytest.approx(hit[0]["e_alpha_mean"] / hit[0]["crlb_e_alpha"], rel=1e-12)
    assert ax.get_yscale() == "log" and ax.get_xscale() == "log"  # σ = 0 has no bound: left out


def test_efficiency_without_crlb_is_a_clear_error(committed):
    with pytest.raises(SystemExit) as e:
        cli.main(["efficiency", committed["results/paper_noise"]])
    assert "no CRLB column (crlb_e_alpha, crlb_e_beta)" in str(e.value)


def test_misclassification_map_cells_equal_the_summary(committed, committed_figs):
    fig, stem, caption = [f for f in committed_figs["results/robustness_map"][1]
                          if f[1].startswith("misclassification_map")][0]
    assert "white = 0" in caption
    run = data.Run(committed["results/robustness_map"])
    rows = [r for r in run.summary.rows if r["detector"] == "paper"]
    sigmas, dts, rs = (sorted({r[k] for r in rows}) for k in ("sigma", "dt", "r"))
    images = [ax.images[0] for ax in fig.axes if ax.images]
    assert len(images) == len(sigmas) == 7
    for img, sg in zip(images, sigmas):
        arr = np.ma.filled(img.get_array(), np.nan)
        for r in rows:
            if r["sigma"] == sg:
                v = arr[dts.index(r["dt"]), rs.index(r["r"])]
                want = r["misclassification_mean"]
                assert (want == 0 and math.isnan(v)) or v == want
        assert img.norm.vmin > 0 and isinstance(img.norm, maps.matplotlib.colors.LogNorm)


def test_paper_figures(paper_run, captured, tmp_path):
    render(["paper", paper_run, "--format", "pdf,png", "--width", "single", "--dpi", "60", "--out", str(tmp_path)])
    stems = [s for _, s, _ in captured.figs[:5]]
    assert stems == ["fig4", "fig5", "fig6", "fig7", "fig8"]
    check_files(str(tmp_path), stems, n=False)
    for fig, stem, _ in captured.figs:
        check_figure(fig)
        for ax in data_axes(fig):
            assert ax.get_legend() is None  # legends sit in their own row, off the data
        if stem in ("fig5", "fig7"):
            assert data_axes(fig)[0].get_yscale() == "log"
            assert "detected jump" in legend_texts(fig)


def test_series_order_is_numeric():
    class S:
        keys = ["sigma", "r", "estimator", "detector"]

        def values(self, k):
            return {"r": [5.0, 20.0, 220.0, 1000.0], "estimator": ["rls"], "detector": ["paper"]}[k]
    rows = [{"sigma": 0.1, "r": r, "estimator": "rls", "detector": "paper", "false_alarm": math.nan}
            for r in (1000.0, 20.0, 220.0, 5.0)]
    assert [s.label for s in series.series(S(), rows)] == ["paper r = 5", "paper r = 20", "paper r = 220",
                                                          "paper r = 1000"]


def test_same_data_same_bytes(committed, tmp_path):
    for d in ("a", "b"):
        render(["error-vs-sigma", committed["results/paper_noise"], "--format", "pdf,svg,png", "--dpi", "60",
                "--out", str(tmp_path / d)])
    for name in sorted(os.listdir(tmp_path / "a")):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name


def example6(path, xi0=1e-2, dt=0.5, t_end=12.0):
    """Example 6 in closed form: ξ(t) = 2 atan(exp(t − ln cot(ξ0/2))), D = |ξ(t) − ξ(t − δt)|/δt and
    τ = (1/δt)∫ ξ ds over [t − δt, t] (k = 1; Simpson's rule on 64 intervals), with made-up τ̂ columns
    in non-numeric order."""
    def xi(t):
        return 2 * np.arctan(np.exp(t - np.log(1 / np.tan(xi0 / 2))))
    t = np.arange(dt, t_end + dt / 2, dt)
    s = np.linspace(0, 1, 65)
    w = np.array([1] + [4 if i % 2 else 2 for i in range(1, 64)] + [1]) / (3 * 64)
    tau = np.array([np.sum(w * xi(tk - dt + s * dt)) for tk in t])
    rows = np.column_stack([t, xi(t), np.abs(xi(t) - xi(t - dt)) / dt, tau, 20 * tau, 5 * tau])
    np.savetxt(path, rows, delimiter=",", header="t,xi,D,tau,tau_hat_r20,tau_hat_r5", comments="")
    return rows


def test_fig2_example6(captured, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    rows = example6(run / "fig2_smoothness.csv")
    assert np.all(rows[:, 2] <= rows[:, 3])  # Proposition 5: D <= tau, the data drawn are right
    render(["paper", str(run), "--format", "pdf", "--out", str(tmp_path / "f")])
    assert [s for _, s, _ in captured.figs] == ["fig2"]  # no fig4_*.csv: Fig. 2 only
    fig, stem, caption = captured.figs[0]
    assert "Example 6" in caption
    check_figure(fig)
    panels = data_axes(fig)
    np.testing.assert_array_equal(panels[0].get_lines()[0].get_ydata(), rows[:, 1])
    assert legend_texts(fig) == [r"$D_{\delta t}\xi$ (Euler derivative)", r"$\tau$ (smoothness bound)",
                                 r"$\hat\tau$, r = 5", r"$\hat\tau$, r = 20"]
    np.testing.assert_array_equal(panels[1].get_lines()[2].get_ydata(), rows[:, 5])


def test_median_points_are_medians_of_the_trials(small_run, captured, tmp_path):
    render(["error-vs-sigma", small_run, "--stat", "median", "--format", "pdf", "--out", str(tmp_path)])
    fig, stem, caption = captured.figs[0]
    assert stem.endswith("dt0.001") and caption.startswith("impact-msd") and "Points: median" in caption
    trials = list(csv.DictReader(open(os.path.join(small_run, "trials.csv"))))
    ln = data_axes(fig)[0].get_lines()[0]  # e_alpha, paper r = 20
    for x, y in zip(ln.get_xdata(), ln.get_ydata()):
        v = [float(t["e_alpha"]) for t in trials
             if t["dt"] == "0.001" and float(t["sigma"]) == x and t["detector"] == "paper" and t["r"] == "20"]
        assert len(v) == 5 and y == np.median(v)


def test_fig2_from_reproduce_example6(example6_run, captured, tmp_path):
    render(["paper", example6_run, "--format", "pdf,png", "--dpi", "60", "--width", "single", "--out",
            str(tmp_path)])
    check_files(str(tmp_path), ["fig2"], n=False)
    fig, _, _ = captured.figs[0]
    check_figure(fig)
    assert legend_texts(fig)[2:] == [r"$\hat\tau$, r = 1", r"$\hat\tau$, r = 2", r"$\hat\tau$, r = 5"]
    bottom = data_axes(fig)[1]
    d, tau = bottom.get_lines()[0].get_ydata(), bottom.get_lines()[1].get_ydata()
    assert np.all(d <= tau)  # Proposition 5 in what is drawn


def test_heat_map_cell_labels_are_at_least_8_pt(committed_figs):
    for rel in ("results/robustness_map", "results/paper_noise"):
        for fig, stem, _ in committed_figs[rel][1]:
            if not stem.startswith(("misclassification_map", "detector_comparison")):
                continue
            assert abs(fig.get_size_inches()[0] - style.WIDTHS["single"]) < 1e-9
            for ax in fig.axes:
                for t in ax.texts:
                    assert t.get_fontsize() >= 8, (stem, t.get_text(), t.get_fontsize())


def with_failures(src, dst, gone, partial):
    """src's summary with the cells of `gone` (cell numbers) failed in every trial (their metrics empty)
    and those of `partial` ({cell: failed trials}) with that many failures."""
    os.makedirs(dst)
    shutil.copy(os.path.join(src, "run.json"), dst)
    rows = list(csv.reader(open(os.path.join(src, "summary.csv"))))
    h = rows[0]
    fi, ti, ci = h.index("failures"), h.index("trials"), h.index("cell")
    with open(os.path.join(dst, "summary.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(h)
        for r in rows[1:]:
            cell = int(r[ci])
            if cell in gone:
                r = r[:fi] + [r[ti]] + [""] * (len(r) - fi - 1)
            elif cell in partial:
                r[fi] = str(partial[cell])
            w.writerow(r)
    return dst


def test_failed_cells_are_drawn_and_counted(committed, captured, tmp_path):
    # paper_noise: cell 41 (σ = 1, frisch, residual) fails in all 100 trials, cell 40 (σ = 1, frisch, paper)
    # in 7; the all-failed cell is an × at the foot of every panel at its σ, the other's count beside its point.
    src = committed["results/paper_noise"]
    rows = {int(r["cell"]): r for r in csv.DictReader(open(os.path.join(src, "summary.csv")))}
    assert (rows[41]["sigma"], rows[41]["estimator"], rows[41]["detector"]) == ("1", "frisch", "residual")
    assert (rows[40]["sigma"], rows[40]["estimator"], rows[40]["detector"]) == ("1", "frisch", "paper")
    run_dir = with_failures(src, str(tmp_path / "run"), {41}, {40: 7})
    render(["error-vs-sigma", run_dir, "--out", str(tmp_path / "f"), "--format", "pdf"])
    fig, stem, caption = captured.figs[0]
    assert sweep_figs.FAILED_NOTE in caption and sweep_figs.FAILED_LABEL in legend_texts(fig)
    labels = legend_texts(fig)
    for ax, metric in zip(data_axes(fig), ["e_alpha", "e_beta", "misclassification"]):
        failed = [ln for ln in ax.get_lines() if ln.get_gid() == "failed"]
        assert len(failed) == 1 and list(failed[0].get_xdata()) == [1.0]
        counts = [t for t in ax.texts if t.get_gid() == "failures"]  # annotations are texts too
        assert sorted(t.get_text() for t in counts) == ["100", "7"]
        # The 7 sits at the partly failed cell's point: σ = 1 and its mean (the summary's, trials.csv absent).
        (seven,) = [t for t in counts if t.get_text() == "7"]
        assert seven.xy == (1.0, pytest.approx(float(rows[40][f"{metric}_mean"]), rel=1e-12))
        line = ax.get_lines()[labels.index("frisch, paper r = 220")]
        assert 1.0 in list(line.get_xdata())
        gone = ax.get_lines()[labels.index("frisch, residual p = 1e-08")]
        assert 1.0 not in list(gone.get_xdata())  # no point: every trial failed
    assert ax.get_xlim()[1] > 1.0  # the failed σ is on the axis


def test_failed_cells_of_a_map_are_grey_not_white(committed, captured, tmp_path):
    src = committed["results/robustness_map"]
    rows = {int(r["cell"]): r for r in csv.DictReader(open(os.path.join(src, "summary.csv")))}
    (cell,) = [c for c, r in rows.items() if (r["sigma"], r["dt"], r["r"], r["detector"]) == ("0.1", "0.001", "50",
                                                                                          "paper")]
    run_dir = with_failures(src, str(tmp_path / "run"), {cell}, {})
    render(["misclassification-map", run_dir, "--out", str(tmp_path / "f"), "--format", "pdf", "--width", "double"])
    fig, stem, caption = captured.figs[0]
    assert "Grey, hatched: a cell every trial of which failed (1 cells)" in caption
    sigmas = sorted({float(r["sigma"]) for r in rows.values()})
    panels = [ax for ax in fig.axes if ax.images]
    dts = sorted({float(r["dt"]) for r in rows.values()})
    rs = sorted({float(r["r"]) for r in rows.values() if r["r"]})
    for ax, sg in zip(panels, sigmas):
        patches = [p for p in ax.patches if p.get_gid() == "failed"]
        if sg != 0.1:
            assert not patches
            continue
        (p,) = patches
        assert (p.get_x() + 0.5, p.get_y() + 0.5) == (rs.index(50.0), dts.index(0.001))
        assert [t.get_text() for t in ax.texts if t.get_gid() == "failures"] == ["100×"]


def test_coverage_figure_draws_the_summarys_shares_and_wilson_intervals(tmp_path, captured):
    # The committed efficiency study: per unknown parameter, the share of refined trials whose 95 %
    # interval covers the truth, with the summary's Wilson interval as its band; no point for refine = none.
    from conftest import committed_copy
    run_dir = committed_copy(str(tmp_path), "results/efficiency")
    render(["coverage", run_dir, "--format", "pdf", "--out", str(tmp_path / "f")])
    (fig, stem, caption), = captured.figs
    assert stem == "coverage_impact-msd_dt0.0005" and "Wilson score interval" in caption
    rows = list(csv.DictReader(open(os.path.join(run_dir, "summary.csv"))))
    labels = legend_texts(fig)
    assert labels[-1] == "nominal 0.95" and all("ml" in label for label in labels[:-1])
    for ax, name in zip(data_axes(fig), ["a", "b", "lambda", "mu"]):
        for ln, label in zip(ax.get_lines(), labels[:-1]):
            est = label.split(",")[0]
            mine = sorted((float(r["sigma"]), r) for r in rows if r["estimator"] == est and r["refine"] == "ml")
            np.testing.assert_array_equal(ln.get_xdata(), [s for s, _ in mine])
            np.testing.assert_array_equal(ln.get_ydata(), [float(r[f"cover_{name}_mean"]) for _, r in mine])
        # The bands' vertices hold each cell's Wilson bounds.
        drawn = np.concatenate([p.vertices[:, 1] for c in ax.collections if isinstance(c, PolyCollection)
                                for p in c.get_paths()])
        for _, r in mine:
            for end in ("lo", "hi"):
                assert np.min(np.abs(drawn - float(r[f"cover_{name}_ci95_{end}"]))) < 1e-12
        assert [ln.get_ydata()[0] for ln in ax.get_lines() if ln.get_label() == "nominal 0.95"] == [0.95]


def test_efficiency_divides_by_the_bound_of_the_samples_used(tmp_path, captured):
    from conftest import committed_copy
    run_dir = committed_copy(str(tmp_path), "results/efficiency")
    render(["efficiency", run_dir, "--format", "pdf", "--out", str(tmp_path / "f")])
    (fig, stem, caption), = captured.figs
    assert "over the samples its estimates used" in caption
    rows = data.Summary(os.path.join(run_dir, "summary.csv")).rows
    labels = [label for label in legend_texts(fig) if "refine = " in label]
    assert len(labels) == 6
    for ax, metric in zip(data_axes(fig), ["e_alpha", "e_beta"]):
        for ln, label in zip(ax.get_lines(), labels):
            est, refine = label.split(", ")[0], label.split("refine = ")[1]
            for x, y in zip(ln.get_xdata(), ln.get_ydata()):
                (r,) = [r for r in rows if r["sigma"] == x and r["estimator"] == est and r["refine"] == refine]
                assert y == pytest.approx(r[f"{metric}_mean"] / r[f"crlb_fit_{metric}"], rel=1e-12)


def test_efficiency_of_a_cut_record_uses_the_bound_of_the_fitted_samples(tmp_path, captured):
    # 27 of the drag ball's 100 fits leave out its last bounces (the fit on the detected labels over
    # 680 of 751 samples): the mean bound of the samples fit exceeds the whole record's by 6 % for e_β.
    from conftest import committed_copy
    run_dir = committed_copy(str(tmp_path), "results/drag-ball")
    render(["efficiency", run_dir, "--format", "pdf", "--out", str(tmp_path / "f")])
    (fig, stem, caption), = captured.figs
    (r,) = data.Summary(os.path.join(run_dir, "summary.csv")).rows
    assert r["crlb_fit_e_beta"] > 1.05 * r["crlb_e_beta"]
    for ax, metric in zip(data_axes(fig), ["e_alpha", "e_beta"]):
        y = ax.get_lines()[0].get_ydata()
        assert list(y) == [pytest.approx(r[f"{metric}_mean"] / r[f"crlb_fit_{metric}"], rel=1e-12)]

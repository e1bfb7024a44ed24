"""The fit figure (hysid_plots fit): what it draws equals the report's and the trace's values; a
synthetic identification (a parabola with one jump, residuals, the fitted model and a hidden state in
the trace) and a real `hysid identify` run (fixture analysis.identify_run)."""
import csv
import json
import math
import os

import numpy as np
import pytest
from scipy import stats as sps

from hysid_plots import cli, fit

from conftest import env_dir


def gid_lines(ax, gid):
    return [ln for ln in ax.get_lines() if ln.get_gid() == gid]


def synthetic(tmp_path, with_fit=True):
    """Two runs of a ball's height h and velocity v (60 samples each, a jump in run 1 at t = 0.5), its
    report and trace (the fitted model's output and residuals when `with_fit`)."""
    rng = np.random.default_rng(3)
    t = np.arange(60) * 0.02
    rows, trace = [], []
    for run in (1, 2):
        h = 1.0 + 0.1 * run - 4.9 * t ** 2 + np.where(t >= 0.5, 1.2, 0.0)
        v = -9.8 * t
        y = np.column_stack([h, v]) + rng.normal(0, [0.01, 0.1], (60, 2))
        for k in range(60):
            rows.append([run, t[k], y[k, 0], y[k, 1]])
            tr = {"run": run, "chain": run, "line": len(rows) + 1, "t": t[k], "missing": 0, "z": abs(y[k, 0] - h[k]),
                  "q": 5.0, "gamma": int(run == 1 and k == 25)}
            if with_fit:
                tr.update({"fit_h": h[k], "fit_v": v[k], "fit_w": 2.0 * t[k], "sd_h": 0.001, "sd_v": 0.002,
                           "sd_w": 0.01 * (1 + t[k]), "residual_h": y[k, 0] - h[k], "residual_v": y[k, 1] - v[k],
                           "recursive_h": h[k] + 0.05, "recursive_v": v[k], "recursive_w": 2.1 * t[k],
                           "in_fit": int(k < 50)})
            trace.append(tr)
    with open(tmp_path / "data.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["# a comment line, skipped"])
        w.writerow(["run", "t", "height", "velocity"])
        w.writerows(rows)
    with open(tmp_path / "id.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(trace[0]))
        w.writeheader()
        w.writerows(trace)
    report = {"model": "ball", "data": {"path": "data.csv", "state_columns": ["height", "velocity"]},
              "measured": ["h", "v"],
              "detections": [{"sample": 25, "run": 1, "chain": 1, "line": 28, "t": 0.5}],
              "fitted_events": {"jumps": [{"t": 0.4963, "se": 0.004, "chain": 1, "in_fit": True}],
                                "modes": [{"first_sample": 0, "t": 0.0, "mode": "up"},
                                          {"first_sample": 25, "t": 0.5, "mode": "down"},
                                          {"first_sample": 60, "t": 0.0, "mode": "up"}],
                                "reason": ""},
              "checks": {"lag1": {"value": 0.03, "test_size": 0.005}},
              "status": "ok", "reason": "", "names": ["g", "x0[h]"], "estimate": [9.79, 1.1],
              "standard_errors": [0.02, 0.01], "sigma": [0.01, 0.1, 0.0], "lag1": 0.03}
    with open(tmp_path / "id.json", "w") as f:
        json.dump(report, f)
    return np.array(rows), trace


def test_fit_figure_draws_the_trace_and_report(tmp_path, captured):
    rows, trace = synthetic(tmp_path)
    assert cli.main(["fit", str(tmp_path / "id.json"), "--format", "pdf,png", "--dpi", "60",
                     "--out", str(tmp_path / "f")]) == 0
    assert [s for _, s, _ in captured.figs] == ["id_fit_run1", "id_fit_run2"]
    for fig, stem, caption in captured.figs:
        run = int(stem[-1])
        mine = rows[:, 0] == run
        tr = [r for r in trace if r["run"] == run]
        col = {k: np.array([r[k] for r in tr], dtype=float) for k in tr[0]}
        used = col["in_fit"] == 1
        axes = [ax for ax in fig.axes if ax.axison]
        # Panels: h, v, the hidden w, the detector, residuals; then the autocorrelation and the quantiles.
        assert [ax.get_ylabel() for ax in axes] == ["h", "v", "w (hidden)", r"max $|z|$, $q$", "residual / σ",
                                                   "autocorrelation", "residual / σ, sorted"]
        for i, name in enumerate(["h", "v", "w"]):
            (model,) = gid_lines(axes[i], "fit")
            np.testing.assert_array_equal(model.get_xdata(), col["t"])
            np.testing.assert_array_equal(model.get_ydata(), col[f"fit_{name}"])
            (band,) = [c for c in axes[i].collections if c.get_gid() == "fit_band"]
            ys = band.get_paths()[0].vertices[:, 1]
            for edge in (col[f"fit_{name}"] - 1.96 * col[f"sd_{name}"], col[f"fit_{name}"] + 1.96 * col[f"sd_{name}"]):
                assert np.all(np.isclose(edge[:, None], ys[None, :], rtol=0, atol=1e-12).any(axis=1))
            rec = gid_lines(axes[i], "recursive")
            if name == "v":  # equal to the fit: not drawn
                assert not rec
            else:
                np.testing.assert_array_equal(rec[0].get_ydata(), col[f"recursive_{name}"])
            fitted = gid_lines(axes[i], "fitted_events")
            spans = [p for p in axes[i].patches if p.get_gid() == "fitted_event_se"]
            det = gid_lines(axes[i], "detections")
            if run == 1:
                assert list(det[0].get_xdata())[::3] == [0.5]
                assert [ln.get_xdata()[0] for ln in fitted] == [0.4963]
                xs = spans[0].get_xy()[:, 0]
                assert xs.min() == pytest.approx(0.4963 - 0.004) and xs.max() == pytest.approx(0.4963 + 0.004)
            else:
                assert not det and not fitted and not spans
        for i, name in enumerate(["h", "v"]):
            (meas,) = gid_lines(axes[i], "measured")
            np.testing.assert_array_equal(meas.get_xdata(), rows[mine, 1])
            np.testing.assert_array_equal(meas.get_ydata(), rows[mine, 2 + i])
            sigma = [0.01, 0.1][i]
            r = col[f"residual_{name}"] / sigma
            (res,) = gid_lines(axes[4], f"residual_{name}")
            np.testing.assert_allclose(res.get_ydata(), np.where(used, r, np.nan), rtol=1e-15)
            (out,) = gid_lines(axes[4], f"residual_unfitted_{name}")
            np.testing.assert_allclose(out.get_ydata(), np.where(used, np.nan, r), rtol=1e-15)
            # The autocorrelation over the fitted samples of both runs as the refinement pools them
            # (pairs within a chain), and its test's band.
            (acf,) = gid_lines(axes[5], f"acf_{name}")
            per_run = [np.array([tr[f"residual_{name}"] / sigma for tr in trace if tr["run"] == q and tr["in_fit"]])
                       for q in (1, 2)]
            den = sum(np.sum(u * u) for u in per_run)
            want = [sum(np.sum(u[k:] * u[:-k]) for u in per_run) / den for k in range(1, 21)]
            np.testing.assert_allclose(acf.get_ydata(), want, rtol=1e-12)
        (band,) = [p for p in axes[5].patches if p.get_gid() == "acf_band"]
        ys = band.get_xy()[:, 1]
        half = sps.norm.isf(0.005 / 4) / math.sqrt(100)
        assert ys.min() == pytest.approx(-half) and ys.max() == pytest.approx(half)
        (stat,) = gid_lines(axes[3], "statistic")
        np.testing.assert_array_equal(stat.get_ydata(), np.where(col["z"] > 0, col["z"], np.nan))
        (qq,) = gid_lines(axes[6], "qq")
        pooled = np.sort([x for tr in trace if tr["in_fit"] for x in (tr["residual_h"] / 0.01, tr["residual_v"] / 0.1)])
        np.testing.assert_allclose(qq.get_ydata(), pooled, rtol=1e-15)
        ribbon = [(p.get_x(), p.get_x() + p.get_width(), p.get_label()) for p in axes[0].patches
                  if p.get_gid() == "mode"]
        if run == 1:
            assert ribbon == [(0.0, 0.5, "up"), (0.5, pytest.approx(59 * 0.02), "down")]
            assert "the fitted mode sequence" in caption
        else:
            assert ribbon == [(0.0, pytest.approx(59 * 0.02), "up")]
        assert "g = 9.79 ± 0.02" in caption and "lag-1 test" in caption and "hidden w" in caption
        assert os.path.exists(tmp_path / "f" / f"{stem}.pdf") and os.path.exists(tmp_path / "f" / f"{stem}.png")


def test_plot_fit_from_a_result_dict_draws_the_same_arrays(tmp_path):
    rows, trace = synthetic(tmp_path)
    report = json.load(open(tmp_path / "id.json"))
    arrays = {k: np.array([r[k] for r in trace], dtype=float) for k in trace[0]}
    arrays["measured"] = rows[:, 2:4]
    fig = fit.plot_fit({"report": report, "fit_trace": arrays}, runs=[2])
    axes = [ax for ax in fig.axes if ax.axison]
    (model,) = gid_lines(axes[0], "fit")
    np.testing.assert_array_equal(model.get_ydata(), arrays["fit_h"][arrays["run"] == 2])
    (meas,) = gid_lines(axes[1], "measured")
    np.testing.assert_array_equal(meas.get_ydata(), rows[rows[:, 0] == 2, 3])
    paths = fit.plot_fit({"report": report, "fit_trace": arrays}, out_dir=str(tmp_path / "py"), formats=["png"])
    assert [os.path.basename(p) for p in paths] == ["identify_fit_run1.png", "identify_fit_run2.png"]


def test_autocorrelation_of_an_ar1_series():
    # r_k = 0.6 r_{k-1} + e_k: lag-l autocorrelation 0.6^l (to sampling error at N = 200 000).
    rng = np.random.default_rng(1)
    e = rng.normal(size=200_000)
    r = np.empty_like(e)
    r[0] = e[0]
    for k in range(1, e.size):
        r[k] = 0.6 * r[k - 1] + e[k]
    np.testing.assert_allclose(fit.autocorrelation(r, 3), [0.6, 0.36, 0.216], atol=0.01)


def test_without_the_fitted_model_the_caption_names_the_missing_columns(tmp_path, captured):
    synthetic(tmp_path, with_fit=False)
    assert cli.main(["fit", str(tmp_path / "id"), "--runs", "2", "--format", "pdf", "--out", str(tmp_path / "f")]) == 0
    (fig, stem, caption), = captured.figs
    assert stem == "id_fit_run2"
    assert "The trace has no fit_h, residual_h, fit_v, residual_v" in caption
    assert [ax.get_ylabel() for ax in fig.axes if ax.axison] == ["h", "v", r"max $|z|$, $q$"]


def test_fit_errors_name_the_file(tmp_path):
    synthetic(tmp_path)
    with pytest.raises(SystemExit) as e:
        cli.main(["fit", str(tmp_path / "id"), "--runs", "7"])
    assert "--runs 7: not a run of" in str(e.value)
    os.remove(tmp_path / "data.csv")
    with pytest.raises(SystemExit) as e:
        cli.main(["fit", str(tmp_path / "id")])
    assert "data.csv: the report's data file is not found" in str(e.value)


def test_fit_of_a_real_identification(captured, tmp_path):
    run = env_dir("HYSID_IDENTIFY_RUN")
    assert cli.main(["fit", os.path.join(run, "id"), "--format", "png", "--dpi", "60", "--out", str(tmp_path)]) == 0
    (fig, stem, caption), = captured.figs
    report = json.load(open(os.path.join(run, "id.json")))
    data = np.genfromtxt(os.path.join(run, "data.csv"), delimiter=",", names=True)
    trace = np.genfromtxt(os.path.join(run, "id.csv"), delimiter=",", names=True)
    axes = [ax for ax in fig.axes if ax.axison]
    jumps = [j["t"] for j in report["fitted_events"]["jumps"]]
    assert len(jumps) == 4 and report["fitted_events"]["reason"] == ""
    for i, name in enumerate(report["data"]["state_columns"]):
        (meas,) = gid_lines(axes[i], "measured")
        np.testing.assert_array_equal(meas.get_ydata(), data[name])
        (model,) = gid_lines(axes[i], "fit")
        np.testing.assert_array_equal(model.get_ydata(), trace[f"fit_{name}"])
        det = gid_lines(axes[i], "detections")
        assert list(det[0].get_xdata())[::3] == [d["t"] for d in report["detections"]]
        assert [ln.get_xdata()[0] for ln in gid_lines(axes[i], "fitted_events")] == jumps
        # The fitted model follows the data: the drawn residual is the trace's, y − fit away from the jumps,
        # and within 5 σ everywhere.
        sigma = report["sigma"][i]
        (res,) = gid_lines(axes[3], f"residual_{name}")
        np.testing.assert_allclose(res.get_ydata(), trace[f"residual_{name}"] / sigma, rtol=1e-12)
        plain = (data[name] - trace[f"fit_{name}"]) / sigma
        assert np.mean(np.isclose(res.get_ydata(), plain, rtol=0, atol=1e-3)) > 0.99  # two integrations
        assert np.nanmax(np.abs(res.get_ydata())) < 5
    assert f"Refinement: {report['status']}" in caption


def test_fit_of_an_automaton_draws_its_fitted_events_and_modes(captured, tmp_path):
    """examples/heater as scripts/example-figures.sh runs it: the fitted model's switches with their
    standard errors and its mode sequence are the report's fitted_events, the band the trace's sd_T."""
    run = env_dir("HYSID_HEATER_RUN")
    assert cli.main(["fit", os.path.join(run, "id"), "--format", "png", "--dpi", "60", "--out", str(tmp_path)]) == 0
    (fig, stem, caption), = captured.figs
    report = json.load(open(os.path.join(run, "id.json")))
    trace = np.genfromtxt(os.path.join(run, "id.csv"), delimiter=",", names=True)
    fe = report["fitted_events"]
    assert report["status"] == "ok" and fe["reason"] == "" and len(fe["jumps"]) == 11
    axes = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_ylabel() for ax in axes] == ["T", "residual / σ", "autocorrelation", "residual / σ, sorted"]
    ax = axes[0]
    assert [ln.get_xdata()[0] for ln in gid_lines(ax, "fitted_events")] == [j["t"] for j in fe["jumps"]]
    spans = [p.get_xy()[:, 0] for p in ax.patches if p.get_gid() == "fitted_event_se"]
    np.testing.assert_allclose([x.max() - x.min() for x in spans], [2 * j["se"] for j in fe["jumps"]], rtol=1e-9)
    ribbon = [(p.get_x(), p.get_label()) for p in ax.patches if p.get_gid() == "mode"]
    assert ribbon == [(m["t"], m["mode"]) for m in fe["modes"]]
    (band,) = [c for c in ax.collections if c.get_gid() == "fit_band"]
    ys = band.get_paths()[0].vertices[:, 1]
    upper = trace["fit_T"] + 1.96 * trace["sd_T"]
    assert np.all(np.isclose(upper[:, None], ys[None, :], rtol=0, atol=1e-12).any(axis=1))
    assert "the fitted mode sequence" in caption

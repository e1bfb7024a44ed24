"""The fit figure (hysid_plots fit): what it draws equals the report's and the trace's values; a
synthetic identification (a parabola with one jump, residuals and the fitted model in the trace) and a
real `hysid identify` run (fixture analysis.identify_run)."""
import csv
import json
import math
import os

import numpy as np
import pytest

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
                tr.update({"fit_h": h[k], "fit_v": v[k], "residual_h": y[k, 0] - h[k], "residual_v": y[k, 1] - v[k]})
            trace.append(tr)
    with open(tmp_path / "data.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["# a comment line, skipped"])
        w.writerow(["run", "t", "h", "v"])
        w.writerows(rows)
    with open(tmp_path / "id.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(trace[0]))
        w.writeheader()
        w.writerows(trace)
    report = {"model": "ball", "data": {"path": "data.csv", "state_columns": ["h", "v"]},
              "detections": [{"sample": 25, "run": 1, "chain": 1, "line": 28, "t": 0.5}],
              "automaton": {"events": [{"sample": 25, "t": 0.5, "time_fitted": 0.4963, "time_fitted_se": 0.004}],
                            "modes": []},
              "status": "ok", "reason": "", "names": ["g", "x0[h]"], "estimate": [9.79, 1.1],
              "standard_errors": [0.02, 0.01], "sigma": [0.01, 0.1], "lag1": 0.03}
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
        axes = [ax for ax in fig.axes if ax.axison]
        # Panels: h, v, the detector, residuals; then the autocorrelation and the normal quantiles.
        assert [ax.get_ylabel() for ax in axes] == ["h", "v", r"max $|z|$, $q$", "residual / σ", "autocorrelation",
                                                   "residual / σ, sorted"]
        for i, name in enumerate(["h", "v"]):
            (meas,) = gid_lines(axes[i], "measured")
            np.testing.assert_array_equal(meas.get_xdata(), rows[mine, 1])
            np.testing.assert_array_equal(meas.get_ydata(), rows[mine, 2 + i])
            (model,) = gid_lines(axes[i], "fit")
            np.testing.assert_array_equal(model.get_ydata(), [tr[f"fit_{name}"] for tr in trace if tr["run"] == run])
            (res,) = gid_lines(axes[3], f"residual_{name}")
            sigma = [0.01, 0.1][i]
            np.testing.assert_allclose(res.get_ydata(), [tr[f"residual_{name}"] / sigma for tr in trace
                                                         if tr["run"] == run], rtol=1e-15)
            det = gid_lines(axes[i], "detections")
            fitted = gid_lines(axes[i], "fitted_events")
            if run == 1:
                assert list(det[0].get_xdata())[::3] == [0.5]
                assert [ln.get_xdata()[0] for ln in fitted] == [0.4963]
            else:
                assert not det and not fitted
            # The autocorrelation as the refinement pools it, and the band of white noise.
            r = np.array([tr[f"residual_{name}"] / sigma for tr in trace if tr["run"] == run])
            (acf,) = gid_lines(axes[4], f"acf_{name}")
            want = [np.sum(r[k:] * r[:-k]) / np.sum(r * r) for k in range(1, 21)]
            np.testing.assert_allclose(acf.get_ydata(), want, rtol=1e-12)
            (band,) = [p for p in axes[4].patches if p.get_gid() == "acf_band"]
            ys = band.get_xy()[:, 1]
            assert ys.min() == pytest.approx(-1.96 / math.sqrt(60)) and ys.max() == pytest.approx(1.96 / math.sqrt(60))
        (stat,) = gid_lines(axes[2], "statistic")
        np.testing.assert_array_equal(stat.get_ydata(), [tr["z"] if tr["z"] > 0 else np.nan for tr in trace
                                                         if tr["run"] == run])
        (qq,) = gid_lines(axes[5], "qq")
        pooled = np.sort(np.concatenate([[tr["residual_h"] / 0.01, tr["residual_v"] / 0.1] for tr in trace
                                         if tr["run"] == run]))
        np.testing.assert_allclose(qq.get_ydata(), pooled, rtol=1e-15)
        assert "g = 9.79 ± 0.02" in caption and "±1.96/√N" in caption
        assert os.path.exists(tmp_path / "f" / f"{stem}.pdf") and os.path.exists(tmp_path / "f" / f"{stem}.png")


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
    axes = [ax for ax in fig.axes if ax.axison]
    for i, name in enumerate(report["data"]["state_columns"]):
        (meas,) = gid_lines(axes[i], "measured")
        np.testing.assert_array_equal(meas.get_ydata(), data[name])
        det = gid_lines(axes[i], "detections")
        assert list(det[0].get_xdata())[::3] == [d["t"] for d in report["detections"]]
    assert f"Refinement: {report['status']}" in caption

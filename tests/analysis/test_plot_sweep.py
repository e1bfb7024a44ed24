"""analysis/plot_sweep.py: the values it plots are the values of summary.csv.

Run by CTest with pytest (Debian's python3-pytest); HYSID_SWEEP_RUN names a run directory of
tests/data/sweep_small.toml made by the fixture test sweep.small.
"""
import csv
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "analysis"))
import plot_sweep  # noqa: E402

RUN = os.environ.get("HYSID_SWEEP_RUN", "")


def summary_rows():
    with open(os.path.join(RUN, "summary.csv"), newline="") as f:
        return list(csv.DictReader(f))


def mean_of(rows, metric, **keys):
    hits = [r for r in rows if all(r[k] == v for k, v in keys.items())]
    assert len(hits) == 1, keys
    v = hits[0][metric + "_mean"]
    return float(v) if v else math.nan


@pytest.fixture(scope="module")
def rows():
    if not RUN:
        pytest.skip("HYSID_SWEEP_RUN not set")
    return summary_rows()


def test_error_vs_sigma_lines_equal_summary(rows):
    groups = plot_sweep.error_vs_sigma(plot_sweep.read_summary(RUN))
    assert set(groups) == {("impact-msd", 0.001), ("impact-msd", 0.002)}
    for (model, dt), lines in groups.items():
        fig = plot_sweep.plot_error_vs_sigma(lines, "t")
        dt_text = {0.001: "0.001", 0.002: "0.002"}[dt]
        for ax, (metric, _) in zip(fig.axes, plot_sweep.ERROR_PANELS):
            plotted = {ln.get_label(): ln for ln in ax.get_lines()}
            assert len(plotted) == 3  # paper r=20, paper r=220, residual
            for label, ln in plotted.items():
                det = "residual" if "residual" in label else "paper"
                r = "" if det == "residual" else label.split("r=")[1].split(",")[0]
                for x, y in zip(ln.get_xdata(), ln.get_ydata()):
                    want = mean_of(rows, metric, dt=dt_text, sigma=f"{x:g}", detector=det, r=r)
                    assert (math.isnan(want) and math.isnan(y)) or y == want
        plot_sweep.plt.close(fig)


def test_misclassification_map_equals_summary(rows):
    maps = plot_sweep.misclassification_maps(plot_sweep.read_summary(RUN))
    assert set(maps) == {("impact-msd", "rls", "paper")}
    per_sigma = maps[("impact-msd", "rls", "paper")]
    assert sorted(per_sigma) == [0.0, 0.05, 0.2]
    fig = plot_sweep.plot_misclassification_map(per_sigma, "t")
    images = [ax.images[0] for ax in fig.axes if ax.images]
    assert len(images) == 3
    for img, sigma in zip(images, sorted(per_sigma)):
        dts, rvals, _ = per_sigma[sigma]
        arr = np.asarray(img.get_array())
        for i, dt in enumerate(dts):
            for j, r in enumerate(rvals):
                want = mean_of(rows, "misclassification", dt=f"{dt:g}", sigma=f"{sigma:g}",
                               detector="paper", r=f"{r:g}")
                assert arr[i, j] == want
    plot_sweep.plt.close(fig)


def test_plot_run_writes_every_figure(tmp_path):
    if not RUN:
        pytest.skip("HYSID_SWEEP_RUN not set")
    written = plot_sweep.plot_run(RUN, str(tmp_path))
    names = sorted(os.path.basename(p) for p in written)
    assert names == ["error_vs_sigma_impact-msd_dt0.001.png", "error_vs_sigma_impact-msd_dt0.002.png",
                     "misclassification_map_impact-msd_rls_paper.png"]
    for p in written:
        assert os.path.getsize(p) > 1000

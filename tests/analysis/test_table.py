"""Tables: the numbers of summary.csv / trials.csv in md, LaTeX and CSV, intervals never below 0."""
import csv
import io
import os

import numpy as np
import pytest

from hysid_plots import data, stats, table


def test_csv_table_equals_the_bootstrap_of_trials(small_run):
    run = data.Run(small_run)
    rows = list(csv.DictReader(io.StringIO(table.render(run, "csv"))))
    assert len(rows) == 18 and list(rows[0])[:3] == ["detector", "dt", "sigma"]
    trials = list(csv.DictReader(open(os.path.join(small_run, "trials.csv"))))
    for r in rows:
        for m in ("e_alpha", "e_beta", "misclassification"):
            est, lo, hi = (float(r[f"{m}_{s}"]) for s in ("mean", "lo", "hi"))
            assert 0.0 <= lo <= est <= hi
        det, _, _, val = r["detector"].split(" ")
        v = [float(t["e_alpha"]) for t in trials if t["dt"] == r["dt"] and t["sigma"] == r["sigma"] and
             t["detector"] == det and (t["r"] if det == "paper" else t["false_alarm"]) == val]
        assert len(v) == 5 == int(r["n"])
        d = stats.digits_for(np.mean(v), float(r["e_alpha_lo"]), float(r["e_alpha_hi"]))
        assert r["e_alpha_mean"] == stats.sig(float(np.mean(v)), d)


@pytest.mark.parametrize("fmt", ["md", "latex"])
def test_text_tables(committed, fmt):
    text = table.render(data.Run(committed["results/paper_noise"]), fmt)
    lines = text.strip().splitlines()
    body = [ln for ln in lines if "rls" in ln]
    assert len(body) == 14  # 7 σ x 2 detectors
    assert "normal-approximation 95 % interval" in text and "clipped at 0" in text
    if fmt == "latex":
        assert lines[1].startswith(r"\begin{tabular}{") and lines[-1] == r"\end{tabular}"
        assert all(ln.endswith(r"\\") for ln in body)
    else:
        assert lines[0].startswith("| detector | estimator | σ | e_α | e_β | misclassification | n |")
    assert " [-" not in text  # no interval bound below 0


def test_unknown_metric(committed):
    with pytest.raises(data.DataError, match="no column 'speed_mean'"):
        table.render(data.Run(committed["results/paper_noise"]), "md", ["speed"])

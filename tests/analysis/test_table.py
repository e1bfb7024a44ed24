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
    assert "Wilson score interval" in text and "percentile bootstrap" in text
    assert "Common random numbers" in text and "*_diff_mean" in text  # paper_noise has a baseline
    if fmt == "latex":
        assert lines[1].startswith(r"\begin{tabular}{") and lines[-1] == r"\end{tabular}"
        assert all(ln.endswith(r"\\") for ln in body)
    else:
        assert lines[0].startswith("| detector | estimator | σ | e_α | e_β | misclassification | n |")
    assert " [-" not in text  # no interval bound below 0


def test_unknown_metric(committed):
    with pytest.raises(data.DataError, match="no column 'speed_mean'"):
        table.render(data.Run(committed["results/paper_noise"]), "md", ["speed"])


def test_generated_grid_values_are_labelled_to_the_digits_that_separate_them(committed, tmp_path):
    # σ = 0.5 replaced by 10**-0.5 (a value of a { from, to, count, log = true } range): the table shows
    # 0.32, not 0.316228; the values as written stay as they are.
    src = committed["results/paper_noise"]
    rows = list(csv.reader(open(os.path.join(src, "summary.csv"))))
    si = rows[0].index("sigma")
    for r in rows[1:]:
        if r[si] == "0.5":
            r[si] = repr(10 ** -0.5)
    os.makedirs(tmp_path / "run")
    with open(tmp_path / "run" / "summary.csv", "w", newline="") as f:
        csv.writer(f).writerows(rows)
    text = table.render(data.Run(str(tmp_path / "run")), "md")
    sigmas = {ln.split(" | ")[2] for ln in text.splitlines() if ln.startswith("| paper") and " | rls | " in ln}
    assert sigmas == {"0", "0.05", "0.1", "0.25", "0.32", "0.75", "1"}
    assert "0.316" not in text

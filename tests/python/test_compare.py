"""hysid.compare against `hysid compare --json`: the same ranking and numbers from the same call."""
import json
import os
import subprocess

import numpy as np
import pytest

import hysid

SOURCE = os.environ.get("HYSID_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("HYSID_BIN", "hysid")
FILES = [os.path.join(SOURCE, "tests", "compare", f"thermostat-{m}.toml") for m in (1, 2)]


def test_compare_matches_the_command_line(tmp_path):
    run = hysid.simulate(hysid.Model(FILES[1]), sigma=0.05, seed=3)
    data = tmp_path / "data.csv"
    np.savetxt(data, np.column_stack([run["t"], run["y"][:, 0]]), delimiter=",", header="t,T", comments="",
               fmt="%.17g")
    py = hysid.compare(FILES, data=str(data), holdout=0)
    report = tmp_path / "compare.json"
    subprocess.run([BIN, "compare", *FILES, "--data", str(data), "--holdout", "0", "--json", str(report)],
                   check=True, capture_output=True)
    cli = json.loads(report.read_text())
    assert py["best"] == cli["best"] and py["best"]["bic"] == FILES[1]
    for a, b in zip(py["models"], cli["models"]):
        assert a["status"] == b["status"] and a["k"] == b["k"] and a["ranked"] == b["ranked"]
        for key in ("loglik", "aic", "bic"):
            assert a[key] == pytest.approx(b[key], rel=1e-12)


def test_compare_refuses_one_model():
    with pytest.raises(ValueError, match="at least 2 candidate model files"):
        hysid.compare(FILES[:1], data="none.csv")
    with pytest.raises(ValueError, match="holdout = 2"):
        hysid.compare(FILES, data="none.csv", holdout=2)


def without_data(report):
    """The report less its `data` key (file paths against run names)."""
    return {k: v for k, v in report.items() if k != "data"}


def test_compare_from_arrays_equals_from_files(tmp_path):
    """The same samples as arrays (y, t; two runs) and as CSV files: the same report, number for number."""
    runs = [hysid.simulate(hysid.Model(FILES[1]), sigma=0.05, seed=s, t_end=300.0) for s in (4, 5)]
    paths = []
    for i, run in enumerate(runs):
        paths.append(str(tmp_path / f"run{i}.csv"))
        np.savetxt(paths[-1], np.column_stack([run["t"], run["y"][:, 0]]), delimiter=",", header="t,T", comments="",
                   fmt="%.17g")
    from_files = hysid.compare(FILES, data=paths, holdout=0.2)
    from_arrays = hysid.compare(FILES, y=[r["y"][:, :1] for r in runs], t=[r["t"] for r in runs], holdout=0.2)
    assert from_arrays["data"] == ["run 1", "run 2"] and from_files["data"] == paths
    assert without_data(from_arrays) == without_data(from_files)
    assert from_arrays["best"]["bic"] == FILES[1] and from_arrays["models"][1]["chains"] == 2


def test_compare_from_one_array_with_dt(tmp_path):
    """One run as a (samples, 1) array at spacing dt: the ranking and criteria of its CSV file."""
    run = hysid.simulate(hysid.Model(FILES[1]), sigma=0.05, seed=6, t_end=300.0)
    data = tmp_path / "data.csv"
    np.savetxt(data, np.column_stack([run["t"], run["y"][:, 0]]), delimiter=",", header="t,T", comments="",
               fmt="%.17g")
    from_file = hysid.compare(FILES, data=str(data), holdout=0)
    from_array = hysid.compare(FILES, y=run["y"][:, :1], dt=1.0, holdout=0)
    assert from_array["best"] == from_file["best"]
    for a, b in zip(from_array["models"], from_file["models"]):
        assert a["status"] == b["status"] and a["k"] == b["k"] and a["ranked"] == b["ranked"]
        for key in ("loglik", "aic", "bic"):
            assert a[key] == pytest.approx(b[key], rel=1e-9)


def test_compare_refuses_bad_array_input(tmp_path):
    y = np.zeros((50, 1)) + 20.0
    with pytest.raises(ValueError, match="give the data files .data=. or the samples .y=."):
        hysid.compare(FILES, data="none.csv", y=y, dt=1.0)
    with pytest.raises(ValueError, match="dt: required when t is not given"):
        hysid.compare(FILES, y=y)
    with pytest.raises(ValueError, match=r"must be a \(samples, 1\) array"):
        hysid.compare(FILES, y=np.zeros((50, 2)), dt=1.0)
    with pytest.raises(ValueError, match="holdout_by = 'chains': must be tail or chain"):
        hysid.compare(FILES, y=y, dt=1.0, holdout_by="chains")
    with pytest.raises(ValueError, match="holdout_by='chain': the data .* are 1 chain"):
        hysid.compare(FILES, y=y, dt=1.0, holdout_by="chain")

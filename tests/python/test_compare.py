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

"""Shared fixtures of the analysis tests (ctest runs each item, label plots, with Debian's python3-pytest).

HYSID_SWEEP_RUN: a run directory of tests/data/sweep_small.toml (fixture test sweep.small);
HYSID_PAPER_RUN: the output of `hysid reproduce paper` (fixture test analysis.paper_run);
HYSID_EXAMPLE6_RUN: the output of `hysid reproduce example6` (fixture test analysis.example6_run);
HYSID_IDENTIFY_RUN: data.csv of `hysid simulate` and its `hysid identify` report id.json and trace id.csv
(fixture test analysis.identify_run).
The committed results/* are copied without their trials.csv, as a fresh checkout has them.
"""
import os
import shutil
import sys

import matplotlib
import pytest

matplotlib.use("Agg")
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "analysis"))

from hysid_plots import style  # noqa: E402

SWEEP_RUNS = ["results/paper_noise", "results/robustness_map", "results/eiv/oracle", "results/eiv/detector",
              "results/eiv/bbrf_plain_oracle"]


def env_dir(name):
    d = os.environ.get(name, "")
    if not d:
        pytest.skip(f"{name} not set (run through ctest)")
    return d


@pytest.fixture(scope="session")
def small_run():
    return env_dir("HYSID_SWEEP_RUN")


@pytest.fixture(scope="session")
def paper_run():
    return env_dir("HYSID_PAPER_RUN")


@pytest.fixture(scope="session")
def example6_run():
    return env_dir("HYSID_EXAMPLE6_RUN")


def committed_copy(tmp, rel):
    """results/<rel> as committed: summary.csv and run.json only."""
    dst = os.path.join(tmp, rel.replace("/", "_"))
    os.makedirs(dst, exist_ok=True)
    for f in ("summary.csv", "run.json"):
        if os.path.exists(os.path.join(ROOT, rel, f)):
            shutil.copy(os.path.join(ROOT, rel, f), dst)
    return dst


@pytest.fixture(scope="session")
def committed(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("committed"))
    return {rel: committed_copy(tmp, rel) for rel in SWEEP_RUNS}


class Captured:
    """While active, the figures style.save is given (figure, stem, caption), for checks after saving."""

    def __init__(self):
        self.figs = []
        self.original = style.save

    def __enter__(self):
        def save(fig, out_dir, stem, formats, caption):
            self.figs.append((fig, stem, caption))
            return self.original(fig, out_dir, stem, formats, caption)
        style.save = save
        return self

    def __exit__(self, *exc):
        style.save = self.original


@pytest.fixture
def captured():
    with Captured() as cap:
        yield cap


@pytest.fixture(scope="session")
def committed_figs(committed, tmp_path_factory):
    """{rel: (output directory, [(figure, stem, caption)])}: `all` of each committed summary, single
    width, PDF and PNG (PNG at 60 dpi: the pixels are not what is checked)."""
    from hysid_plots import cli
    out = {}
    for rel, run_dir in committed.items():
        d = str(tmp_path_factory.mktemp("figs"))
        with Captured() as cap:
            assert cli.main(["all", run_dir, "--format", "pdf,png", "--width", "single", "--dpi", "60",
                             "--out", d]) == 0
        out[rel] = (d, cap.figs)
    return out

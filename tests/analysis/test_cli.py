"""The command line: errors name the file or flag and the constraint; a missing matplotlib says what to do."""
import os
import subprocess
import sys

import pytest

from conftest import ROOT
from hysid_plots import cli

PKG = os.path.join(ROOT, "analysis", "hysid_plots")


def run(*args, code="pass"):
    """Runs the package as a directory (as the README does) in a fresh interpreter."""
    prog = (f"import runpy, sys; {code}; sys.argv = ['hysid_plots'] + {list(args)!r}; "
            f"runpy.run_path({PKG!r}, run_name='__main__')")
    return subprocess.run([sys.executable, "-c", prog], capture_output=True, text=True,
                          env=dict(os.environ, MPLBACKEND="Agg"))


def test_missing_matplotlib_names_the_fix():
    p = run("error-vs-sigma", "results/paper_noise", code="sys.modules['matplotlib'] = None")
    assert p.returncode != 0
    assert "has no module 'matplotlib': run with /usr/bin/python3 or install python3-matplotlib" in p.stderr


def test_table_needs_no_matplotlib(committed):
    p = run("table", committed["results/paper_noise"], code="sys.modules['matplotlib'] = None")
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("| detector | estimator | σ | e_α | e_β | misclassification | n |")


@pytest.mark.parametrize("argv,message", [
    (["error-vs-sigma", "no-such-dir"], "no-such-dir/summary.csv: no such file"),
    (["error-vs-sigma", "x", "--format", "jpg"], "'jpg': must be pdf, svg, png"),
    (["relative-error", "x", "--truth", "a=five"], "'a=five': expected NAME=VALUE with a number"),
    (["table", "x", "--format", "html"], "invalid choice: 'html'"),
])
def test_bad_arguments(argv, message, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert message in str(e.value) + capsys.readouterr().err


def test_bad_summary_cell_names_file_line_and_column(tmp_path):
    (tmp_path / "summary.csv").write_text("cell,sigma,estimator,trials,e_alpha_mean\n0,0.1,rls,5,1e-3\n"
                                          "1,0.2,rls,5,abc\n")
    with pytest.raises(SystemExit) as e:
        cli.main(["error-vs-sigma", str(tmp_path)])
    assert "summary.csv:3: column 'e_alpha_mean': 'abc' is not a number" in str(e.value)


@pytest.mark.parametrize("kind", [[], ["error-vs-sigma"], ["table"], ["paper"], ["all"]])
def test_help(kind):
    p = run(*kind, "--help")
    assert p.returncode == 0 and p.stdout.startswith("usage: hysid_plots"), p.stderr

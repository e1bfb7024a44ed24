"""The hysid Python module against the command line (HYSID_BIN) and against itself."""
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import hysid

BIN = os.environ.get("HYSID_BIN", "hysid")
SOURCE = Path(os.environ.get("HYSID_SOURCE_DIR", Path(__file__).resolve().parents[2]))
MODELS = SOURCE / "models"


def cli(*args):
    return subprocess.run([BIN, *map(str, args)], check=True, capture_output=True, text=True).stdout


@pytest.fixture(scope="module")
def paper_data(tmp_path_factory):
    """The Sec. 5 run with sigma = 0.25, seed 3, written by `hysid simulate`."""
    out = tmp_path_factory.mktemp("paper") / "noisy.csv"
    cli("simulate", "--sigma", 0.25, "--seed", 3, "--out", out)
    return out


def test_models_by_name_and_file():
    assert hysid.models() == ["bouncing-ball", "impact-msd", "impact-pendulum"]
    m = hysid.Model("impact-msd")
    assert m.state_names == ["x", "v"]
    assert m.parameters["a"] == 5.0
    w = hysid.Model.from_file(MODELS / "wall-msd.toml")
    assert w.name == "wall-msd"
    assert "guard wall: h(xi) = x - 1 (rising)" in w.equations
    assert hysid.Model(str(MODELS / "wall-msd.toml")).set("k", 3.0).parameters["k"] == 3.0
    with pytest.raises(ValueError, match="neither a built-in model nor a model file"):
        hysid.Model("no-such-model")
    with pytest.raises(ValueError, match="is a known constant"):
        m.set("alpha_x", 2.0)


def test_bad_model_file_names_line_and_key(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text((MODELS / "wall-msd.toml").read_text().replace('[0, "-x", "-v"]', '[0, "-y", "-v"]'))
    with pytest.raises(ValueError, match=r'bad.toml:\d+: flow.phi\[1\]\[1\]: "-y": unknown symbol "y"'):
        hysid.Model.from_file(bad)


def test_simulate_equals_cli(paper_data):
    table = np.loadtxt(paper_data, delimiter=",", skiprows=1)
    traj = hysid.simulate("impact-msd", sigma=0.25, seed=3)
    assert traj["status"] == "completed"
    assert len(traj["jumps"]) == 14
    np.testing.assert_array_equal(traj["t"], table[:, 0])
    np.testing.assert_array_equal(traj["j"], table[:, 1])
    np.testing.assert_array_equal(traj["x"], table[:, 2:4])
    np.testing.assert_array_equal(traj["y"], table[:, 4:6])


def test_identify_equals_cli(paper_data, tmp_path):
    trace = tmp_path / "trace.csv"
    printed = cli("identify", "--data", paper_data, "--detector", "paper", "--refine", "none", "--trace", trace)
    expected = {k: float(v) for k, v in re.findall(r"(?:alpha|beta) +(\w+) += (\S+)", printed)}
    table = np.loadtxt(paper_data, delimiter=",", skiprows=1)
    fit = hysid.identify("impact-msd", table[:, 4:6], dt=5e-4, detector="paper", refine="none")
    assert "refined" not in fit
    assert set(fit["estimates"]) == set(expected) == {"a", "b", "lambda", "mu"}
    for name, value in expected.items():  # printed with 10 significant digits
        assert fit["estimates"][name] == pytest.approx(value, rel=1e-9, abs=1e-12)
    assert f"jumps detected: {fit['jumps_detected']} " in printed
    cols = np.genfromtxt(trace, delimiter=",", names=True)
    np.testing.assert_array_equal(fit["gamma"], cols["gamma"])
    np.testing.assert_array_equal(fit["alpha_trace"][:, 1:], np.column_stack([cols["a_hat"], cols["b_hat"]]))
    np.testing.assert_array_equal(fit["beta_trace"][:, 1:], np.column_stack([cols["lambda_hat"], cols["mu_hat"]]))


def test_identify_defaults_are_the_cli_defaults(paper_data, tmp_path):
    """No tuning arguments: the residual detector and the refinement, as `hysid identify` with no flags
    (which reads the data accuracy, the solver's 1e-12, from the simulation's sidecar)."""
    import json
    out = tmp_path / "fit.json"
    subprocess.run([BIN, "identify", "--data", str(paper_data), "--json", str(out)], capture_output=True,
                   text=True)
    cli_fit = json.loads(out.read_text())
    y = np.loadtxt(paper_data, delimiter=",", skiprows=1)[:, 4:6]
    fit = hysid.identify("impact-msd", y, dt=5e-4, data_rtol=1e-12, data_atol=1e-12)
    assert fit["jumps_detected"] == cli_fit["detector"]["jumps_detected"] == 14
    assert fit["refined"]["status"] == cli_fit["status"] == "ok"
    np.testing.assert_allclose(list(fit["refined"]["estimates"].values()), cli_fit["estimate"], rtol=1e-12)
    np.testing.assert_allclose(list(fit["refined"]["standard_errors"].values()), cli_fit["standard_errors"],
                               rtol=1e-12)


def test_model_file_identifies_like_builtin(paper_data):
    y = np.loadtxt(paper_data, delimiter=",", skiprows=1)[:, 4:6]
    a = hysid.identify("impact-msd", y, dt=5e-4, estimator="gtls", refine="none")
    b = hysid.identify(hysid.Model.from_file(MODELS / "impact-msd.toml"), y, dt=5e-4, estimator="gtls",
                       refine="none")
    np.testing.assert_array_equal(a["alpha"], b["alpha"])
    np.testing.assert_array_equal(a["beta"], b["beta"])
    np.testing.assert_array_equal(a["gamma"], b["gamma"])


def test_identify_refuses_bad_input():
    with pytest.raises(ValueError, match=r"y must be a \(samples, 2\) array"):
        hysid.identify("impact-msd", np.zeros((10, 3)), dt=1e-3)
    with pytest.raises(ValueError, match="dt = -1"):
        hysid.identify("impact-msd", np.zeros((10, 2)), dt=-1.0)
    with pytest.raises(ValueError, match="unknown estimator"):
        hysid.identify("impact-msd", np.zeros((10, 2)), dt=1e-3, estimator="kalman")


def test_run_sweep_equals_cli(tmp_path):
    sweep = SOURCE / "tests" / "data" / "sweep_model_file.toml"
    out = hysid.run_sweep(sweep, out=str(tmp_path / "py"), threads=2)
    assert (out["trials"], out["failed"]) == (3, 0)
    cli("sweep", sweep, "--out", tmp_path / "cli", "--threads", 1, "--progress", "none")
    assert (tmp_path / "py" / "trials.csv").read_bytes() == (tmp_path / "cli" / "trials.csv").read_bytes()


def test_refinement_equals_cli(paper_data, tmp_path):
    """refine='ml' is `hysid identify --refine ml`: the same estimates and standard errors."""
    import json
    out = tmp_path / "fit.json"
    subprocess.run([BIN, "identify", "--data", str(paper_data), "--detector", "residual", "--refine", "ml",
                    "--json", str(out)], capture_output=True, text=True)
    cli_fit = json.loads(out.read_text())
    y = np.loadtxt(paper_data, delimiter=",", skiprows=1)[:, 4:6]
    fit = hysid.identify("impact-msd", y, dt=5e-4)["refined"]  # the defaults: residual detector, refine='ml'
    assert fit["status"] == cli_fit["status"]
    assert list(fit["estimates"]) == cli_fit["names"]
    np.testing.assert_allclose(list(fit["estimates"].values()), cli_fit["estimate"], rtol=1e-12)
    if cli_fit["standard_errors"]:
        np.testing.assert_allclose(list(fit["standard_errors"].values()), cli_fit["standard_errors"], rtol=1e-12)
    with pytest.raises(ValueError, match="refine = 'x'"):
        hysid.identify("impact-msd", y, dt=5e-4, refine="x")


def test_crlb_equals_cli():
    """hysid.crlb is `hysid crlb`: the same sd (printed to 6 digits); the bound scales with sigma."""
    printed = cli("crlb", "--model", "impact-msd", "--sigma", "0.5")
    expected = {k: float(v) for k, v in re.findall(r"^  (\S+) += \S+ +sd (\S+)$", printed, re.M)}
    bound = hysid.crlb("impact-msd", sigma=0.5)
    assert bound["status"] == "ok" and bound["jumps"] == 14
    assert list(bound["sd"]) == bound["names"] == list(expected)
    for name, sd in expected.items():
        assert bound["sd"][name] == pytest.approx(sd, rel=1e-5)
    np.testing.assert_allclose(np.sqrt(np.diag(bound["covariance"])), list(bound["sd"].values()), rtol=1e-12)
    doubled = hysid.crlb("impact-msd", sigma=1.0)
    assert doubled["mean_e_alpha"] == pytest.approx(2 * bound["mean_e_alpha"], rel=1e-9)
    known = hysid.crlb("impact-msd", sigma=0.5, x0_known=True)
    assert known["names"] == ["a", "b", "lambda", "mu"]
    with pytest.raises(ValueError, match="sigma = 0: must be > 0"):
        hysid.crlb("impact-msd", sigma=0.0)


def test_identify_times_on_the_grid_equal_dt():
    """t given as the grid's own times (exact: δt a power of two) is the dt path, bit for bit."""
    traj = hysid.simulate("impact-msd", t_end=5.0, dt=1.0 / 2048, sigma=0.05, seed=5)
    a = hysid.identify("impact-msd", traj["y"], dt=1.0 / 2048, refine="none")
    b = hysid.identify("impact-msd", traj["y"], t=traj["t"], refine="none")
    np.testing.assert_array_equal(a["alpha"], b["alpha"])
    np.testing.assert_array_equal(a["gamma"], b["gamma"])
    assert b["chains"] == 1


def test_identify_runs_with_missing_rows_equals_cli(tmp_path):
    """Two runs with NaN rows, refined: the estimates of `hysid identify --data a --data b` and within
    4 standard errors of the truth."""
    import json
    runs = []
    for r, x0 in enumerate([(20.0, 0.0), (12.0, 6.0)]):
        traj = hysid.simulate("impact-msd", x0=list(x0), t_end=10.0, sigma=0.02, seed=9, trial=r)
        y = traj["y"].copy()
        y[[500 + 3000 * r, 7000 + 1000 * r], r] = np.nan
        runs.append((traj["t"], y))
        with open(tmp_path / f"run{r}.csv", "w") as f:
            f.write("t,x,v\n")
            for t, (x, v) in zip(traj["t"], y):
                f.write(f"{t!r},{'' if np.isnan(x) else repr(x)},{'nan' if np.isnan(v) else repr(v)}\n")
    fit = hysid.identify("impact-msd", [y for _, y in runs], t=[t for t, _ in runs], detector="residual",
                         refine="ml")
    assert fit["chains"] == 2 and fit["missing_rows"] == 4  # a missing row keeps its chain
    refined = fit["refined"]
    assert refined["status"] == "ok", refined["reason"]
    truth = {"a": 5.0, "b": 0.1, "lambda": 0.99, "mu": 0.0}
    for name, value in truth.items():
        assert abs(refined["estimates"][name] - value) < 4 * refined["standard_errors"][name]
    out = tmp_path / "fit.json"
    subprocess.run([BIN, "identify", "--data", str(tmp_path / "run0.csv"), "--data", str(tmp_path / "run1.csv"),
                    "--json", str(out)], check=True, capture_output=True)
    cli_fit = json.loads(out.read_text())
    for name, value in zip(cli_fit["names"], cli_fit["estimate"]):
        assert refined["estimates"][name] == pytest.approx(value, rel=1e-12)
    # Per chain: the samples fit add up to the total, and the module says the same as the command line.
    assert len(refined["chain_samples_used"]) == fit["chains"]
    assert sum(refined["chain_samples_used"]) == cli_fit["samples_used"]
    assert refined["chain_samples_used"] == cli_fit["chain_samples_used"]
    assert refined["chain_span_reason"] == cli_fit["chain_span_reason"]


def keyword(message):
    """A command-line message with each flag spelled as the Python keyword (--t-end as t_end)."""
    return re.sub(r"--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_"), message)


def cli_refusal(*args):
    """The message `hysid ARGS` refuses with (exit 2), without its "hysid: error: " prefix."""
    p = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    assert p.returncode == 2, p.stderr
    return p.stderr.strip().splitlines()[-1].removeprefix("hysid: error: ")


NAN, INF = float("nan"), float("inf")
# (command-line arguments, the same values as Python arguments) for each value the command line refuses.
SIMULATE_REFUSED = [
    (["--sigma", "nan"], {"sigma": NAN}), (["--sigma", "inf"], {"sigma": INF}), (["--sigma", "-1"], {"sigma": -1.0}),
    (["--sigma", "0.1,nan"], {"sigma": [0.1, NAN]}), (["--sigma", "1,2,3"], {"sigma": [1.0, 2.0, 3.0]}),
    (["--dt", "1e-320"], {"dt": 1e-320}), (["--dt", "0"], {"dt": 0.0}), (["--dt", "nan"], {"dt": NAN}),
    (["--t-end", "-1"], {"t_end": -1.0}), (["--dt", "1e-7"], {"dt": 1e-7}),
]
CRLB_REFUSED = [(["--sigma", "0"], {"sigma": 0.0}), (["--sigma", "nan"], {"sigma": NAN}),
                (["--dt", "1e-320"], {"dt": 1e-320})]
IDENTIFY_REFUSED = [
    (["--sigma", "nan"], {"sigma": NAN}), (["--sigma", "-1"], {"sigma": -1.0}),
    (["--forgetting", "2"], {"forgetting": 2.0}), (["--jump-forgetting", "0"], {"jump_forgetting": 0.0}),
    (["--detector", "paper", "--r", "1"], {"detector": "paper", "r": 1.0}),
    (["--detector", "paper", "--false-alarm", "1e-3"], {"detector": "paper", "false_alarm": 1e-3}),
    (["--tau0", "10"], {"tau0": 10.0}),
    (["--estimator", "kalman"], {"estimator": "kalman"}), (["--detector", "oracle"], {"detector": "oracle"}),
    (["--data-atol", "nan"], {"data_atol": NAN}), (["--data-rtol", "-1"], {"data_rtol": -1.0}),
]


@pytest.mark.parametrize("args,kwargs", SIMULATE_REFUSED)
def test_simulate_refuses_what_the_cli_refuses(tmp_path, args, kwargs):
    message = cli_refusal("simulate", *args, "--out", tmp_path / "t.csv")
    with pytest.raises(ValueError) as e:
        hysid.simulate("impact-msd", **kwargs)
    assert str(e.value) == keyword(message)


@pytest.mark.parametrize("args,kwargs", CRLB_REFUSED)
def test_crlb_refuses_what_the_cli_refuses(args, kwargs):
    message = cli_refusal("crlb", *args)
    with pytest.raises(ValueError) as e:
        hysid.crlb("impact-msd", **kwargs)
    assert str(e.value) == keyword(message)


@pytest.mark.parametrize("args,kwargs", IDENTIFY_REFUSED)
def test_identify_refuses_what_the_cli_refuses(paper_data, args, kwargs):
    message = cli_refusal("identify", *args, "--data", paper_data)
    y = np.loadtxt(paper_data, delimiter=",", skiprows=1)[:200, 4:6]
    with pytest.raises(ValueError) as e:
        hysid.identify("impact-msd", y, dt=5e-4, **kwargs)
    assert str(e.value) == keyword(message)


@pytest.mark.parametrize("rows", [0, 1, 2])
def test_identify_refuses_too_few_samples_as_the_cli(tmp_path, rows):
    """0, 1 or 2 samples: the CLI's message for a file of that many rows (never a crash)."""
    data = tmp_path / "few.csv"
    data.write_text("t,y1,y2\n" + "".join(f"{k * 1e-3},1,0\n" for k in range(rows)))
    message = cli_refusal("identify", "--data", data)
    assert message.startswith(f"{data}: {rows} samples")
    for refine in ("ml", "none"):
        with pytest.raises(ValueError) as e:
            hysid.identify("impact-msd", np.zeros((rows, 2)), dt=1e-3, refine=refine)
        assert str(e.value) == message.replace(str(data), "run 1")


def test_identify_refuses_steps_below_the_smallest(tmp_path):
    data = tmp_path / "tiny.csv"
    data.write_text("t,y1,y2\n" + "".join(f"{k * 1e-320},1,0\n" for k in range(5)))
    message = cli_refusal("identify", "--data", data)
    with pytest.raises(ValueError) as e:
        hysid.identify("impact-msd", np.ones((5, 2)), dt=1e-320)
    tail = r"column 1 \('t'\): the step \S+ after line {} is below 1e-150 s \(rescale the time\)$"
    assert re.search(tail.format(2), message) and re.search(tail.format(1), str(e.value))


def test_identify_refuses_a_state_column_below_the_smallest_scale(tmp_path):
    """Values below 1e-150 underflow in the regressions: refused by name, as the CLI does; 1e-100 is identified."""
    t = np.arange(50) * 1e-3
    y = np.column_stack([np.cos(t), -np.sin(t)])
    for scale, refused in ((1e-200, True), (1e-100, False)):
        data = tmp_path / f"scaled{scale:g}.csv"
        data.write_text("t,y1,y2\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(t, *(y * scale).T)))
        run = subprocess.run([BIN, "identify", "--refine", "none", "--data", data], capture_output=True, text=True)
        if not refused:
            assert run.returncode in (0, 1) and "below 1e-150" not in run.stderr
            hysid.identify("impact-msd", y * scale, dt=1e-3, refine="none")
            continue
        message = cli_refusal("identify", "--data", data)
        assert message == f"{data}: column 'y1': the largest |value| is 1e-200, below 1e-150 (rescale the data)"
        with pytest.raises(ValueError) as e:
            hysid.identify("impact-msd", y * scale, dt=1e-3)
        assert str(e.value) == message.replace(str(data), "run 1")


def test_identify_refuses_infinite_samples_as_the_cli(tmp_path):
    """An infinite state cell is refused (a NaN is a missing cell, left out), in a file and in an array."""
    data = tmp_path / "inf.csv"
    data.write_text("t,y1,y2\n0,1,2\n0.001,1,-inf\n0.002,1,2\n0.003,1,2\n")
    assert cli_refusal("identify", "--data", data) == f"{data}:3: column 3 ('y2'): '-inf' is not finite"
    y = np.ones((4, 2))
    y[1, 1] = -np.inf
    with pytest.raises(ValueError) as e:
        hysid.identify("impact-msd", y, dt=1e-3)
    assert str(e.value) == "run 1:2: column 3 ('y2'): '-inf' is not finite"


def test_seed_is_decimal(tmp_path):
    """--seed 010 is ten (CLI11 alone reads it as octal 8)."""
    for seed in ("010", "10", "8"):
        cli("simulate", "--sigma", 0.1, "--t-end", 1, "--seed", seed, "--out", tmp_path / f"s{seed}.csv")
    text = {s: (tmp_path / f"s{s}.csv").read_text() for s in ("010", "10", "8")}
    assert text["010"] == text["10"] != text["8"]


def test_jump_counters_of_several_files_join_without_a_step(paper_data, tmp_path):
    """Two files cut from one run, the second starting at j > 0: the true jumps are the run's own
    (no phantom jump at the boundary, whatever j the second file starts at)."""
    lines = paper_data.read_text().splitlines(True)
    j = [int(float(l.split(",")[1])) for l in lines[1:]]
    cut = next(k for k in range(len(j) // 3, len(j)) if j[k] == j[k - 1] > 0) + 1  # line index of row k
    (tmp_path / "a.csv").write_text("".join(lines[:cut]))
    (tmp_path / "b.csv").write_text(lines[0] + "".join(lines[cut:]))
    whole = re.search(r"truth \(column j\): (\d+) true jumps", cli("identify", "--data", paper_data, "--refine", "none"))
    parts = re.search(r"truth \(column j\): (\d+) true jumps",
                      cli("identify", "--data", tmp_path / "a.csv", "--data", tmp_path / "b.csv", "--refine", "none"))
    assert int(parts.group(1)) == int(whole.group(1)) == j[-1] - j[0]


def test_cr_line_endings_read_as_lf(paper_data, tmp_path):
    cr = tmp_path / "cr.csv"
    cr.write_bytes(paper_data.read_bytes().replace(b"\n", b"\r"))
    lf = tmp_path / "lf.csv"
    lf.write_bytes(paper_data.read_bytes())
    a = cli("identify", "--data", cr, "--refine", "none", "--data-rtol", 0, "--data-atol", 0)
    b = cli("identify", "--data", lf, "--refine", "none", "--data-rtol", 0, "--data-atol", 0)
    assert a.replace("cr.csv", "lf.csv") == b


def test_byte_order_mark_in_a_model_file(tmp_path):
    text = (MODELS / "impact-msd.toml").read_text(encoding="utf-8")
    bom = tmp_path / "bom.toml"
    bom.write_text("\ufeff" + text, encoding="utf-8")
    assert hysid.Model.from_file(bom).equations == hysid.Model.from_file(MODELS / "impact-msd.toml").equations


def test_hulls_above_their_dimension_limit_are_left_out_with_a_reason(paper_data, monkeypatch):
    y = np.loadtxt(paper_data, delimiter=",", skiprows=1)[:2000, 4:6]
    assert hysid.identify("impact-msd", y, dt=5e-4, refine="none")["flow_hull"].shape[0] > 0
    monkeypatch.setenv("HYSID_MAX_HULL_DIMENSION", "1")
    fit = hysid.identify("impact-msd", y, dt=5e-4, refine="none")
    assert fit["flow_hull"].shape[0] == fit["jump_hull"].shape[0] == 0
    assert fit["sets_skipped"] == ("2 states exceed the limit of 1 states for the exact hulls of C and D "
                                   "(raise it with HYSID_MAX_HULL_DIMENSION=N)")


def test_python_sample_limit(monkeypatch):
    monkeypatch.setenv("HYSID_MAX_SAMPLES", "100")
    with pytest.raises(ValueError, match="exceeds the limit of 100 samples per trajectory"):
        hysid.simulate("impact-msd", t_end=1.0, dt=1e-3)
    with pytest.raises(ValueError, match="exceeds the limit of 100 samples per trajectory"):
        hysid.identify("impact-msd", np.ones((101, 2)), dt=1e-3)


def test_a_signal_ends_a_long_unit_of_a_sweep(tmp_path):
    """SIGINT while one long unit runs: exit 130 long before the unit would end, the journal intact."""
    import signal
    import time
    sweep = tmp_path / "long.toml"
    sweep.write_text('[model]\nname = "impact-msd"\nt_end = 200.0\n[grid]\nsigma = 0.1\ndt = 5e-4\n'
                     'refine = ["ml"]\n[run]\ntrials = 1\n')  # a refinement over 400 001 samples: minutes
    out = tmp_path / "run"
    p = subprocess.Popen([BIN, "sweep", str(sweep), "--out", str(out), "--progress", "none", "--threads", "1"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    journal = out / "trials.journal"
    while not journal.exists() and p.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    assert p.poll() is None, "the unit ended before the signal: make it longer"
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=5)
    assert p.returncode == 130, err
    assert "run the same command again" in err
    assert journal.read_text().startswith("# hysid journal sweep=")


def test_second_pass_at_r_near_one_is_a_refinement_status(paper_data):
    """The paper detector at r ≈ 1 with --second-pass flags nearly every sample: the refinement has
    too few samples to fit, a status (exit 1), not an internal error reported as bad input."""
    p = subprocess.run([BIN, "identify", "--detector", "paper", "--r", "1.0001", "--second-pass", "--data",
                        str(paper_data)], capture_output=True, text=True)
    assert p.returncode == 1, p.stderr
    assert "refinement (maximum likelihood on the detected hybrid time domain): too-few-samples" in p.stdout
    assert "error" not in p.stderr


def test_ctrl_c_stops_run_sweep_between_units(tmp_path):
    """KeyboardInterrupt in run_sweep: the sweep stops after the running units, the journal keeps them."""
    import signal
    import sys
    import time
    sweep = tmp_path / "many.toml"
    sweep.write_text('[model]\nname = "impact-msd"\n[grid]\nsigma = 0.1\ndt = 5e-4\n[run]\ntrials = 5000\n')
    out = tmp_path / "run"
    code = f"import hysid\nhysid.run_sweep({str(sweep)!r}, out={str(out)!r}, threads=1)\n"
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    journal = out / "trials.journal"
    while p.poll() is None and (not journal.exists() or journal.read_text().count("\n") < 4):
        time.sleep(0.05)
    assert p.poll() is None, "the sweep ended before the signal: give it more trials"
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=10)
    assert p.returncode != 0 and "KeyboardInterrupt" in err
    rows = journal.read_text().splitlines()[2:]
    assert 2 <= len(rows) < 5000
    assert not (out / "trials.csv").exists()


def test_cli_reports_hulls_left_out_above_their_limit(paper_data):
    """Data with the truth (column j) and hulls beyond their limit: the report says so, exit 0."""
    p = subprocess.run([BIN, "identify", "--data", str(paper_data), "--refine", "none"], capture_output=True,
                       text=True, env={**os.environ, "HYSID_MAX_HULL_DIMENSION": "1"})
    assert p.returncode == 0, p.stderr
    assert "sets C^ and D^: not computed: 2 states exceed the limit of 1 states" in p.stdout
    assert "  sets: not computed\n" in p.stdout

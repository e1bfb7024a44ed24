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
    with pytest.raises(ValueError, match="is neither a registered model .* nor a model file"):
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
    with pytest.raises(ValueError, match=r"refine: x not in \{ml,none\}"):
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
    (["--x0", "-1,0"], {"x0": [-1.0, 0.0]}), (["--x0", "1,2,3"], {"x0": [1.0, 2.0, 3.0]}),
    (["--x0", "nan,0"], {"x0": [NAN, 0.0]}),
]
CRLB_REFUSED = [(["--sigma", "0"], {"sigma": 0.0}), (["--sigma", "nan"], {"sigma": NAN}),
                (["--dt", "1e-320"], {"dt": 1e-320}),
                (["--sigma", "1e-300"], {"sigma": 1e-300}), (["--sigma", "1e300"], {"sigma": 1e300}),
                (["--t-end", "1e-300"], {"t_end": 1e-300})]
IDENTIFY_REFUSED = [
    (["--sigma", "nan"], {"sigma": NAN}), (["--sigma", "-1"], {"sigma": -1.0}),
    (["--forgetting", "2"], {"forgetting": 2.0}), (["--jump-forgetting", "0"], {"jump_forgetting": 0.0}),
    (["--detector", "paper", "--r", "1"], {"detector": "paper", "r": 1.0}),
    (["--detector", "paper", "--false-alarm", "1e-3"], {"detector": "paper", "false_alarm": 1e-3}),
    (["--tau0", "10"], {"tau0": 10.0}),
    (["--estimator", "kalman"], {"estimator": "kalman"}), (["--detector", "oracle"], {"detector": "oracle"}),
    (["--data-atol", "nan"], {"data_atol": NAN}), (["--data-rtol", "-1"], {"data_rtol": -1.0}),
    (["--sigma", "0"], {"sigma": 0.0}), (["--sigma", "1e-300"], {"sigma": 1e-300}),
    (["--param-bound", "mu=-0.01,0.01", "--refine", "none"], {"param_bound": {"mu": (-0.01, 0.01)}, "refine": "none"}),
    (["--flow-noise-shape", "1,0,0,0,1,0,0,0,1"], {"flow_noise_shape": np.eye(3)}),
    (["--estimator", "integral", "--jump-noise-shape", "1,0,0,0,1,0,0,0,1"],
     {"estimator": "integral", "jump_noise_shape": np.eye(3)}),
]


@pytest.mark.parametrize("args,kwargs", SIMULATE_REFUSED)
def test_simulate_refuses_what_the_cli_refuses(tmp_path, args, kwargs):
    message = cli_refusal("simulate", *args, "--out", tmp_path / "t.csv")
    with pytest.raises(ValueError) as e:
        hysid.simulate("impact-msd", **kwargs)
    assert str(e.value) == keyword(message)


# A ball thrown sideways onto a floor, its position measured, its velocity not.
PARTLY_MEASURED = """name = "ball-2d"
states = ["x", "z", "vx", "vz"]
measured = ["x", "z"]
alpha = [{ name = "one", value = 1.0, known = true }, { name = "g", value = 9.81 }]
beta = [{ name = "one_b", value = 1.0, known = true }, { name = "e", value = 0.8 }]
[flow]
phi = [["vx", 0], ["vz", 0], [0, 0], [0, -1]]
rows = ["vz"]
[jump]
psi = [["x", 0], ["z", 0], ["vx", 0], [0, "-vz"]]
rows = ["vz"]
[[guard]]
h = "z"
direction = "falling"
project = { z = "0" }
[sets]
C = "z > 0 || (z == 0 && vz >= 0)"
D = "z == 0 && vz <= 0"
[defaults]
x0 = [0.0, 1.0, 1.0, 0.0]
t_end = 1.0
dt = 0.1
"""


def test_simulate_sigma_one_per_measured_state(tmp_path):
    model = tmp_path / "partly.toml"
    model.write_text(PARTLY_MEASURED)
    cli("simulate", "--model-file", model, "--sigma", "0.1,0.2,0,0", "--seed", 5, "--out", tmp_path / "all.csv")
    cli("simulate", "--model-file", model, "--sigma", "0.1,0.2", "--seed", 5, "--out", tmp_path / "measured.csv")
    # One per measured state: the same draws as one per state with the unmeasured state's sigma 0.
    assert (tmp_path / "measured.csv").read_bytes() == (tmp_path / "all.csv").read_bytes()
    table = np.loadtxt(tmp_path / "measured.csv", delimiter=",", skiprows=1)
    truth, noisy = table[:, 2:6], table[:, 6:10]
    assert np.all(noisy[:, :2] != truth[:, :2])
    np.testing.assert_array_equal(noisy[:, 2:], truth[:, 2:])
    traj = hysid.simulate(str(model), sigma=[0.1, 0.2], seed=5)
    np.testing.assert_array_equal(traj["y"], noisy)
    message = cli_refusal("simulate", "--model-file", model, "--sigma", "1,2,3", "--out", tmp_path / "t.csv")
    assert message == "--sigma has 3 values; give one, one per state (4) or one per measured state (2)"
    with pytest.raises(ValueError) as e:
        hysid.simulate(str(model), sigma=[1.0, 2.0, 3.0])
    assert str(e.value) == keyword(message)


def test_crlb_on_the_sample_times_of_a_data_file(tmp_path):
    def sd_lines(text):
        return [line for line in text.splitlines() if " sd " in line]

    grid = np.arange(1601) * 5e-3  # --t-end 8 --dt 5e-3
    every = tmp_path / "every.csv"
    np.savetxt(every, np.column_stack([grid, np.zeros_like(grid)]), delimiter=",", header="t,x", comments="")
    flags = ["crlb", "--t-end", 8, "--dt", 5e-3, "--sigma", 0.25]
    plain = cli(*flags)
    assert sd_lines(cli(*flags, "--times", every)) == sd_lines(plain)
    # Half the samples (the first 4 s): each bound wider, the count said.
    half = tmp_path / "half.csv"
    np.savetxt(half, np.column_stack([grid[:801], grid[:801]]), delimiter=",", header="t,x", comments="")
    cut = cli(*flags, "--times", half)
    assert f"(801 of 1601 samples: the times of {half})" in cut
    sd = lambda text: [float(line.split(" sd ")[1].split()[0]) for line in sd_lines(text)]
    assert all(c > p for c, p in zip(sd(cut), sd(plain)))
    # A row with a missing cell is not a sample, as identify leaves it out.
    gappy = tmp_path / "gappy.csv"
    lines = half.read_text().splitlines()
    lines[3] = lines[3].split(",")[0] + ",nan"
    gappy.write_text("\n".join(lines) + "\n")
    assert f"(800 of 1601 samples: the times of {gappy})" in cli(*flags, "--times", gappy)
    # Python: the same bound from the times themselves (the CLI prints 6 significant digits).
    bound = hysid.crlb("impact-msd", t_end=8.0, dt=5e-3, sigma=0.25, times=grid[:801])
    assert bound["samples"] == 801
    np.testing.assert_allclose(list(bound["sd"].values()), sd(cut), rtol=1e-5)
    off = tmp_path / "off.csv"
    off.write_text("t,x\n0,0\n0.0075,0\n")
    assert cli_refusal(*flags, "--times", off) == (
        f"--times {off}:3: t = 0.0075: not a sample time of the grid (k·dt, dt = 0.005, from 0 to 8)")
    with pytest.raises(ValueError, match=r"^times\[1\]: t = 0.0075: not a sample time of the grid"):
        hysid.crlb("impact-msd", t_end=8.0, dt=5e-3, sigma=0.25, times=[0.0, 0.0075])
    with pytest.raises(ValueError, match=r"^times\[2\]: t = 0.005: the same sample as times\[1\]"):
        hysid.crlb("impact-msd", t_end=8.0, dt=5e-3, sigma=0.25, times=[0.0, 0.005, 0.005])


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
        assert str(e.value) == message.replace(str(data), "y")  # the array, not a file


def test_identify_refuses_steps_below_the_smallest(tmp_path):
    data = tmp_path / "tiny.csv"
    data.write_text("t,y1,y2\n" + "".join(f"{k * 1e-320},1,0\n" for k in range(5)))
    message = cli_refusal("identify", "--data", data)
    with pytest.raises(ValueError) as e:
        hysid.identify("impact-msd", np.ones((5, 2)), dt=1e-320)
    tail = r"the step \S+ after {} is below 1e-150 s \(rescale the time\)$"
    assert re.search(r"tiny.csv:3: column 1 \('t'\): " + tail.format("line 2"), message)
    assert re.fullmatch(r"t\[1\]: " + tail.format(r"t\[0\]"), str(e.value))  # the array's elements


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
        assert str(e.value) == message.replace(f"{data}: column 'y1'", "y[:, 0]")


def test_identify_refuses_infinite_samples_as_the_cli(tmp_path):
    """An infinite state cell is refused (a NaN is a missing cell, left out), in a file and in an array."""
    data = tmp_path / "inf.csv"
    data.write_text("t,y1,y2\n0,1,2\n0.001,1,-inf\n0.002,1,2\n0.003,1,2\n")
    assert cli_refusal("identify", "--data", data) == f"{data}:3: column 3 ('y2'): '-inf' is not finite"
    y = np.ones((4, 2))
    y[1, 1] = -np.inf
    with pytest.raises(ValueError) as e:
        hysid.identify("impact-msd", y, dt=1e-3)
    assert str(e.value) == "y[1, 1]: '-inf' is not finite"


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
    """The paper detector at r ≈ 1 with --second-pass flags nearly every sample: the labelled routes
    have too few samples between the labels; multiple shooting by time needs no label and fits every
    sample. Never an internal error reported as bad input."""
    p = subprocess.run([BIN, "identify", "--detector", "paper", "--r", "1.0001", "--second-pass", "--data",
                        str(paper_data)], capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "refinement (maximum likelihood, output error): ok" in p.stdout
    assert "route: multiple shooting by time" in p.stdout
    assert "tried: the detected labels' routes: too-few-samples" in p.stdout
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


def test_version_is_the_projects():
    """hysid.__version__ is the version `hysid --version` prints."""
    assert cli("--version").split()[0] == hysid.__version__
    assert re.fullmatch(r"\d+\.\d+\.\d+", hysid.__version__)


def test_set_returns_a_new_model_and_leaves_this_one():
    m = hysid.Model("impact-msd")
    changed = m.set("a", 3.0)
    assert m.parameters["a"] == 5.0 and changed.parameters["a"] == 3.0
    assert changed != m and changed.set("a", 5.0) == m
    traj = hysid.simulate(changed, t_end=2.0)
    assert not np.array_equal(traj["x"], hysid.simulate(m, t_end=2.0)["x"])
    with pytest.raises(ValueError, match="value: expected a number, got str 'x'"):
        m.set("a", "x")


def test_pickled_models_are_equal_and_rebuild_without_their_file(tmp_path):
    import pickle
    text = (MODELS / "wall-msd.toml").read_text()
    (tmp_path / "wall.toml").write_text(text)
    models = [hysid.Model("bouncing-ball"), hysid.Model("impact-msd").set("b", 0.2),
              hysid.Model.from_file(tmp_path / "wall.toml").set("k", 3.0)]
    blobs = [pickle.dumps(m) for m in models]
    (tmp_path / "wall.toml").unlink()  # the model file travels as its text
    for m, blob in zip(models, blobs):
        copy = pickle.loads(blob)
        assert copy == m and copy.parameters == m.parameters and copy.equations == m.equations
        np.testing.assert_array_equal(hysid.simulate(copy, t_end=1.0)["x"], hysid.simulate(m, t_end=1.0)["x"])
    assert models[0] != models[1]


def test_a_guard_parameter_travels_with_the_pickled_model(tmp_path):
    """wall-msd with its wall at a guard parameter w (bounds [0.5, 2]): set, pickled, rebuilt."""
    text = (MODELS / "wall-msd.toml").read_text()
    text = text.replace('h = "x - 1"', 'h = "x - w"').replace('project = { x = "1" }', 'project = { x = "w" }')
    text = text.replace('C = "x < 1 || (x == 1 && v <= 0)"', 'C = "x < w || (x == w && v <= 0)"')
    text = text.replace('D = "x == 1 && v >= 0"', 'D = "x == w && v >= 0"')
    text = text.replace('distance_to_D = "sqrt((x - 1)^2 + min(v, 0)^2)"', 'distance_to_D = "sqrt((x - w)^2 + min(v, 0)^2)"')
    text = text.replace("\n[flow]", '\nguard_params = [{ name = "w", value = 1.0, bounds = [0.5, 2.0] }]\n\n[flow]', 1)
    (tmp_path / "wall-w.toml").write_text(text)
    import pickle
    m = hysid.Model(tmp_path / "wall-w.toml")
    assert m.unknowns["gamma"] == ["w"] and m.parameters["w"] == 1.0
    far = m.set("w", 1.5)
    copy = pickle.loads(pickle.dumps(far))
    assert copy == far != m and copy.parameters["w"] == 1.5
    assert hysid.simulate(copy, t_end=3.0)["jumps"][0]["pre"][0] == pytest.approx(1.5, abs=1e-9)
    with pytest.raises(ValueError, match="w"):
        m.set("w", 3.0)  # outside its bounds


def _fitted_a(model):
    """One identification in a worker process: the estimate of a on the model's own noise-free run."""
    traj = hysid.simulate(model, t_end=4.0)
    return hysid.identify(model, traj["y"], dt=traj["dt"], refine="none")["estimates"]["a"]


def test_models_cross_process_boundaries():
    """multiprocessing.Pool on 2 processes: each worker gets the pickled model (with its changed a)."""
    import multiprocessing
    models = [hysid.Model("impact-msd").set("a", a) for a in (3.0, 4.0, 6.0)]
    with multiprocessing.get_context("fork").Pool(2) as pool:
        remote = pool.map(_fitted_a, models)
    assert remote == [_fitted_a(m) for m in models]
    for a, estimate in zip((3.0, 4.0, 6.0), remote):
        assert estimate == pytest.approx(a, rel=1e-3)


def interrupted(setup, call, env=None, wait=False):
    """Runs `setup`, then the long `call` in a child Python; SIGINT 0.5 s into the call. Returns the seconds
    from the signal to the KeyboardInterrupt reaching the script, the exit code and stderr; with `wait`,
    also the seconds until the process has no thread but those it had before the call (the computation
    has stopped; None when it still runs 30 s later). Threads are told apart by id, not counted: a thread
    of the setup's last call may still be ending when the call starts."""
    import signal
    import sys
    import time
    script = (f"import os, time, numpy as np, hysid\n{setup}\n"
              "tasks = lambda: set(os.listdir('/proc/self/task'))\nbefore = tasks()\n"
              f"print('started', flush=True)\ntry:\n    {call}\n"
              "    print('finished', flush=True)\nexcept KeyboardInterrupt:\n"
              "    at = time.monotonic()\n    print('interrupted', at, flush=True)\n")
    if wait:
        script += ("    while not tasks() <= before and time.monotonic() - at < 30.0:\n        time.sleep(0.01)\n"
                   "    print('stopped', time.monotonic() - at if tasks() <= before else None, flush=True)\n")
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env={**os.environ, **(env or {})})
    assert p.stdout.readline().strip() == "started", p.stderr.read()
    time.sleep(0.5)
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=90)
    words = out.split()
    assert words and words[0] == "interrupted", (out, err)
    if wait:
        assert words[2] == "stopped", (out, err)
        return float(words[1]) - sent, p.returncode, err, None if words[3] == "None" else float(words[3])
    return float(words[1]) - sent, p.returncode, err


LONG_CALLS = {
    # undamped, lossless impacts for 1e4 s: 7118 jumps (seconds)
    "simulate": ("m = hysid.Model('impact-msd').set('b', 0.0).set('lambda', 1.0)",
                 "hysid.simulate(m, t_end=1e4, dt=1.0)"),
    # the refinement over 400 001 noisy samples (minutes)
    "identify": ("tr = hysid.simulate('impact-msd', t_end=200.0, dt=5e-4, sigma=0.1)",
                 "hysid.identify('impact-msd', tr['y'], dt=5e-4)"),
    # the refinement of 40 runs of 10 001 samples each (minutes)
    "identify runs": ("tr = hysid.simulate('impact-msd', t_end=200.0, dt=5e-4, sigma=0.1)",
                      "hysid.identify('impact-msd', np.array_split(tr['y'], 40), dt=5e-4)"),
    # the bound of undamped, lossless impacts over 6000 s: about 4300 jumps (seconds)
    "crlb": ("m = hysid.Model('impact-msd').set('b', 0.0).set('lambda', 1.0)", "hysid.crlb(m, t_end=6000.0, dt=2e-2)"),
    "run_sweep": ("import pathlib, tempfile\nd = pathlib.Path(tempfile.mkdtemp())\n"
                  "(d / 's.toml').write_text('[model]\\nname = \"impact-msd\"\\nt_end = 200.0\\n[grid]\\nsigma = 0.1\\n"
                  "dt = 5e-4\\nrefine = [\"ml\"]\\n[run]\\ntrials = 1\\n')",
                  "hysid.run_sweep(str(d / 's.toml'), out=str(d / 'run'), threads=1)"),
}
# Every call's computation polls the stop flag that Ctrl-C raises (the run loop before each CVODE step, the
# refinement's iterations and retries, the sweep's units): it ends soon after, and the process exits normally.
STOPPED = set(LONG_CALLS)


@pytest.mark.parametrize("name", sorted(LONG_CALLS))
def test_ctrl_c_interrupts_a_long_call(name):
    """SIGINT in the middle of one long C++ computation: KeyboardInterrupt within 0.5 s (the module checks
    every 50 ms), and the computation stops too (the process is back to its threads long before the time
    the call would take; exit code 0, nothing left running at exit)."""
    if name in STOPPED:
        delay, code, err, stopped = interrupted(*LONG_CALLS[name], wait=True)
        print(f"{name}: KeyboardInterrupt {delay:.3f} s after SIGINT, computation stopped after {stopped} s")
        assert 0.0 <= delay < 0.5
        assert stopped is not None and stopped < 20.0, err
        assert code == 0 and "still running" not in err, err
        return
    delay, code, err = interrupted(*LONG_CALLS[name])
    print(f"{name}: KeyboardInterrupt {delay:.3f} s after SIGINT")
    assert 0.0 <= delay < 0.5
    assert code == 130 and "an interrupted computation is still running" in err, err


# A child Python's script for test_ctrl_c_stops_the_recursive_pass: one identify timed uninterrupted, then the
# same with SIGINT sent once the thread running its recursive pass has used a quarter of the CPU time the
# uninterrupted pass used (the threads' CPU times read from /proc every 2 ms). The pass's thread is the
# one that started after as many others as in the uninterrupted call (the array checks' thread, which
# can use as much CPU time as a quarter of the pass, starts first). Prints one JSON line.
RECURSIVE_PASS_SCRIPT = """\
import json, os, signal, threading, time, numpy as np, hysid
tr = hysid.simulate('impact-msd', t_end=20.0, dt=5e-4, sigma=0.01)
y = np.tile(tr['y'], (25, 1))  # 1 000 025 samples, 25 copies of the run
kw = dict(dt=5e-4, refine='none', trace=False, estimator='frisch', window=0, second_pass=True)
tasks = lambda: set(os.listdir('/proc/self/task'))
ticks = os.sysconf('SC_CLK_TCK')


def cpu(task):
    \"\"\"The CPU seconds a thread of this process has used; None once it has ended.\"\"\"
    try:
        with open(f'/proc/self/task/{task}/stat') as f:
            fields = f.read().rsplit(')', 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / ticks


class Watch(threading.Thread):
    \"\"\"While a call runs: the CPU seconds of each thread it starts (`used`) and the order they were first
    seen (`order`); with `at`, SIGINT once the thread seen after `skip` others has used `at` s (the wall
    time kept in `sent`), then that thread's CPU seconds from the signal to its end (`after`).\"\"\"

    def __init__(self, at=None, skip=0):
        super().__init__()
        self.before, self.at, self.used, self.sent, self.after, self.done = tasks(), at, {}, None, None, False
        self.order, self.skip = [], skip

    def run(self):
        me = str(threading.get_native_id())
        while not self.done:
            for task in sorted(tasks() - self.before - {me}, key=int):
                if task not in self.used:
                    self.order.append(task)
                self.used[task] = max(self.used.get(task, 0.0), cpu(task) or 0.0)
                if self.at is not None and self.order.index(task) == self.skip and self.used[task] >= self.at:
                    self.sent = time.monotonic()
                    os.kill(os.getpid(), signal.SIGINT)
                    self.follow(task)
                    return
            time.sleep(0.002)

    def follow(self, task):
        start = last = self.used[task]
        while (used := cpu(task)) is not None:
            last = used
            time.sleep(0.002)
        self.after = last - start


before = tasks()
watch = Watch()
watch.start()
cpu0 = time.process_time()
r = hysid.identify('impact-msd', y, **kw)
out = {'status': r['flow_status'], 'full_cpu': time.process_time() - cpu0}
watch.done = True
watch.join()
busiest = max(watch.used, key=watch.used.get)  # the identification's thread
out['pass_cpu'] = watch.used[busiest]
out['skip'] = watch.order.index(busiest)  # threads the call started before it (the array checks')
out['other_cpu'] = [watch.used[t] for t in watch.order if t != busiest]
watch = Watch(at=out['pass_cpu'] / 4, skip=out['skip'])
watch.start()
cpu0 = time.process_time()
try:
    hysid.identify('impact-msd', y, **kw)
    out['outcome'] = 'finished'
    watch.done = True
except KeyboardInterrupt:
    raised = time.monotonic()
    kept = before | {str(watch.native_id)}  # the threads before the call and the watch (it ends with the pass)
    while not tasks() <= kept and time.monotonic() - raised < 30.0:
        time.sleep(0.01)
    out.update(outcome='interrupted', delay=raised - watch.sent, stopped=tasks() <= kept,
               cpu=time.process_time() - cpu0)
    watch.join()
    out['cpu_after_signal'] = watch.after
print(json.dumps(out), flush=True)
"""


def test_ctrl_c_stops_the_recursive_pass():
    """SIGINT while the recursive pass of an identify without refinement runs (its thread, the one started
    after the array checks', has used a quarter of the uninterrupted pass's CPU time): KeyboardInterrupt
    within 0.5 s, and the abandoned pass stops (it looks at the stop flag every 4096 samples), leaving no
    thread of the call and no computation for the interpreter's exit to wait on, long before it would end:
    its thread uses under half the pass's CPU time after the signal (it had three quarters left), the
    interrupted call less than the whole call. CPU times, not wall times, place the signal and bound the
    work, so the machine's load does not change what is tested."""
    import json
    import sys
    p = subprocess.run([sys.executable, "-c", RECURSIVE_PASS_SCRIPT], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and "still running" not in p.stderr, (p.stdout, p.stderr)
    r = json.loads(p.stdout.splitlines()[-1])
    print(f"recursive pass: {r['pass_cpu']:.2f} s CPU uninterrupted (the call {r['full_cpu']:.2f} s, the array "
          f"checks {r['other_cpu']} s); SIGINT at {r['pass_cpu'] / 4:.2f} s of it: KeyboardInterrupt "
          f"{r.get('delay', 0):.3f} s later, {r.get('cpu_after_signal', 0):.3f} s CPU after the signal, "
          f"the call {r.get('cpu', 0):.2f} s CPU")
    assert r["status"] == "ok" and r["outcome"] == "interrupted", r
    assert 0.0 <= r["delay"] < 0.5
    assert r["stopped"]
    assert r["cpu_after_signal"] < r["pass_cpu"] / 2
    assert r["cpu"] < r["full_cpu"]


def test_ctrl_c_while_the_arrays_are_checked():
    """SIGINT 0.05 s into an identify of 2 000 005 samples, while the arrays are checked and copied into the
    identifier's data (over a second here, before the identification starts): KeyboardInterrupt within
    0.5 s, as during the computation."""
    import sys
    script = (
        "import os, signal, threading, time, numpy as np, hysid\n"
        "tr = hysid.simulate('impact-msd', t_end=200.0, dt=5e-4, sigma=0.01)\n"
        "y = np.tile(tr['y'], (5, 1))\n"
        "sent = []\n"
        "def fire():\n    sent.append(time.monotonic())\n    os.kill(os.getpid(), signal.SIGINT)\n"
        "threading.Timer(0.05, fire).start()\n"
        "try:\n    hysid.identify('impact-msd', y, dt=5e-4, refine='none')\n    print('finished', flush=True)\n"
        "except KeyboardInterrupt:\n    print('interrupted', time.monotonic() - sent[0], flush=True)\n")
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    words = p.stdout.split()
    assert words and words[0] == "interrupted", (p.stdout, p.stderr)
    print(f"SIGINT 0.05 s into the call: KeyboardInterrupt {float(words[1]):.3f} s after it")
    assert 0.0 <= float(words[1]) < 0.5


def test_identify_takes_every_option_of_the_tables():
    """Every detector and estimator option of `hysid identify --help` is a keyword with its help and
    default: one table feeds both."""
    flags = set(re.findall(r"^\s+(--[a-z0-9-]+)", cli("identify", "--help"), re.M))
    options = hysid.identify_options()
    assert {o["flag"] for o in options.values()} <= flags
    assert {"window", "p0", "frisch_box", "frisch_point", "frisch_confidence", "false_alarm", "r", "tau0",
            "jump_window", "refactor_every"} <= set(options)
    for name, o in options.items():
        assert o["flag"] == "--" + name.replace("_", "-") and o["read_by"]
        assert f"  {name} = None (default {o['default']}): {o['help']}" in hysid.identify.__doc__


# The options only one front-end has (docs/architecture.md, "One identification under two front-ends"):
# the command line's files, outputs, terminal and candidate-term selection; Python's arrays, truth and
# the parts of its dict. `trace` is in both, with two meanings: a file (--trace) and a switch (trace=).
CLI_ONLY = {"model_file", "param", "data", "columns", "trace", "hulls", "json", "progress", "chosen_model",
            "select_bootstrap", "select_seed"}
PYTHON_ONLY = {"y", "dt", "t", "u", "truth", "sets", "trace"}


def identify_keywords():
    """The keywords hysid.identify takes, as its refusal of an unknown one lists them."""
    with pytest.raises(TypeError) as refusal:
        hysid.identify("impact-msd", np.ones((10, 2)), dt=1e-3, no_such_keyword=1)
    return set(str(refusal.value).split("its keywords are ", 1)[1].split(", "))


def test_identify_settings_are_the_same_in_both_front_ends():
    """Every option of `hysid identify` is a keyword of hysid.identify and the reverse, through their
    spellings (--max-gap is max_gap), but for the front-end-only ones named in docs/architecture.md."""
    flags = set(re.findall(r"^\s+(?:-h,)?(--[a-z0-9-]+)", cli("identify", "--help"), re.M))
    flags -= {"--help", "--version"}  # every subcommand's
    as_keywords = {f[2:].replace("-", "_") for f in flags}
    keywords = identify_keywords()
    assert CLI_ONLY <= as_keywords and PYTHON_ONLY <= keywords
    assert as_keywords - CLI_ONLY == keywords - PYTHON_ONLY, (
        f"only on the command line: {sorted(as_keywords - CLI_ONLY - keywords)}; "
        f"only in Python: {sorted(keywords - PYTHON_ONLY - as_keywords)}")
    doc = (SOURCE / "docs" / "architecture.md").read_text()
    for name in sorted(CLI_ONLY):
        assert "`--" + name.replace("_", "-") + "`" in doc
    for name in sorted(PYTHON_ONLY - {"y", "dt", "t"}):
        assert "`" + name + "`" in doc


def test_unknown_keywords_are_refused_by_name():
    y = np.ones((10, 2))
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'windw'; its keywords are .*\bwindow\b"):
        hysid.identify("impact-msd", y, dt=1e-3, windw=3)
    with pytest.raises(ValueError, match=r"^window: the alpha estimator 'rls' does not read it \(its options: "
                                         r"forgetting, p0\)$"):
        hysid.identify("impact-msd", y, dt=1e-3, window=3)


ARRAY_REFUSALS = [
    # (arguments, the message): each names the argument and the constraint, in Python's terms
    (dict(y=np.ones((10, 2)), dt=1e-3, t=np.arange(10) * 2e-3),
     "dt = 0.001: t has the step 0.002; give dt or t, or both that agree"),
    (dict(y=np.ones((10, 2)), t=np.ones((10, 2))), r"t must be a 1-D array of times, one per sample; got shape (10, 2)"),
    (dict(y=np.ones((10, 2)), dt=1e-3, sigma="x"), "sigma: expected numbers, got str 'x'"),
    (dict(y=np.ones((10, 2)) + 1j, dt=1e-3),
     "y: complex values (dtype complex128); samples and options are real numbers"),
    (dict(y=np.array([["a", "b"]] * 4), dt=1e-3), "y: expected real numbers, got an array of dtype <U1"),
    (dict(y=np.ones((10, 2)), dt="0.001"), "dt: expected a number, got str '0.001'"),
    (dict(y=np.ones((10, 2)), dt=1e-3, localize=1), "localize: expected True or False, got int 1"),
    (dict(y=np.ones((10, 3)), dt=1e-3), "y must be a (samples, 2) array, one row per sample; got shape (10, 3)"),
    (dict(y=[np.ones((10, 2)), np.ones((5, 3))], dt=1e-3),
     "y[1] must be a (samples, 2) array, one row per sample; got shape (5, 3)"),
    (dict(y=[np.ones((10, 2)), np.ones((5, 2))], t=np.arange(10.0)),
     "t: y is a list of 2 runs; give t as a list of as many 1-D arrays"),
    (dict(y=[np.ones((4, 2)), np.ones((4, 2))], t=[np.arange(4.0), np.array([0, 1, 1, 2.0])]),
     "t[1][2]: time 1 is not after 1 (t[1][1]): time must increase"),
    (dict(y=np.ones((4, 2)), dt=1e-3, flow_noise_shape=np.ones((2, 3))),
     "flow_noise_shape: shape (2, 3): give a square matrix (parameters + 1)^2"),
]


@pytest.mark.parametrize("kwargs,message", ARRAY_REFUSALS)
def test_identify_refuses_malformed_arguments_by_name(kwargs, message):
    with pytest.raises(ValueError) as e:
        hysid.identify("impact-msd", **kwargs)
    assert str(e.value).startswith(message)
    assert "::" not in str(e.value) and "line" not in str(e.value) and "run 1" not in str(e.value)


def test_a_list_of_rows_is_one_run():
    """A list of lists is one run's rows (as np.asarray reads it), not a list of runs."""
    traj = hysid.simulate("impact-msd", t_end=2.0, sigma=0.01)
    rows = traj["y"].tolist()
    a = hysid.identify("impact-msd", rows, dt=traj["dt"], refine="none")
    b = hysid.identify("impact-msd", traj["y"], dt=traj["dt"], refine="none")
    np.testing.assert_array_equal(a["alpha"], b["alpha"])
    assert "chains" not in a


OTHER_REFUSALS = [
    # (call, the message): arguments of the wrong kind, named, never a pybind11 cast error
    (lambda: hysid.identify("no-model", np.ones((5, 2)), dt=1e-3), "'no-model' is neither a registered model (bouncing-ball, impact-msd, impact-pendulum) nor a model file"),
    (lambda: hysid.identify(3, np.ones((5, 2)), dt=1e-3),
     "model: expected a hysid.Model, a built-in model's name or a model file's path, got int 3"),
    (lambda: hysid.Model(3), "model: expected a hysid.Model, a built-in model's name or a model file's path, got int 3"),
    (lambda: hysid.identify("impact-msd", [], dt=1e-3), "y: an empty list; give a (samples, n) array, or a list of runs"),
    (lambda: hysid.simulate("impact-msd", seed="x"), "seed: expected an integer >= 0, got str 'x'"),
    (lambda: hysid.simulate("impact-msd", trial=-1), "trial: must be ≥ 0, got -1"),
    (lambda: hysid.simulate("impact-msd", rtol=-1.0), "rtol = -1: must be > 0"),
    (lambda: hysid.simulate("impact-msd", x0=[[20.0, 0.0]]),
     "x0: expected a number or a 1-D sequence of numbers, got shape (1, 2)"),
    (lambda: hysid.crlb("impact-msd", sigma="x"), "sigma: expected numbers, got str 'x'"),
    (lambda: hysid.crlb("impact-msd", x0_known=1), "x0_known: expected True, 'all' or state names (a list or comma-separated), got int 1"),
    (lambda: hysid.identify(str(SOURCE / "examples" / "floor-ceiling" / "model.toml"), np.ones((5, 1)), dt=1e-3,
                            localize=True),
     "localize: model 'floor-ceiling' is a hybrid automaton (modes or jump maps); the jump localiser fits one flow "
     "and one jump map, so it is not available for it"),
]


@pytest.mark.parametrize("call,message", OTHER_REFUSALS)
def test_arguments_of_the_wrong_kind_are_refused_by_name(call, message):
    with pytest.raises(ValueError) as e:
        call()
    assert str(e.value) == message


def test_a_model_is_a_model_a_name_or_a_path():
    y = hysid.simulate("impact-msd", t_end=2.0, sigma=0.01)["y"]
    fits = [hysid.identify(m, y, dt=5e-4, refine="none")["alpha"]
            for m in ("impact-msd", hysid.Model("impact-msd"), MODELS / "impact-msd.toml",
                      str(MODELS / "impact-msd.toml"))]
    for alpha in fits[1:]:
        np.testing.assert_array_equal(alpha, fits[0])


def test_an_interrupted_sweep_resumes_to_the_same_trials(tmp_path):
    """Ctrl-C in run_sweep (in this process): KeyboardInterrupt; while the abandoned runner finishes its
    unit the run directory is locked (refused by name, never two runners at once); then the same call
    resumes, and trials.csv is byte for byte that of an uninterrupted run."""
    import signal
    import threading
    import time
    sweep = tmp_path / "s.toml"
    sweep.write_text('[model]\nname = "impact-msd"\nt_end = 100.0\n[grid]\nsigma = 0.1\ndt = 5e-4\n'
                     'refine = ["none"]\n[run]\ntrials = 24\n')
    run = tmp_path / "run"

    def interrupt_after_two_units():  # the journal: two header lines, then one row per finished unit
        journal = run / "trials.journal"
        while not journal.exists() or journal.read_text().count("\n") < 4:
            time.sleep(0.01)
        os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt_after_two_units, daemon=True).start()
    with pytest.raises(KeyboardInterrupt):
        hysid.run_sweep(sweep, out=str(run), threads=1)
    locked = 0
    deadline = time.monotonic() + 120
    while True:
        try:
            out = hysid.run_sweep(sweep, out=str(run), threads=1)
            break
        except ValueError as e:
            assert str(e).endswith("is locked); wait for it or use another out (an interrupted run_sweep of "
                                   "this process is finishing the units it was running)"), str(e)
            assert time.monotonic() < deadline
            locked += 1
            time.sleep(0.05)
    assert 2 <= out["resumed"] < 24 and out["resumed"] + out["run"] == 24
    whole = hysid.run_sweep(sweep, out=str(tmp_path / "whole"), threads=1)
    assert whole["run"] == 24
    assert (run / "trials.csv").read_bytes() == (tmp_path / "whole" / "trials.csv").read_bytes()
    print(f"locked {locked} times while the abandoned unit finished")


@pytest.mark.parametrize("path", sorted(str(p) for p in (SOURCE / "examples").glob("*/*.toml")
                                        if "[[jump]]" in p.read_text()))
def test_modes_and_jump_maps_are_those_of_the_model_file(path):
    """Model.modes and Model.jumps against the file read by tomllib: names, guard, from, to (None when the
    file leaves them out), the names of the map's beta, its rows and whether it is an identity (no psi)."""
    import tomllib
    spec = tomllib.loads(Path(path).read_text())
    m = hysid.Model(path)
    assert m.modes == spec.get("modes", [])
    assert [j["name"] for j in m.jumps] == [j["name"] for j in spec["jump"]]
    for got, given in zip(m.jumps, spec["jump"]):
        assert (got["guard"], got["from"], got["to"]) == (given["guard"], given.get("from"), given.get("to"))
        assert got["beta"] == [b["name"] for b in given.get("beta", [])]
        assert got["rows"] == given.get("rows", []) and got["identity"] == ("psi" not in given)


def test_an_automatons_report_has_the_fitted_event_times():
    """The pump tank: the report (the CLI's --json) gives each switch its time from the fitted model, within
    a sample of the true switch and within 5 of its standard errors, where the detected kinks are coarser."""
    model = hysid.Model(str(SOURCE / "examples" / "pump-tank" / "model.toml"))
    traj = hysid.simulate(model, sigma=1e-3, seed=1)
    fit = hysid.identify(model, traj["y"], dt=traj["dt"])
    assert fit["refined"]["status"] == "ok"
    events = fit["report"]["automaton"]["events"]
    truth = [jump["t"] for jump in traj["jumps"]]
    assert len(events) == len(truth) == 9
    for event, t in zip(events, truth):
        assert abs(event["time_fitted"] - t) < traj["dt"]
        assert abs(event["time_fitted"] - t) < 5 * event["time_fitted_se"]


def test_units_note_on_an_estimate_far_from_its_start(paper_data):
    """Time in ms (v in m/ms): a and b come out 1e6 and 1e3 times smaller than the model's values, a
    note, not a refusal; the same samples in s: no note."""
    data = np.loadtxt(paper_data, delimiter=",", skiprows=1)
    y = data[:, 4:6]
    plain = hysid.identify("impact-msd", y, dt=5e-4, refine="none")
    assert plain["notes"] == []
    ms = hysid.identify("impact-msd", y / [1.0, 1000.0], dt=0.5, refine="none")
    assert any(n.startswith("a = ") and "check the units" in n for n in ms["notes"]), ms["notes"]


def test_bounds_note_on_a_recursive_estimate_outside_them(tmp_path):
    """A model file's bounds on mu = [-0.01, 0.01]: the recursive estimate (refine='none', which applies no
    bounds) lies outside them and `notes` says so; the refined one lies inside, without that note."""
    text = (MODELS / "impact-msd.toml").read_text()
    bounded = text.replace('{ name = "mu", value = 0.0,', '{ name = "mu", value = 0.0, bounds = [-0.01, 0.01],')
    assert bounded != text
    (tmp_path / "mb.toml").write_text(bounded)
    model = hysid.Model(str(tmp_path / "mb.toml"))
    traj = hysid.simulate(model, sigma=0.01, seed=1)
    recursive = hysid.identify(model, traj["y"], dt=traj["dt"], refine="none")
    assert not -0.01 <= recursive["estimates"]["mu"] <= 0.01
    assert any(n.startswith("mu = ") and "outside its bounds [-0.01, 0.01]" in n for n in recursive["notes"])
    refined = hysid.identify(model, traj["y"], dt=traj["dt"])
    assert refined["refined"]["status"] == "ok" and -0.01 <= refined["refined"]["estimates"]["mu"] <= 0.01
    assert not any("outside its bounds" in n for n in refined["notes"]), refined["notes"]


def _measured_ball(tmp_path):
    """A ball measured by its height alone (g = 9.81, lambda = 0.85, mu = 0.5), 801 samples at 100 Hz,
    sigma = 2 mm: the start model file's text (start values about 2x off, also written to start.toml)
    and the simulation."""
    text = (MODELS / "bouncing-ball.toml").read_text().replace('states = ["h", "v"]',
                                                             'states = ["h", "v"]\nmeasured = ["h"]')
    truth = text.replace("value = 0.8, desc", "value = 0.85, desc").replace("value = 0.0, desc", "value = 0.5, desc")
    start = text.replace("value = 9.81, desc", "value = 5.0, desc").replace("value = 0.8, desc", "value = 0.5, desc")
    start = start.replace("value = 0.0, desc", "value = 1.0, desc")
    (tmp_path / "truth.toml").write_text(truth)
    (tmp_path / "start.toml").write_text(start)
    traj = hysid.simulate(hysid.Model.from_file(tmp_path / "truth.toml"), sigma=0.002, seed=3, t_end=8.0, dt=0.01)
    return start, traj


def test_outliers_left_out_unless_kept(tmp_path):
    """A ball measured by its height alone, start values 2x off, three samples displaced by 0.25-0.4 m:
    left out and listed, the fit ok within 4 SE of the truth; kept, the fit is not ok."""
    _, traj = _measured_ball(tmp_path)
    y = np.array(traj["y"])[:, :1]
    for k, size in [(150, 0.3), (402, -0.25), (611, 0.4)]:
        y[k, 0] += size
    model = hysid.Model.from_file(tmp_path / "start.toml")
    fit = hysid.identify(model, y, dt=0.01)
    outliers = fit["report"]["data"]["outliers"]
    assert [o["t"] for o in outliers] == pytest.approx([1.5, 4.02, 6.11])
    assert all(o["column"] == "y1" or o["column"] == "h" for o in outliers)
    refined = fit["refined"]
    assert refined["status"] == "ok"
    for name, true in [("g", 9.81), ("lambda", 0.85), ("mu", 0.5)]:
        assert abs(refined["estimates"][name] - true) < 4 * refined["standard_errors"][name]
    kept = hysid.identify(model, y, dt=0.01, keep_outliers=True)
    assert kept["report"]["data"]["outliers"] == []
    assert kept["refined"]["status"] != "ok"
    # The command line's trace keeps their rows, marked 2 in `missing`, the fit's cells nan.
    data = tmp_path / "ball.csv"
    np.savetxt(data, np.column_stack([traj["t"], y[:, 0]]), delimiter=",", header="t,h", comments="")
    cli("identify", "--model-file", tmp_path / "start.toml", "--data", data, "--trace", tmp_path / "trace.csv")
    trace = np.genfromtxt(tmp_path / "trace.csv", delimiter=",", names=True)
    assert len(trace) == len(y)
    assert list(trace["line"][trace["missing"] == 2]) == [152, 404, 613]
    assert np.isnan(trace["fit_h"][trace["missing"] == 2]).all()
    assert np.isfinite(trace["fit_h"][trace["missing"] == 0]).all()


def test_outliers_off_the_fit_left_out_by_the_fit(tmp_path):
    """The same ball with a pair of samples displaced together by 0.3 and 0.12 m and the last sample by
    -0.25 m: the data's rules keep them (the pair's second differences are not the pattern of two bad
    frames, d at the second sample of the other sign; the last sample is at a chain's end); the first
    fit ends residual-rms,
    the three stand alone off it and are left out by the fit, which is then ok on all the others within
    4 SE of the truth. Kept, the fit is ok only before the pair, or not ok. A model that is wrong leaves
    none out: its residuals are not alone."""
    start, traj = _measured_ball(tmp_path)
    y = np.array(traj["y"])[:, :1]
    for k, size in [(300, 0.3), (301, 0.12), (len(y) - 1, -0.25)]:
        y[k, 0] += size
    model = hysid.Model.from_file(tmp_path / "start.toml")
    fit = hysid.identify(model, y, dt=0.01)
    assert fit["report"]["data"]["outliers"] == []
    refined = fit["refined"]
    assert refined["status"] == "ok", refined["reason"]
    assert [o["t"] for o in refined["outliers"]] == pytest.approx([3.0, 3.01, 8.0])
    assert all(o["sds"] > 10 for o in refined["outliers"])
    assert refined["samples_used"] == len(y) - 3
    for name, true in [("g", 9.81), ("lambda", 0.85), ("mu", 0.5)]:
        assert abs(refined["estimates"][name] - true) < 4 * refined["standard_errors"][name]
    kept = hysid.identify(model, y, dt=0.01, keep_outliers=True)["refined"]
    assert kept["outliers"] == []
    # Kept: ok only on the span before the pair (the detector takes it for jumps), or not ok.
    assert kept["status"] != "ok" or kept["samples_used"] < 300
    # The clean samples and a model with the impact term mu held at 0 (the truth's is 0.5): not ok, and
    # none left out.
    clean = np.array(traj["y"])[:, :1]
    no_mu = start.replace("value = 1.0, desc", "value = 0.0, known = true, desc")
    (tmp_path / "no_mu.toml").write_text(no_mu)
    misfit = hysid.identify(hysid.Model.from_file(tmp_path / "no_mu.toml"), clean, dt=0.01)["refined"]
    assert misfit["status"] != "ok" and misfit["outliers"] == []


def test_singular_fit_reports_what_the_data_determine(tmp_path):
    """An integrate-and-fire neuron (threshold and reset one direction): singular-fisher at the noise,
    `determined` gives a, b and x0[v] with standard errors (truth within 4 of them), not c or theta;
    the same numbers as the command line's --json."""
    start = SOURCE / "tests" / "data" / "lif.toml"  # every value 2x off
    truth = (start.read_text().replace("value = 4.0", "value = 2.0").replace("value = 1.0 }", "value = 0.5 }")
             .replace("value = 0.4", "value = 0.2").replace("value = 1.5,", "value = 3.0,"))
    (tmp_path / "lif.toml").write_text(truth)
    traj = hysid.simulate(hysid.Model.from_file(tmp_path / "lif.toml"), sigma=0.02, seed=7)
    fit = hysid.identify(hysid.Model.from_file(start), np.array(traj["y"]), dt=0.01)["refined"]
    assert fit["status"] == "singular-fisher"
    assert fit["standard_errors"] == {}
    determined = fit["determined"]
    assert sorted(determined) == ["a", "b", "x0[v]"]
    for name, true in [("a", 2.0), ("b", 0.5), ("x0[v]", 0.5)]:
        assert abs(determined[name]["value"] - true) < 4 * determined[name]["standard_error"]
    data = tmp_path / "lif.csv"
    np.savetxt(data, np.column_stack([traj["t"], np.array(traj["y"])[:, 0]]), delimiter=",", header="t,v",
               comments="")
    run = subprocess.run([BIN, "identify", "--model-file", start, "--data", data, "--json",
                          tmp_path / "fit.json"], capture_output=True, text=True)
    assert run.returncode == 1  # not ok
    import json
    cli_fit = json.loads((tmp_path / "fit.json").read_text())
    assert cli_fit["determined"] == determined

"""Python and the command line give the same numbers and the same refusals: for three models (two built-ins
and a model file) and every option of `hysid identify` (one value other than the default each), the dict of
hysid.identify equals the `--json` of `hysid identify` number for number, and a bad value of each option
is refused by both with the same message. The options come from hysid.identify_options(), the tables the
command line builds its flags from: an option added to a table is tested here without editing this file."""
import json
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import hysid

BIN = os.environ.get("HYSID_BIN", "hysid")
SOURCE = Path(os.environ.get("HYSID_SOURCE_DIR", Path(__file__).resolve().parents[2]))
MODELS = {"impact-msd": "impact-msd", "bouncing-ball": "bouncing-ball",
          "wall-msd (file)": str(SOURCE / "models" / "wall-msd.toml")}


def model_flags(model):
    return ["--model-file", model] if model.endswith(".toml") else ["--model", model]


@pytest.fixture(scope="module", params=sorted(MODELS))
def data(request, tmp_path_factory):
    """(model, t, y, csv): a noisy run of the model written as t,y1..yn with every digit (no sidecar: the
    command line reads no data accuracy and no truth)."""
    model = MODELS[request.param]
    m = hysid.Model(model)
    traj = hysid.simulate(m, t_end=min(m.default_t_end, 6.0), sigma=0.01, seed=4)
    path = tmp_path_factory.mktemp("parity") / "data.csv"
    header = ",".join(["t"] + [f"y{i + 1}" for i in range(traj["y"].shape[1])])
    path.write_text(header + "\n" + "".join(",".join(repr(float(v)) for v in (t, *row)) + "\n"
                                            for t, row in zip(traj["t"], traj["y"])))
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    return model, table[:, 0], table[:, 1:], path


def other_value(option):
    """A value other than the default, within the option's range (as Python gives it)."""
    default = option["default"]
    if option["type"] == "choice":
        return next(c for c in option["choices"] if c != default)
    if option["type"] == "integer":
        return int(default) * 9 // 10 if int(default) > 1 else 50
    return float(default) * 0.9


def bad_value(option):
    return {"choice": "bogus", "integer": -1, "real": float("nan")}[option["type"]]


def plugins_for(name, option):
    """estimator and detector keywords under which the option is read."""
    kind = option["family"]
    return {kind: option["read_by"][0]}


# Each option: (keywords for Python, the same as flags). The plugin options from the tables, then the rest.
def cases():
    out = []
    for name, option in sorted(hysid.identify_options().items()):
        value = other_value(option)
        kwargs = {**plugins_for(name, option), name: value}
        text = value if isinstance(value, str) else repr(value)
        out.append((name, kwargs, [*sum(([f"--{k}", str(v)] for k, v in plugins_for(name, option).items()), []),
                                   option["flag"], text]))
    out += [("sigma", {"sigma": 0.02}, ["--sigma", "0.02"]),
            ("sigma per state", {"sigma": [0.02, 0.03]}, ["--sigma", "0.02,0.03"]),
            ("localize", {"localize": True}, ["--localize"]),
            ("second_pass", {"second_pass": True}, ["--second-pass"]),
            ("keep_outliers", {"keep_outliers": True}, ["--keep-outliers"]),
            ("data_rtol", {"data_rtol": 1e-9}, ["--data-rtol", "1e-09"]),
            ("data_atol", {"data_atol": 1e-9}, ["--data-atol", "1e-09"]),
            ("max_gap", {"max_gap": 0.25}, ["--max-gap", "0.25"]),
            ("detector paper", {"detector": "paper"}, ["--detector", "paper"])]
    out += [(f"estimator {e}", {"estimator": e}, ["--estimator", e]) for e in hysid.plugins()["estimator"]]
    return out


def cli_json(tmp_path, csv, model, flags):
    out = tmp_path / "fit.json"
    p = subprocess.run([BIN, "identify", *model_flags(model), "--data", str(csv), *flags, "--json", str(out)],
                       capture_output=True, text=True)
    assert p.returncode in (0, 1), p.stderr
    return json.loads(out.read_text())


def same_fit(fit, cli, y):
    """The dict's numbers against the --json's: exactly (JSON carries every digit)."""
    detector = cli["detector"]
    assert fit["jumps_detected"] == detector["jumps_detected"]
    assert (fit["flow_status"], fit["jump_status"]) == (detector["flow_estimator"], detector["jump_estimator"])
    assert (fit["flow_reason"], fit["jump_reason"]) == (detector["flow_estimator_reason"],
                                                       detector["jump_estimator_reason"])
    refined = fit.get("refined")
    if refined is None:  # refine='none': the recursive estimate, then the first sample as x0
        names = cli["names"]
        assert list(fit["estimates"]) == names[:len(fit["estimates"])]
        assert [fit["estimates"][n] for n in fit["estimates"]] == cli["estimate"][:len(fit["estimates"])]
        assert cli["estimate"][len(fit["estimates"]):] == list(y[0])
        assert list(fit["alpha"]) == cli["alpha"] and list(fit["beta"]) == cli["beta"]
        return
    assert refined["status"] == cli["status"] and refined["reason"] == cli["reason"]
    assert refined["names"] == cli["names"]
    assert list(refined["estimates"].values()) == cli["estimate"]
    assert list(refined["recursive_estimates"].values()) == cli["recursive_estimate"]
    assert list(refined["standard_errors"].values()) == cli["standard_errors"]
    assert refined["covariance"].tolist() == cli["covariance"]
    assert list(refined["sigma"]) == cli["sigma"] and refined["sigma_estimated"] == cli["sigma_estimated"]
    for key in ("normalized_rms", "lag1", "iterations", "samples_used", "model_jumps", "start_repair", "mended"):
        assert refined[key] == cli[key], key


@pytest.mark.parametrize("name,kwargs,flags", cases(), ids=[c[0] for c in cases()])
def test_every_option_gives_the_cli_numbers(data, tmp_path, name, kwargs, flags):
    model, t, y, csv = data
    fit = hysid.identify(model, y, t=t, refine="none", **kwargs)
    same_fit(fit, cli_json(tmp_path, csv, model, [*flags, "--refine", "none"]), y)


@pytest.mark.parametrize("kwargs,flags", [({}, []), ({"sigma": 0.01}, ["--sigma", "0.01"])], ids=["ml", "ml sigma"])
def test_the_refinement_gives_the_cli_numbers(data, tmp_path, kwargs, flags):
    model, t, y, csv = data
    fit = hysid.identify(model, y, t=t, refine="ml", **kwargs)
    same_fit(fit, cli_json(tmp_path, csv, model, flags), y)


def keyword(message):
    """A command-line message with each flag spelled as the Python keyword (--jump-window as jump_window)."""
    return re.sub(r"--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_"), message)


def cli_refusal(csv, model, flags):
    """The message `hysid identify` refuses FLAGS with (exit 2), or None when it runs them."""
    p = subprocess.run([BIN, "identify", *model_flags(model), "--data", str(csv), *flags, "--refine", "none"],
                       capture_output=True, text=True)
    assert p.returncode in (0, 1, 2), p.stderr
    return p.stderr.strip().splitlines()[-1].removeprefix("hysid: error: ") if p.returncode == 2 else None


def refusal_cases():
    out = []
    for name, option in sorted(hysid.identify_options().items()):
        plugins = plugins_for(name, option)
        value = bad_value(option)
        text = value if isinstance(value, str) else repr(value)
        out.append((f"{name} bad", {**plugins, name: value},
                    [*sum(([f"--{k}", v] for k, v in plugins.items()), []), option["flag"], text]))
        unread = [p for p in hysid.plugins()[option["family"]] if p not in option["read_by"]]
        if unread:  # an option the chosen plugin may not read (the beta estimator of integral is rls)
            good = other_value(option)
            out.append((f"{name} unread", {option["family"]: unread[0], name: good},
                        [f"--{option['family']}", unread[0], option["flag"],
                         good if isinstance(good, str) else repr(good)]))
    out += [("sigma", {"sigma": -1.0}, ["--sigma", "-1.0"]), ("sigma 3", {"sigma": [1.0, 2.0, 3.0]}, ["--sigma", "1,2,3"]),
            ("data_rtol", {"data_rtol": -1.0}, ["--data-rtol", "-1"]),
            ("estimator", {"estimator": "kalman"}, ["--estimator", "kalman"]),
            ("detector", {"detector": "oracle"}, ["--detector", "oracle"]),
            ("max_gap", {"max_gap": -1.0}, ["--max-gap", "-1"])]
    return out


@pytest.mark.parametrize("name,kwargs,flags", refusal_cases(), ids=[c[0] for c in refusal_cases()])
def test_every_bad_value_is_refused_as_the_cli_refuses_it(data, name, kwargs, flags):
    """Refused by the command line (exit 2): refused by Python with the same message; run by the one,
    run by the other. Every bad value is refused."""
    model, t, y, csv = data
    message = cli_refusal(csv, model, flags)
    assert message is not None or name.endswith(" unread"), flags
    if message is None:
        hysid.identify(model, y, t=t, refine="none", **kwargs)
        return
    with pytest.raises(ValueError) as e:
        hysid.identify(model, y, t=t, refine="none", **kwargs)
    assert str(e.value) == keyword(message)


def test_noise_shapes_give_the_cli_numbers(data, tmp_path):
    """gtls with given noise shapes C ((p + 1) x (p + 1) for the p unknowns of each regression)."""
    model, t, y, csv = data
    unknowns = hysid.Model(model).unknowns
    flow = np.diag(np.arange(1.0, len(unknowns["alpha"]) + 2))
    jump = np.diag(np.arange(2.0, len(unknowns["beta"]) + 3))
    fit = hysid.identify(model, y, t=t, refine="none", estimator="gtls", flow_noise_shape=flow,
                         jump_noise_shape=jump.ravel())  # a square array, or its values row-major
    flags = ["--estimator", "gtls", "--flow-noise-shape", ",".join(map(repr, flow.ravel())),
             "--jump-noise-shape", ",".join(map(repr, jump.ravel()))]
    same_fit(fit, cli_json(tmp_path, csv, model, [*flags, "--refine", "none"]), y)
    wrong = np.eye(len(unknowns["alpha"]) + 2)  # one row and column too many
    message = cli_refusal(csv, model, ["--estimator", "gtls", "--flow-noise-shape", ",".join(map(repr, wrong.ravel()))])
    with pytest.raises(ValueError) as e:
        hysid.identify(model, y, t=t, estimator="gtls", flow_noise_shape=wrong)
    assert str(e.value) == keyword(message.replace("--*-noise-shape", "*_noise_shape"))
    message = cli_refusal(csv, model, ["--flow-noise-shape", "1,2,3"])
    with pytest.raises(ValueError) as e:
        hysid.identify(model, y, t=t, flow_noise_shape=[1.0, 2.0, 3.0])
    assert str(e.value) == keyword(message)


# ---- the examples beyond the paper's class: measured inputs, height only, a guard parameter ----

EXAMPLES = {name: str(SOURCE / "examples" / name / f"{name}.toml") for name in ("wall", "driven-oscillator", "drag-ball")}


@pytest.fixture(scope="module", params=sorted(EXAMPLES))
def example(request, tmp_path_factory):
    """(model file, csv, arguments of hysid.identify): `hysid simulate` of the example with its default inputs,
    read as the command line reads it: the measured states' columns, the inputs' columns, j and the sidecar's
    truth (x0, sigma)."""
    model = EXAMPLES[request.param]
    csv = tmp_path_factory.mktemp(request.param) / "data.csv"
    subprocess.run([BIN, "simulate", "--model-file", model, "--sigma", "0.001", "--seed", "3", "--t-end", "8",
                    "--out", str(csv)], check=True, capture_output=True)
    with open(csv) as f:
        header = f.readline().strip().split(",")
    table = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    column = {name: table[:, i] for i, name in enumerate(header)}
    m = hysid.Model(model)
    sidecar = json.loads(csv.with_suffix(".json").read_text())
    args = {"y": np.column_stack([column[s] for s in m.measured]), "t": column["t"],
            "truth": {"j": column["j"], "x0": sidecar["x0"], "sigma": sidecar["sigma"]}}
    if m.inputs:
        args["u"] = {name: column[name] for name in m.inputs}
    return model, csv, args


def key_differences(py, cli, path="report"):
    """Where the dict's key tree differs from that of the command line's --json (derived from the JSON
    itself: a key the command line gains is missing here until Python carries it)."""
    if isinstance(cli, dict):
        if not isinstance(py, dict):
            return [f"{path}: {type(py).__name__} where --json has an object"]
        out = [f"{path}.{k}: missing from the dict" for k in cli.keys() - py.keys()]
        out += [f"{path}.{k}: not in --json" for k in py.keys() - cli.keys()]
        for k in cli.keys() & py.keys():
            out += key_differences(py[k], cli[k], f"{path}.{k}")
        return out
    if isinstance(cli, list):
        if not isinstance(py, list) or len(py) != len(cli):
            return [f"{path}: {py!r:.60} where --json has a list of {len(cli)}"]
        return [d for i, (a, b) in enumerate(zip(py, cli)) for d in key_differences(a, b, f"{path}[{i}]")]
    if (cli is None) != (py is None):
        return [f"{path}: {py!r:.60} where --json has {cli!r:.60}"]
    return []


def value_differences(py, cli, path="report"):
    """Where the values differ (numbers exactly: JSON carries every digit)."""
    if isinstance(cli, dict):
        return [d for k in cli for d in value_differences(py.get(k), cli[k], f"{path}.{k}")]
    if isinstance(cli, list):
        return [d for i, (a, b) in enumerate(zip(py, cli)) for d in value_differences(a, b, f"{path}[{i}]")]
    return [] if py == cli else [f"{path}: {py!r} != {cli!r}"]


# The data's own names: the file (or "run 1" for arrays), where its accuracy came from, and line numbers
# (a file's lines count its header; an array's rows are its samples from 1).
def named_by_the_source(path):
    return path in {"report.data.path", "report.data.runs[0]", "report.settings.data_accuracy_source"} or \
        re.search(r"\.(line|first_line|first_missing_line)$", path) is not None


def cli_report(model, csv, tmp_path, flags):
    out = tmp_path / "fit.json"
    p = subprocess.run([BIN, "identify", "--model-file", model, "--data", str(csv), *flags, "--json", str(out)],
                       capture_output=True, text=True)
    assert p.returncode in (0, 1), p.stderr
    return json.loads(out.read_text())


EXAMPLE_CASES = [("defaults", {}, []),
                 ("refine none", {"refine": "none"}, ["--refine", "none"]),
                 ("sigma", {"sigma": 0.001}, ["--sigma", "0.001"]),
                 ("x0 known", {"x0_known": True}, ["--x0-known", "all"]),
                 ("bounded", {"param_bound": {"k": (0.001, 100.0)}}, ["--param-bound", "k=0.001,100.0"])]


@pytest.mark.parametrize("name,kwargs,flags", EXAMPLE_CASES, ids=[c[0] for c in EXAMPLE_CASES])
def test_examples_give_the_cli_report(example, tmp_path, name, kwargs, flags):
    """identify on the examples (measured inputs, height only, an unknown wall position): the dict's `report`
    is `hysid identify --json` on the same data, key for key and number for number, truth and CRLB included."""
    model, csv, args = example
    m = hysid.Model(model)
    if "param_bound" in kwargs and "k" not in m.parameters:
        pytest.skip("no parameter k")
    if "x0_known" in kwargs:
        kwargs = {**kwargs, "x0": list(args["truth"]["x0"])}
        flags = [*flags, "--x0", ",".join(map(repr, args["truth"]["x0"]))]
    accuracy = {"data_rtol": 1e-12, "data_atol": 1e-12}  # the sidecar's, which the command line reads
    fit = hysid.identify(model, **args, **accuracy, **kwargs)
    cli = cli_report(model, csv, tmp_path, [*flags, "--data-rtol", "1e-12", "--data-atol", "1e-12"])
    assert key_differences(fit["report"], cli) == []
    assert [d for d in value_differences(fit["report"], cli) if not named_by_the_source(d.split(":")[0])] == []
    assert cli["truth"] is not None and fit["report"]["truth"]["tp"] == cli["truth"]["tp"]
    if fit.get("refined"):
        assert list(fit["refined"]["estimates"].values()) == cli["estimate"]


def test_the_report_carries_every_key_of_the_cli_json(paper_data_csv, tmp_path):
    """A built-in model, several runs with a gap and a second pass: every key of --json (nested) is in the
    dict's report, and no other."""
    model, csv, t, y = paper_data_csv
    fit = hysid.identify(model, [y[:1500], y[1500:]], t=[t[:1500], t[1500:]], second_pass=True, max_gap=0.25)
    out = tmp_path / "fit.json"
    head = csv.read_text().splitlines()
    (tmp_path / "a.csv").write_text("\n".join(head[:1501]) + "\n")
    (tmp_path / "b.csv").write_text("\n".join([head[0], *head[1501:]]) + "\n")
    p = subprocess.run([BIN, "identify", *model_flags(model), "--data", str(tmp_path / "a.csv"), "--data",
                        str(tmp_path / "b.csv"), "--second-pass", "--max-gap", "0.25", "--json", str(out)],
                       capture_output=True, text=True)
    assert p.returncode in (0, 1), p.stderr
    cli = json.loads(out.read_text())
    assert key_differences(fit["report"], cli) == []
    assert fit["report"]["detections"] and fit["report"]["detections"][0]["t"] == cli["detections"][0]["t"]
    assert len(fit["report"]["chains"]) == len(cli["chains"]) == 2


@pytest.fixture(scope="module")
def paper_data_csv(tmp_path_factory):
    model = "impact-msd"
    traj = hysid.simulate(model, t_end=3.0, sigma=0.01, seed=4)
    path = tmp_path_factory.mktemp("keys") / "data.csv"
    path.write_text("t,y1,y2\n" + "".join(",".join(repr(float(v)) for v in (t, *row)) + "\n"
                                          for t, row in zip(traj["t"], traj["y"])))
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    return model, path, table[:, 0], table[:, 1:]


EXAMPLE_REFUSALS = [
    ("x0_known name", {"x0_known": "q"}, ["--x0-known", "q"]),
    ("x0 alone", {"x0": [0.0, 1.0]}, ["--x0", "0.0,1.0"]),
    ("x0_known refine none", {"x0_known": True, "refine": "none"}, ["--x0-known", "all", "--refine", "none"]),
    ("bound unknown name", {"param_bound": {"zz": (0.5, 1.5)}}, ["--param-bound", "zz=0.5,1.5"]),
    ("bound excludes the value", {"param_bound": {"k": (100.5, 200.5)}}, ["--param-bound", "k=100.5,200.5"]),
    ("bound lo >= hi", {"param_bound": {"k": (2.5, 1.5)}}, ["--param-bound", "k=2.5,1.5"]),
    ("sigma count", {"sigma": [0.1, 0.1, 0.1]}, ["--sigma", "0.1,0.1,0.1"]),
]


@pytest.mark.parametrize("name,kwargs,flags", EXAMPLE_REFUSALS, ids=[c[0] for c in EXAMPLE_REFUSALS])
def test_examples_refuse_as_the_cli(example, name, kwargs, flags):
    """The same refusals with the same messages (the flag spelled as the keyword)."""
    model, csv, args = example
    p = subprocess.run([BIN, "identify", "--model-file", model, "--data", str(csv), *flags],
                       capture_output=True, text=True)
    assert p.returncode == 2, (p.stdout, p.stderr)
    message = p.stderr.strip().splitlines()[-1].removeprefix("hysid: error: ")
    with pytest.raises(ValueError) as e:
        hysid.identify(model, **args, **kwargs)
    assert str(e.value) == keyword(message)


def test_inputs_are_required_and_named(example):
    """A model with inputs without u (or u naming no input), and u for a model without inputs: refused by
    name, as the command line refuses data without the input's column."""
    model, csv, args = example
    m = hysid.Model(model)
    no_u = {k: v for k, v in args.items() if k != "u"}
    if m.inputs:
        with pytest.raises(ValueError, match=r"^u: model 'driven-oscillator' has measured inputs \(u\): give u"):
            hysid.identify(model, **no_u)
        with pytest.raises(ValueError, match=r"^u: 'w' is not an input of model 'driven-oscillator'"):
            hysid.identify(model, **no_u, u={"u": args["u"]["u"], "w": args["u"]["u"]})
        with pytest.raises(ValueError, match=r"^u must be a \(\d+, 1\) array aligned with y"):
            hysid.identify(model, **no_u, u=np.zeros((3, 1)))
    else:
        with pytest.raises(ValueError, match=rf"^u: model '{m.name}' has no inputs"):
            hysid.identify(model, **args, u=np.zeros((len(args["t"]), 1)))


def test_simulate_with_inputs_equals_the_cli(tmp_path):
    """simulate of a model with inputs: the default expressions, or given samples; the states and u as
    `hysid simulate` writes them (the same given inputs from a file)."""
    model = EXAMPLES["driven-oscillator"]
    t = np.linspace(0.0, 5.0, 11)
    given = {"t": t, "u": np.cos(t)}
    (tmp_path / "u.csv").write_text("t,u\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(t, np.cos(t))))
    for kwargs, flags in (({}, []), ({"inputs": given}, ["--inputs", str(tmp_path / "u.csv")])):
        out = tmp_path / "sim.csv"
        subprocess.run([BIN, "simulate", "--model-file", model, "--t-end", "5", "--sigma", "0.01", "--out", str(out),
                        *flags], check=True, capture_output=True)
        table = np.loadtxt(out, delimiter=",", skiprows=1)
        traj = hysid.simulate(model, t_end=5.0, sigma=0.01, **kwargs)
        assert np.array_equal(traj["x"], table[:, 2:4]) and np.array_equal(traj["y"], table[:, 4:6])
        assert np.array_equal(traj["u"][:, 0], table[:, 6])
    with pytest.raises(ValueError, match=r"^inputs: .*u"):  # a range that does not cover the run
        hysid.simulate(model, t_end=5.0, inputs={"t": t[:3], "u": np.cos(t[:3])})


CRLB_CASES = [("defaults", {}, []), ("x0 known v", {"x0_known": ["v"]}, ["--x0-known", "v"]),
              ("x0 known", {"x0_known": True}, ["--x0-known", "all"])]


@pytest.mark.parametrize("example_name", sorted(EXAMPLES))
@pytest.mark.parametrize("name,kwargs,flags", CRLB_CASES, ids=[c[0] for c in CRLB_CASES])
def test_crlb_of_the_examples_equals_the_cli(example_name, name, kwargs, flags):
    """The bound for measured subsets, inputs (the model's defaults) and guard parameters, as `hysid crlb`
    prints it (sd to its 6 digits)."""
    model = EXAMPLES[example_name]
    m = hysid.Model(model)
    if "v" in str(kwargs.get("x0_known")) and "v" not in m.state_names:
        pytest.skip("no state v")
    sigma = [0.001] * len(m.measured)
    p = subprocess.run([BIN, "crlb", "--model-file", model, "--t-end", "4", "--sigma", ",".join(map(str, sigma)),
                        *flags], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    bound = hysid.crlb(model, t_end=4.0, sigma=sigma, **kwargs)
    assert bound["status"] == "ok"
    printed = dict(re.findall(r"^  (\S+)\s+= \S+\s+(?:sd (\S+)|known)", p.stdout, re.M))
    assert set(printed) == set(bound["names"])
    for name_, sd in bound["sd"].items():
        assert (printed[name_] == "" and sd == 0.0) or float(printed[name_]) == float(f"{sd:.6g}"), name_


@pytest.mark.parametrize("mode", ["off", "on"])
def test_crlb_of_an_automaton_from_either_mode_equals_the_cli(mode):
    """The pump tank's bound from a given initial mode, as `hysid crlb --mode` prints it; the two modes give
    different bounds (the first switch comes at another time)."""
    model = str(SOURCE / "examples" / "pump-tank" / "model.toml")
    p = subprocess.run([BIN, "crlb", "--model-file", model, "--sigma", "0.001", "--mode", mode],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    bound = hysid.crlb(model, sigma=[0.001], mode=mode)
    assert bound["status"] == "ok"
    printed = dict(re.findall(r"^  (\S+)\s+= \S+\s+sd (\S+)", p.stdout, re.M))
    assert set(printed) == set(bound["names"])
    for name_, sd in bound["sd"].items():
        assert float(printed[name_]) == float(f"{sd:.6g}"), name_
    other = hysid.crlb(model, sigma=[0.001], mode="on" if mode == "off" else "off")
    assert other["sd"] != bound["sd"]


def test_runs_with_inputs_give_the_cli_report(tmp_path):
    """Two runs of the driven oscillator, each with its own input column: a list of y, u (dicts), t and the
    true jump counters, as two --data files; the same report, chains, truth and per-chain initial states."""
    model = EXAMPLES["driven-oscillator"]
    files, ys, us, ts, js = [], [], [], [], []
    for seed, x0 in ((5, "0,0"), (6, "0.5,0")):
        csv = tmp_path / f"run{seed}.csv"
        subprocess.run([BIN, "simulate", "--model-file", model, "--sigma", "0.001", "--seed", str(seed), "--t-end", "6",
                        "--x0", x0, "--out", str(csv)], check=True, capture_output=True)
        csv.with_suffix(".json").unlink()  # no sidecar: no truth, the same accuracy for both
        table = np.loadtxt(csv, delimiter=",", skiprows=1)
        files += ["--data", str(csv)]
        ys.append(table[:, 4:6])
        us.append({"u": table[:, 6]})
        ts.append(table[:, 0])
        js.append(table[:, 1])
    fit = hysid.identify(model, ys, t=ts, u=us, truth={"j": js})
    out = tmp_path / "fit.json"
    p = subprocess.run([BIN, "identify", "--model-file", model, *files, "--json", str(out)], capture_output=True, text=True)
    assert p.returncode in (0, 1), p.stderr
    cli = json.loads(out.read_text())
    assert key_differences(fit["report"], cli) == []
    assert [d for d in value_differences(fit["report"], cli) if not named_by_the_source(d.split(":")[0])
            and not d.startswith("report.data.runs")] == []
    assert len(cli["chains"]) == 2 and fit["refined"]["chains_used"] == 2
    with pytest.raises(ValueError, match=r"^u: y is a list of 2 runs; give u as a list of as many arrays or dicts"):
        hysid.identify(model, ys, t=ts, u=us[0])


# Refusals outside identify's option tables, each with the command line that refuses the same value: the
# CLI's message with its flag spelled as the keyword and CLI11's "(see hysid CMD --help)" hint left off.
# Model(name_or_file) takes what `models --show` takes: a registered name or a model file.
OTHER_REFUSALS = [
    ("seed -1", "hysid.simulate('impact-msd', seed=-1)", ["simulate", "--seed", "-1", "--out", "o/t.csv"]),
    ("trial -1", "hysid.simulate('impact-msd', trial=-1)", ["simulate", "--trial", "-1", "--out", "o/t.csv"]),
    ("seed 2^64", "hysid.simulate('impact-msd', seed=2**64)",
     ["simulate", "--seed", str(2**64), "--out", "o/t.csv"]),
    ("rtol -1", "hysid.simulate('impact-msd', rtol=-1.0)", ["simulate", "--rtol", "-1", "--out", "o/t.csv"]),
    ("atol nan", "hysid.simulate('impact-msd', atol=float('nan'))", ["simulate", "--atol", "nan", "--out", "o/t.csv"]),
    ("crlb rtol 0", "hysid.crlb('impact-msd', rtol=0.0)", ["crlb", "--rtol", "0"]),
    ("crlb mode of a model without modes", "hysid.crlb('impact-msd', mode='on')", ["crlb", "--mode", "on"]),
    ("Model unknown", "hysid.Model('pendulum')", ["models", "--show", "pendulum"]),
    ("Model missing file", "hysid.Model('nosuch.toml')", ["models", "--show", "nosuch.toml"]),
    ("Model directory", "hysid.Model('adir')", ["models", "--show", "adir"]),
    ("refine maybe", "hysid.identify('impact-msd', y, dt=5e-4, refine='maybe')",
     ["identify", "--data", "data.csv", "--refine", "maybe"]),
]


@pytest.mark.parametrize("name,call,args", OTHER_REFUSALS, ids=[c[0] for c in OTHER_REFUSALS])
def test_simulate_crlb_model_and_refine_refuse_as_the_cli(tmp_path, monkeypatch, name, call, args):
    (tmp_path / "adir").mkdir()
    y = np.zeros((50, 2))
    np.savetxt(tmp_path / "data.csv", np.hstack([np.arange(50)[:, None] * 5e-4, y]), delimiter=",",
               header="t,y1,y2", comments="")
    monkeypatch.chdir(tmp_path)
    p = subprocess.run([BIN, *args], capture_output=True, text=True)
    assert p.returncode == 2, (p.stdout, p.stderr)
    message = re.sub(r" \(see hysid [a-z]+ --help\)$", "",
                     p.stderr.strip().splitlines()[-1].removeprefix("hysid: error: "))
    message = re.sub(r"^--(show|model-file): ", "", message)  # Model() has no flag to name
    with pytest.raises(ValueError) as e:
        eval(call)
    assert str(e.value) == keyword(message)
    assert sorted(os.listdir(tmp_path)) == ["adir", "data.csv"]  # the refusals created nothing

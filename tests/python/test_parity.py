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

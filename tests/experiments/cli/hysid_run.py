"""What the tests here share: run a command, stopping the test when it exits with a code it does not
expect; the sd `hysid crlb` prints; a start file from a true model file; an identify report held
against the truth and the bound (the data as a user has them: bench/own_system.py's user_data); a
chosen model (--chosen-model) taken as it is by identify, simulate and crlb."""
import json
import os
import re
import subprocess
import sys

CRLB_LINE = re.compile(r"^\s+(\S+)\s+=\s+\S+\s+sd\s+(\S+)")


def run(*args, codes=(0,)):
    """Runs args; its standard output, or sys.exit with the command, its exit and its output."""
    p = subprocess.run(list(args), capture_output=True, text=True)
    if p.returncode not in codes:
        sys.exit(f"{' '.join(args)}: exit {p.returncode}, expected {' or '.join(map(str, codes))}\n"
                 f"{p.stdout}\n{p.stderr}")
    return p.stdout


def start_file(truth_file, replacements, path):
    """Writes truth_file's text with each (old, new) of replacements made (each old must occur)."""
    with open(truth_file) as f:
        text = f.read()
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new)
    with open(path, "w") as f:
        f.write(text)


def crlb_sd(*args):
    """`hysid crlb` run with args: {name: sd}."""
    return {m.group(1): float(m.group(2)) for m in map(CRLB_LINE.match, run(*args).splitlines()) if m}


def at_the_bound(label, report, truth, crlb):
    """The failures of an identify report (its JSON as a dict) against the truth and the bound: status
    not ok, an unknown beyond 4 reported SE of the truth, an SE off the CRLB sd by more than 25 %."""
    if report["status"] != "ok":
        return [f"{label}: status {report['status']}: {report['reason']}"]
    failures = []
    for name, value, se in zip(report["names"], report["estimate"], report["standard_errors"]):
        z = abs(value - truth[name]) / se
        ratio = se / crlb[name]
        print(f"{label}: {name} = {value:.9g} +- {se:.3g} (|z| {z:.2f}, se/crlb {ratio:.3f})")
        if z > 4.0:
            failures.append(f"{label}: {name} = {value} is {z:.2f} SE from {truth[name]}")
        if not 0.75 <= ratio <= 1.25:
            failures.append(f"{label}: {name}: se {se:.4g} is {ratio:.3f} x the CRLB sd {crlb[name]:.4g}")
    return failures


def chosen_model_taken(hysid, chosen, data_args, est, sigma, work, extra=(), rel=1e-6, floor=1e-3, se=None):
    """The failures of the chosen model file `chosen` taken as it is: `hysid identify` on it (data_args,
    extra) selects nothing and gives the estimates `est` ({name: value}) within rel × max(|value|,
    floor), or with `se` ({name: standard error}) within rel × se; `simulate` and `crlb` (at sigma)
    accept it."""
    bad = []
    out = os.path.join(work, "chosen_again.json")
    run(hysid, "identify", "--model-file", chosen, *data_args, "--json", out, *extra)
    with open(out) as f:
        again = json.load(f)
    if "selection" in again:
        bad.append("identify on the chosen model selected again")
    for name, value in zip(again["names"], again["estimate"]):
        if name not in est:
            continue
        if abs(value - est[name]) > rel * (se[name] if se is not None else max(abs(est[name]), floor)):
            bad.append(f"{name}: {value} on the chosen model, {est[name]} from the selection")
    run(hysid, "simulate", "--model-file", chosen, "--out", os.path.join(work, "chosen_sim.csv"))
    run(hysid, "crlb", "--model-file", chosen, "--sigma", sigma)
    return bad, again

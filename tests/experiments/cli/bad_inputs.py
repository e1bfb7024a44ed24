#!/usr/bin/env python3
"""Runs hysid on a list of bad inputs and writes docs/bad-inputs.md: each input, its exit code and its
message. Every case must exit 2 (bad input or usage) or 1 (a run that finished with a failed status),
without a crash, with exactly one line starting with "hysid:" on stderr, its last line, which names the
case's subject (the file, flag, key or run directory at fault; for run directories and flags the
script derives it from the command, see subject()). Inputs are created in a scratch directory under
relative names, so the table does not depend on where it runs.

Usage: tests/experiments/cli/bad_inputs.py HYSID OUT.md           writes the table
       tests/experiments/cli/bad_inputs.py --check HYSID DOC.md   checks every case and that DOC.md is what the
                                                    first form writes (the ctest bad_inputs.table)
"""
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")  # the source tree

SIM = ["--out", "o/t.csv"]
BASE = '[model]\nname = "impact-msd"\nt_end = 4.0\n[grid]\nsigma = 0.0\n'


def files():
    """name -> content of the inputs the cases read."""
    f = {
        "unclosed.csv": 't,y1,y2\n0,1,2\n0.1,"1,2\n0.2,1,2\n',
        "afterquote.csv": 't,y1,y2\n0,1,2\n0.1,"1"x,2\n0.2,1,2\n',
        "notime.csv": "t,y1,y2\n0,1,2\n,1,2\n0.2,1,2\n",
        "runsplit.csv": "run,t,y1,y2\n1,0,1,2\n2,0,1,2\n1,0.1,1,2\n",
        "runfrac.csv": "run,t,y1,y2\n1.5,0,1,2\n1.5,0.1,1,2\n1.5,0.2,1,2\n",
        "noheader.csv": "0,20,0\n0.0005,19.9,-0.1\n0.001,19.8,-0.2\n",
        "jhuge.csv": "t,j,y1,y2\n0,0,1,2\n0.1,10000000000,1,2\n0.2,0,1,2\n",
        "jfrac.csv": "t,j,y1,y2\n0,0,1,2\n0.1,0.5,1,2\n0.2,0,1,2\n",
        "jneg.csv": "t,j,y1,y2\n0,0,1,2\n0.1,-1,1,2\n0.2,0,1,2\n",
        "mapfrac.csv": "t,j,map,y1,y2\n0,0,-1,1,2\n0.1,1,0.5,1,2\n0.2,1,0,1,2\n",
        "big.csv": "t,y1,y2\n0,1,2\n0.1,1e308,2\n0.2,1,2\n",
        "tiny.csv": "t,y1,y2\n0,2e-200,1\n0.1,1e-200,2\n0.2,-1e-200,3\n",
        "overflow.csv": "t,y1,y2\n0,1,2\n0.1,1e400,2\n0.2,1,2\n",
        "nan.csv": "t,y1,y2\n0,1,2\n0.1,nan,2\n0.2,1,2\n",
        "inf.csv": "t,y1,y2\n0,1,2\n0.1,1,-inf\n0.2,1,2\n",
        "word.csv": "t,y1,y2\n0,1,2\n0.1,abc,2\n0.2,1,2\n",
        "emptycell.csv": "t,y1,y2\n0,1,2\n0.1,,2\n0.2,1,2\n",
        "ragged.csv": "t,y1,y2\n0,1,2\n0.1,1\n0.2,1,2\n",
        "extra.csv": "t,y1,y2\n0,1,2\n0.1,1,2,3\n0.2,1,2\n",
        "emptyhead.csv": "t,,y2\n0,1,2\n0.1,1,2\n0.2,1,2\n",
        "empty.csv": "",
        "comments.csv": "# only\n\n# comments\n",
        "headeronly.csv": "t,y1,y2\n",
        "two.csv": "t,y1,y2\n0,1,2\n0.1,1,2\n",
        "onecol.csv": "t,y1\n0,1\n0.1,1\n0.2,1\n",
        "backwards.csv": "t,y1,y2\n0,1,2\n0.2,1,2\n0.1,1,2\n",
        "same.csv": "t,y1,y2\n0,1,2\n0.1,1,2\n0.1,1,2\n",
        "longcell.csv": "t,y1,y2\n0,1,2\n0.1," + "1" * 5000 + ",2\n0.2,1,2\n",
        "longline.csv": "t,y1,y2\n0,1,2\n0.1," + "1," * 600000 + "2\n",
        "binary.csv": "t,y1,y2\n\x00\x01\x02,\xff\xfe,1\n",
        "hex.csv": "t,y1,y2\n0,0x10,2\n0.1,1,2\n0.2,1,2\n",
        "empty.toml": "",
        "syntax.toml": "[model\nname = 1\n",
        "nomodel.toml": "[grid]\nsigma = 0.0\ndt = 1e-3\n",
        "nogrid.toml": '[model]\nname = "impact-msd"\n',
        "unknownkey.toml": BASE + "dt = 1e-3\ncolour = 1\n",
        "unknownmodel.toml": '[model]\nname = "pendulum"\n[grid]\nsigma = 0.0\ndt = 1e-3\n',
        "badparam.toml": '[model]\nname = "impact-msd"\nparams = { k = 1.0 }\n[grid]\nsigma = 0.0\ndt = 1e-3\n',
        "x0len.toml": '[model]\nname = "impact-msd"\nx0 = [1.0]\n[grid]\nsigma = 0.0\ndt = 1e-3\n',
        "x0both.toml": '[model]\nname = "impact-msd"\nx0 = [1.0, 0.0]\nx0_range = [[0, 1], [0, 1]]\n'
                       '[grid]\nsigma = 0.0\ndt = 1e-3\n',
        "x0range.toml": '[model]\nname = "impact-msd"\nx0_range = [[2, 1], [0, 1]]\n[grid]\nsigma = 0.0\ndt = 1e-3\n',
        "tend.toml": '[model]\nname = "impact-msd"\nt_end = -1.0\n[grid]\nsigma = 0.0\ndt = 1e-3\n',
        "dtneg.toml": BASE + "dt = -1e-3\n",
        "dtstring.toml": BASE + 'dt = "fast"\n',
        "dtbig.toml": BASE + "dt = 3.0\n",
        "dttiny.toml": BASE + "dt = 1e-12\n",
        "dtdup.toml": BASE + "dt = [1e-3, 1e-3]\n",
        "dtempty.toml": BASE + "dt = []\n",
        "sigmaneg.toml": '[model]\nname = "impact-msd"\n[grid]\nsigma = -0.1\ndt = 1e-3\n',
        "rsmall.toml": BASE + "dt = 1e-3\nr = 0.5\n",
        "countzero.toml": BASE + "dt = { from = 1e-3, to = 2e-3, count = 0 }\n",
        "counthuge.toml": BASE + "dt = { from = 1e-3, to = 2e-3, count = 1000000000000 }\n",
        "countmiss.toml": BASE + "dt = { from = 1e-3, to = 2e-3 }\n",
        "logneg.toml": BASE + "dt = { from = -1e-3, to = 2e-3, count = 3, log = true }\n",
        "falsealarm.toml": BASE + "dt = 1e-3\nfalse_alarm = 0.7\n",
        "estimator.toml": BASE + 'dt = 1e-3\nestimator = "kalman"\n',
        "detector.toml": BASE + 'dt = 1e-3\ndetector = "oracle"\n',
        "trialszero.toml": BASE + "dt = 1e-3\n[run]\ntrials = 0\n",
        "trials2p62.toml": BASE + "dt = 1e-3\n[run]\ntrials = 4611686018427387904\n",
        "trials1e12.toml": BASE + "dt = 1e-3\n[run]\ntrials = 1000000000000\n",
        "cellsxtrials.toml": BASE + "dt = 1e-3\nr = { from = 2, to = 300, count = 10000 }\n[run]\ntrials = 10000\n",
        "seedneg.toml": BASE + "dt = 1e-3\n[run]\nseed = -1\n",
        "seedfloat.toml": BASE + "dt = 1e-3\n[run]\nseed = 1.5\n",
        "maxjumps.toml": BASE + "dt = 1e-3\n[simulator]\nmax_jumps = 4294967296\n",
        "window.toml": BASE + "dt = 1e-3\n[identifier]\nwindow = -4294967296\n",
        "rtol.toml": BASE + "dt = 1e-3\n[simulator]\nrtol = -1.0\n",
        "nonascii.toml": BASE + "dt = 1e-3 \u00fb\n",
        "mlstring.toml": 'a = """\\\n\u00fb"""\n',
        "bracket.toml": "[&\n",
        "nanvalue.toml": BASE + "dt = nan\n",
        "ok.toml": BASE + "dt = 2e-3\n[run]\ntrials = 1\n",
        "fapaper.toml": BASE + "dt = 1e-3\nfalse_alarm = 1e-3\n",
    }
    f.update(safety_files())
    f.update(LIMITS_FILES)
    f.update(INPUTS_FILES)
    f.update(TRUTH_FILES)
    f.update(AUTOMATON_FILES)
    f.update(ACCEPTED_FILES)
    f.update(UNCLEAR_FILES)
    return f


# Outputs never replace inputs, one study per run directory, expressions that may not assign: the inputs.
WALL = open(os.path.join(ROOT, "models", "wall-msd.toml")).read()
STUDY = '[model]\nfile = "study-model.toml"\nt_end = 4.0\n[grid]\nsigma = 0.0\ndt = 2e-3\n[run]\ntrials = 1\n'


def safety_files():
    return {
        "wall.toml": WALL,
        "wallm.json": WALL,
        "study-model.toml": WALL,
        "study.toml": STUDY,
        "in/summary.csv": BASE + "dt = 2e-3\n[run]\ntrials = 1\n",
        "assignD.toml": WALL.replace('D = "x == 1 && v >= 0"', 'D = "x = 1 && v >= 0"'),
        "assignphi.toml": WALL.replace('phi = [["v", 0, 0],', 'phi = [["v = v*2", 0, 0],'),
        "measured.toml": WALL.replace('states = ["x", "v"]', 'states = ["x", "v"]\nmeasured = ["y"]'),
        "inputunused.toml": WALL.replace('states = ["x", "v"]', 'states = ["x", "v"]\ninputs = ["u"]'),
        "inputclash.toml": WALL.replace('states = ["x", "v"]', 'states = ["x", "v"]\ninputs = ["v"]'),
        "gammaunused.toml": WALL.replace('[flow]', 'guard_params = [{ name = "w", value = 1.0 }]\n[flow]'),
        "bounds.toml": WALL.replace('value = 4.0,', 'value = 4.0, bounds = [5.0, 9.0],'),
        "flowrows.toml": WALL.replace('name = "alpha_x", value = 1.0, known = true,', 'name = "alpha_x", value = 1.0,'),
        "jumprows.toml": WALL.replace('name = "beta_x", value = 1.0, known = true,', 'name = "beta_x", value = 1.0,'),
        "jumpcandrow.toml": WALL.replace('rows = ["v"]\n\n[[guard]]', 'rows = ["v"]\ncandidates = { x = ["x"] }\n\n[[guard]]'),
        "jumpcandmany.toml": WALL.replace('rows = ["v"]\n\n[[guard]]', 'rows = ["v"]\ncandidates = { v = ['
                                          + ", ".join(f'"v^{i + 1}"' for i in range(30)) + "] }\n\n[[guard]]"),
    }


def safety_setup(hysid, d):
    """After the files: links to the data, a finished study whose model file then changes."""
    os.link(os.path.join(d, "sim.csv"), os.path.join(d, "hard-sim.csv"))
    os.symlink(os.path.join(d, "sim.csv"), os.path.join(d, "soft-sim.csv"))
    os.symlink(os.path.join(d, "wall.toml"), os.path.join(d, "soft-wall.toml"))
    subprocess.run([hysid, "sweep", "study.toml", "--out", "study", "--progress", "none"], cwd=d, check=True,
                   capture_output=True)
    subprocess.run([hysid, "merge", "done", "--out", "merged"], cwd=d, check=True, capture_output=True)
    with open(os.path.join(d, "study-model.toml"), "w") as f:
        f.write(WALL.replace('name = "k", value = 4.0', 'name = "k", value = 6.0'))


def safety_cases():
    data = ["identify", "--refine", "none", "--data", "sim.csv"]
    return [
        ("identify: --trace is the --data file", data + ["--trace", "sim.csv"]),
        ("identify: --hulls is the --data file through a hard link", data + ["--hulls", "hard-sim.csv"]),
        ("identify: --json is the --data file through a symbolic link", data + ["--json", "soft-sim.csv"]),
        ("identify: --json is the sidecar of --data", data + ["--json", "sim.json"]),
        ("identify: --json a directory", data + ["--json", "o"]),
        ("identify: --json under a file", data + ["--json", "ok.toml/x.json"]),
        ("identify: --hulls the same file as --trace", data + ["--trace", "o/x.csv", "--hulls", "./o/x.csv"]),
        ("simulate: --out is the --model-file", ["simulate", "--model-file", "wall.toml", "--out", "wall.toml"]),
        ("simulate: the sidecar of --out is the --model-file",
         ["simulate", "--model-file", "wallm.json", "--out", "wallm.csv"]),
        ("simulate: --jumps-out is the --model-file through a symbolic link",
         ["simulate", "--model-file", "wall.toml", "--jumps-out", "soft-wall.toml"] + SIM),
        ("sweep: the sweep file is the run's summary.csv", ["sweep", "in/summary.csv", "--out", "in"]),
        ("sweep: resumed after the model file's k changed", ["sweep", "study.toml", "--out", "study"]),
        ("merge: --out is another sweep's run directory", ["merge", "done", "--out", "theirs"]),
        ("sweep: --out holds a merge's tables", ["sweep", "ok.toml", "--out", "merged"]),
        ("reproduce paper: --out is a sweep's run directory", ["reproduce", "paper", "--out", "done"]),
        ("reproduce paper: --out holds a merge's tables", ["reproduce", "paper", "--out", "merged"]),
        ("model file: '=' for '==' in sets.D", ["simulate", "--model-file", "assignD.toml"] + SIM),
        ("model file: an assignment in flow.phi", ["simulate", "--model-file", "assignphi.toml"] + SIM),
        ("model file: a measured name that is not a state", ["models", "--show", "measured.toml"]),
        ("model file: an input used in no expression", ["models", "--show", "inputunused.toml"]),
        ("model file: an input named like a state", ["models", "--show", "inputclash.toml"]),
        ("model file: a guard parameter used in no expression", ["models", "--show", "gammaunused.toml"]),
        ("model file: bounds that exclude the value", ["models", "--show", "bounds.toml"]),
    ]


SAFETY_SUBJECTS = {
    "compare: one model file": "candidate model files",
    "compare: a model file that does not load": "pumpguard.toml",
    'identify: a sidecar with "rtol": "x"': "rtolx.json",
    "sweep: sweep.json is a directory": "jsondir/sweep.json",
    "crlb: --t-end= with nothing after": "--t-end",
    "HYSID_MAX_SAMPLES=1000: the built-in models load, the run is refused": "HYSID_MAX_SAMPLES",
    "HYSID_MAX_SAMPLES=abc": "HYSID_MAX_SAMPLES",
    "reproduce paper: beyond HYSID_MAX_SAMPLES": "HYSID_MAX_SAMPLES",
    "simulate: --out is the --model-file": "--out wall.toml",
    "simulate: the sidecar of --out is the --model-file": "--out (sidecar)",
    "simulate: --jumps-out is the --model-file through a symbolic link": "--jumps-out",
    "sweep: resumed after the model file's k changed": "study: holds",
    "merge: --out is another sweep's run directory": "--out theirs",
    "sweep: --out holds a merge's tables": "merged: holds another study",
    "reproduce paper: --out is a sweep's run directory": "--out done",
    "reproduce paper: --out holds a merge's tables": "--out merged",
    "model file: '=' for '==' in sets.D": "assignD.toml:39: sets.D",
    "model file: an assignment in flow.phi": "assignphi.toml:21: flow.phi[0][0]",
    "model file: a measured name that is not a state": "measured.toml:8: measured[0]",
    "model file: an input used in no expression": "inputunused.toml:8: inputs[0]",
    "model file: an input named like a state": "inputclash.toml:8: inputs[0]",
    "model file: a guard parameter used in no expression": "gammaunused.toml:20: guard_params[0].name",
    "model file: bounds that exclude the value": "bounds.toml:11: alpha[1].bounds",
    "model file: an unknown α outside the flow's rows": "flowrows.toml:23: flow.rows",
    "model file: an unknown β outside the jump's rows": "jumprows.toml:29: jump.rows",
    "model file: jump candidates in a row the jump does not identify": "jumpcandrow.toml:30: jump.candidates.x",
    "model file: jump candidates beyond β's 32 entries": "jumpcandmany.toml:30: jump.candidates.v[29]",
}


def cases():
    """(description, argv after hysid). Setup steps are run by main() first."""
    return [
        ("unknown subcommand", ["frobnicate"]),
        ("no subcommand", []),
        ("unknown flag", ["simulate", "--bogus", "1"] + SIM),
        ("flag without its value", ["simulate", "--dt"]),
        ("required flag missing", ["simulate"]),
        ("not a number", ["simulate", "--dt", "abc"] + SIM),
        ("--dt nan", ["simulate", "--dt", "nan"] + SIM),
        ("--t-end nan", ["simulate", "--t-end", "nan"] + SIM),
        ("--dt inf", ["simulate", "--dt", "inf"] + SIM),
        ("--dt 0", ["simulate", "--dt", "0"] + SIM),
        ("--dt -1", ["simulate", "--dt", "-1"] + SIM),
        ("--dt beyond the sample limit", ["simulate", "--dt", "1e-7"] + SIM),
        ("--t-end 0", ["simulate", "--t-end", "0"] + SIM),
        ("--seed -1", ["simulate", "--seed", "-1"] + SIM),
        ("--trial -1", ["simulate", "--trial", "-1"] + SIM),
        ("--seed 2^64", ["simulate", "--seed", "18446744073709551616"] + SIM),
        ("--sigma negative", ["simulate", "--sigma", "-0.1"] + SIM),
        ("--sigma of the wrong length", ["simulate", "--sigma", "1,2,3"] + SIM),
        ("--x0 of the wrong length", ["simulate", "--x0", "1,2,3"] + SIM),
        ("--x0 outside C and D", ["simulate", "--x0", "-1,0"] + SIM),
        ("--x0 nan", ["simulate", "--x0", "nan,0"] + SIM),
        ("--param unknown", ["simulate", "--param", "k=1"] + SIM),
        ("--param inf", ["simulate", "--param", "a=inf"] + SIM),
        ("--param without =", ["simulate", "--param", "a"] + SIM),
        ("--model unknown", ["simulate", "--model", "pendulum"] + SIM),
        ("--rtol negative", ["simulate", "--rtol", "-1"] + SIM),
        ("--max-jumps 0", ["simulate", "--max-jumps", "0"] + SIM),
        ("--out a directory", ["simulate", "--out", "o"]),
        ("--out under a file", ["simulate", "--out", "ok.toml/t.csv"]),
        ("--jumps-out a directory", ["simulate", "--jumps-out", "o"] + SIM),
        ("--jumps-out the sidecar of --out", ["simulate", "--jumps-out", "./o/t.json"] + SIM),
        ("jump budget exhausted (exit 1)", ["simulate", "--max-jumps", "2"] + SIM),
        ("stiff spring a = 1e12: not Zeno (exit 1, budget)", ["simulate", "--param", "a=1e12", "--max-jumps", "1000"] + SIM),
    ] + [
        (f"identify: {d}", ["identify", "--data", f])
        for d, f in [
            ("a quote not closed", "unclosed.csv"), ("text after a closing quote", "afterquote.csv"),
            ("time missing", "notime.csv"), ("a run's rows not contiguous", "runsplit.csv"),
            ("a fractional run number", "runfrac.csv"), ("no header", "noheader.csv"), ("j = 1e10", "jhuge.csv"),
            ("j = 0.5", "jfrac.csv"), ("j = -1", "jneg.csv"), ("a ground-truth map of 0.5", "mapfrac.csv"),
            ("a cell of 1e308", "big.csv"),
            ("a state column of values near 1e-200", "tiny.csv"),
            ("a cell of 1e400", "overflow.csv"), ("nan cell", "nan.csv"), ("-inf cell", "inf.csv"),
            ("a word", "word.csv"), ("an empty cell", "emptycell.csv"), ("too few cells", "ragged.csv"),
            ("too many cells", "extra.csv"), ("an empty header name", "emptyhead.csv"),
            ("empty file", "empty.csv"), ("only comments", "comments.csv"), ("header only", "headeronly.csv"),
            ("2 samples", "two.csv"), ("too few columns", "onecol.csv"), ("time backwards", "backwards.csv"),
            ("time repeated", "same.csv"),
            ("a 5000-byte cell", "longcell.csv"), ("a 1.2 MB line", "longline.csv"), ("binary bytes", "binary.csv"),
            ("hexadecimal", "hex.csv"), ("missing file", "nosuch.csv"), ("a directory", "o"),
        ]
    ] + [
        ("identify: --trace a directory", ["identify", "--data", "sim.csv", "--trace", "o"]),
        ("identify: --r 1", ["identify", "--detector", "paper", "--r", "1", "--data", "sim.csv"]),
        ("identify: --columns names a column that is not there",
         ["identify", "--columns", "t=time,x,v", "--data", "sim.csv"]),
        ("identify: --columns names one state of two", ["identify", "--columns", "x", "--data", "sim.csv"]),
        ("identify: --columns names the time column with spaces, and one state of two",
         ["identify", "--columns", " t = t , x ", "--data", "sim.csv"]),
        ("identify: --model names a model file", ["identify", "--model", "wall.toml", "--data", "sim.csv"]),
        ("identify: the model's state names and y1, y2 both present as different columns",
         ["identify", "--data", "bothnames.csv"]),
        ("identify: --max-gap 0", ["identify", "--max-gap", "0", "--data", "sim.csv"]),
        ("identify: --forgetting 2", ["identify", "--forgetting", "2", "--data", "sim.csv"]),
        ("identify: --false-alarm 0", ["identify", "--detector", "residual", "--false-alarm", "0", "--data", "sim.csv"]),
        ("identify: --data-atol nan", ["identify", "--detector", "residual", "--data-atol", "nan", "--data", "sim.csv"]),
        ("identify: --estimator unknown", ["identify", "--estimator", "kalman", "--data", "sim.csv"]),
        ("identify: noise shape not square", ["identify", "--estimator", "gtls", "--flow-noise-shape", "1,0,0",
                                             "--data", "sim.csv"]),
    ] + [
        (f"sweep: {d}", ["sweep", f, "--out", "run", "--dry-run"])
        for d, f in [
            ("empty file", "empty.toml"), ("TOML syntax", "syntax.toml"), ("no [model]", "nomodel.toml"),
            ("no [grid]", "nogrid.toml"), ("unknown key", "unknownkey.toml"), ("unknown model", "unknownmodel.toml"),
            ("unknown parameter", "badparam.toml"), ("x0 length", "x0len.toml"), ("x0 and x0_range", "x0both.toml"),
            ("x0_range lo > hi", "x0range.toml"), ("t_end < 0", "tend.toml"), ("dt < 0", "dtneg.toml"),
            ("dt a string", "dtstring.toml"), ("dt > t_end/2", "dtbig.toml"), ("dt beyond the sample limit", "dttiny.toml"),
            ("dt twice", "dtdup.toml"), ("dt empty", "dtempty.toml"), ("sigma < 0", "sigmaneg.toml"),
            ("r ≤ 1", "rsmall.toml"), ("range count 0", "countzero.toml"), ("range count 1e12", "counthuge.toml"),
            ("range without count", "countmiss.toml"), ("log range from < 0", "logneg.toml"),
            ("false_alarm 0.7", "falsealarm.toml"), ("unknown estimator", "estimator.toml"),
            ("unknown detector", "detector.toml"), ("trials = 0", "trialszero.toml"), ("trials = 2^62", "trials2p62.toml"),
            ("trials = 1e12", "trials1e12.toml"), ("seed = -1", "seedneg.toml"), ("seed = 1.5", "seedfloat.toml"),
            ("max_jumps = 2^32", "maxjumps.toml"), ("window = -2^32", "window.toml"), ("rtol < 0", "rtol.toml"),
            ("non-ASCII outside strings", "nonascii.toml"), ("non-ASCII after a line-ending backslash", "mlstring.toml"),
            ("'[&' (a toml++ assertion)", "bracket.toml"), ("dt = nan", "nanvalue.toml"),
            ("missing file", "nosuch.toml"),
        ]
    ] + [
        ("sweep: 10 000 cells × 10 000 trials", ["sweep", "cellsxtrials.toml", "--out", "run"]),
        ("sweep: --out a file", ["sweep", "ok.toml", "--out", "ok.toml"]),
        ("sweep: --shard 0/2", ["sweep", "ok.toml", "--shard", "0/2", "--out", "run"]),
        ("sweep: --threads -1", ["sweep", "ok.toml", "--threads", "-1", "--out", "run"]),
        ("sweep: --progress fancy", ["sweep", "ok.toml", "--progress", "fancy", "--out", "run"]),
        ("identify: --progress fancy", ["identify", "--data", "sim.csv", "--progress", "fancy"]),
        ("sweep: HYSID_MAX_TRIALS=many", ["env:HYSID_MAX_TRIALS=many", "sweep", "ok.toml", "--out", "run"]),
        ("sweep: another sweep's journal (sweep.json deleted)", ["sweep", "ok.toml", "--out", "foreign"]),
        ("sweep: a foreign row in the journal", ["sweep", "ok.toml", "--out", "forged"]),
        ("sweep: a torn line inside the journal", ["sweep", "ok.toml", "--out", "torn"]),
        ("sweep: the run directory is locked", ["sweep", "ok.toml", "--out", "locked"]),
        ("merge: output is an input", ["merge", "done", "--out", "done"]),
        ("merge: not a run directory", ["merge", "o", "--out", "m"]),
    ] + safety_cases() + LIMITS_CASES + INPUTS_CASES + TRUTH_CASES + MEASURED_CASES + AUTOMATON_CASES + PROBE_CASES \
      + ACCEPTED_CASES + UNCLEAR_CASES + COMPARE_CASES


# Found by tests/experiments/cli/probe_hostile.py: empty flag values, a column named twice, a grid axis no detector
# reads, a small sample limit with the built-in models.
PROBE_CASES = [
    ("an empty flag value (an unset shell variable)", ["simulate", "--dt", ""] + SIM),
    ("crlb: --t-end= with nothing after", ["crlb", "--t-end="]),
    ("identify: --columns names one column twice", ["identify", "--columns", "x,x", "--data", "sim.csv"]),
    ("identify: --columns names the time as a state", ["identify", "--columns", "t,x", "--data", "sim.csv"]),
    ("sweep: false_alarm with the paper detector only", ["sweep", "fapaper.toml", "--out", "run", "--dry-run"]),
    ("HYSID_MAX_SAMPLES=1000: the built-in models load, the run is refused",
     ["env:HYSID_MAX_SAMPLES=1000", "simulate"] + SIM),
    ("HYSID_MAX_SAMPLES=abc", ["env:HYSID_MAX_SAMPLES=abc", "simulate"] + SIM),
    ("reproduce paper: beyond HYSID_MAX_SAMPLES", ["env:HYSID_MAX_SAMPLES=1000", "reproduce", "paper", "--out", "rp"]),
    ("model file: an unknown α outside the flow's rows", ["models", "--show", "flowrows.toml"]),
    ("model file: an unknown β outside the jump's rows", ["models", "--show", "jumprows.toml"]),
    ("model file: jump candidates in a row the jump does not identify", ["models", "--show", "jumpcandrow.toml"]),
    ("model file: jump candidates beyond β's 32 entries", ["models", "--show", "jumpcandmany.toml"]),
]


# Bounded inputs and the smaller flag, data and model-file refusals: their inputs and cases.
MSD = open(os.path.join(ROOT, "models", "impact-msd.toml"),
           encoding="utf-8").read()
LIMITS_FILES = {
    "jdown.csv": "t,j,y1,y2\n0,0,1,2\n0.1,1,1,2\n0.2,0,1,2\n0.3,1,1,2\n",
    "dupcol.csv": "t,y1,y1,y2\n0,1,1,2\n0.1,1,1,2\n0.2,1,1,2\n",
    "bothnames.csv": "t,x,v,y1,y2\n0,1,2,1,2\n0.1,1,2,1,2\n0.2,1,2,1,2\n",
    "cronly.csv": "t,y1,y2\r0,1,2\r0.1,1,2\r",
    "tinystep.csv": "t,y1,y2\n0,1,2\n1e-320,1,2\n2e-320,1,2\n",
    "rowsdup.toml": MSD.replace('rows = ["v"]', 'rows = ["v", "v"]', 1),
    "x0name.toml": MSD.replace('name = "mu"', 'name = "x0[x]"', 1),
    "longdefault.toml": re.sub(r"\ndt = [^\n]*", "\ndt = 1e-9", MSD, count=1),
}
LIMITS_CASES = [
    ("--seed 0x10 (only decimal; 010 is ten)", ["simulate", "--seed", "0x10"] + SIM),
    ("--sigma with an empty item", ["simulate", "--sigma", "0.1,,0.2"] + SIM),
    ("--x0 with an empty item", ["simulate", "--x0", "1,"] + SIM),
    ("--param twice", ["simulate", "--param", "a=5", "--param", "a=6"] + SIM),
    ("identify: an option the detector does not read", ["identify", "--tau0", "10", "--data", "sim.csv"]),
    ("identify: an option the estimator does not read", ["identify", "--estimator", "gtls", "--jump-p0", "10",
                                                         "--data", "sim.csv"]),
    ("reproduce example6: a flag it does not read", ["reproduce", "example6", "--estimator", "bogus"]),
    ("reproduce: --false-alarm with the paper detector", ["reproduce", "--false-alarm", "1e-3"]),
    ("identify: j decreasing", ["identify", "--data", "jdown.csv"]),
    ("identify: two columns named y1", ["identify", "--data", "dupcol.csv"]),
    ("identify: CR line endings, 2 samples", ["identify", "--data", "cronly.csv"]),
    ("identify: a time step of 1e-320 s", ["identify", "--data", "tinystep.csv"]),
    ("identify: a FIFO as data", ["identify", "--data", "fifo.csv"]),
    ("model file: a row named twice", ["simulate", "--model-file", "rowsdup.toml"] + SIM),
    ("model file: a parameter named x0[x]", ["simulate", "--model-file", "x0name.toml"] + SIM),
    ("model file: default trajectory beyond the sample limit", ["simulate", "--model-file", "longdefault.toml"] + SIM),
    ("model file: a character device", ["simulate", "--model-file", "/dev/zero"] + SIM),
    ("model file: beyond the size limit", ["env:HYSID_MAX_INPUT_FILE=100", "simulate", "--model-file", "rowsdup.toml"]
     + SIM),
    ("sweep: a FIFO as the sweep file", ["sweep", "fifo.csv", "--out", "run", "--dry-run"]),
    ("identify: --param-bound of an unknown parameter", ["identify", "--param-bound", "k=0,1", "--data", "sim.csv"]),
    ("identify: --param-bound with LO >= HI", ["identify", "--param-bound", "a=6,4", "--data", "sim.csv"]),
    ("identify: --param-bound that excludes the start", ["identify", "--param-bound", "a=6,7", "--data", "sim.csv"]),
    ("identify: --param-bound without HI", ["identify", "--param-bound", "a=1", "--data", "sim.csv"]),
    ("identify: --param-bound LO not a number", ["identify", "--param-bound", "a=low,7", "--data", "sim.csv"]),
    ("crlb: --param-bound of a known constant", ["crlb", "--param-bound", "alpha_x=0,2"]),
    ("crlb: --param-bound twice", ["crlb", "--param-bound", "a=0,10", "--param-bound", "a=1,9"]),
]

# Measured inputs: the driven oscillator's model file, input files and data without the input column.
DRIVEN = open(os.path.join(ROOT, "examples", "driven-oscillator",
                           "driven-oscillator.toml"), encoding="utf-8").read()
INPUTS_FILES = {
    "driven.toml": DRIVEN,
    "driven-nodefault.toml": re.sub(r"\ninput_defaults = [^\n]*", "", DRIVEN, count=1),
    "u-short.csv": "t,u\n0,0\n1,1\n2,0\n",
    "times-off.csv": "t,x\n0,20\n0.00075,20\n",
    "times-twice.csv": "t,x\n0,20\n0.0005,20\n0.0005,20\n",
    "u-nocol-t.csv": "time,x\n0,20\n0.0005,20\n",
    "u-nocol.csv": "t,w\n0,0\n50,1\n",
    "u-missing.csv": "t,u\n0,0\n1,\n50,1\n",
    "nou.csv": "t,y1,y2\n0,0,0\n0.001,0,0\n0.002,0,0\n",
    "gtlsinputs.toml": '[model]\nfile = "driven.toml"\n[grid]\nsigma = 0.0\ndt = 1e-2\nestimator = ["rls", "gtls"]\n',
}
INPUTS_CASES = [
    ("simulate --inputs: a model without inputs", ["simulate", "--inputs", "u-short.csv"] + SIM),
    ("simulate --inputs: no column for the input", ["simulate", "--model-file", "driven.toml", "--inputs",
                                                    "u-nocol.csv"] + SIM),
    ("simulate --inputs: a missing input cell", ["simulate", "--model-file", "driven.toml", "--inputs",
                                                 "u-missing.csv"] + SIM),
    ("simulate --inputs: shorter than the run", ["simulate", "--model-file", "driven.toml", "--inputs",
                                                 "u-short.csv"] + SIM),
    ("simulate: an input without a default and no --inputs", ["simulate", "--model-file",
                                                              "driven-nodefault.toml"] + SIM),
    ("identify: a model input missing from the data", ["identify", "--model-file", "driven.toml", "--data",
                                                       "nou.csv"]),
    ("sweep: gtls on a model with inputs", ["sweep", "gtlsinputs.toml", "--out", "run", "--dry-run"]),
]

# The truth of simulated data, files of several without samples, malformed expressions.
TRUTH_FILES = {
    "plusplus.toml": WALL.replace('phi = [["v", 0, 0],', 'phi = [["v++", 0, 0],'),
}
TRUTH_CASES = [
    ("identify: --param disagrees with the data's sidecar", ["identify", "--param", "a=6", "--data", "sim.csv"]),
    ("identify: the sidecars of two --data files disagree", ["identify", "--data", "sim.csv", "--data", "simb.csv"]),
    ("identify: a second --data file with a header only",
     ["identify", "--data", "sim.csv", "--data", "headeronly.csv"]),
    ("model file: \"v++\" in flow.phi (muParser's internal error)", ["simulate", "--model-file", "plusplus.toml"] + SIM),
]


# Hybrid automata in model files: the examples with one thing wrong each.
EXAMPLES = os.path.join(ROOT, "examples")
PUMP = open(os.path.join(EXAMPLES, "pump-tank", "model.toml"), encoding="utf-8").read()
FC = open(os.path.join(EXAMPLES, "floor-ceiling", "model.toml"), encoding="utf-8").read()
AUTOMATON_FILES = {
    "pumpfrom.toml": PUMP.replace('from = "off"', 'from = "idle"', 1),
    "pumpmode.toml": PUMP.replace('mode = "on"\nt_end', 'mode = "idle"\nt_end', 1),
    "pumpguard.toml": PUMP.replace('guard = "low"', 'guard = "lowest"', 1),
    "pumpunused.toml": PUMP.replace('guard = "high"', 'guard = "low"', 1),
    "pumprows.toml": PUMP.replace('guard = "low"', 'guard = "low"\nrows = ["h"]', 1),
    "pumpnoflow.toml": PUMP.replace('modes = ["off", "on"]', 'modes = ["off", "on", "boost"]', 1),
    "pumpflowtable.toml": PUMP.replace('[[flow]]\nmode = "off"\nphi = [["-sqrt(h)", 0]]\n\n[[flow]]\nmode = "on"\n',
                                       '[flow]\n', 1),
    "pumpdupname.toml": PUMP.replace('name = "pump-off"', 'name = "pump-on"', 1),
    "pump.toml": PUMP,
    "fctwo.toml": FC.replace('guard = "ceiling"', 'guard = "floor"', 1),
    "fcnobeta.toml": re.sub(r'beta = \[ \{ name = "one_c".*?\]\n', "", FC, count=1, flags=re.S),
    "fcboth.toml": FC.replace("[flow]", '[[flow]]\nmode = "x"\nphi = [["v", 0], [0, -1]]\n\n[flow]', 1),
    "fcrows.toml": FC.replace('psi = [["h", 0], [0, "-v"]]\nrows = ["v"]', 'psi = [["h", 0], [0, "-v"]]\nrows = ["h"]', 1),
    "localizeauto.toml": '[model]\nfile = "pump.toml"\n[grid]\nsigma = 0.0\ndt = 1e-2\n[identifier]\nlocalize = true\n',
}
AUTOMATON_CASES = [
    ("model file: a map from a mode that does not exist", ["simulate", "--model-file", "pumpfrom.toml"] + SIM),
    ("model file: defaults.mode not among the modes", ["simulate", "--model-file", "pumpmode.toml"] + SIM),
    ("model file: a map on a guard that does not exist", ["simulate", "--model-file", "pumpguard.toml"] + SIM),
    ("model file: a guard that triggers no map", ["simulate", "--model-file", "pumpunused.toml"] + SIM),
    ("model file: two maps on one guard in one mode", ["simulate", "--model-file", "fctwo.toml"] + SIM),
    ("model file: psi without beta", ["simulate", "--model-file", "fcnobeta.toml"] + SIM),
    ("model file: an identity map with rows", ["simulate", "--model-file", "pumprows.toml"] + SIM),
    ("model file: a jump map name twice", ["simulate", "--model-file", "pumpdupname.toml"] + SIM),
    ("model file: a mode without a [[flow]]", ["simulate", "--model-file", "pumpnoflow.toml"] + SIM),
    ("model file: [flow] with modes", ["simulate", "--model-file", "pumpflowtable.toml"] + SIM),
    ("model file: [flow] and [[flow]] together", ["simulate", "--model-file", "fcboth.toml"] + SIM),
    ("model file: an unknown β of a [[jump]] map outside its rows", ["models", "--show", "fcrows.toml"]),
    ("identify: --localize with a hybrid automaton",
     ["identify", "--model-file", "pump.toml", "--data", "sim.csv", "--localize"]),
    ("sweep: localize = true with a hybrid automaton", ["sweep", "localizeauto.toml", "--out", "run", "--dry-run"]),
    ("crlb: --mode for a model without modes", ["crlb", "--mode", "on"]),
    ("crlb: --mode that is not one of the model's", ["crlb", "--model-file", "pump.toml", "--mode", "idle"]),
]
# Inputs that were accepted and gave a wrong answer: refused by name.
ACCEPTED_FILES = {
    "knownbound.toml": MSD.replace('{ name = "alpha_x", value = 1.0, known = true,',
                                   '{ name = "alpha_x", value = 1.0, known = true, bounds = [0, 2],', 1),
    "linebreakname.toml": MSD.replace('name = "mu"', 'name = "k\\nz"', 1),
    "nodefaultsweep.toml": '[model]\nfile = "driven-nodefault.toml"\n[grid]\nsigma = 0.0\ndt = 1e-2\n',
}
ACCEPTED_CASES = [
    ("identify: --sigma 0", ["identify", "--sigma", "0", "--data", "sim.csv"]),
    ("identify: --param-bound with --refine none",
     ["identify", "--param-bound", "mu=-0.01,0.01", "--refine", "none", "--data", "sim.csv"]),
    ("model file: bounds on a known parameter", ["simulate", "--model-file", "knownbound.toml"] + SIM),
    ("identify: --flow-noise-shape with rls",
     ["identify", "--flow-noise-shape", "1,0,0,0,1,0,0,0,1", "--data", "sim.csv"]),
    ("model file: a parameter name with a line break", ["simulate", "--model-file", "linebreakname.toml"] + SIM),
    ("sweep: an input without input_defaults", ["sweep", "nodefaultsweep.toml", "--out", "run", "--dry-run"]),
]

# Messages that did not name the file, flag or key, or not the real reason.
UNCLEAR_FILES = {
    "utf16.csv": "\ufefft,y1,y2\n0,1,2\n0.1,1,2\n0.2,1,2\n".encode("utf-16-le"),
    "divzero.toml": MSD.replace('[0, "-x", "-v"]', '[0, "-x/0", "-v"]', 1),
    "sqrtneg.toml": MSD.replace('[0, "-x", "-v"]', '[0, "sqrt(-1-x*x)", "-v"]', 1),
    "uhuge.toml": DRIVEN.replace('u = "sin(1.3*t) + 0.5*sin(3.7*t)"', 'u = "1e999"', 1),
}
UNCLEAR_CASES = [
    ("identify: a UTF-16 CSV", ["identify", "--data", "utf16.csv"]),
    ("identify: a sidecar with \"rtol\": \"x\"", ["identify", "--data", "rtolx.csv"]),
    ("sweep: sweep.json is a directory", ["sweep", "ok.toml", "--out", "jsondir"]),
    ("model file: -x/0 in phi", ["simulate", "--model-file", "divzero.toml"] + SIM),
    ("model file: sqrt(-1-x*x) in phi", ["simulate", "--model-file", "sqrtneg.toml"] + SIM),
    ("crlb: --sigma 1e-300", ["crlb", "--sigma", "1e-300"]),
    ("crlb: --sigma 1e300", ["crlb", "--sigma", "1e300"]),
    ("crlb: --t-end 1e-300", ["crlb", "--t-end", "1e-300"]),
    ("simulate: --param a=1e999", ["simulate", "--param", "a=1e999"] + SIM),
    ("identify: --r 1e999", ["identify", "--detector", "paper", "--r", "1e999", "--data", "sim.csv"]),
    ("identify: --false-alarm 1e-320",
     ["identify", "--detector", "residual", "--false-alarm", "1e-320", "--data", "sim.csv"]),
    ("simulate: input_defaults u = \"1e999\"", ["simulate", "--model-file", "uhuge.toml"] + SIM),
    ("simulate: --max-jumps 2147483648", ["simulate", "--max-jumps", "2147483648"] + SIM),
    ("identify: --columns gives t= twice", ["identify", "--columns", "t=t,t=j,x,v", "--data", "sim.csv"]),
]


def truth_setup(d):
    """simb.csv: sim.csv again, its sidecar saying a = 6."""
    with open(os.path.join(d, "sim.csv")) as src, open(os.path.join(d, "simb.csv"), "w") as dst:
        dst.write(src.read())
    with open(os.path.join(d, "sim.json")) as src, open(os.path.join(d, "simb.json"), "w") as dst:
        dst.write(src.read().replace('"a": 5.0', '"a": 6.0'))


# hysid compare: candidate model files on one record.
COMPARE_CASES = [
    ("compare: one model file", ["compare", "pump.toml", "--data", "sim.csv"]),
    ("compare: a model file that does not load", ["compare", "pump.toml", "pumpguard.toml", "--data", "sim.csv"]),
    ("compare: --holdout 1", ["compare", "pump.toml", "pump.toml", "--data", "sim.csv", "--holdout", "1"]),
    ("compare: --json is a model file", ["compare", "pump.toml", "pump.toml", "--data", "sim.csv", "--json", "pump.toml"]),
    ("compare: --holdout-by chains", ["compare", "pump.toml", "pump.toml", "--data", "sim.csv", "--holdout-by", "chains"]),
    ("compare: --holdout-by chain on one chain",
     ["compare", "pump.toml", "pump.toml", "--data", "sim.csv", "--holdout-by", "chain"]),
    ("compare: --chain-head 0.7", ["compare", "pump.toml", "pump.toml", "--data", "sim.csv", "--chain-head", "0.7"]),
]

# Partial outputs and known initial states (examples/drag-ball).
MEASURED_CASES = [
    ("identify: --x0-known names no state", ["identify", "--data", "sim.csv", "--x0-known", "q"]),
    ("identify: --x0 without --x0-known", ["identify", "--data", "sim.csv", "--x0", "20,0"]),
    ("identify: --x0-known on two runs", ["identify", "--data", "sim.csv", "--data", "sim.csv", "--x0-known"]),
    ("identify: --x0-known with --refine none", ["identify", "--data", "sim.csv", "--x0-known", "--refine", "none"]),
    ("crlb: --x0-known names a state twice", ["crlb", "--x0-known", "x,x"]),
    ("crlb: --sigma of the wrong length", ["crlb", "--sigma", "1,2,3"]),
    ("crlb: --times off the grid", ["crlb", "--times", "times-off.csv"]),
    ("crlb: --times twice the same", ["crlb", "--times", "times-twice.csv"]),
    ("crlb: --times without a column t", ["crlb", "--times", "u-nocol-t.csv"]),
]

# Cases whose message names something the command line does not show as its last flag or file.
SUBJECTS = {
    "no subcommand": "subcommand",
    "required flag missing": "--out",
    "--out a directory": "--out",
    "--out under a file": "--out",
    "jump budget exhausted (exit 1)": "jump budget",
    "stiff spring a = 1e12: not Zeno (exit 1, budget)": "jump budget",
    "sweep: --out a file": "--out",
    "sweep: HYSID_MAX_TRIALS=many": "HYSID_MAX_TRIALS",
    "sweep: another sweep's journal (sweep.json deleted)": "foreign/trials.journal:1",
    "sweep: a foreign row in the journal": "forged/trials.journal:3",
    "sweep: a torn line inside the journal": "torn/trials.journal:3",
    "sweep: the run directory is locked": "locked",
    "merge: output is an input": "--out",
    "merge: not a run directory": "o:",
    **SAFETY_SUBJECTS,
    "model file: beyond the size limit": "rowsdup.toml",
    "simulate: an input without a default and no --inputs": "--inputs",
    "identify: a model input missing from the data": "nou.csv",
    "identify: the sidecars of two --data files disagree": "simb.json: parameters.a",
    "identify: a second --data file with a header only": "headeronly.csv",
    "model file: \"v++\" in flow.phi (muParser's internal error)": "plusplus.toml:21: flow.phi[0][0]",
    "identify: --x0-known on two runs": "--x0-known",
    "model file: a map from a mode that does not exist": "pumpfrom.toml:27: jump[0].from",
    "model file: defaults.mode not among the modes": "pumpmode.toml:49: defaults.mode",
    "model file: a map on a guard that does not exist": "pumpguard.toml:29: jump[0].guard",
    "model file: a guard that triggers no map": "pumpunused.toml:42: guard[1]",
    "model file: two maps on one guard in one mode": "fctwo.toml:26: jump[1].guard",
    "model file: psi without beta": "fcnobeta.toml:27: jump[1].psi",
    "model file: an identity map with rows": "pumprows.toml:30: jump[0].rows",
    "model file: a jump map name twice": "pumpdupname.toml:32: jump[1].name",
    "model file: a mode without a [[flow]]": "pumpnoflow.toml:7: modes",
    "model file: [flow] with modes": "pumpflowtable.toml:17: flow",
    "model file: [flow] and [[flow]] together": "fcboth.toml:15: TOML syntax",
    "model file: an unknown β of a [[jump]] map outside its rows": "fcrows.toml:22: jump[0].rows",
    "sweep: localize = true with a hybrid automaton": "localizeauto.toml:7: identifier.localize",
    "sweep: gtls on a model with inputs": "gtlsinputs.toml:6: grid.estimator",
    "identify: --x0-known with --refine none": "--x0-known",
}


def subject(desc, args):
    """What the message must name: the last flag other than --out/--data/--dry-run, else the input file."""
    if desc in SUBJECTS:
        return SUBJECTS[desc]
    args = [a for a in args if not a.startswith("env:")]
    flags = [a for a in args if a.startswith("--") and a not in ("--out", "--data", "--dry-run")]
    if flags:
        return flags[-1]
    if args[0] == "identify":
        return args[args.index("--data") + 1]
    return args[1] if len(args) > 1 else args[0]


def run(hysid, args, cwd):
    env = dict(os.environ)
    while args and args[0].startswith("env:"):
        k, v = args[0][4:].split("=", 1)
        env[k] = v
        args = args[1:]
    p = subprocess.run([hysid] + args, cwd=cwd, env=env, capture_output=True)
    return p.returncode, p.stderr.decode("utf-8", "replace")


def setup(hysid, d):
    for name, text in files().items():
        os.makedirs(os.path.dirname(os.path.join(d, name)), exist_ok=True)
        if isinstance(text, bytes):
            with open(os.path.join(d, name), "wb") as f:
                f.write(text)
            continue
        with open(os.path.join(d, name), "w", encoding="utf-8", newline="") as f:
            f.write(text)
    os.makedirs(os.path.join(d, "o"))
    os.makedirs(os.path.join(d, "jsondir", "sweep.json"))
    os.mkfifo(os.path.join(d, "fifo.csv"))
    subprocess.run([hysid, "simulate", "--sigma", "0.1", "--out", "sim.csv"], cwd=d, check=True, capture_output=True)
    # The same data with a sidecar whose solver.rtol is text.
    import json
    with open(os.path.join(d, "sim.csv")) as src, open(os.path.join(d, "rtolx.csv"), "w") as dst:
        dst.write(src.read())
    with open(os.path.join(d, "sim.json")) as src:
        meta = json.load(src)
    meta["solver"]["rtol"] = "x"
    with open(os.path.join(d, "rtolx.json"), "w") as dst:
        json.dump(meta, dst)
    # A finished run, and run directories corrupted from it.
    subprocess.run([hysid, "sweep", "ok.toml", "--out", "done", "--progress", "none"], cwd=d, check=True,
                   capture_output=True)
    other = files()["ok.toml"].replace("trials = 1", "trials = 1\nseed = 7")
    with open(os.path.join(d, "other.toml"), "w") as f:
        f.write(other)
    subprocess.run([hysid, "sweep", "other.toml", "--out", "theirs", "--progress", "none"], cwd=d, check=True,
                   capture_output=True)
    mine = open(os.path.join(d, "done", "trials.journal")).read().splitlines(True)
    theirs = open(os.path.join(d, "theirs", "trials.journal")).read().splitlines(True)
    for name, lines, identity in [("foreign", theirs, False), ("forged", mine[:2] + theirs[2:3], True),
                                  ("torn", mine[:2] + [mine[2][:20] + mine[2]], True), ("locked", mine, True)]:
        os.makedirs(os.path.join(d, name))
        with open(os.path.join(d, name, "trials.journal"), "w") as f:
            f.writelines(lines)
        if identity:
            with open(os.path.join(d, "done", "sweep.json")) as src, open(os.path.join(d, name, "sweep.json"), "w") as dst:
                dst.write(src.read())
    safety_setup(hysid, d)
    truth_setup(d)


def check_case(desc, args, code, err):
    """The policy every case must meet, or a description of how it fails."""
    lines = [l for l in err.strip().splitlines() if l.strip()]
    said = [l for l in lines if l.startswith("hysid:")]
    want = subject(desc, args)
    if code not in (1, 2):
        return f"exit {code} (a crash or an accepted input)"
    if len(said) != 1 or lines[-1] != said[0]:
        return "not exactly one 'hysid:' line, the last on stderr"
    if len(said[0]) > 400:
        return "a message longer than 400 characters"
    if want not in said[0]:
        return f"the message does not name {want!r}"
    return None


def table(rows):
    cell = lambda s: s.replace("|", "\\|").replace("\n", " ")
    out = ("# Bad inputs and their messages\n\n"
           "Generated by `tests/experiments/cli/bad_inputs.py build/bin/hysid docs/bad-inputs.md`; the\n"
           "test `bad_inputs.table` runs `tests/experiments/cli/bad_inputs.py --check` and fails when a case\n"
           "crashes, exits other than 2 (bad input or usage) or 1 (a run that finished with a failed status),\n"
           "prints other than one `hysid:` line naming the file, line, key, flag or directory at fault, or\n"
           "when this file is not what the script writes. Each input is run in a scratch directory.\n"
           f"{len(rows)} inputs.\n\n| # | input | command | exit | message |\n|---|---|---|---|---|\n")
    for i, (desc, cmd, code, msg) in enumerate(rows, 1):
        out += f"| {i} | {cell(desc)} | `{cell(cmd)}` | {code} | {cell(msg)} |\n"
    return out


def normalized(text):
    """The table with long decimals, sweep hashes and the length of a quoted journal row masked: the
    last digits of a stop time may differ between compilers, a sweep's hash changes whenever the
    configuration gains a field, and a journal row ends with its trial's run time."""
    text = re.sub(r"… \(\d+ bytes\)", "… (<n> bytes)", text)
    return re.sub(r"\b[0-9a-f]{16}\b", "<hash>", re.sub(r"\d+\.\d{6,}", "<t>", text))


def main():
    check = sys.argv[1] == "--check"
    hysid, out = os.path.abspath(sys.argv[1 + check]), sys.argv[2 + check]
    rows, bad = [], []
    with tempfile.TemporaryDirectory(prefix="hysid-bad-inputs-") as d:
        setup(hysid, d)
        import fcntl
        lock = open(os.path.join(d, "locked", ".lock"), "w")
        fcntl.flock(lock, fcntl.LOCK_EX)
        for desc, args in cases():
            code, err = run(hysid, list(args), d)
            problem = check_case(desc, args, code, err)
            if problem:
                bad.append(f"{desc}: {problem}; exit {code}, stderr {err!r:.300}")
            lines = [l for l in err.strip().splitlines() if l.strip()]
            msg = lines[-1] if lines else ""
            shown = " ".join(a or "''" for a in args if not a.startswith("env:"))
            env = " ".join(a[4:] for a in args if a.startswith("env:"))
            cmd = (env + " " if env else "") + "hysid " + shown
            rows.append((desc, cmd.replace(d, "."), code, msg.replace(d, ".")))
    text = table(rows)
    if check:
        with open(out, encoding="utf-8") as f:
            doc = f.read()
        if normalized(doc) != normalized(text):
            old, new = normalized(doc).splitlines(), normalized(text).splitlines()
            diff = [f"  doc: {a}\n  now: {b}" for a, b in zip(old, new) if a != b][:5]
            bad.append(f"{out} is not current (regenerate: tests/experiments/cli/bad_inputs.py HYSID {out}); "
                       f"{len(old)} vs {len(new)} lines, first differences:\n" + "\n".join(diff))
    else:
        with open(out, "w", encoding="utf-8") as f:
            f.write(text)
    if bad:
        print("\n".join(bad), file=sys.stderr)
        sys.exit(1)
    print(f"{len(rows)} bad inputs: each refused by name" + (f", {out} current" if check else f", wrote {out}"))


if __name__ == "__main__":
    main()

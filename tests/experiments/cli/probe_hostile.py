#!/usr/bin/python3
"""A hostile-input probe of hysid, as a new user would try it: every class of the "never destroy a
user's data, never mix two studies, never crash Python" issue, varied (other flags, files, orders and
subcommands than the bad-inputs table of tests/), and the six guarantees as properties:

  refuse    a bad input is refused by name: exit 2, one `hysid: error:` line naming the flag, key, file
            or line; every input unchanged byte for byte, no new file, no temporary file left
  ok        an input that is fine runs (exit 0), and what it means is what it says (--seed 010 is ten)
  overwrite (1) no output overwrites an input: every output flag x every input x every spelling
            (./, absolute, dir/.., hard link, symbolic link, link to a link)
  study     (2) a run directory holds one study: a sweep killed, a model- or sweep-file field changed
            (each kind), resumed -> refused; names with commas, quotes, line breaks stay one CSV cell;
            merge onto another study refused
  expr      (3) no expression key accepts an assignment, an increment or a comma list
  units     (4) identify is invariant to rescaling time and state by 1e-6 and 1e+6 (default options and
            --refine none): the estimates, mapped back, agree in relative terms
  python    (5) the module refuses what the CLI refuses, with the CLI's message, and never crashes
  limits    (6) FIFOs, devices, directories, huge and sparse files, the named limits and their
            variables, a full stdout, SIGINT/SIGTERM inside a long sweep unit honoured within 1 s,
            a 16-state model (the exact hulls' limit named, the run bounded, a signal honoured)
  readonly  every output flag onto a read-only directory (a read-only bind mount in a private mount
            namespace as root, a mode-0555 directory otherwise): refused by name with the errno
            text, exit 2, nothing written anywhere (no partial set of outputs), an existing file
            there unchanged

Usage: probe_hostile.py [--full] [--only CLASS,...] HYSID PYTHON_DIR
Prints one line per failure and a summary by class; exits 1 on any failure. Without --full a fixed
subset (every class, about a minute on a laptop) runs; --full runs every case. Each case runs in a
scratch directory that is removed afterwards.
"""
import argparse
import csv
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

ARGS = None
HYSID = None
PYDIR = None
ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")  # the source tree
WALL = open(os.path.join(ROOT, "models", "wall-msd.toml")).read()
DRIVEN = open(os.path.join(ROOT, "examples", "driven-oscillator", "driven-oscillator.toml")).read()
COUNTS = {}
SECONDS = {}
FAILURES = []
TEMPLATE = None
WORK = None  # every scratch directory is under TMPDIR/probe_hostile-PID-*, removed at the end


def remove_stale_work():
    """Removes the scratch directories of earlier probes that were killed (their process is gone)."""
    base = tempfile.gettempdir()
    for name in os.listdir(base):
        m = re.fullmatch(r"probe_hostile-(\d+)-\w+", name)
        if m and not os.path.exists(f"/proc/{m.group(1)}"):
            shutil.rmtree(os.path.join(base, name), ignore_errors=True)


# Open findings that the probe reports but does not count as failures, each with why it is open; a
# known finding that no longer occurs is printed so that it can be removed from here.
KNOWN = {}
KNOWN_SEEN = set()


def fail(cls, name, what):
    if (cls, name) in KNOWN:
        KNOWN_SEEN.add((cls, name))
        print(f"known [{cls}] {name}: {what}", flush=True)
        return
    FAILURES.append((cls, name, what))
    print(f"FAIL [{cls}] {name}: {what}", flush=True)


def count(cls):
    COUNTS[cls] = COUNTS.get(cls, 0) + 1


# ---------------------------------------------------------------- scratch directories and hashes

def snapshot(d):
    """path -> sha256 of every regular file under d (symbolic links: their target text; directories:
    "dir", so that a refusal that leaves a new directory is seen)."""
    out = {}
    for base, dirs, files in os.walk(d):
        for sub in dirs:
            out[os.path.relpath(os.path.join(base, sub), d) + "/"] = "dir"
        for f in files:
            p = os.path.join(base, f)
            rel = os.path.relpath(p, d)
            if os.path.islink(p):
                out[rel] = "link:" + os.readlink(p)
            elif os.path.isfile(p) and os.path.getsize(p) < (64 << 20):
                with open(p, "rb") as fh:
                    out[rel] = hashlib.sha256(fh.read()).hexdigest()
            else:
                out[rel] = "special"
    return out


def temporaries(d):
    return [os.path.join(b, f) for b, _, fs in os.walk(d) for f in fs if f.endswith(".tmp")]


def build_template():
    """The inputs every case may read: a simulation of impact-msd and of wall-msd, model files, sweep
    files, a finished sweep."""
    d = tempfile.mkdtemp(prefix="template-", dir=WORK)
    def w(name, text):
        os.makedirs(os.path.dirname(os.path.join(d, name)) or d, exist_ok=True)
        with open(os.path.join(d, name), "w") as f:
            f.write(text)
    w("wall.toml", WALL)
    w("wallj.json", WALL)
    w("driven.toml", DRIVEN)
    w("ok.toml", OK_SWEEP)
    w("study-model.toml", WALL)
    w("study.toml", STUDY_SWEEP)
    w("u.csv", "t,u\n" + "".join(f"{i * 0.01:.2f},{(i % 7) * 0.1:.1f}\n" for i in range(1001)))
    w("empty.toml", "")
    w("syntax.toml", "[model\n")
    w("empty.csv", "")
    for cmd in (["simulate", "--t-end", "5", "--sigma", "1e-3", "--out", "sim.csv"],
                ["simulate", "--t-end", "5", "--sigma", "1e-3", "--seed", "2", "--out", "simb.csv"],
                ["simulate", "--model-file", "wall.toml", "--t-end", "5", "--sigma", "1e-4", "--out", "wsim.csv"],
                ["sweep", "ok.toml", "--out", "done", "--progress", "none"]):
        r = subprocess.run([HYSID] + cmd, cwd=d, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"probe: cannot build the template ({' '.join(cmd)}): {r.stderr}")
    return d


class Scratch:
    """A copy of the template, removed on exit."""
    def __enter__(self):
        self.d = tempfile.mkdtemp(prefix="case-", dir=WORK)
        shutil.rmtree(self.d)
        shutil.copytree(TEMPLATE, self.d, symlinks=True)
        return self.d

    def __exit__(self, *exc):
        shutil.rmtree(self.d, ignore_errors=True)


def env_with(extra):
    e = dict(os.environ)
    e.pop("HYSID_MAX_SAMPLES", None)
    e.update(extra or {})
    return e


def run(args, cwd, env=None, timeout=120, stdout=None, prefix=()):
    t0 = time.monotonic()
    try:
        r = subprocess.run(list(prefix) + [HYSID] + args, cwd=cwd, env=env_with(env), timeout=timeout,
                           stdout=stdout if stdout is not None else subprocess.PIPE,
                           stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return None, "", f"timed out after {timeout} s", timeout
    out = r.stdout.decode(errors="replace") if r.stdout is not None else ""
    return r.returncode, out, r.stderr.decode(errors="replace"), time.monotonic() - t0


def show(args):
    return "hysid " + " ".join(a if a and " " not in a and "\n" not in a else repr(a) for a in args)


def check_refusal(cls, name, args, subject, d, env=None, before=None, allow_new=(), prefix=()):
    """Runs args in d and checks a refusal: exit 2, one hysid: line naming subject, inputs unchanged,
    no new file, no temporary file."""
    count(cls)
    before = before if before is not None else snapshot(d)
    rc, _, err, _ = run(args, d, env, prefix=prefix)
    where = f"{show(args)}"
    lines = [l for l in err.splitlines() if l.startswith("hysid:")]
    if rc is None or rc < 0:
        fail(cls, name, f"{where}: crashed or hung ({err.strip()[-200:] or rc})")
        return
    if rc != 2:
        fail(cls, name, f"{where}: exit {rc}, expected 2 (refused); stderr: {err.strip()[-300:]!r}")
    elif len(lines) != 1 or not lines[0].startswith("hysid: error:"):
        fail(cls, name, f"{where}: expected one 'hysid: error:' line, got {lines!r}")
    elif subject and subject not in lines[0]:
        fail(cls, name, f"{where}: the message does not name {subject!r}: {lines[0]!r}")
    check_unchanged(cls, name, where, d, before, allow_new)


def check_unchanged(cls, name, where, d, before, allow_new=()):
    after = snapshot(d)
    for p, h in before.items():
        if after.get(p) != h:
            fail(cls, name, f"{where}: input {p} {'deleted' if p not in after else 'changed'}")
    new = [p for p in after if p not in before and not any(p.startswith(a) for a in allow_new)]
    if new:
        fail(cls, name, f"{where}: left new files {sorted(new)[:4]}")
    if temporaries(d):
        fail(cls, name, f"{where}: left temporary files {temporaries(d)[:3]}")


def refuse(cls, name, args, subject, setup=None, env=None):
    with Scratch() as d:
        if setup:
            setup(d)
        check_refusal(cls, name, args, subject, d, env)


def accept(cls, name, args, setup=None, env=None, expect=(0,), check=None):
    """A run that must finish with an exit code in expect (0 ok, 1 a finished run with a not-ok
    status); check(d, stdout, stderr) returns an error text or None."""
    count(cls)
    with Scratch() as d:
        if setup:
            setup(d)
        rc, out, err, _ = run(args, d, env)
        if rc not in expect:
            fail(cls, name, f"{show(args)}: exit {rc}, expected {expect}; stderr: {err.strip()[-300:]!r}")
            return
        if temporaries(d):
            fail(cls, name, f"{show(args)}: left temporary files")
        if check:
            problem = check(d, out, err)
            if problem:
                fail(cls, name, f"{show(args)}: {problem}")


def write(d, name, text, mode="w"):
    p = os.path.join(d, name)
    os.makedirs(os.path.dirname(p), exist_ok=True)
    with open(p, mode) as f:
        f.write(text)


OK_SWEEP = '[model]\nname = "impact-msd"\nt_end = 4.0\n[grid]\nsigma = 0.0\ndt = 2e-3\nrefine = "none"\n' \
           '[run]\ntrials = 2\n'
STUDY_SWEEP = '[model]\nfile = "study-model.toml"\nt_end = 3.0\n[grid]\nsigma = 1e-3\ndt = 2e-3\n' \
              'refine = "none"\n[run]\ntrials = 40\n'
MODEL_FLAGS = {"simulate": ["--out", "o/t.csv"], "crlb": [], "identify": ["--data", "sim.csv", "--refine", "none"]}


# ---------------------------------------------------------------- refuse: bad values, varied

def cases_refuse():
    """Bad flag values across subcommands (the table has most of them for simulate only)."""
    c = []
    for sub, tail in MODEL_FLAGS.items():
        floats = ["--t-end", "--dt", "--rtol", "--atol"] if sub != "identify" else []
        for flag in floats:
            for v in ["nan", "inf", "-inf", "-1", "abc", "1e400", ""]:
                c.append((f"{sub} {flag} {v!r}", [sub, flag, v] + tail, flag))
        if sub != "identify":
            for v in ["nan", "inf", "-1", "0.1,,0.2", ",0.1", "0.1,", "1,2,3", "abc", "0.1;0.2"]:
                c.append((f"{sub} --sigma {v!r}", [sub, "--sigma", v] + tail, "--sigma"))
            for v in ["nan,0", "1", "1,2,3", ",", "1,,2", "inf,0", "abc,0", "20,0,"]:
                c.append((f"{sub} --x0 {v!r}", [sub, "--x0", v] + tail, "--x0"))
        for v in ["a", "=5", "a=", "a=nan", "a=inf", "k=1", "a=abc", "a=5=6", " a=5x"]:
            c.append((f"{sub} --param {v!r}", [sub, "--param", v] + tail, "--param"))
        c.append((f"{sub} --param given twice, same value", [sub, "--param", "a=5", "--param", "a=5"] + tail, "--param"))
        c.append((f"{sub} --param a known constant twice", [sub, "--param", "b=1", "--param", "b=0.1"] + tail, "--param"))
        for v in ["pendulum", "", "impact-msd ", "../models/impact-msd"]:
            c.append((f"{sub} --model {v!r}", [sub, "--model", v] + tail, "--model"))
        for v in ["nosuch.toml", "o", "empty.toml", "syntax.toml", "sim.csv", "/dev/zero", "/dev/null"]:
            c.append((f"{sub} --model-file {v}", [sub, "--model-file", v] + tail, v.split("/")[-1] if v != "o" else "o"))
        c.append((f"{sub} --model and --model-file", [sub, "--model", "impact-msd", "--model-file", "wall.toml"] + tail, "--model"))
    for sub in ("simulate", "reproduce"):
        tail = MODEL_FLAGS.get(sub, ["--out", "rp"])
        for v in ["-1", "0x10", "1e3", "18446744073709551616", "+5", "5.0", "", "٥", "1 2"]:
            c.append((f"{sub} --seed {v!r}", [sub, "--seed", v] + tail, "--seed"))
    for v in ["-1", "0x10", "2.5", "99999999999999999999999"]:
        c.append((f"simulate --trial {v!r}", ["simulate", "--trial", v, "--out", "o/t.csv"], "--trial"))
    # identify: the table's bad data, as a second --data file, behind a good one, in another order
    bad = {"dup.csv": "t,x,x\n0,1,2\n0.1,1,2\n0.2,1,2\n", "jdown.csv": "t,j,x,v\n0,1,1,2\n0.1,0,1,2\n0.2,0,1,2\n",
           "back.csv": "t,x,v\n0,1,2\n0.2,1,2\n0.1,1,2\n", "nul.csv": "t,x,v\n0,1,2\n\0,1,2\n0.2,1,2\n",
           "inf.csv": "t,x,v\n0,1,2\n0.1,inf,2\n0.2,1,2\n", "word.csv": "t,x,v\n0,1,2\n0.1,1,zz\n0.2,1,2\n",
           "ragged.csv": "t,x,v\n0,1,2\n0.1,1\n0.2,1,2\n", "tiny.csv": "t,x,v\n0,1,2\n1e-200,1,2\n0.2,1,2\n",
           "huge.csv": "t,x,v\n0,1,2\n0.1,1,1e200\n0.2,1,2\n", "quote.csv": 't,x,v\n0,1,2\n0.1,"1,2\n',
           "hdr.csv": "t,x,v\n",
           "jbig.csv": "t,j,x,v\n0,0,1,2\n0.1,2147483648,1,2\n0.2,2147483648,1,2\n",
           "runs.csv": "run,t,x,v\n1,0,1,2\n2,0,1,2\n1,0.1,1,2\n"}
    for f, text in bad.items():
        setup = (lambda t, n: lambda d: write(d, n, t))(text, f)
        c.append((f"identify --data sim.csv --data {f}", ["identify", "--refine", "none", "--data", "sim.csv",
                                                          "--data", f], f, setup))
        c.append((f"identify --data {f} (flags after)", ["identify", "--data", f, "--estimator", "gtls"], f, setup))
    for cols in ["x,x", "t=t,x,x", "t=,x,v", "x,v,true_x", "t=x,x,v", ",x,v", "X,V"]:
        c.append((f"identify --columns {cols}", ["identify", "--refine", "none", "--data", "sim.csv", "--columns", cols], "--columns"))
    ident = [("--forgetting", ["0", "-1", "nan", "1.5"], []), ("--false-alarm", ["0.5", "1", "nan", "-1"], []),
             ("--r", ["0.5", "nan", "inf"], ["--detector", "paper"]), ("--max-gap", ["-1", "nan"], []),
             ("--data-atol", ["-1", "inf"], []), ("--estimator", ["", "RLS", "rls,gtls"], []),
             ("--detector", ["bogus", ""], []), ("--refine", ["maybe", ""], []),
             ("--r", ["2"], []), ("--tau0", ["1"], ["--detector", "residual"]), ("--jump-refactor-every", ["3"], ["--estimator", "integral"]),
             ("--x0-known", ["z", "x,x", ""], []), ("--sigma", ["-1", "nan", "1,2,3"], []),
             ("--param-bound", ["a=1", "a=2,1", "a=nan,7", "zz=0,1", "a=0,1"], [])]
    for flag, values, extra in ident:
        for v in values:
            c.append((f"identify {flag} {v!r} {' '.join(extra)}", ["identify", "--data", "sim.csv"] + extra + [flag, v], flag))
    # sweep-file keys the table does not vary
    base = '[model]\nname = "impact-msd"\nt_end = 4.0\n[grid]\nsigma = 0.0\ndt = 2e-3\n'
    sw = {"sigma nan": (base.replace("sigma = 0.0", "sigma = nan"), "grid.sigma"),
          "sigma inf": (base.replace("sigma = 0.0", "sigma = inf"), "grid.sigma"),
          "sigma list with a string": (base.replace("sigma = 0.0", 'sigma = [0.0, "x"]'), "grid.sigma"),
          "dt inf": (base.replace("dt = 2e-3", "dt = inf"), "grid.dt"),
          "r nan": (base + "r = nan\n", "grid.r"),
          "t_end nan": (base.replace("t_end = 4.0", "t_end = nan"), "model.t_end"),
          "t_end 0": (base.replace("t_end = 4.0", "t_end = 0.0"), "model.t_end"),
          "params a nan": (base.replace("t_end = 4.0", "t_end = 4.0\nparams = { a = nan }"), "model.params.a"),
          "x0 nan": (base.replace("t_end = 4.0", "t_end = 4.0\nx0 = [nan, 0.0]"), "model.x0"),
          "x0 strings": (base.replace("t_end = 4.0", 't_end = 4.0\nx0 = ["1", "0"]'), "model.x0"),
          "x0_range nan": (base.replace("t_end = 4.0", "t_end = 4.0\nx0_range = [[nan, 1], [0, 1]]"), "model.x0_range"),
          "unknown table": (base + "[colour]\nred = 1\n", "colour"),
          "unknown run key": (base + "[run]\ntrial = 3\n", "run.trial"),
          "unknown model key": (base.replace("t_end = 4.0", "t_end = 4.0\nparam = { a = 1 }"), "model.param"),
          "unknown simulator key": (base + "[simulator]\nrtoll = 1e-9\n", "simulator.rtoll"),
          "unknown identifier key": (base + "[identifier]\nwindoww = 3\n", "identifier.windoww"),
          "model file missing": ('[model]\nfile = "nosuch.toml"\n[grid]\nsigma = 0.0\ndt = 2e-3\n', "nosuch.toml"),
          "model file a directory": ('[model]\nfile = "o"\n[grid]\nsigma = 0.0\ndt = 2e-3\n', "o"),
          "model file is the sweep file": ('[model]\nfile = "bad.toml"\n[grid]\nsigma = 0.0\ndt = 2e-3\n', "bad.toml"),
          "model file and name": ('[model]\nfile = "wall.toml"\nname = "impact-msd"\n[grid]\nsigma = 0.0\ndt = 2e-3\n', "model"),
          "seed 2^64": (base + "[run]\nseed = 18446744073709551616\n", "bad.toml"),
          "trials string": (base + '[run]\ntrials = "3"\n', "run.trials"),
          "estimator list unknown": (base + 'estimator = ["rls", "kalman"]\n', "grid.estimator"),
          "estimator twice": (base + 'estimator = ["rls", "rls"]\n', "grid.estimator"),
          "detector twice in file": (base + 'detector = "paper"\ndetector = "residual"\n', "bad.toml"),
          "false_alarm with paper": (base + 'detector = "paper"\nfalse_alarm = 1e-3\n', "grid.false_alarm"),
          "refine unknown": (base + 'refine = "maybe"\n', "grid.refine"),
          "max_steps 0": (base + "[simulator]\nmax_steps = 0\n", "simulator.max_steps"),
          "atol nan": (base + "[simulator]\natol = nan\n", "simulator.atol"),
          "bom then syntax": ("\ufeff" + base + "[grid\n", "bad.toml"),
          "NUL byte": (base + "\0\n", "bad.toml")}
    for what, (text, subject) in sw.items():
        setup = (lambda t: lambda d: write(d, "bad.toml", t))(text)
        c.append((f"sweep: {what}", ["sweep", "bad.toml", "--out", "run", "--dry-run"], subject, setup))
    for flag, v in [("--shard", "3/2"), ("--shard", "1/0"), ("--shard", "a/b"), ("--shard", "1"), ("--threads", "abc"),
                    ("--progress", ""), ("--out", "ok.toml"), ("--out", "sim.csv/x")]:
        c.append((f"sweep {flag} {v!r}", ["sweep", "ok.toml", "--out", "run", flag, v] if flag != "--out" else
                  ["sweep", "ok.toml", flag, v], flag if flag != "--out" else v.split("/")[0]))
    c.append(("merge: a missing directory", ["merge", "nosuch", "--out", "m"], "nosuch"))
    c.append(("merge: a file as input", ["merge", "sim.csv", "--out", "m"], "sim.csv"))
    c.append(("merge: --out a file", ["merge", "done", "--out", "sim.csv"], "sim.csv"))
    c.append(("merge: no input", ["merge", "--out", "m"], "merge"))
    for sub in (["reproduce", "paper"], ["reproduce"]):
        for flag, v in [("--sigma", "nan"), ("--sigma", "-1"), ("--estimator", "bogus"), ("--detector", "bogus"),
                        ("--false-alarm", "0.1"), ("--out", "sim.csv")]:
            c.append((f"{' '.join(sub)} {flag} {v}", sub + ["--out", "rp", flag, v] if flag != "--out" else sub + [flag, v],
                      flag if flag != "--out" else "sim.csv"))
    c.append(("reproduce an unknown study", ["reproduce", "paper2"], "paper2"))
    c.append(("reproduce example6 --sigma", ["reproduce", "example6", "--sigma", "0.1", "--out", "rp"], "--sigma"))
    for v in ["nosuch", "o", "empty.toml", "syntax.toml", "/dev/zero", "sim.csv"]:
        c.append((f"models --show {v}", ["models", "--show", v], v.split("/")[-1]))
    out = []
    for case in c:
        name, args, subject = case[:3]
        setup = case[3] if len(case) > 3 else None
        out.append(lambda n=name, a=args, s=subject, st=setup: refuse("refuse", n, a, s, st))
    return out


# ---------------------------------------------------------------- ok: accepted inputs mean what they say

def same_files(a, b):
    def check(d, out, err):
        if open(os.path.join(d, a), "rb").read() != open(os.path.join(d, b), "rb").read():
            return f"{a} and {b} differ"
        return None
    return check


def cases_ok():
    c = []
    def twice(name, first, second, a, b):
        c.append(lambda: accept("ok", name, ["simulate"] + first + ["--out", a],
                                setup=lambda d: run(["simulate"] + second + ["--out", b], d),
                                check=same_files(a, b)))
    twice("--seed 010 is ten", ["--seed", "010", "--sigma", "0.1", "--t-end", "2"],
          ["--seed", "10", "--sigma", "0.1", "--t-end", "2"], "a.csv", "b.csv")
    twice("--trial 007 is seven", ["--trial", "007", "--sigma", "0.1", "--t-end", "2"],
          ["--trial", "7", "--sigma", "0.1", "--t-end", "2"], "a.csv", "b.csv")
    twice("--param a=5 is the default", ["--param", "a=5", "--t-end", "2"], ["--t-end", "2"], "a.csv", "b.csv")
    twice("--sigma 0.1 is --sigma 0.1,0.1", ["--sigma", "0.1", "--t-end", "2"], ["--sigma", "0.1,0.1", "--t-end", "2"],
          "a.csv", "b.csv")
    twice("the model file is the built-in", ["--model-file", os.path.join(ROOT, "models", "impact-msd.toml"), "--t-end", "2"],
          ["--t-end", "2"], "a.csv", "b.csv")
    bom = lambda d: write(d, "bom.toml", "\ufeff" + WALL)
    crlf = lambda d: write(d, "crlf.toml", WALL.replace("\n", "\r\n"))
    c.append(lambda: accept("ok", "model file with a BOM", ["models", "--show", "bom.toml"], setup=bom))
    c.append(lambda: accept("ok", "model file with CRLF", ["models", "--show", "crlf.toml"], setup=crlf))
    def crlf_data(d):
        text = open(os.path.join(d, "sim.csv")).read()
        write(d, "crlf.csv", "\ufeff" + text.replace("\n", "\r\n"))
        write(d, "cr.csv", text.replace("\n", "\r"))
    for f in ("crlf.csv", "cr.csv"):
        c.append(lambda f=f: accept("ok", f"identify {f} reads as sim.csv", ["identify", "--refine", "none", "--data", f,
                                                                          "--json", "x.json"], setup=crlf_data,
                                    check=lambda d, o, e: None if json.load(open(os.path.join(d, "x.json")))["samples"]
                                    == 10001 else "not all samples read"))
    def truth_doubles(d, out, err):
        m = re.search(r"truth \(column j\): (\d+) true jumps", out)
        return None if m and int(m.group(1)) == 2 * JUMPS5 else f"true jumps of sim.csv twice: {m and m.group(1)}, expected {2 * JUMPS5}"
    def short_runs(d):
        write(d, "onerow.csv", "t,x,v\n0,1,2\n")
        write(d, "bomcr.csv", "\ufefft,x,v\r0,1,2\r0.1,1,2\r")
    samples = lambda n: lambda d, o, e: None if json.load(open(os.path.join(d, "x.json")))["samples"] == n else "samples"
    c.append(lambda: accept("ok", "a second run of one sample", ["identify", "--refine", "none", "--data", "sim.csv",
                                                                "--data", "onerow.csv", "--json", "x.json"],
                            setup=short_runs, check=samples(10002)))
    c.append(lambda: accept("ok", "a second run with a BOM and CR line ends", ["identify", "--refine", "none", "--data",
                                                                              "sim.csv", "--data", "bomcr.csv", "--json",
                                                                              "x.json"], setup=short_runs, check=samples(10003)))
    c.append(lambda: accept("ok", "ground truth of two --data files is the sum", ["identify", "--refine", "none", "--data",
                                                                                 "sim.csv", "--data", "sim.csv"],
                            check=truth_doubles))
    for sub in (["models"], ["models", "--show", "wall.toml"], ["crlb"], ["crlb", "--model-file", "wall.toml"],
                ["identify", "--data", "sim.csv"], ["identify", "--model-file", "wall.toml", "--data", "wsim.csv"],
                ["identify", "--data", "sim.csv", "--estimator", "frisch", "--refine", "none"],
                ["simulate", "--model-file", "driven.toml", "--inputs", "u.csv", "--t-end", "5", "--out", "d.csv"],
                ["sweep", "ok.toml", "--out", "done"], ["merge", "done", "--out", "merged"]):
        c.append(lambda a=sub: accept("ok", " ".join(a), a))
    no_internal = lambda d, o, e: "invariant" in e.lower() and "internal invariant printed as an error" or None
    for r in ("1.0001", "1.01", "2"):
        c.append(lambda r=r: accept("ok", f"--second-pass with the paper detector at r = {r}",
                                    ["identify", "--data", "sim.csv", "--refine", "none", "--detector", "paper", "--r", r,
                                     "--second-pass"], expect=(0, 1), check=no_internal))
    c.append(lambda: accept("ok", "status not ok: jump budget", ["simulate", "--max-jumps", "3", "--out", "o.csv"], expect=(1,),
                            check=lambda d, o, e: None if "jump-budget" in e else "no jump-budget status"))
    c.append(lambda: accept("ok", "status not ok: dt longer than the time between jumps, in seconds",
                            ["identify", "--data", "coarse.csv"], expect=(0, 1),
                            setup=lambda d: run(["simulate", "--dt", "0.4", "--sigma", "1e-3", "--out", "coarse.csv"], d)))
    return c


# ---------------------------------------------------------------- overwrite: (1) no output replaces an input

def spellings(d, target):
    """name -> how to make it: the ways a user can name the file target (relative to d)."""
    base = os.path.basename(target)
    def hard(n):
        os.link(os.path.join(d, target), os.path.join(d, n))
    def soft(n):
        os.symlink(target, os.path.join(d, n))
    def soft2(n):
        os.symlink(target, os.path.join(d, "s1-" + base))
        os.symlink("s1-" + base, os.path.join(d, n))
    def softdir(n):
        os.symlink(".", os.path.join(d, "here"))
    return {"plain": (target, None), "./": ("./" + target, None), "absolute": (os.path.join(d, target), None),
            "dir/..": ("o/../" + target, lambda n: os.makedirs(os.path.join(d, "o"), exist_ok=True)),
            "hard link": ("hl-" + base, hard), "symbolic link": ("sl-" + base, soft),
            "link to a link": ("sl2-" + base, soft2), "through a linked directory": ("here/" + target, softdir)}


def overwrite_case(name, make_args, target, sidecar=False):
    """make_args(spelled name) -> args; the output spelled as each spelling of target must be refused."""
    out = []
    for sp in ("plain", "./", "absolute", "dir/..", "hard link", "symbolic link", "link to a link",
               "through a linked directory"):
        def f(sp=sp):
            with Scratch() as d:
                spelled, make = spellings(d, target)[sp]
                if make:
                    make(spelled)
                if sidecar:  # the output is X.csv whose sidecar X.json is the input
                    if not spelled.endswith(".json"):
                        return
                    spelled = spelled[:-5] + ".csv"
                args = make_args(spelled)
                before = snapshot(d)
                check_refusal("overwrite", f"{name} as {sp}", args, None, d, before=before)
        out.append(f)
    return out


def cases_overwrite():
    c = []
    ident = ["identify", "--refine", "none"]
    for flag in ("--trace", "--hulls", "--json"):
        for target, data in (("sim.csv", ["--data", "sim.csv"]), ("sim.json", ["--data", "sim.csv"]),
                             ("simb.csv", ["--data", "sim.csv", "--data", "simb.csv"]),
                             ("simb.json", ["--data", "sim.csv", "--data", "simb.csv"]),
                             ("wall.toml", ["--model-file", "wall.toml", "--data", "wsim.csv"])):
            c += overwrite_case(f"identify {flag} onto {target}", lambda s, f=flag, dd=data: ident + dd + [f, s], target)
    for target, pre in (("wall.toml", ["--model-file", "wall.toml"]),
                        ("u.csv", ["--model-file", "driven.toml", "--inputs", "u.csv", "--t-end", "5"])):
        c += overwrite_case(f"simulate --out onto {target}", lambda s, p=pre: ["simulate"] + p + ["--out", s], target)
        c += overwrite_case(f"simulate --jumps-out onto {target}",
                            lambda s, p=pre: ["simulate"] + p + ["--out", "o/t.csv", "--jumps-out", s], target)
    c += overwrite_case("simulate --out whose sidecar is the model file",
                        lambda s: ["simulate", "--model-file", "wallj.json", "--out", s], "wallj.json", sidecar=True)
    c += overwrite_case("identify --trace whose name is the data's sidecar",
                        lambda s: ident + ["--data", "sim.csv", "--trace", s], "sim.json")
    # run directories: the sweep file or its model file is one of the files the run writes
    for runfile in ("summary.csv", "trials.csv", "timings.csv", "run.json", "sweep.json"):
        def setup_sweep(d, rf=runfile):
            write(d, f"in/{rf}", OK_SWEEP)
        c.append(lambda rf=runfile, st=setup_sweep: refuse("overwrite", f"sweep file is the run's {rf}",
                                                           ["sweep", f"in/{rf}", "--out", "in"], rf, st))
        def setup_model(d, rf=runfile):
            write(d, f"in/{rf}", WALL)
            write(d, "s.toml", STUDY_SWEEP.replace("study-model.toml", f"in/{rf}"))
        c.append(lambda rf=runfile, st=setup_model: refuse("overwrite", f"sweep's model file is the run's {rf}",
                                                           ["sweep", "s.toml", "--out", "in"], rf, st))
    def linked(d):
        os.symlink("done", os.path.join(d, "done-link"))
    for out_spelling in ("done-link", "./done", "done/", "o/../done"):
        c.append(lambda s=out_spelling: refuse("overwrite", f"merge --out {s} is its input", ["merge", "done", "--out", s],
                                               "--out", lambda d: (linked(d), os.makedirs(os.path.join(d, "o")))))
    c.append(lambda: refuse("overwrite", "reproduce paper --out a sweep's run directory through a link",
                            ["reproduce", "paper", "--out", "done-link"], "done-link", linked))
    return c


# ---------------------------------------------------------------- study: (2) a run directory holds one study

MODEL_EDITS = {
    "alpha value k": ('{ name = "k", value = 4.0', '{ name = "k", value = 6.0'),
    "alpha value b": ('value = 0.2,', 'value = 0.3,'),
    "beta value lambda": ('value = 0.8,', 'value = 0.7,'),
    "beta value mu": ('{ name = "mu", value = 0.0', '{ name = "mu", value = 0.1'),
    "known flag": ('{ name = "mu", value = 0.0,', '{ name = "mu", value = 0.0, known = true,'),
    "bounds": ('{ name = "k", value = 4.0,', '{ name = "k", value = 4.0, bounds = [1, 9],'),
    "phi entry": ('[0, "-x", "-v"]', '[0, "-1.5*x", "-v"]'),
    "psi entry": ('[0, "-v", 1]', '[0, "-v", 0.5]'),
    "guard direction": ('direction = "rising"', 'direction = "both"'),
    "projection": ('project = { x = "1" }\n', ''),
    "set C": ('C = "x < 1 || (x == 1 && v <= 0)"', 'C = "x < 1 || (x == 1 && v < 0)"'),
    "set D": ('D = "x == 1 && v >= 0"', 'D = "x == 1 && v > -1e-9"'),
    "distance_to_D": ('distance_to_D = "sqrt(', 'distance_to_D = "2*sqrt('),
    "flow rows": ('rows = ["v"]\njacobian_constant', 'rows = ["x", "v"]\njacobian_constant'),
    "jacobian_constant": ('jacobian_constant = true', 'jacobian_constant = false'),
    "defaults x0": ('x0 = [0.0, 5.0]', 'x0 = [0.0, 4.0]'),
    "defaults t_end": ('t_end = 20.0', 't_end = 30.0'),
    "defaults dt": ('dt = 5e-4', 'dt = 1e-3'),
    "model name": ('name = "wall-msd"', 'name = "wall-msd-2"'),
    "description": ('description = "mass', 'description = "a mass'),
    "comment": ('# A unit mass', '# One unit mass'),
    "parameter name": ('name = "b", value', 'name = "c", value'),
}
SWEEP_EDITS = {
    "seed": ("[run]\n", "[run]\nseed = 7\n"), "trials": ("trials = 20", "trials = 21"),
    "sigma": ("sigma = 1e-3", "sigma = 2e-3"), "dt": ("dt = 2e-3", "dt = 2.5e-3"), "t_end": ("t_end = 2.0", "t_end = 2.5"),
    "estimator": ('refine = "none"', 'refine = "none"\nestimator = "gtls"'),
    "detector": ('refine = "none"', 'refine = "none"\ndetector = "paper"'),
    "simulator rtol": ("[run]\n", "[simulator]\nrtol = 1e-10\n[run]\n"),
    "model params": ('t_end = 2.0', 't_end = 2.0\nparams = { k = 5.0 }'),
    "model x0": ('t_end = 2.0', 't_end = 2.0\nx0 = [0.0, 4.0]'),
    "identifier window": ("[run]\n", "[identifier]\nwindow = 50\n[run]\n"),
}
STUDY = '[model]\nfile = "m.toml"\nt_end = 2.0\n[grid]\nsigma = 1e-3\ndt = 2e-3\nrefine = "none"\n[run]\ntrials = 20\n'


def rows_of(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


def study_case(what, model_edit=None, sweep_edit=None):
    """Sweep, SIGKILL once the journal has rows, edit one field, resume: refused by name, or the
    resumed tables equal a fresh run of the edited study (nothing mixed)."""
    count("study")
    name = f"resume after a change of {what}"
    with Scratch() as d:
        write(d, "m.toml", WALL)
        write(d, "s.toml", STUDY)
        cmd = ["sweep", "s.toml", "--out", "st", "--threads", "1", "--progress", "none"]
        p = subprocess.Popen([HYSID] + cmd, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        journal = os.path.join(d, "st", "trials.journal")
        end = time.monotonic() + 60
        while p.poll() is None and time.monotonic() < end:
            if os.path.exists(journal) and open(journal, "rb").read().count(b"\n") >= 4:
                break
            time.sleep(0.002)
        p.kill()
        p.wait()
        if model_edit:
            text = WALL.replace(*model_edit)
            if text == WALL:
                fail("study", name, "probe: the edit does not apply")
            write(d, "m.toml", text)
        if sweep_edit:
            write(d, "s.toml", STUDY.replace(*sweep_edit))
        before = snapshot(d)
        rc, _, err, _ = run(cmd, d)
        if rc == 2:
            lines = [l for l in err.splitlines() if l.startswith("hysid:")]
            if len(lines) != 1 or "st" not in lines[0] or ("another study" not in lines[0] and "m.toml" not in lines[0]):
                fail("study", name, f"refused without naming the run directory: {lines!r}")
            check_unchanged("study", name, "resume", d, before, allow_new=("st/.lock",))
            return
        if rc != 0:
            fail("study", name, f"resume: exit {rc}: {err.strip()[-300:]!r}")
            return
        rc2, _, err2, _ = run(cmd[:3] + ["fresh"] + cmd[4:], d)
        if rc2 != 0:
            fail("study", name, f"fresh run: exit {rc2}: {err2.strip()[-200:]!r}")
        elif rows_of(os.path.join(d, "st", "trials.csv")) != rows_of(os.path.join(d, "fresh", "trials.csv")):
            fail("study", name, "resumed with exit 0 and trials.csv mixes two studies (differs from a fresh run)")


def names_case(label, toml_name, expected):
    """A model named with a comma, quote or line break: one CSV cell, resumable, mergeable."""
    count("study")
    name = f"model named {label}"
    with Scratch() as d:
        write(d, "m.toml", WALL.replace('name = "wall-msd"', f"name = {toml_name}"))
        write(d, "s.toml", STUDY.replace("trials = 20", "trials = 2"))
        cmd = ["sweep", "s.toml", "--out", "st", "--progress", "none"]
        rc, _, err, _ = run(cmd, d)
        if rc == 2 and "m.toml" in err:
            return  # refused by name: fine
        if rc != 0:
            fail("study", name, f"sweep: exit {rc}: {err.strip()[-200:]!r}")
            return
        for table in ("trials.csv", "summary.csv"):
            rows = rows_of(os.path.join(d, "st", table))
            col = rows[0].index("model")
            if any(len(r) != len(rows[0]) for r in rows) or any(r[col] != expected for r in rows[1:]):
                fail("study", name, f"{table}: the name is not one cell")
        first = snapshot(os.path.join(d, "st"))
        rc, _, err, _ = run(cmd, d)
        if rc != 0:
            fail("study", name, f"rerun: exit {rc}: {err.strip()[-200:]!r}")
        rc, _, err, _ = run(["merge", "st", "--out", "mg"], d)
        if rc != 0:
            fail("study", name, f"merge: exit {rc}: {err.strip()[-200:]!r}")
        elif rows_of(os.path.join(d, "mg", "trials.csv")) != rows_of(os.path.join(d, "st", "trials.csv")):
            fail("study", name, "merge of one shard differs from the shard")
        del first


def cases_study():
    c = [lambda w=w, e=e: study_case(w, model_edit=e) for w, e in MODEL_EDITS.items()]
    c += [lambda w=w, e=e: study_case("sweep " + w, sweep_edit=e) for w, e in SWEEP_EDITS.items()]
    for label, toml, expected in (("with a comma", '"wall,msd"', "wall,msd"), ("with a quote", "'wall\"msd'", 'wall"msd'),
                                  ("with a line break", '"wall\\nmsd"', "wall\nmsd"), ("with edge spaces", '" wall "', " wall "),
                                  ("with a semicolon and CR", '"wall;\\rmsd"', "wall;\rmsd")):
        c.append(lambda l=label, t=toml, e=expected: names_case(l, t, e))
    def other(d):
        write(d, "s.toml", STUDY.replace("trials = 20", "trials = 1").replace("m.toml", "study-model.toml"))
        run(["sweep", "s.toml", "--out", "theirs"], d)
        run(["merge", "theirs", "--out", "merged-theirs"], d)
    c.append(lambda: refuse("study", "merge --out another sweep's run directory", ["merge", "done", "--out", "theirs"],
                            "theirs", other))
    c.append(lambda: refuse("study", "merge --out a merge of another sweep", ["merge", "done", "--out", "merged-theirs"],
                            "merged-theirs", other))
    c.append(lambda: refuse("study", "sweep --out a merge's tables", ["sweep", "ok.toml", "--out", "merged-theirs"],
                            "merged-theirs", other))
    c.append(lambda: refuse("study", "sweep --out another sweep's directory", ["sweep", "ok.toml", "--out", "theirs"],
                            "theirs", other))
    c.append(lambda: refuse("study", "merge the same shard twice", ["merge", "done", "done-copy", "--out", "m"],
                            "done", lambda d: shutil.copytree(os.path.join(d, "done"), os.path.join(d, "done-copy"))))
    c.append(lambda: refuse("study", "merge two different sweeps", ["merge", "done", "theirs", "--out", "m"], "theirs", other))
    c.append(lambda: accept("study", "merge over an earlier merge of the same sweep", ["merge", "done", "--out", "m"],
                            setup=lambda d: run(["merge", "done", "--out", "m"], d)))
    return c


# ---------------------------------------------------------------- expr: (3) expressions are expressions

EXPR_KEYS = {  # key -> (model text, the expression's text in it, the state it uses)
    "flow.phi": (WALL, '[["v", 0, 0],', '[["{}", 0, 0],', "v"),
    "jump.psi": (WALL, '[0, "-v", 1]]', '[0, "{}", 1]]', "v"),
    "guard.h": (WALL, 'h = "x - 1"', 'h = "{}"', "x"),
    "guard.project": (WALL, 'project = { x = "1" }', 'project = { x = "{}" }', "x"),
    "sets.C": (WALL, 'C = "x < 1 || (x == 1 && v <= 0)"', 'C = "{}"', "x"),
    "sets.D": (WALL, 'D = "x == 1 && v >= 0"', 'D = "{}"', "v"),
    "sets.distance_to_D": (WALL, 'distance_to_D = "sqrt((x - 1)^2 + min(v, 0)^2)"', 'distance_to_D = "{}"', "x"),
    "input_defaults": (DRIVEN, 'u = "sin(1.3*t) + 0.5*sin(3.7*t)"', 'u = "{}"', "t"),
}
EXPR_FORMS = ["{s} = 1", "{s} += 1", "{s} -= 1", "{s} *= 2", "{s} /= 2", "({s} = 2) + 0", "{s}++", "++{s}", "{s}--",
              "1, {s}", "{s} == 1 ? ({s} = 0) : 1", "sin({s} = 1)", "{s}=={s} = 1"]
EXPR_LOADERS = {
    "simulate": lambda f: ["simulate", "--model-file", f, "--out", "o/t.csv"],
    "models --show": lambda f: ["models", "--show", f],
    "crlb": lambda f: ["crlb", "--model-file", f],
    "identify": lambda f: ["identify", "--model-file", f, "--data", "wsim.csv", "--refine", "none"],
    "sweep": lambda f: ["sweep", "s.toml", "--out", "run", "--dry-run"],
}


def expr_text(key, form):
    text, old, new, s = EXPR_KEYS[key]
    expr = form.format(s=s)
    bad = text.replace(old, new.replace("{}", expr.replace('"', '\\"')))
    assert bad != text, key
    return bad


def expr_case(key, form, loader):
    bad = expr_text(key, form)
    def setup(d):
        write(d, "bad.toml", bad)
        write(d, "s.toml", STUDY.replace("m.toml", "bad.toml"))
    refuse("expr", f"{loader}: {key} = {form.format(s='s')!r}", EXPR_LOADERS[loader]("bad.toml"), "bad.toml:", setup)


def cases_expr():
    c = [cases_expr_python]  # first: also in the quick subset
    loaders = list(EXPR_LOADERS)
    i = 0
    for key in EXPR_KEYS:
        for form in EXPR_FORMS:
            chosen = loaders if ARGS.full else [loaders[i % len(loaders)]]
            i += 1
            for ld in chosen:
                c.append(lambda k=key, f=form, ld=ld: expr_case(k, f, ld))
    return c


def cases_expr_python():
    """Every (key, form) loaded by hysid.Model in one interpreter: refused with the CLI's message."""
    with Scratch() as d:
        calls = []
        for k in EXPR_KEYS:
            for f in EXPR_FORMS:
                name = f"e{len(calls)}.toml"
                write(d, name, expr_text(k, f))
                calls.append((f"Model: {k} = {f.format(s='s')!r}", f"hysid.Model({name!r})", ["models", "--show", name]))
        compare_python("expr", d, calls)


# ---------------------------------------------------------------- python: (5) the module refuses what the CLI refuses

PY_CHILD = r'''
import json, os, sys
import numpy as np
import hysid
nan, inf = float("nan"), float("inf")
try:
    m = hysid.Model("impact-msd")
except Exception as e:  # a case then fails with NameError, naming it
    print(json.dumps({"setup": f"{type(e).__name__}: {e}"}), flush=True)
def load(name, cols=("x", "v")):
    import csv
    rows = list(csv.reader(open(name)))
    h = rows[0]
    return np.array([[float(r[h.index(c)]) for c in cols] for r in rows[1:]])
y = load("sim.csv") if os.path.exists("sim.csv") else None
for line in sys.stdin:
    i, expr = json.loads(line)
    try:
        eval(expr)
        out = {"i": i, "raised": False}
    except Exception as e:
        out = {"i": i, "raised": True, "type": type(e).__name__, "msg": str(e)}
    print(json.dumps(out), flush=True)
'''


def normalized(msg):
    msg = msg.strip()
    for p in ("hysid: error: ", "--model-file: "):
        if msg.startswith(p):
            msg = msg[len(p):]
    msg = re.sub(r" \(see hysid [a-z]+ --help\)$", "", msg)
    return re.sub(r"--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_"), msg)


def run_python(d, exprs, env=None):
    """Evaluates each expression in one interpreter (restarted after a crash): i -> result dict or
    None (the interpreter died on it)."""
    results, todo = {}, list(range(len(exprs)))
    while todo:
        e = env_with({"PYTHONPATH": PYDIR, **(env or {})})
        p = subprocess.run(["/usr/bin/python3", "-c", PY_CHILD], cwd=d, env=e, capture_output=True, text=True,
                           input="".join(json.dumps([i, exprs[i]]) + "\n" for i in todo), timeout=600)
        done = [json.loads(l) for l in p.stdout.splitlines() if l.startswith('{"i"')]
        for r in done:
            results[r["i"]] = r
        if p.returncode == 0 and len(done) == len(todo):
            break
        if len(done) == len(todo):
            break
        dead = todo[len(done)]
        results[dead] = {"crash": p.returncode, "stderr": p.stderr[-300:]}
        todo = todo[len(done) + 1:]
    return results


def compare_python(cls, d, calls, env=None):
    """calls: (name, python expression, CLI args or None). The expression must raise (no crash); with
    CLI args the CLI must refuse (exit 2) and the messages agree."""
    results = run_python(d, [c[1] for c in calls], env)
    for i, (name, expr, cli) in enumerate(calls):
        count(cls)
        r = results.get(i)
        if r is None or "crash" in r:
            fail(cls, name, f"python {expr}: the interpreter died ({r and r['crash']}): {r and r['stderr']!r}")
            continue
        if not r["raised"]:
            fail(cls, name, f"python {expr}: accepted, expected a refusal")
            continue
        if r["type"] not in ("InputError", "ValueError", "TypeError", "FileNotFoundError", "OSError"):
            fail(cls, name, f"python {expr}: raised {r['type']}: {r['msg']}")
        if cli is None:
            continue
        rc, _, err, _ = run(cli, d, env)
        lines = [l for l in err.splitlines() if l.startswith("hysid:")]
        if rc != 2 or not lines:
            fail(cls, name, f"{show(cli)}: exit {rc}, expected 2")
        elif normalized(lines[-1]) != normalized(r["msg"]) and not normalized(lines[-1]).endswith(": " + r["msg"]):
            fail(cls, name, f"messages differ: python {expr}: {r['msg']!r}; CLI {show(cli)}: {lines[-1]!r}")


def cases_python():
    S, C = ["simulate"], ["crlb"]
    o = ["--out", "o/t.csv"]
    I = ["identify", "--data", "sim.csv"]
    calls = []
    for v, t in (("nan", "nan"), ("inf", "inf"), ("-1.0", "-1"), ("[0.1, 0.2, 0.3]", "0.1,0.2,0.3")):
        calls.append((f"simulate sigma={v}", f"hysid.simulate(m, sigma={v})", S + ["--sigma", t] + o))
        calls.append((f"crlb sigma={v}", f"hysid.crlb(m, sigma={v})", C + ["--sigma", t]))
    for v, t in (("[1, 2, 3]", "1,2,3"), ("[nan, 0]", "nan,0"), ("[-1, 0]", "-1,0")):
        calls.append((f"simulate x0={v}", f"hysid.simulate(m, x0={v})", S + ["--x0", t] + o))
        calls.append((f"crlb x0={v}", f"hysid.crlb(m, x0={v})", C + ["--x0", t]))
    for key, flag in (("t_end", "--t-end"), ("dt", "--dt")):
        for v in ("0", "-1", "nan", "inf") + (("1e-320",) if key == "dt" else ()):
            calls.append((f"simulate {key}={v}", f"hysid.simulate(m, {key}=float('{v}'))", S + [flag, v] + o))
            calls.append((f"crlb {key}={v}", f"hysid.crlb(m, {key}=float('{v}'))", C + [flag, v]))
    calls.append(("simulate rtol=-1", "hysid.simulate(m, rtol=-1)", S + ["--rtol", "-1"] + o))
    calls.append(("simulate seed=-1", "hysid.simulate(m, seed=-1)", S + ["--seed", "-1"] + o))
    calls.append(("simulate trial=-1", "hysid.simulate(m, trial=-1)", S + ["--trial", "-1"] + o))
    calls.append(("set k", "m.set('k', 1.0)", S + ["--param", "k=1"] + o))
    calls.append(("set a inf", "m.set('a', inf)", S + ["--param", "a=inf"] + o))
    calls.append(("set a nan", "m.set('a', nan)", S + ["--param", "a=nan"] + o))
    # Model() takes a registered name or a model file, as `models --show` does.
    calls.append(("Model unknown", "hysid.Model('pendulum')", ["models", "--show", "pendulum"]))
    for f in ("nosuch.toml", "adir", "/dev/zero", "empty.toml", "syntax.toml", "fifo.toml", "sim.csv"):
        calls.append((f"Model {f}", f"hysid.Model({f!r})", ["models", "--show", f]))
    for kw, flags in (("forgetting=2", ["--forgetting", "2"]), ("false_alarm=0", ["--false-alarm", "0"]),
                      ("detector='paper', r=1", ["--detector", "paper", "--r", "1"]),
                      ("estimator='kalman'", ["--estimator", "kalman"]), ("max_gap=0", ["--max-gap", "0"]),
                      ("data_atol=nan", ["--data-atol", "nan"]), ("tau0=10", ["--tau0", "10"]),
                      ("estimator='gtls', jump_p0=10", ["--estimator", "gtls", "--jump-p0", "10"]),
                      ("sigma=-1", ["--sigma", "-1"]), ("sigma=nan", ["--sigma", "nan"]), ("refine='maybe'", ["--refine", "maybe"]),
                      ("detector='paper', r=nan", ["--detector", "paper", "--r", "nan"])):
        calls.append((f"identify {kw}", f"hysid.identify(m, y, dt=5e-4, {kw})", I + flags))
    for what, expr in (("0 samples", "np.zeros((0, 2))"), ("1 sample", "np.zeros((1, 2))"), ("2 samples", "y[:2]"),
                       ("1-D y", "y[:, 0]"), ("3-D y", "y[None]"), ("strings", "np.array([['a', 'b']] * 5)"),
                       ("inf", "np.where(np.arange(len(y))[:, None] == 5, inf, y)"), ("all nan", "np.full((100, 2), nan)"),
                       ("None", "None"), ("1e200", "y * 1e200"), ("1e-200", "y * 1e-200"),
                       ("a list with an empty run", "[y, np.zeros((0, 2))]"), ("an object array", "np.array([[1, None]] * 5)"),
                       ("complex", "y.astype(complex)"), ("3 columns", "np.hstack([y, y[:, :1]])")):
        calls.append((f"identify y {what}", f"hysid.identify(m, {expr}, dt=5e-4)", None))
    for what, kw in (("dt=0", "dt=0.0"), ("dt=-1", "dt=-1.0"), ("dt=nan", "dt=nan"), ("dt=1e-320", "dt=1e-320"),
                     ("no dt nor t", ""), ("dt and t that disagree", "dt=1e-3, t=np.arange(len(y)) * 5e-4"),
                     ("t decreasing", "t=-np.arange(len(y)) * 5e-4"), ("t short", "t=np.arange(len(y) - 1) * 5e-4"),
                     ("t with nan", "t=np.where(np.arange(len(y)) == 3, nan, np.arange(len(y)) * 5e-4)"),
                     ("unknown keyword", "dt=5e-4, bogus=1"), ("dt a string", "dt='fast'")):
        calls.append((f"identify {what}", f"hysid.identify(m, y, {kw})", None))
    for what, expr in (("seed 2^64", "hysid.simulate(m, seed=2**64)"), ("seed 1.5", "hysid.simulate(m, seed=1.5)"),
                       ("sigma a string", "hysid.simulate(m, sigma='abc')"), ("x0 a string", "hysid.simulate(m, x0='ab')"),
                       ("model None", "hysid.simulate(None)"), ("crlb t_end 1e9", "hysid.crlb(m, t_end=1e9)"),
                       ("run_sweep missing", "hysid.run_sweep('nosuch.toml')"),
                       ("run_sweep onto its file", "hysid.run_sweep('ok.toml', out='ok.toml')")):
        calls.append((what, expr, None))
    def f():
        with Scratch() as d:
            os.mkfifo(os.path.join(d, "fifo.toml"))
            os.mkdir(os.path.join(d, "adir"))
            compare_python("python", d, calls)
    def limits():
        with Scratch() as d:
            compare_python("python", d, [
                ("simulate beyond HYSID_MAX_SAMPLES", "hysid.simulate(m)", ["simulate", "--out", "o/t.csv"]),
                ("crlb beyond HYSID_MAX_SAMPLES", "hysid.crlb(m)", ["crlb"]),
                ("identify beyond HYSID_MAX_SAMPLES", "hysid.identify(m, y, dt=5e-4)", None)],
                env={"HYSID_MAX_SAMPLES": "1000"})
            compare_python("python", d, [("Model beyond HYSID_MAX_INPUT_FILE", "hysid.Model('wall.toml')",
                                          ["models", "--show", "wall.toml"])], env={"HYSID_MAX_INPUT_FILE": "100"})
    return [f, limits]


# ---------------------------------------------------------------- units: (4) units do not matter

UNIT_FIGURES = []


def identify_json(d, data, refine):
    args = ["identify", "--data", data, "--json", data + ".json.out"] + (["--refine", "none"] if refine == "none" else [])
    rc, _, err, _ = run(args, d)
    if rc not in (0, 1):
        return None, f"{show(args)}: exit {rc}: {err.strip()[-200:]!r}"
    return json.load(open(os.path.join(d, data + ".json.out"))), None


def units_case(refines, scales):
    """The same trajectory with time in other units (t * s, v / s) and the states in other units
    (x * s, v * s): the estimates, mapped back (a s^2, b s, lambda, mu s or mu / s), agree with the
    unscaled data's in relative terms, and so do the statuses."""
    with Scratch() as d:
        run(["simulate", "--sigma", "1e-3", "--out", "u.sim.csv"], d)
        rows = rows_of(os.path.join(d, "u.sim.csv"))
        h = rows[0]
        t, x, v = (np.array([float(r[h.index(c)]) for r in rows[1:]]) for c in ("t", "x", "v"))
        def save(name, tt, xx, vv):
            with open(os.path.join(d, name), "w") as f:
                f.write("t,x,v\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in zip(tt, xx, vv)))
        save("base.csv", t, x, v)
        for refine in refines:
            base, problem = identify_json(d, "base.csv", refine)
            if problem:
                count("units")
                fail("units", f"baseline --refine {refine}", problem)
                continue
            names = base["names"]
            for kind, s in scales:
                count("units")
                name = f"{kind} x {s:g}, --refine {refine}"
                if kind == "time":
                    save("s.csv", t * s, x, v / s)
                    back = {"a": s * s, "b": s, "lambda": 1.0, "mu": s, "x0[x]": 1.0, "x0[v]": s}
                else:
                    save("s.csv", t, x * s, v * s)
                    back = {"a": 1.0, "b": 1.0, "lambda": 1.0, "mu": 1 / s, "x0[x]": 1 / s, "x0[v]": 1 / s}
                got, problem = identify_json(d, "s.csv", refine)
                if problem:
                    fail("units", name, problem)
                    continue
                if got["status"] != base["status"]:
                    fail("units", name, f"status {got['status']!r} ({got.get('reason')}), unscaled {base['status']!r}")
                rel = {}
                for i, n in enumerate(names):
                    ref = base["estimate"][i]
                    mapped = got["estimate"][i] * back[n]
                    scale = abs(ref) if n not in ("mu", "x0[v]") else max(abs(ref), float(np.max(np.abs(v))))
                    rel[n] = abs(mapped - ref) / scale
                worst = max(rel.values())
                UNIT_FIGURES.append((name, worst, rel))
                if not worst <= 1e-4:
                    fail("units", name, "estimates differ: " + ", ".join(f"{n} {r:.2g}" for n, r in rel.items()))


def cases_units():
    scales = [("time", 1e-6), ("time", 1e6), ("state", 1e-6), ("state", 1e6)]
    return [lambda: units_case(["none", "ml"] if ARGS.full else ["none"], scales)] + \
           ([] if ARGS.full else [lambda: units_case(["ml"], [("time", 1e-6)])])


# ---------------------------------------------------------------- limits: (6) bounded inputs, signals

def cases_limits():
    c = [lambda s=sig: signal_case(s) for sig in (signal.SIGINT, signal.SIGTERM)]  # first: SIGINT in the quick subset
    def fifo(name):
        return lambda d: os.mkfifo(os.path.join(d, name))
    for args, subj, setup in (
            (["identify", "--data", "f.csv"], "f.csv", fifo("f.csv")),
            (["identify", "--data", "sim.csv", "--data", "f.csv"], "f.csv", fifo("f.csv")),
            (["identify", "--model-file", "f.toml", "--data", "wsim.csv"], "f.toml", fifo("f.toml")),
            (["simulate", "--model-file", "f.toml", "--out", "o/t.csv"], "f.toml", fifo("f.toml")),
            (["crlb", "--model-file", "f.toml"], "f.toml", fifo("f.toml")),
            (["models", "--show", "f.toml"], "f.toml", fifo("f.toml")),
            (["sweep", "f.toml", "--out", "run"], "f.toml", fifo("f.toml")),
            (["sweep", "s.toml", "--out", "run"], "f.toml",
             lambda d: (fifo("f.toml")(d), write(d, "s.toml", STUDY.replace("m.toml", "f.toml")))),
            (["simulate", "--model-file", "driven.toml", "--inputs", "f.csv", "--out", "o/t.csv"], "f.csv", fifo("f.csv")),
            (["identify", "--data", "/dev/zero"], "/dev/zero", None),
            (["identify", "--data", "/dev/urandom"], "/dev/urandom", None),
            (["sweep", "/dev/zero", "--out", "run"], "/dev/zero", None),
            (["simulate", "--model-file", "driven.toml", "--inputs", "/dev/zero", "--out", "o/t.csv"], "/dev/zero", None),
            (["simulate", "--model-file", "driven.toml", "--inputs", "o", "--out", "o/t.csv"], "o",
             lambda d: os.makedirs(os.path.join(d, "o"))),
            (["models", "--show", "big.toml"], "big.toml", lambda d: os.truncate(open(os.path.join(d, "big.toml"), "w").name, 20 << 20)),
            (["sweep", "big.toml", "--out", "run"], "big.toml", lambda d: os.truncate(open(os.path.join(d, "big.toml"), "w").name, 20 << 20)),
            (["identify", "--data", "big.csv"], "big.csv",
             lambda d: (write(d, "big.csv", "t,x,v\n"), os.truncate(os.path.join(d, "big.csv"), 3 << 30))),
            (["identify", "--data", "long.csv"], "long.csv", lambda d: write(d, "long.csv", "t,x,v\n0,1," + "9" * (2 << 20) + "\n")),
    ):
        c.append(lambda a=args, s=subj, st=setup: refuse("limits", f"{' '.join(a)} (not a regular file or too large)", a, s, st))
    limit_runs = {"HYSID_MAX_SAMPLES": ["simulate", "--out", "o/t.csv"], "HYSID_MAX_CSV_LINE": ["identify", "--data", "sim.csv"],
                  "HYSID_MAX_CSV_CELL": ["identify", "--data", "sim.csv"], "HYSID_MAX_CSV_ROWS": ["identify", "--data", "sim.csv"],
                  "HYSID_MAX_INPUT_FILE": ["models", "--show", "wall.toml"], "HYSID_MAX_TRIALS": ["sweep", "ok.toml", "--out", "r"],
                  "HYSID_MAX_CELLS": ["sweep", "cells.toml", "--out", "r"], "HYSID_MAX_AXIS_VALUES": ["sweep", "ax.toml", "--out", "r"]}
    def ax(d):
        write(d, "ax.toml", OK_SWEEP.replace("dt = 2e-3", "dt = { from = 1e-3, to = 2e-3, count = 3 }"))
        write(d, "cells.toml", OK_SWEEP.replace("sigma = 0.0", "sigma = [0.0, 0.1]"))
    for var, args in limit_runs.items():
        for v in ("abc", "-1", "0", "1e3", "99999999999999999999999", "12x"):
            c.append(lambda var=var, a=args, v=v: refuse("limits", f"{var}={v!r}", a, var, ax, env={var: v}))
        small = {"HYSID_MAX_SAMPLES": "1000", "HYSID_MAX_CSV_LINE": "10", "HYSID_MAX_CSV_CELL": "3",
                 "HYSID_MAX_CSV_ROWS": "100", "HYSID_MAX_INPUT_FILE": "100", "HYSID_MAX_TRIALS": "1",
                 "HYSID_MAX_CELLS": "1", "HYSID_MAX_AXIS_VALUES": "2"}[var]
        c.append(lambda var=var, a=args, v=small: refuse("limits", f"{var}={v} honoured", a, var, ax, env={var: v}))
    for args, v in ((["models", "--show", "wall.toml"], "1000"), (["crlb"], "1000"),
                    (["sweep", "ok.toml", "--out", "r", "--dry-run"], "1000"),
                    (["sweep", "s.toml", "--out", "r", "--dry-run"], "1000"),
                    (["reproduce", "paper", "--out", "rp"], "1000")):
        c.append(lambda a=args, v=v: refuse("limits", f"HYSID_MAX_SAMPLES={v}: {' '.join(a)}", a, "HYSID_MAX_SAMPLES",
                                            lambda d: (write(d, "s.toml", STUDY), write(d, "m.toml", WALL)),
                                            env={"HYSID_MAX_SAMPLES": v}))
    for args in (["simulate", "--t-end", "2", "--out", "o/t.csv"], ["identify", "--data", "sim.csv", "--refine", "none"],
                 ["models"], ["models", "--show", "wall.toml"], ["crlb", "--t-end", "2"], ["sweep", "ok.toml", "--out", "r"],
                 ["merge", "done", "--out", "m"], ["hysid-version"]):
        c.append(lambda a=args: full_stdout(a))
    c += many_states_cases()
    c.append(lambda: accept("limits", "dt longer than the time between jumps ends within 30 s",
                            ["identify", "--data", "coarse.csv"], expect=(0, 1),
                            setup=lambda d: run(["simulate", "--dt", "0.25", "--t-end", "40", "--sigma", "1e-3",
                                                 "--out", "coarse.csv"], d)))
    return c


def full_stdout(args):
    """Standard output on a full disk: a non-zero exit that says so, no temporary file."""
    count("limits")
    if args == ["hysid-version"]:
        args = ["--version"]
    with Scratch() as d:
        with open("/dev/full", "w") as full:
            rc, _, err, _ = run(args, d, stdout=full)
        if rc in (0, None) or "standard output" not in err:
            fail("limits", f"{' '.join(args)} > /dev/full", f"exit {rc}, stderr {err.strip()[-200:]!r}")
        if temporaries(d):
            fail("limits", f"{' '.join(args)} > /dev/full", "left temporary files")


def signal_and_wait(p, sig, name):
    """Sends sig to p and waits for it (killed after 10 s): the seconds it took, recorded as a figure."""
    t0 = time.monotonic()
    p.send_signal(sig)
    try:
        p.wait(timeout=10)
    except subprocess.TimeoutExpired:
        p.kill()
        p.wait()
    took = time.monotonic() - t0
    SIGNAL_FIGURES.append((name, took))
    return took


def signal_case(sig):
    """SIGINT or SIGTERM in the middle of one long sweep unit: the sweep ends within 1 s, with 128 +
    the signal, no temporary file, and the same command resumes to the end."""
    count("limits")
    name = f"{signal.Signals(sig).name} during a long sweep unit"
    with Scratch() as d:
        # A ball near its Zeno time at 10 % noise: the detector misses jumps and the refinement tries
        # every route on 400 001 samples (about 2 s, 80 MB).
        write(d, "long.toml", '[model]\nname = "bouncing-ball"\nt_end = 4.0\n[grid]\nsigma = 0.2\ndt = 1e-5\n'
                               'detector = "residual"\nrefine = "ml"\n[run]\ntrials = 1\n')
        cmd = ["sweep", "long.toml", "--out", "long", "--threads", "1", "--progress", "none"]
        p = subprocess.Popen([HYSID] + cmd, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             preexec_fn=lambda: [signal.signal(s, signal.SIG_DFL) for s in (signal.SIGINT, signal.SIGTERM)])
        journal = os.path.join(d, "long", "trials.journal")
        end = time.monotonic() + 60
        while p.poll() is None and not os.path.exists(journal) and time.monotonic() < end:
            time.sleep(0.005)
        time.sleep(0.5)  # inside the unit
        if p.poll() is not None:
            fail("limits", name, "the unit ended before the signal: make it longer")
            return
        took = signal_and_wait(p, sig, name)
        err = p.stderr.read().decode(errors="replace")
        if p.returncode != 128 + sig:
            fail("limits", name, f"exit {p.returncode}, expected {128 + sig}: {err.strip()[-200:]!r}")
        if took > 1.0:
            fail("limits", name, f"honoured after {took:.2f} s (limit 1 s)")
        if temporaries(d):
            fail("limits", name, f"left {temporaries(d)}")
        if ARGS.full:
            rc, _, err, _ = run(cmd, d)
            if rc != 0:
                fail("limits", name, f"resume: exit {rc}: {err.strip()[-200:]!r}")


SIGNAL_FIGURES = []


# ---------------------------------------------------------------- limits: a 16-state model

def many_states_model(n, rows=None):
    """wall-msd with n − 2 more states z_i' = −c z_i that the jump keeps: exact hulls of C and D in n
    dimensions would not finish."""
    zs = [f"z{i}" for i in range(1, n - 1)]
    phi = ['["v", 0, 0, 0]', '[0, "-x", "-v", 0]'] + [f'[0, 0, 0, "-{z}"]' for z in zs]
    psi = ['["x", 0, 0]', '[0, "-v", 1]'] + [f'["{z}", 0, 0]' for z in zs]
    x0 = [0.0, 5.0] + [1.0 + 0.1 * i for i in range(len(zs))]
    return (f'name = "wall-msd-{n}"\nstates = {json.dumps(["x", "v"] + zs)}\n'
            'alpha = [{ name = "alpha_x", value = 1.0, known = true }, { name = "k", value = 4.0 },\n'
            '         { name = "b", value = 0.2 }, { name = "c", value = 0.1 }]\n'
            'beta = [{ name = "beta_x", value = 1.0, known = true }, { name = "lambda", value = 0.8 },\n'
            '        { name = "mu", value = 0.0 }]\n'
            f'[flow]\nphi = [{", ".join(phi)}]\nrows = {json.dumps(rows or ["v"] + zs)}\njacobian_constant = true\n'
            f'[jump]\npsi = [{", ".join(psi)}]\nrows = ["v"]\n'
            '[[guard]]\nname = "wall"\nh = "x - 1"\ndirection = "rising"\nproject = { x = "1" }\n'
            '[sets]\nC = "x < 1 || (x == 1 && v <= 0)"\nD = "x == 1 && v >= 0"\n'
            f'[defaults]\nx0 = {json.dumps(x0)}\nt_end = 5.0\ndt = 5e-4\n')


def many_states_setup(d):
    write(d, "m16.toml", many_states_model(16))
    rc, _, err, _ = run(["simulate", "--model-file", "m16.toml", "--sigma", "1e-4", "--out", "s16.csv"], d)
    if rc != 0:
        raise RuntimeError(f"simulate m16.toml: exit {rc}: {err.strip()[-200:]}")


M16 = ["identify", "--model-file", "m16.toml", "--data", "s16.csv", "--refine", "none"]


def many_states_bounded():
    """16 states: identify ends within 60 s (under the default limit of the exact hulls' dimension) and
    says that C and D were not computed, naming the limit and its variable, in the report and the JSON."""
    count("limits")
    name = "16 states: the exact hulls' limit named, the run bounded"
    with Scratch() as d:
        many_states_setup(d)
        rc, out, err, took = run(M16 + ["--json", "r.json"], d, timeout=60)
        if rc != 0:
            fail("limits", name, f"exit {rc} after {took:.0f} s: {err.strip()[-200:]!r}")
            return
        why = "16 states exceed the limit of 6 states for the exact hulls of C and D (raise it with HYSID_MAX_HULL_DIMENSION=N)"
        if why not in out:
            fail("limits", name, f"the report does not say why the sets are missing: {out[-300:]!r}")
        if json.load(open(os.path.join(d, "r.json"))).get("sets", {}).get("sets_skipped") != why and \
                why not in open(os.path.join(d, "r.json")).read():
            fail("limits", name, "r.json does not say why the sets are missing")


def many_states_signal():
    """The limit raised to 16: the hull computation runs long; SIGINT inside it ends the run within 1 s
    (exit 130, no temporary file)."""
    count("limits")
    name = "16 states, HYSID_MAX_HULL_DIMENSION=16: SIGINT inside the hulls"
    with Scratch() as d:
        many_states_setup(d)
        p = subprocess.Popen([HYSID] + M16 + ["--json", "r.json"], cwd=d, env=env_with({"HYSID_MAX_HULL_DIMENSION": "16"}),
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(4.0)  # the recursive pass takes well under a second; then the hulls
        if p.poll() is not None:
            fail("limits", name, f"ended before the signal (exit {p.returncode}): make the model larger")
            return
        took = signal_and_wait(p, signal.SIGINT, name)
        if p.returncode != 130 or took > 1.0:
            fail("limits", name, f"exit {p.returncode} {took:.2f} s after SIGINT, expected 130 within 1 s")
        if temporaries(d) or os.path.exists(os.path.join(d, "r.json")):
            fail("limits", name, "left r.json or a temporary file")


def many_states_cases():
    c = [many_states_bounded, many_states_signal]
    # c enters the rows z_i alone: with rows = ["v"] the recursive pass would report c = 0 as an estimate
    c.append(lambda: refuse("limits", "16 states: an unknown parameter outside the flow's rows", ["models", "--show", "m.toml"],
                            "flow.rows", lambda d: write(d, "m.toml", many_states_model(16, rows=["v"]))))
    for v in ("abc", "-1", "0", "1e3", "12x"):
        c.append(lambda v=v: refuse("limits", f"HYSID_MAX_HULL_DIMENSION={v!r}", M16, "HYSID_MAX_HULL_DIMENSION",
                                    many_states_setup, env={"HYSID_MAX_HULL_DIMENSION": v}))
    return c


# ---------------------------------------------------------------- readonly: outputs onto a read-only directory

READONLY_MODE = None  # "mount", "chmod" or "" (neither possible: the class is skipped)


def readonly_mode():
    """How a read-only directory is made here: as root a bind mount remounted read-only in a private
    mount namespace (root writes through a mode-0555 directory), else a mode-0555 directory."""
    global READONLY_MODE
    if READONLY_MODE is None:
        READONLY_MODE = "chmod" if os.geteuid() != 0 else ""
        if os.geteuid() == 0 and shutil.which("unshare"):
            d = tempfile.mkdtemp(dir=WORK)
            os.mkdir(os.path.join(d, "ro"))
            r = subprocess.run(["unshare", "-m", "--propagation", "private", "sh", "-c",
                                "mount --bind ro ro && mount -o remount,bind,ro ro && ! touch ro/x 2>/dev/null"],
                               cwd=d, capture_output=True)
            READONLY_MODE = "mount" if r.returncode == 0 else ""
            shutil.rmtree(d, ignore_errors=True)
    return READONLY_MODE


def readonly_case(name, args, subject):
    """args run with ro/ read-only (ro/t.csv, ro/done: existing files there): refused, exit 2, the
    message names subject and gives the errno text; nothing new anywhere, nothing changed."""
    mode = readonly_mode()
    if not mode:
        print(f"skipped [readonly] {name}: no read-only directory can be made here (root without mount namespaces)")
        return
    with Scratch() as d:
        os.makedirs(os.path.join(d, "ro"))
        write(d, "ro/t.csv", "t,x,v\n0,1,2\n")
        shutil.copytree(os.path.join(d, "done"), os.path.join(d, "ro", "done"))
        before = snapshot(d)
        prefix = ()
        if mode == "mount":
            prefix = ("unshare", "-m", "--propagation", "private", "sh", "-c",
                      'mount --bind ro ro && mount -o remount,bind,ro ro && exec "$@"', "sh")
        else:
            for base, dirs, _ in os.walk(os.path.join(d, "ro")):
                for sub in [base] + [os.path.join(base, x) for x in dirs]:
                    os.chmod(sub, 0o555)
        try:
            n = len(FAILURES)
            check_refusal("readonly", name, args, subject, d, before=before, prefix=prefix)
            errno_text = os.strerror(30 if mode == "mount" else 13)  # EROFS, EACCES
            rc, _, err, _ = run(args, d, prefix=prefix) if len(FAILURES) == n else (None, "", "", 0)
            if rc == 2 and errno_text not in err:
                fail("readonly", name, f"{show(args)}: the message lacks the errno text {errno_text!r}: {err.strip()!r}")
        finally:
            for base, dirs, _ in os.walk(os.path.join(d, "ro")):
                for sub in [base] + [os.path.join(base, x) for x in dirs]:
                    os.chmod(sub, 0o755)


def cases_readonly():
    c = []
    for name, args, subject in (
            ("simulate --out onto a read-only file", ["simulate", "--t-end", "2", "--out", "ro/t.csv"], "ro"),
            ("simulate --out into a new directory below", ["simulate", "--t-end", "2", "--out", "ro/sub/t.csv"], "ro/sub"),
            ("simulate --jumps-out read-only, --out writable", ["simulate", "--t-end", "2", "--out", "o/t.csv",
                                                               "--jumps-out", "ro/j.csv"], "--jumps-out"),
            ("identify --json", ["identify", "--data", "sim.csv", "--refine", "none", "--json", "ro/r.json"], "--json"),
            ("identify --trace, --json writable", ["identify", "--data", "sim.csv", "--refine", "none",
                                                   "--json", "r.json", "--trace", "ro/t.csv"], "--trace"),
            ("identify --hulls", ["identify", "--data", "sim.csv", "--refine", "none", "--hulls", "ro/h.csv"], "--hulls"),
            ("sweep --out below", ["sweep", "ok.toml", "--out", "ro/run", "--progress", "none"], "ro/run"),
            ("sweep --out the directory", ["sweep", "ok.toml", "--out", "ro", "--progress", "none"], "--out ro"),
            ("sweep resumed in a read-only run directory", ["sweep", "ok.toml", "--out", "ro/done", "--progress", "none"],
             "ro/done"),
            ("merge --out", ["merge", "done", "--out", "ro/m"], "ro/m"),
            ("reproduce --out", ["reproduce", "paper", "--out", "ro/rp"], "ro/rp")):
        c.append(lambda n=name, a=args, s=subject: readonly_case(n, a, s))
    return c


# ---------------------------------------------------------------- main

CLASSES = {"refuse": cases_refuse, "ok": cases_ok, "overwrite": cases_overwrite, "study": cases_study,
           "expr": cases_expr, "units": cases_units, "python": cases_python, "limits": cases_limits,
           "readonly": cases_readonly}
QUICK_EVERY = {"refuse": 5, "ok": 3, "overwrite": 9, "study": 4, "expr": 5, "limits": 3}  # without --full: every k-th case


def main():
    global ARGS, HYSID, PYDIR, TEMPLATE, JUMPS5, WORK
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--full", action="store_true", help="every case (without: a fixed subset of each class)")
    ap.add_argument("--only", default="", help="comma-separated classes to run")
    ap.add_argument("hysid")
    ap.add_argument("python_dir")
    ARGS = ap.parse_args()
    HYSID, PYDIR = os.path.abspath(ARGS.hysid), os.path.abspath(ARGS.python_dir)
    only = [c for c in ARGS.only.split(",") if c] or list(CLASSES)
    t0 = time.monotonic()
    remove_stale_work()
    WORK = tempfile.mkdtemp(prefix=f"probe_hostile-{os.getpid()}-")
    for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):  # end through finally: remove WORK
        signal.signal(sig, lambda s, f: sys.exit(128 + s))
    try:
        TEMPLATE = build_template()
        JUMPS5 = json.load(open(os.path.join(TEMPLATE, "sim.json")))["jumps"]
        for cls in only:
            t_cls = time.monotonic()
            cases = CLASSES[cls]()
            k = 1 if ARGS.full else QUICK_EVERY.get(cls, 1)
            for i, case in enumerate(cases):
                if i % k == 0:
                    case()
            SECONDS[cls] = time.monotonic() - t_cls
    finally:
        shutil.rmtree(WORK, ignore_errors=True)
    failed = {}
    for cls, _, _ in FAILURES:
        failed[cls] = failed.get(cls, 0) + 1
    print(f"\nprobe_hostile ({'full' if ARGS.full else 'quick'}, {time.monotonic() - t0:.0f} s): cases by class")
    for cls in only:
        print(f"  {cls:10} {COUNTS.get(cls, 0):4} cases, {failed.get(cls, 0):3} failures ({SECONDS.get(cls, 0):.0f} s)")
    if UNIT_FIGURES:
        print("units: largest relative difference of the mapped-back estimates from the unscaled data's")
        for name, worst, _ in UNIT_FIGURES:
            print(f"  {name:32} {worst:.2e}")
    for name, took in SIGNAL_FIGURES:
        print(f"signals: {name}: ended {took:.2f} s after the signal")
    for key, why in KNOWN.items():
        if key in KNOWN_SEEN:
            print(f"open (known, not counted): [{key[0]}] {key[1]}: {why}")
        elif key[0] in only and ARGS.full:
            print(f"known finding no longer seen: [{key[0]}] {key[1]} (remove it from KNOWN)")
    print(f"total {sum(COUNTS.values())} cases, {len(FAILURES)} failures")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())

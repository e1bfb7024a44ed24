#!/usr/bin/env python3
"""Properties of hysid's outputs, each checked over every case of its kind (not one example):

1. No output overwrites an input of the same run: every output flag of `identify`, `simulate` and
   `sweep` × every input kind (data file, its sidecar, model file, sweep file), named directly, through
   another relative spelling, a hard link and a symbolic link → exit 2 naming the flag, the input's
   bytes unchanged.
2. A failed write (a full disk, emulated with RLIMIT_FSIZE) exits non-zero with strerror and the path,
   and leaves the older good file as it was and no temporary file; a write error on standard output
   (/dev/full, a closed pipe with SIGPIPE ignored) exits non-zero with a message.
3. A run directory holds one study: a sweep resumed after any change of its model file (a parameter
   value, a guard parameter, input_defaults, measured, a projection, a set, a default, a comment) is
   refused naming the directory and the model file;
   `merge --out` onto another sweep's run directory is refused and leaves its tables as they were.
4. Names are written per RFC 4180: a model named with a comma, a quote and a line break runs,
   resumes, and reads back with Python's csv module.

Usage: outputs_safety.py HYSID MODELS_DIR
"""
import csv
import hashlib
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile

HYSID, MODELS = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
FAILURES = []
SWEEP = ('[model]\nfile = "{model}"\nt_end = 4.0\n[grid]\nsigma = 0.0\ndt = 2e-3\n'
         '[run]\ntrials = 2\n')


def run(args, cwd, **kw):
    return subprocess.run([HYSID] + args, cwd=cwd, capture_output=True, **kw)


def digest(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def expect(ok, what):
    if not ok:
        FAILURES.append(what)


def expect_refused(p, flag, what):
    err = p.stderr.decode(errors="replace")
    expect(p.returncode == 2 and flag in err and err.strip().splitlines()[-1].startswith("hysid: error:"),
           f"{what}: exit {p.returncode}, stderr {err!r:.300}")


def spellings(d, target, tag):
    """`target` as the same name, another relative spelling, a hard link and a symbolic link."""
    base = os.path.basename(target)
    os.makedirs(os.path.join(d, "links"), exist_ok=True)
    hard = os.path.join("links", f"hard-{tag}-{base}")
    soft = os.path.join("links", f"soft-{tag}-{base}")
    if not os.path.exists(os.path.join(d, hard)):
        os.link(os.path.join(d, target), os.path.join(d, hard))
        os.symlink(os.path.abspath(os.path.join(d, target)), os.path.join(d, soft))
    return {"name": target, "./name": "./" + target, "hard link": hard, "symbolic link": soft}


def no_temporaries(d):
    left = [f for _, _, fs in os.walk(d) for f in fs if f.endswith(".tmp")]
    expect(not left, f"temporary files left: {left}")


def outputs_never_inputs(d):
    shutil.copy(os.path.join(MODELS, "wall-msd.toml"), os.path.join(d, "wall.toml"))
    # A model file named like a sidecar: `simulate --out wallmodel.csv` would write wallmodel.json.
    shutil.copy(os.path.join(MODELS, "wall-msd.toml"), os.path.join(d, "wallmodel.json"))
    subprocess.run([HYSID, "simulate", "--model-file", "wall.toml", "--t-end", "4", "--sigma", "1e-3",
                    "--out", "sim.csv"], cwd=d, check=True, capture_output=True)
    inputs = {"--data": "sim.csv", "--data (sidecar)": "sim.json", "--model-file": "wall.toml"}
    before = {f: digest(os.path.join(d, f)) for f in list(inputs.values()) + ["wallmodel.json"]}
    identify = ["identify", "--model-file", "wall.toml", "--data", "sim.csv", "--refine", "none"]
    cases = 0
    for flag in ["--trace", "--hulls", "--json"]:
        for kind, path in inputs.items():
            for how, name in spellings(d, path, "i").items():
                expect_refused(run(identify + [flag, name], d), flag, f"identify {flag} onto {kind} as {how}")
                cases += 1
    simulate = ["simulate", "--model-file", "wall.toml", "--t-end", "4"]
    for flag in ["--out", "--jumps-out"]:
        for how, name in spellings(d, "wall.toml", "s").items():
            extra = ["--out", "s.csv"] if flag == "--jumps-out" else []
            expect_refused(run(simulate + extra + [flag, name], d), flag, f"simulate {flag} onto the model as {how}")
            cases += 1
    expect_refused(run(["simulate", "--model-file", "wallmodel.json", "--t-end", "4", "--out", "wallmodel.csv"], d),
                   "--out (sidecar)", "simulate: the sidecar of --out is the model file")
    # The sweep's outputs: each file of the run directory × the sweep file and the model file placed there.
    for out_name in ["sweep.json", "trials.journal", "trials.csv", "summary.csv", "timings.csv", "run.json"]:
        for which in ["sweep file", "model file"]:
            run_dir = os.path.join(d, f"run-{out_name}-{which[0]}")
            os.makedirs(run_dir)
            model = os.path.join(run_dir, out_name) if which == "model file" else "../wall.toml"
            if which == "model file":
                shutil.copy(os.path.join(d, "wall.toml"), model)
                model = out_name
            sweep = os.path.join(run_dir, out_name if which == "sweep file" else "s.toml")
            with open(sweep, "w") as f:
                f.write(SWEEP.format(model=model))
            keep = digest(os.path.join(run_dir, out_name))
            expect_refused(run(["sweep", sweep, "--out", run_dir, "--progress", "none"], d), "--out",
                           f"sweep: {out_name} is the {which}")
            expect(digest(os.path.join(run_dir, out_name)) == keep, f"sweep: {out_name} ({which}) changed")
            cases += 1
    for f, h in before.items():
        expect(digest(os.path.join(d, f)) == h, f"input {f} changed")
    no_temporaries(d)
    return cases


def limit_file_size(bytes_):
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (bytes_, bytes_))
    return apply


def failed_writes(d):
    """Every output flag written on a "full disk": non-zero, strerror and path, the old file kept."""
    identify = ["identify", "--model-file", "wall.toml", "--data", "sim.csv", "--refine", "none"]
    cases = 0
    for flag in ["--trace", "--hulls", "--json"]:
        target = f"old{flag[2:]}.out"
        with open(os.path.join(d, target), "w") as f:
            f.write("an older good result\n")
        p = run(identify + [flag, target], d, preexec_fn=limit_file_size(40))
        err = p.stderr.decode(errors="replace")
        expect(p.returncode != 0 and "File too large" in err and target in err,
               f"identify {flag} on a full disk: exit {p.returncode}, {err!r:.300}")
        expect(open(os.path.join(d, target)).read() == "an older good result\n", f"{flag}: older file lost")
        cases += 1
    p = run(["simulate", "--t-end", "4", "--out", "full.csv"], d, preexec_fn=limit_file_size(1000))
    err = p.stderr.decode(errors="replace")
    expect(p.returncode != 0 and "File too large" in err and "full.csv" in err and
           not os.path.exists(os.path.join(d, "full.csv")), f"simulate on a full disk: {err!r:.300}")
    no_temporaries(d)
    # The same under a shell's `ulimit -f`, SIGXFSZ at its default action (subprocess restores it):
    # hysid ignores it itself, so the write fails with EFBIG: exit 2 naming the file, no .tmp left.
    p = run(["simulate", "--t-end", "2", "--out", "t.csv"], d,
            preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_FSIZE, (100 * 1024, 100 * 1024)))
    err = p.stderr.decode(errors="replace")
    expect(p.returncode == 2 and "File too large" in err and "t.csv" in err and
           not os.path.exists(os.path.join(d, "t.csv")),
           f"simulate under ulimit -f 100 (SIGXFSZ at its default): exit {p.returncode}, {err!r:.300}")
    no_temporaries(d)
    cases += 1
    # Standard output: a full device and a closed pipe (SIGPIPE ignored, as under many shells and Python).
    for args in [["models"], identify]:
        with open("/dev/full", "w") as full:
            p = subprocess.run([HYSID] + args, cwd=d, stdout=full, stderr=subprocess.PIPE)
        err = p.stderr.decode(errors="replace")
        expect(p.returncode != 0 and "standard output" in err and "No space left on device" in err,
               f"{args[0]} > /dev/full: exit {p.returncode}, {err!r:.300}")
        # A pipe whose reader has gone before anything is written (deterministic, unlike `| head -c1`).
        read_end, write_end = os.pipe()
        os.close(read_end)
        p = subprocess.run([HYSID] + args, cwd=d, stdout=write_end, stderr=subprocess.PIPE,
                           preexec_fn=lambda: signal.signal(signal.SIGPIPE, signal.SIG_IGN))
        os.close(write_end)
        err = p.stderr.decode(errors="replace")
        expect(p.returncode != 0 and "standard output" in err and "Broken pipe" in err,
               f"{args[0]} into a closed pipe: exit {p.returncode}, {err!r:.300}")
        cases += 2
    return cases


def one_study_per_directory(d):
    """Each change of the model file (any byte of it): the resumed sweep is refused, naming the file."""
    wall_msd = os.path.join(MODELS, "wall-msd.toml")
    examples = os.path.join(MODELS, os.pardir, "examples")
    changes = {
        "parameter value": (wall_msd, 'value = 4.0', 'value = 6.0'),
        "known constant": (wall_msd, '{ name = "alpha_x", value = 1.0', '{ name = "alpha_x", value = 2.0'),
        "projection": (wall_msd, 'project = { x = "1" }', 'project = { x = "1.0 + 0" }'),
        "flow set": (wall_msd, 'C = "x < 1 || (x == 1 && v <= 0)"', 'C = "x <= 1"'),
        "jump set distance": (wall_msd, 'sqrt((x - 1)^2 + min(v, 0)^2)', 'abs(x - 1)'),
        "default x0": (wall_msd, 'x0 = [0.0, 5.0]', 'x0 = [0.0, 4.0]'),
        "identified rows": (wall_msd, 'jacobian_constant = true', 'jacobian_constant = false'),
        "measured": (wall_msd, 'states = ["x", "v"]\n', 'states = ["x", "v"]\nmeasured = ["x"]\n'),
        "comment": (wall_msd, '\nstates = ', '\n# a comment\nstates = '),
        "guard parameter": (os.path.join(examples, "wall", "wall.toml"), 'name = "w", value = 0.9,',
                            'name = "w", value = 0.8,'),
        "input defaults": (os.path.join(examples, "driven-oscillator", "driven-oscillator.toml"),
                           'sin(1.3*t)', 'sin(1.4*t)'),
    }
    cases = 0
    for what, (source, old, new) in changes.items():
        text = open(source).read()
        assert old in text, old
        sd = os.path.join(d, "study-" + what.replace(" ", "-"))
        os.makedirs(sd)
        with open(os.path.join(sd, "m.toml"), "w") as f:
            f.write(text)
        with open(os.path.join(sd, "s.toml"), "w") as f:
            f.write(SWEEP.format(model="m.toml"))
        subprocess.run([HYSID, "sweep", "s.toml", "--out", "run", "--progress", "none"], cwd=sd, check=True,
                       capture_output=True)
        tables = {f: digest(os.path.join(sd, "run", f)) for f in ["trials.csv", "summary.csv"]}
        with open(os.path.join(sd, "m.toml"), "w") as f:
            f.write(text.replace(old, new))
        p = run(["sweep", "s.toml", "--out", "run", "--progress", "none"], sd)
        err = p.stderr.decode(errors="replace")
        expect(p.returncode == 2 and "run: holds another study" in err and "the model file" in err
               and "m.toml changed" in err,
               f"resume after a change of the {what}: exit {p.returncode}, {err!r:.300}")
        expect(all(digest(os.path.join(sd, "run", f)) == h for f, h in tables.items()), f"{what}: tables changed")
        cases += 1
    # merge --out onto a sweep's run directory, and onto another study's merge.
    sd = os.path.join(d, "study-parameter-value")
    keep = {f: digest(os.path.join(sd, "run", f)) for f in ["trials.csv", "summary.csv", "timings.csv"]}
    other = os.path.join(d, "study-default-x0", "run")
    expect_refused(run(["merge", other, "--out", "run"], sd), "--out", "merge --out onto a sweep's run directory")
    expect(all(digest(os.path.join(sd, "run", f)) == h for f, h in keep.items()), "merge replaced the tables")
    p = run(["merge", other, "--out", "merged"], sd)
    expect(p.returncode == 0, f"merge into a new directory: {p.stderr!r:.300}")
    p = run(["merge", other, "--out", "merged"], sd)
    expect(p.returncode == 0, f"merge again over the same study's merge: {p.stderr!r:.300}")
    keep = {f: digest(os.path.join(sd, "merged", f)) for f in ["trials.csv", "summary.csv", "run.json"]}
    p = run(["sweep", "s.toml", "--out", "merged", "--progress", "none"], sd)
    expect_refused(p, "merged: holds another study", "sweep --out onto a merge's directory")
    expect(all(digest(os.path.join(sd, "merged", f)) == h for f, h in keep.items()), "sweep replaced a merge")
    # Another study: the changed model file swept into a new directory.
    flow_set = os.path.join(d, "study-flow-set")
    subprocess.run([HYSID, "sweep", "s.toml", "--out", "changed", "--progress", "none"], cwd=flow_set, check=True,
                   capture_output=True)
    p = run(["merge", os.path.join(flow_set, "changed"), "--out", "merged"], sd)
    expect_refused(p, "--out", "merge over another study's merge")
    return cases + 5


def names_escaped(d):
    """A model name with a comma, a quote and a line break: sweep, resume, read back. (Parameter names
    are identifiers, checked by the model file's reader.)"""
    text = open(os.path.join(MODELS, "wall-msd.toml")).read()
    text = text.replace('name = "wall-msd"', 'name = "wall,\\"msd\\"\\nnew"')
    sd = os.path.join(d, "names")
    os.makedirs(sd)
    with open(os.path.join(sd, "m.toml"), "w") as f:
        f.write(text)
    with open(os.path.join(sd, "s.toml"), "w") as f:
        f.write(SWEEP.format(model="m.toml"))
    for attempt in ["run", "resume"]:
        p = run(["sweep", "s.toml", "--out", "run", "--progress", "none"], sd)
        expect(p.returncode == 0, f"names: {attempt}: exit {p.returncode}, {p.stderr!r:.300}")
    with open(os.path.join(sd, "run", "trials.csv"), newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    expect(len(rows) == 3 and all(len(r) == len(header) for r in rows), "names: trials.csv rows")
    expect(rows[1][header.index("model")] == 'wall,"msd"\nnew', f"names: model cell {rows[1][:5]}")
    return 1


def main():
    with tempfile.TemporaryDirectory(prefix="hysid-outputs-") as d:
        n = outputs_never_inputs(d)
        n += failed_writes(d)
        n += one_study_per_directory(d)
        n += names_escaped(d)
    if FAILURES:
        print("\n".join(FAILURES), file=sys.stderr)
        sys.exit(1)
    print(f"{n} cases: no output replaced an input, every failed write reported, one study per directory")


if __name__ == "__main__":
    main()

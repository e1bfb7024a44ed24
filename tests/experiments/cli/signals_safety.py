#!/usr/bin/env python3
"""Signals and closed pipes end hysid without leaving temporary files (core/io/signals.hpp):

1. SIGINT, SIGTERM or SIGHUP while `simulate` or `identify` writes an output (its temporary file
   exists): exit 130, 143 or 129 with "hysid: interrupted by SIGxxx" on stderr, no *.tmp left, and the
   older file of the same name unchanged (nor a sidecar written).
2. The same signals during the computation, before any output is opened: the same exit, no output.
3. SIGTERM during `identify`'s refinement with standard output a file: the recursive report printed
   before the refinement is in the file (flushed before the refinement starts), the exit 143.
4. Standard output a pipe whose reader has gone (`hysid identify … | head -1`; SIGPIPE at its default
   action): hysid dies of SIGPIPE, quietly (nothing on stderr), as pipeline tools do; the files it
   had written are whole and no *.tmp is left.

Usage: signals_safety.py HYSID
"""
import os
import signal
import subprocess
import sys
import tempfile
import time

HYSID = os.path.abspath(sys.argv[1])
FAILURES = []
NAMES = {signal.SIGINT: "SIGINT", signal.SIGTERM: "SIGTERM", signal.SIGHUP: "SIGHUP"}


def expect(ok, what):
    if not ok:
        FAILURES.append(what)


def temporaries(d, pid=None):
    """The temporary files in d (of process pid: NAME.<pid>-<n>.tmp)."""
    return [f for f in os.listdir(d) if f.endswith(".tmp") and (pid is None or f".{pid}-" in f)]


def default_signals():
    """As an interactive shell starts a command: a shell without job control would start a background
    command with SIGINT ignored, and hysid keeps a signal its parent ignores ignored."""
    for sig in NAMES:
        signal.signal(sig, signal.SIG_DFL)


def start(args, cwd):
    return subprocess.Popen([HYSID] + args, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            preexec_fn=default_signals)


def wait_for_temporary(p, d, timeout=300.0):
    """Polls until a temporary file of p exists in d (True) or p ends (False)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if temporaries(d, p.pid):
            return True
        if p.poll() is not None:
            return False
        time.sleep(0.002)
    return False


def wait_for_open(p, name, timeout=300.0):
    """Polls until p has the file `name` open (it reads its input: the handlers are installed)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end and p.poll() is None:
        try:
            if any(os.readlink(f"/proc/{p.pid}/fd/{fd}").endswith("/" + name)
                   for fd in os.listdir(f"/proc/{p.pid}/fd")):
                return True
        except OSError:  # an fd closed between listdir and readlink
            pass
        time.sleep(0.001)
    return False


def check_interrupted(p, sig, d, what):
    err = p.communicate(timeout=300)[1].decode(errors="replace")
    expect(p.returncode == 128 + sig, f"{what}: exit {p.returncode}, expected {128 + sig}; stderr {err!r:.300}")
    expect(err.strip() == f"hysid: interrupted by {NAMES[sig]}", f"{what}: stderr {err!r:.300}")
    expect(not temporaries(d), f"{what}: temporary files left: {temporaries(d)}")


def old_file(path):
    with open(path, "w") as f:
        f.write("old\n")


def is_old(path):
    with open(path) as f:
        return f.read() == "old\n"


def while_writing(d, sig, args, out, what):
    """Case 1: the signal once the temporary file of `out` exists."""
    old_file(os.path.join(d, out))
    p = start(args, d)
    if not wait_for_temporary(p, d):
        p.wait()
        FAILURES.append(f"{what}: no temporary file seen before the run ended (exit {p.returncode})")
        return
    p.send_signal(sig)
    check_interrupted(p, sig, d, what)
    expect(is_old(os.path.join(d, out)), f"{what}: {out} is not the older file")


def report_kept(d, data):
    """Case 3: stdout a file; SIGTERM once the recursive report is in it (the refinement running)."""
    with open(os.path.join(d, "report.txt"), "wb") as out:
        p = subprocess.Popen([HYSID, "identify", "--data", data], cwd=d, stdout=out, stderr=subprocess.PIPE,
                             preexec_fn=default_signals)
        end = time.monotonic() + 300.0
        while p.poll() is None and os.path.getsize(os.path.join(d, "report.txt")) == 0 and time.monotonic() < end:
            time.sleep(0.01)
        ran = p.poll() is None
        expect(ran, f"identify ended (exit {p.returncode}) before any of its report reached the file: "
                    "the recursive report is not flushed before the refinement")
        if ran:
            p.send_signal(signal.SIGTERM)
            check_interrupted(p, signal.SIGTERM, d, "identify, SIGTERM in the refinement")
        else:
            p.communicate()
    with open(os.path.join(d, "report.txt")) as f:
        text = f.read()
    expect("alpha a" in text and "jumps detected" in text, f"SIGTERM in the refinement: the report file {text!r:.300}")


def main():
    with tempfile.TemporaryDirectory(prefix="hysid-signals-") as d:
        # 600 001 samples: about 60 MB of CSV, so writing takes a while on any machine.
        big = ["--t-end", "60", "--dt", "1e-4", "--sigma", "0.01"]
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            while_writing(d, sig, ["simulate"] + big + ["--out", "sim.csv"], "sim.csv",
                          f"simulate, {NAMES[sig]} while writing --out")
            expect(not os.path.exists(os.path.join(d, "sim.json")), f"simulate, {NAMES[sig]}: a sidecar written")
        made = subprocess.run([HYSID, "simulate"] + big + ["--out", "data.csv"], cwd=d, capture_output=True)
        expect(made.returncode == 0, f"simulate the data: exit {made.returncode}")
        identify = ["identify", "--refine", "none", "--data", "data.csv"]
        for sig in (signal.SIGINT, signal.SIGTERM):
            while_writing(d, sig, identify + ["--trace", "trace.csv"], "trace.csv",
                          f"identify, {NAMES[sig]} while writing --trace")
            # Case 2: during the computation (reading the data), before any output is opened.
            p = start(identify + ["--trace", "early.csv"], d)
            expect(wait_for_open(p, "data.csv"), "identify ended before it read data.csv: case 2 not checked")
            p.send_signal(sig)
            check_interrupted(p, sig, d, f"identify, {NAMES[sig]} before any output")
            expect(not os.path.exists(os.path.join(d, "early.csv")), f"identify, {NAMES[sig]}: early.csv written")

        report_kept(d, "data.csv")

        # Case 4: the reader of standard output has gone before hysid writes to it.
        small = subprocess.run([HYSID, "simulate", "--sigma", "0.01", "--out", "small.csv"], cwd=d,
                               capture_output=True)
        expect(small.returncode == 0, f"simulate small.csv: exit {small.returncode}")
        read_end, write_end = os.pipe()
        os.close(read_end)
        p = subprocess.run([HYSID, "identify", "--refine", "none", "--data", "small.csv", "--json", "out.json"],
                           cwd=d, stdout=write_end, stderr=subprocess.PIPE)
        os.close(write_end)
        expect(p.returncode == -signal.SIGPIPE,
               f"closed stdout: exit {p.returncode}, expected death by SIGPIPE ({-signal.SIGPIPE})")
        expect(p.stderr == b"", f"closed stdout: stderr {p.stderr!r:.300}")
        expect(not temporaries(d), f"closed stdout: temporary files left: {temporaries(d)}")
        with open(os.path.join(d, "out.json")) as f:
            expect(f.read().rstrip().endswith("}"), "closed stdout: out.json is not whole")

    if FAILURES:
        print("\n".join(FAILURES), file=sys.stderr)
        sys.exit(1)
    print("signals and closed pipes: exit codes, messages, no temporary file left, older files kept")


if __name__ == "__main__":
    main()

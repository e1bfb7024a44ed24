#!/usr/bin/env python3
"""Command-line cases where hysid accepted an input and answered wrongly, or said something unclear:

1. `identify --data X.csv --json X.json` run twice: the second run replaces the report (a report is
   never read as the data's sidecar); a sidecar of `simulate` stays an input (--json onto it refused).

Usage: trust_checks.py HYSID
"""
import json
import os
import subprocess
import sys
import tempfile

HYSID = os.path.abspath(sys.argv[1])
FAILURES = []


def run(args, cwd):
    p = subprocess.run([HYSID] + args, cwd=cwd, capture_output=True)
    return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


def expect(ok, what):
    if not ok:
        FAILURES.append(what)


def report_twice(d):
    code, _, err = run(["simulate", "--sigma", "0.01", "--t-end", "5", "--out", "X.csv"], d)
    expect(code == 0, f"simulate: exit {code} {err!r:.300}")
    os.rename(os.path.join(d, "X.json"), os.path.join(d, "sidecar.json"))  # X.csv without its sidecar
    for attempt in ["first", "second"]:
        code, out, err = run(["identify", "--data", "X.csv", "--refine", "none", "--json", "X.json"], d)
        expect(code == 0 and "wrote X.json" in out, f"identify --json X.json, {attempt} run: exit {code}, {err!r:.300}")
        with open(os.path.join(d, "X.json")) as f:
            expect("status" in json.load(f), f"{attempt} run: X.json is not a report")
    # The sidecar of simulate is an input: --json onto it is refused, the sidecar kept.
    os.rename(os.path.join(d, "sidecar.json"), os.path.join(d, "X.json"))
    keep = open(os.path.join(d, "X.json")).read()
    code, _, err = run(["identify", "--data", "X.csv", "--refine", "none", "--json", "X.json"], d)
    expect(code == 2 and "--json" in err and "sidecar" in err, f"--json onto the sidecar: exit {code}, {err!r:.300}")
    expect(open(os.path.join(d, "X.json")).read() == keep, "--json onto the sidecar: the sidecar changed")


def main():
    with tempfile.TemporaryDirectory(prefix="hysid-trust-") as d:
        report_twice(d)
    if FAILURES:
        print("\n".join(FAILURES), file=sys.stderr)
        sys.exit(1)
    print("report twice: as documented")


if __name__ == "__main__":
    main()

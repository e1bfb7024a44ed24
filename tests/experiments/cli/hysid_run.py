"""The one helper the selection tests here share: run a command, stop the test when it exits with a
code it does not expect."""
import subprocess
import sys


def run(*args, codes=(0,)):
    """Runs args; its standard output, or sys.exit with the command, its exit and its output."""
    p = subprocess.run(list(args), capture_output=True, text=True)
    if p.returncode not in codes:
        sys.exit(f"{' '.join(args)}: exit {p.returncode}, expected {' or '.join(map(str, codes))}\n"
                 f"{p.stdout}\n{p.stderr}")
    return p.stdout

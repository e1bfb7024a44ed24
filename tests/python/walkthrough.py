"""Runs the ```python blocks of a Markdown page, in order, as one script in an empty temporary directory
with /usr/bin/python3 (or argv[2]) and MPLBACKEND=Agg: the ctest python.walkthrough over docs/python.md.
Fails when the page has no block, when the script fails, or when a figure it saves is missing or empty."""
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path


def blocks(page):
    return re.findall(r"^```python\n(.*?)^```$", page, re.M | re.S)


def main():
    page = Path(sys.argv[1]).read_text(encoding="utf-8")
    python = sys.argv[2] if len(sys.argv) > 2 else "/usr/bin/python3"
    code = blocks(page)
    if not code:
        sys.exit(f"{sys.argv[1]}: no ```python blocks")
    script = "\n".join(f"# ---- block {i + 1}\n{b}" for i, b in enumerate(code))
    with tempfile.TemporaryDirectory() as work:
        (Path(work) / "walkthrough.py").write_text(script, encoding="utf-8")
        run = subprocess.run([python, "walkthrough.py"], cwd=work, env={**os.environ, "MPLBACKEND": "Agg"})
        if run.returncode != 0:
            sys.exit(f"{sys.argv[1]}: the walkthrough failed (exit {run.returncode})")
        for figure in re.findall(r"savefig\(\"([^\"]+)\"", script):
            if not (Path(work) / figure).is_file() or (Path(work) / figure).stat().st_size == 0:
                sys.exit(f"{sys.argv[1]}: {figure} was not written")
    print(f"{sys.argv[1]}: {len(code)} blocks ran")


if __name__ == "__main__":
    main()

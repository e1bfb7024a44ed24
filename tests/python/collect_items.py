#!/usr/bin/python3
"""Writes the ctest entries of the Python module's tests: one per pytest item, named by its pytest id
under tests/ ("python/test_hysid.py::ITEM"), as catch_discover_tests does for the Catch2 cases. Run by
the build once the module is built (collecting imports hysid); ctest includes the file it writes.

Usage: collect_items.py OUT.cmake SOURCE_DIR WORK_DIR NAME=VALUE...
  NAME=VALUE: the tests' environment (PYTHONPATH, HYSID_BIN, ...).
A collection that fails writes one entry, "python::collect", which runs the collection and fails with
its error.
"""
import os
import sys

import pytest


def bracket(text):
    """A CMake bracket argument holding `text` verbatim."""
    level = "="
    while f"]{level}]" in text:
        level += "="
    return f"[{level}[{text}]{level}]"


class Items:
    def __init__(self):
        self.ids = []

    def pytest_collection_finish(self, session):
        self.ids = [item.nodeid for item in session.items]


def main():
    out, source, work = sys.argv[1:4]
    for entry in sys.argv[4:]:
        name, _, value = entry.partition("=")
        os.environ[name] = value
    environment = ";".join(sys.argv[4:])
    sys.path.insert(0, os.environ.get("PYTHONPATH", ""))
    tests = os.path.join(source, "tests", "python")
    pytest_args = ["-q", "-p", "no:cacheprovider", f"--rootdir={source}"]
    collector = Items()
    os.chdir(work)
    status = pytest.main(pytest_args + ["--collect-only", tests], plugins=[collector])
    lines = []
    command = [sys.executable, "-m", "pytest"] + pytest_args
    if status != 0 or not collector.ids:
        entries = [("python::collect", command + ["--collect-only", tests])]
    else:
        # pytest exits 5 when the id selects nothing: a stale entry fails instead of passing empty.
        entries = [(node.removeprefix("tests/"), command + [os.path.join(source, node)]) for node in collector.ids]
    for name, argv in entries:
        lines.append(f"add_test({bracket(name)} {' '.join(bracket(a) for a in argv)})")
        lines.append(f"set_tests_properties({bracket(name)} PROPERTIES WORKING_DIRECTORY {bracket(work)} "
                     f"ENVIRONMENT {bracket(environment)} LABELS python)")
    with open(out + ".tmp", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(out + ".tmp", out)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""docs/model-files.md against the model-file reader, so that the user's page cannot drift from it.

  keys      every table of keys the reader accepts (each `OnlyKeys(table, prefix, {...})` call of
            core/model_file/model_file.cpp: the top level, a parameter, [flow], [[flow]], [jump],
            [[jump]], [[guard]], [sets], [defaults]) is exactly the key column of one key table of the
            page (a table whose header is "| key | type | default | meaning | example |"), and every
            key table of the page is one of the reader's; every key the reader looks up by name
            (Require, get, contains, ...) is in one of those tables
  examples  every ```toml block of the page is a complete model file that loads:
            `hysid models --show FILE` exits 0 and prints the file's name

Usage: model_files_doc.py keys SOURCE_DIR
       model_files_doc.py examples SOURCE_DIR HYSID
"""
import os
import re
import subprocess
import sys
import tempfile

DOC = os.path.join("docs", "model-files.md")
READER = os.path.join("core", "model_file", "model_file.cpp")
KEY_HEADER = "| key | type | default | meaning | example |"


def reader_key_sets(source):
    """The key lists of the reader's OnlyKeys calls, and every key literal it looks up by name."""
    text = open(os.path.join(source, READER)).read()
    lists = [frozenset(re.findall(r'"([^"]+)"', body))
             for body in re.findall(r"OnlyKeys\([^{]*\{([^}]*)\}", text)]
    name = r'"([A-Za-z_][A-Za-z0-9_]*)"'
    looked_up = set(re.findall(r"(?:Require\([^;]*?|\.get\(|\.contains\(|ParseParameters\([^;]*?|"
                               r"ParseNames\([^;]*?|one\(|std::pair\{)" + name, text))
    for group in re.findall(r"for \(const char\* \w+ : \{([^}]*)\}", text):  # for (const char* k : {"a", "b"})
        looked_up.update(re.findall(name, group))
    return lists, looked_up


def doc_key_tables(source):
    """The key column of each key table of the page, with the line of its header."""
    tables, current = [], None
    for number, line in enumerate(open(os.path.join(source, DOC)), 1):
        line = line.rstrip("\n")
        if line == KEY_HEADER:
            current = (number, set())
            tables.append(current)
        elif current and line.startswith("|---"):
            continue
        elif current and line.startswith("| `"):
            current[1].add(re.match(r"\| `([^`]+)` \|", line).group(1))
        else:
            current = None
    return [(number, frozenset(keys)) for number, keys in tables]


def check_keys(source):
    lists, looked_up = reader_key_sets(source)
    tables = doc_key_tables(source)
    bad = []
    if len(lists) < 9:
        bad.append(f"{READER}: found {len(lists)} OnlyKeys lists, expected at least 9 (has the reader changed form?)")
    documented = [keys for _, keys in tables]
    for keys in lists:
        if keys not in documented:
            near = max(documented, key=lambda d: len(d & keys), default=frozenset())
            bad.append(f"the reader's keys {sorted(keys)} are no key table of {DOC}: missing there "
                       f"{sorted(keys - near)}, documented but refused {sorted(near - keys)}")
    for number, keys in tables:
        if keys not in lists:
            bad.append(f"{DOC}:{number}: the key table {sorted(keys)} is none of the reader's tables")
    accepted = set().union(*lists) if lists else set()
    for key in sorted(looked_up - accepted):
        bad.append(f"{READER} looks up '{key}', which no OnlyKeys list accepts")
    return bad


def toml_blocks(source):
    """(line, text) of each ```toml block of the page."""
    blocks, lines, start = [], None, 0
    for number, line in enumerate(open(os.path.join(source, DOC)), 1):
        if lines is None and line.rstrip() == "```toml":
            lines, start = [], number + 1
        elif lines is not None and line.rstrip() == "```":
            blocks.append((start, "".join(lines)))
            lines = None
        elif lines is not None:
            lines.append(line)
    return blocks


def check_examples(source, hysid):
    blocks = toml_blocks(source)
    bad = [] if len(blocks) >= 5 else [f"{DOC}: {len(blocks)} ```toml blocks, expected the 5 worked examples"]
    with tempfile.TemporaryDirectory() as work:
        for line, text in blocks:
            path = os.path.join(work, f"example-line-{line}.toml")
            with open(path, "w") as f:
                f.write(text)
            name = re.search(r'^name = "([^"]+)"', text, re.M)
            run = subprocess.run([hysid, "models", "--show", path], capture_output=True, text=True)
            if run.returncode != 0:
                bad.append(f"{DOC}:{line}: the example does not load (exit {run.returncode}): {run.stderr.strip()}")
            elif not name or name.group(1) not in run.stdout:
                bad.append(f"{DOC}:{line}: `hysid models --show` does not print the example's name")
            else:
                print(f"{DOC}:{line}: {name.group(1)} loads")
    return bad


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "keys":
        bad = check_keys(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "examples":
        bad = check_examples(sys.argv[2], sys.argv[3])
    else:
        sys.exit(__doc__)
    for line in bad:
        print(line)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()

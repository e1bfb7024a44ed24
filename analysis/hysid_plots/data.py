"""Reading a run directory: summary.csv (one row per cell), trials.csv (one row per trial, optional),
run.json (the sweep's resolved configuration). Nothing here draws.

A summary's key columns are the columns before `trials` (without `cell`): the grid axes of a
`hysid sweep` (model, dt, sigma, r, false_alarm, estimator, detector, and any later axis) or of another
study (e.g. sigma, estimator). A metric m has `m_mean` and either `m_ci95_lo`/`m_ci95_hi` (hysid sweep)
or a half width `m_ci95` (hysid_eiv_study).
"""
import csv
import json
import math
import os

import numpy as np

TEXT_KEYS = ("model", "estimator", "detector", "refine")
# Metrics that cannot be negative: intervals of them are never drawn or printed below 0.
NON_NEGATIVE = ("misclassification", "precision", "recall", "fp", "fn", "e_alpha", "e_beta", "rel_alpha",
                "rel_beta", "jump_hausdorff", "flow_outside_share")


class DataError(Exception):
    """Bad or missing input; the message names the file (and line or column)."""


def number(text, where):
    if text == "" or text is None:
        return math.nan
    try:
        return float(text)
    except ValueError:
        raise DataError(f"{where}: '{text}' is not a number") from None


def read_csv(path):
    """(header, rows as lists of strings); a clear error when missing or empty."""
    if not os.path.exists(path):
        raise DataError(f"{path}: no such file")
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    if len(rows) < 2:
        raise DataError(f"{path}: no data rows")
    header = rows[0]
    for line, r in enumerate(rows[1:], start=2):
        if len(r) != len(header):
            raise DataError(f"{path}:{line}: {len(r)} cells, the header has {len(header)}")
    return header, rows[1:]


class Summary:
    """summary.csv: `rows` as dicts (key columns as str for text keys, float otherwise; NaN when empty)."""

    def __init__(self, path):
        self.path = path
        header, body = read_csv(path)
        if "trials" not in header:
            raise DataError(f"{path}: no column 'trials' (not a summary of a study)")
        self.keys = [h for h in header[:header.index("trials")] if h != "cell"]
        self.columns = header
        self.rows = []
        for line, cells in enumerate(body, start=2):
            row = {"_line": line}  # identifies the row when the summary has no `cell` column
            for h, v in zip(header, cells):
                row[h] = v if h in TEXT_KEYS else number(v, f"{path}:{line}: column '{h}'")
            self.rows.append(row)

    def has(self, column):
        return column in self.columns

    def metrics(self):
        return [c[:-5] for c in self.columns if c.endswith("_mean")]

    def values(self, key):
        """The distinct values of a key column, in numeric order (text keys: first appearance)."""
        seen = []
        for r in self.rows:
            v = r.get(key)
            if not any(same(v, s) for s in seen):
                seen.append(v)
        if key in TEXT_KEYS:
            return seen
        return sorted(seen, key=lambda v: (math.isnan(v), v))

    def varying(self, keys):
        return [k for k in keys if k in self.keys and len(self.values(k)) > 1]

    def interval(self, row, metric):
        """(lo, hi) of the summary's 95 % interval of the mean (NaN when absent)."""
        if f"{metric}_ci95_lo" in row:
            return row[f"{metric}_ci95_lo"], row[f"{metric}_ci95_hi"]
        half = row.get(f"{metric}_ci95", math.nan)
        return row[f"{metric}_mean"] - half, row[f"{metric}_mean"] + half


def same(a, b):
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


class Trials:
    """trials.csv: per cell, the numeric columns of the trials whose status is ok (NaN when empty)."""

    def __init__(self, path):
        self.path = path
        header, body = read_csv(path)
        for need in ("cell", "status"):
            if need not in header:
                raise DataError(f"{path}: no column '{need}'")
        self.header = header
        ci, si = header.index("cell"), header.index("status")
        by_cell = {}
        for line, cells in enumerate(body, start=2):
            if cells[si] != "ok":
                continue
            by_cell.setdefault(int(number(cells[ci], f"{path}:{line}: column 'cell'")), []).append((line, cells))
        self.numeric = [h for h in header if h not in TEXT_KEYS and h not in ("status", "message", "flow_status",
                                                                                  "jump_status", "refine_status")]
        self.cells = {}
        for cell, lines in by_cell.items():
            cols = {}
            for h in self.numeric:
                i = header.index(h)
                cols[h] = np.array([number(c[i], f"{path}:{ln}: column '{h}'") for ln, c in lines])
            self.cells[cell] = cols

    def column(self, cell, name):
        """The finite values of column `name` over the ok trials of `cell` (empty when none)."""
        v = self.cells.get(int(cell), {}).get(name)
        return np.array([]) if v is None else v[np.isfinite(v)]


class Run:
    """A run directory: summary (always), trials and run.json (when present)."""

    def __init__(self, run_dir):
        self.dir = run_dir
        self.summary = Summary(os.path.join(run_dir, "summary.csv"))
        tpath = os.path.join(run_dir, "trials.csv")
        self.trials = Trials(tpath) if os.path.exists(tpath) and self.summary.has("cell") else None
        jpath = os.path.join(run_dir, "run.json")
        self.truth = None  # {name: value} given on the command line (--truth), before run.json's
        self.meta = {}
        if os.path.exists(jpath):
            with open(jpath) as f:
                try:
                    self.meta = json.load(f)
                except json.JSONDecodeError as e:
                    raise DataError(f"{jpath}:{e.lineno}: {e.msg}") from None

    def source(self):
        """The data source named in captions: the run directory and the command that made it."""
        what = self.meta.get("source") or self.meta.get("command") or "?"
        return f"{self.dir} ({what})"

    def true_params(self, model):
        """{name: value} of `model`'s parameters: --truth, else run.json's resolved models[] (unknown
        parameters), else its config.model[].params."""
        if self.truth:
            return self.truth
        for m in self.meta.get("models", []):  # the resolved models of the run
            if m.get("name") == model:
                return {p["name"]: float(p["value"]) for p in m.get("alpha", []) + m.get("beta", [])
                        if not p.get("known")}
        for m in self.meta.get("config", {}).get("model", []):
            if m.get("name") == model and m.get("params"):
                return {name: float(v) for name, v in m["params"]}
        raise DataError(f"{os.path.join(self.dir, 'run.json')}: config.model '{model}' lists no params (the "
                        "model's defaults were used): give the true values with --truth NAME=VALUE,...")

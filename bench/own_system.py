"""What the own-system benches (offset-impact, zoh-loop, biased-wall, stick-slip) share: the data as a
user has them from `hysid simulate`, `hysid identify` timed on them, the largest error in SEs, and
the command line that runs seeds."""
import argparse
import csv
import json
import subprocess
import tempfile
import time
from pathlib import Path


def user_data(hysid, truth, sigma, seed, columns, work, keep=lambda row: True):
    """`hysid simulate --model-file truth --sigma sigma --seed seed` (once per seed in work), then
    work/dataSEED.csv with the given columns of the rows `keep` accepts; its path."""
    sim = Path(work) / f"sim{seed}.csv"
    if not sim.exists():
        subprocess.run([str(hysid), "simulate", "--model-file", str(truth), "--sigma", str(sigma),
                        "--seed", str(seed), "--out", str(sim)], check=True, capture_output=True)
    data = Path(work) / f"data{seed}.csv"
    with open(sim) as f, open(data, "w", newline="") as g:
        out = csv.writer(g)
        out.writerow(columns)
        for row in csv.DictReader(f):
            if keep(row):
                out.writerow([row[c] for c in columns])
    return data


def identify(hysid, model, data, result):
    """`hysid identify --model-file model --data data --json result`, timed: (wall seconds, the JSON
    as a dict or None, the end of its standard error)."""
    Path(result).unlink(missing_ok=True)
    t0 = time.perf_counter()
    run = subprocess.run([str(hysid), "identify", "--model-file", str(model), "--data", str(data),
                          "--json", str(result), "--progress", "none"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if not Path(result).exists():
        return wall, None, f"exit {run.returncode} without an estimate: {run.stderr.strip()[-200:]}"
    return wall, json.loads(Path(result).read_text()), ""


def max_z(d, truth):
    """The largest |estimate − truth| / SE over the names in truth (NaN without standard errors)."""
    if not d["standard_errors"]:
        return float("nan")
    se = dict(zip(d["names"], d["standard_errors"]))
    est = dict(zip(d["names"], d["estimate"]))
    return max(abs(est[n] - v) / se[n] for n, v in truth.items() if se.get(n))


def run_seeds(doc, first_seed, default_seeds, each, options=(), after=None):
    """The benches' command line: --hysid, --seeds, --work and `options` ((flag, default, help)
    triples); each(hysid, work, seed, args) yields the lines printed per seed; after(args), when
    given, runs once all seeds have."""
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--seeds", type=int, default=default_seeds,
                    help=f"seeds {first_seed}, {first_seed + 1}, ... (this many)")
    ap.add_argument("--work", help="keep the files here (default: a temporary directory)")
    for flag, default, text in options:
        ap.add_argument(flag, default=default, help=text)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.work or scratch)
        work.mkdir(parents=True, exist_ok=True)
        for seed in range(first_seed, first_seed + args.seeds):
            for line in each(args.hysid, work, seed, args):
                print(line, flush=True)
    if after:
        after(args)
    return 0

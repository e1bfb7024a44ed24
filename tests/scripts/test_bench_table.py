"""scripts/bench_table.py on a sitting directory written here, with figures whose table rows are known:
medians taken from the median aggregate, per-sample counters in ns, ratios of CPU times, `/usr/bin/time -v`
fields, byte-identity verdicts, exit codes and loads."""
import json
import os
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "scripts"))

import bench_table  # noqa: E402


def bench(name, aggregate, cpu_time, unit="ms", **counters):
    return {"run_name": name, "run_type": "aggregate", "aggregate_name": aggregate, "cpu_time": cpu_time,
            "real_time": cpu_time, "time_unit": unit, **counters}


TIME_V = """\tCommand being timed: "hysid sweep"
\tUser time (seconds): 20.50
\tSystem time (seconds): 0.25
\tElapsed (wall clock) time (h:mm:ss or m:ss): {wall}
\tMaximum resident set size (kbytes): {rss}
"""


def write_sitting(out):
    (out / "gb_identify_targets.json").write_text(json.dumps({"benchmarks": [
        bench("BM_IdentifyStep", "mean", 0.9, per_sample=2.25e-8),  # a mean that must not be taken
        bench("BM_IdentifyStep", "median", 0.6, per_sample=1.5e-8),
        bench("BM_IdentifyStepFusedReference", "median", 0.4, per_sample=1.0e-8),
    ]}))
    (out / "gb_estimators_targets.json").write_text(json.dumps({"benchmarks": [
        bench("BM_EstimatorUpdate/gtls/2", "median", 151.0, unit="ns")]}))
    (out / "gb_refine_rest.json").write_text(json.dumps({"benchmarks": [
        bench("BM_RefineRepairedStart", "median", 0.1, unit="s")]}))
    (out / "time_robustness_map_2.txt").write_text(TIME_V.format(wall="1:02.50", rss=131072))
    (out / "time_robustness_map_1.txt").write_text(TIME_V.format(wall="2:05.00", rss=120000))
    (out / "time_many_runs_identify.txt").write_text(TIME_V.format(wall="0:01.20", rss=78000))
    (out / "cmp.txt").write_text("robustness_map trials.csv, 1 vs 2 threads\tidentical\ta\tb\n"
                                 "efficiency trials.csv, 1 vs 2 threads\tdiffer\ta\tb\n")
    (out / "machine.txt").write_text("commit: 0123\nsmoke: 0\nmany runs: 400\n")
    (out / "uptime.log").write_text(
        "identify_targets\tbefore\t 06:00:00 up 1 day,  load average: 0.40, 0.5, 0.6\n"
        "identify_targets\tafter\t 06:01:00 up 1 day,  load average: 1.80, 0.5, 0.6\n"
        "identify_targets\trc\t0\n"
        "robustness_map_2\tbefore\t 06:02:00 up 1 day,  load average: 0.10, 0.5, 0.6\n"
        "robustness_map_2\tafter\t 06:03:00 up 1 day,  load average: 1.00, 0.5, 0.6\n"
        "robustness_map_2\trc\t1\n")


def table(tmp_path):
    write_sitting(tmp_path)
    return {row[0]: row[1:] for row in bench_table.rows(bench_table.Measured(tmp_path))}


def test_benchmark_figures_are_the_medians_against_their_targets(tmp_path):
    rows = table(tmp_path)
    assert rows["BM_IdentifyStep, per sample"] == ("15 ns", "≤ 15 ns", "met", "0.40 → 1.80 (busy)")
    assert rows["BM_IdentifyStep ÷ BM_IdentifyStepFusedReference"][:3] == ("1.5×", "≤ 1.6×", "met")
    assert rows["BM_EstimatorUpdate/gtls/2"][:3] == ("151 ns", "≤ 150 ns", "not met")
    assert rows["BM_RefineRepairedStart"][:3] == ("100 ms", "—", "—")  # a benchmark without a target
    assert rows["BM_RefineSection5"][:3] == ("not measured", "≤ 20 ms", "—")


def test_timed_runs_read_wall_cpu_and_peak_rss_and_the_exit_code(tmp_path):
    rows = table(tmp_path)
    assert rows["robustness map, 2 threads: wall"] == ("62.5 s (exit 1, log_robustness_map_2.txt)", "≤ 12 s",
                                                       "not met", "0.10 → 1.00")
    assert rows["robustness map, 2 threads: CPU (user + sys)"][0].startswith("20.8 s")
    assert rows["robustness map, 2 threads: peak RSS"][:3] == ("128 MB (exit 1, log_robustness_map_2.txt)",
                                                              "≤ 256 MB", "met")
    assert rows["robustness map, 1 thread ÷ 2 threads (wall)"][:3] == ("2×", "≥ 1.9×", "met")
    assert rows["many-run identify (400 × 2 001): wall"][:3] == ("1.2 s", "≤ 1.5 s", "met")
    assert rows["many-run identify: peak RSS per sample"][:3] == ("99.8 B", "≤ 100 B", "met")  # 78 000 kB / 800 400


def test_byte_identity_verdicts(tmp_path):
    rows = table(tmp_path)
    assert rows["robustness map trials.csv, 1 vs 2 threads"][:3] == ("identical", "identical", "met")
    assert rows["efficiency trials.csv, 1 vs 2 threads"][:3] == ("differ", "identical", "not met")
    assert rows["efficiency summary.csv, 1 vs 2 threads"][:3] == ("not measured", "identical", "—")

#!/usr/bin/env python3
"""The table of a benchmark sitting (scripts/bench-sitting.sh): every figure against its target.

Usage: bench_table.py OUT_DIR   (the sitting's directory: gb_*.json, time_*.txt, cmp.txt, uptime.log,
log_python_overhead.txt, log_ctrl_c.txt, machine.txt). Prints one markdown table: figure, measured
(the median of the repetitions for Google Benchmark, CPU time), target, met / not met, and the load
average (1 min) before and after the step that measured it. The targets are BENCHMARKS.md's, here
in TARGETS and nowhere else. Standard library only.
"""
import json
import operator
import re
import sys
from pathlib import Path

SAMPLES_PER_RUN = 2001  # bench/many_runs.py's default; the number of runs is in machine.txt

# figure, what it reads (see Measured.get), target as (comparison, bound) or None.
TARGETS = [
    ("BM_SimulateImpactMsd/500", ("gb_ms", "BM_SimulateImpactMsd/500"), ("<=", 2.0)),
    ("BM_AddMeasurementNoise, per sample", ("gb_ns_sample", "BM_AddMeasurementNoise"), ("<=", 10.0)),
    ("BM_IdentifyStep, per sample", ("gb_ns_sample", "BM_IdentifyStep"), ("<=", 15.0)),
    ("BM_IdentifyStepFusedReference, per sample", ("gb_ns_sample", "BM_IdentifyStepFusedReference"), None),
    ("BM_IdentifyStep ÷ BM_IdentifyStepFusedReference",
     ("gb_ratio", "BM_IdentifyStep", "BM_IdentifyStepFusedReference"), ("<=", 1.6)),
    ("BM_IdentifyStepResidual, per sample", ("gb_ns_sample", "BM_IdentifyStepResidual"), ("<=", 22.0)),
    ("BM_IdentifyStepResidual ÷ BM_IdentifyStep",
     ("gb_ratio", "BM_IdentifyStepResidual", "BM_IdentifyStep"), ("<=", 1.5)),
    ("BM_IdentifyStepIntegral ÷ BM_IdentifyStep",
     ("gb_ratio", "BM_IdentifyStepIntegral", "BM_IdentifyStep"), ("<=", 2.0)),
    ("BM_IdentifyStepWithHulls, per sample", ("gb_ns_sample", "BM_IdentifyStepWithHulls"), ("<=", 100.0)),
    ("BM_IdentifyStepResidualDataAccuracy ÷ BM_IdentifyStepNoisy",
     ("gb_ratio", "BM_IdentifyStepResidualDataAccuracy", "BM_IdentifyStepNoisy"), ("<=", 2.0)),
    ("BM_IdentifyStepResidualKnownSigma ÷ BM_IdentifyStepNoisy",
     ("gb_ratio", "BM_IdentifyStepResidualKnownSigma", "BM_IdentifyStepNoisy"), ("<=", 2.0)),
    ("BM_IdentifyStepModelFile ÷ BM_IdentifyStep",
     ("gb_ratio", "BM_IdentifyStepModelFile", "BM_IdentifyStep"), ("<=", 2.0)),
    ("BM_EstimatorUpdate/gtls/2", ("gb_ns", "BM_EstimatorUpdate/gtls/2"), ("<=", 150.0)),
    ("BM_EstimatorUpdate/frisch/2", ("gb_ns", "BM_EstimatorUpdate/frisch/2"), ("<=", 1000.0)),
    ("BM_EstimatorUpdate/frisch_growing/2", ("gb_ns", "BM_EstimatorUpdate/frisch_growing/2"), ("<=", 1000.0)),
    ("BM_SensitivityTrajectory/12 ÷ BM_PlainTrajectory/12",
     ("gb_ratio", "BM_SensitivityTrajectory/12", "BM_PlainTrajectory/12"), ("<=", 4.0)),
    ("BM_SensitivityTrajectory/10 ÷ BM_PlainTrajectory/10",
     ("gb_ratio", "BM_SensitivityTrajectory/10", "BM_PlainTrajectory/10"), ("<=", 4.0)),
    ("BM_RefineSection5", ("gb_ms", "BM_RefineSection5"), ("<=", 20.0)),
    ("BM_RefineDragBall/40001", ("gb_ms", "BM_RefineDragBall/40001"), ("<=", 200.0)),
    ("BM_RefineWall", ("gb_ms", "BM_RefineWall"), ("<=", 200.0)),
    ("BM_RefineDriven", ("gb_ms", "BM_RefineDriven"), ("<=", 200.0)),
    ("robustness map, 2 threads: wall", ("wall", "robustness_map_2"), ("<=", 12.0)),
    ("robustness map, 2 threads: CPU (user + sys)", ("cpu", "robustness_map_2"), None),
    ("robustness map, 2 threads: peak RSS", ("rss", "robustness_map_2"), ("<=", 256.0)),
    ("robustness map, 1 thread ÷ 2 threads (wall)", ("wall_ratio", "robustness_map_1", "robustness_map_2"),
     (">=", 1.9)),
    ("robustness map trials.csv, 1 vs 2 threads", ("cmp", "robustness_map trials.csv, 1 vs 2 threads"),
     ("==", "identical")),
    ("robustness map summary.csv vs results/", ("cmp", "robustness_map summary.csv vs results/robustness_map"),
     ("==", "identical")),
    ("robustness map tables by `hysid merge`: CPU", ("cpu", "merge_map"), None),
    ("efficiency summary.csv vs results/", ("cmp", "efficiency summary.csv vs results/efficiency"),
     ("==", "identical")),
    ("efficiency study, 2 threads: wall", ("wall", "efficiency_2"), ("<=", 15.0)),
    ("efficiency study, 2 threads: peak RSS", ("rss", "efficiency_2"), None),
    ("efficiency study, 1 thread: wall", ("wall", "efficiency_1"), None),
    ("efficiency trials.csv, 1 vs 2 threads", ("cmp", "efficiency trials.csv, 1 vs 2 threads"),
     ("==", "identical")),
    ("efficiency summary.csv, 1 vs 2 threads", ("cmp", "efficiency summary.csv, 1 vs 2 threads"),
     ("==", "identical")),
    ("paper_noise study, 2 threads: wall", ("wall", "paper_noise_2"), None),
    ("paper_noise summary.csv vs results/", ("cmp", "paper_noise summary.csv vs results/paper_noise"),
     ("==", "identical")),
    ("default study + figures + table: wall", ("wall", "default_study"), None),
    ("many-run identify (400 × 2 001): wall", ("wall", "many_runs_identify"), ("<=", 1.5)),
    ("many-run identify: CPU (user + sys)", ("cpu", "many_runs_identify"), None),
    ("many-run identify: peak RSS", ("rss", "many_runs_identify"), ("<=", 80.0)),
    ("many-run identify: peak RSS per sample", ("rss_per_sample", "many_runs_identify"), ("<=", 100.0)),
    ("many-run identify --refine none: peak RSS", ("rss", "many_runs_identify_norefine"), None),
    ("`hysid identify` of the §5 run (CLI, whole process)", ("python", "cli"), None),
    ("`hysid.identify`, trace=False", ("python", "python hysid.identify, trace=False"), None),
    ("`hysid.identify`, trace=True", ("python", "python hysid.identify, trace=True"), None),
    ("Ctrl-C: KeyboardInterrupt after SIGINT", ("ctrl_c", 1), ("<=", 0.5)),
    ("Ctrl-C: the pass stopped after SIGINT", ("ctrl_c", 2), None),
]

# Which sitting step measured each kind of figure (for the load column).
GB_STEPS = ("simulator", "identify", "refine", "estimators")
OPS = {"<=": operator.le, ">=": operator.ge, "==": operator.eq}


class Measured:
    """The figures of one sitting's directory."""

    def __init__(self, out):
        self.out = out
        self.gb = {}  # benchmark name -> (median aggregate, step)
        for path in sorted(out.glob("gb_*.json")):
            step = path.stem[3:]
            for b in json.loads(path.read_text()).get("benchmarks", []):
                if b.get("aggregate_name") == "median" or (b.get("run_type") == "iteration"
                                                           and b["run_name"] not in self.gb):
                    self.gb[b["run_name"]] = (b, step)
        self.times = {p.stem[5:]: parse_time(p.read_text()) for p in out.glob("time_*.txt")}
        self.cmp = {}
        if (out / "cmp.txt").exists():
            for line in (out / "cmp.txt").read_text().splitlines():
                name, verdict = line.split("\t")[:2]
                self.cmp[name] = verdict
        self.load = parse_uptime(out / "uptime.log")
        machine = out / "machine.txt"
        m = re.search(r"^many runs: (\d+)$", machine.read_text() if machine.exists() else "", re.M)
        self.many_runs = int(m.group(1)) if m else 400

    def gb_value(self, name, per_sample):
        """(value, step): ns per sample from the per_sample counter, else the CPU time in ms (or ns)."""
        b, step = self.gb[name]
        if per_sample:
            return b["per_sample"] * 1e9, step
        scale = {"ns": 1e-6, "us": 1e-3, "ms": 1.0, "s": 1e3}[b["time_unit"]]
        return b["cpu_time"] * scale, step

    def get(self, spec):
        """(value, unit, step) of one figure; KeyError when the sitting did not measure it."""
        kind = spec[0]
        if kind == "gb_ms":
            v, s = self.gb_value(spec[1], False)
            return v, "ms", s
        if kind == "gb_ns":
            v, s = self.gb_value(spec[1], False)
            return v * 1e6, "ns", s
        if kind == "gb_ns_sample":
            v, s = self.gb_value(spec[1], True)
            return v, "ns", s
        if kind == "gb_ratio":
            a, s = self.gb_value(spec[1], False)
            b, _ = self.gb_value(spec[2], False)
            return a / b, "×", s
        if kind in ("wall", "cpu", "rss", "rss_per_sample"):
            t = self.times[spec[1]]
            value = {"wall": t["wall"], "cpu": t["user"] + t["sys"], "rss": t["rss_kb"] / 1024.0,
                     "rss_per_sample": t["rss_kb"] * 1024.0 / (self.many_runs * SAMPLES_PER_RUN)}[kind]
            unit = {"wall": "s", "cpu": "s", "rss": "MB", "rss_per_sample": "B"}[kind]
            return value, unit, spec[1]
        if kind == "wall_ratio":
            return self.times[spec[1]]["wall"] / self.times[spec[2]]["wall"], "×", spec[1]
        if kind == "cmp":
            return self.cmp[spec[1]], "", None
        if kind == "python":
            return parse_python(self.out / "log_python_overhead.txt")[spec[1]], "ms", "python_overhead"
        if kind == "ctrl_c":
            return parse_ctrl_c(self.out / "log_ctrl_c.txt")[spec[1] - 1], "s", "ctrl_c"
        raise ValueError(kind)


def parse_time(text):
    """Wall, user and system seconds and peak RSS (kB) from `/usr/bin/time -v`."""
    def field(label):
        m = re.search(re.escape(label) + r"[^:]*:\s*(\S+)", text)
        if not m:
            raise KeyError(label)
        return m.group(1)
    wall = 0.0
    for part in field("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":"):
        wall = 60.0 * wall + float(part)
    return {"wall": wall, "user": float(field("User time (seconds)")),
            "sys": float(field("System time (seconds)")), "rss_kb": float(field("Maximum resident set size"))}


def parse_uptime(path):
    """step -> {"before": 1-min load, "after": 1-min load, "rc": exit code}."""
    load = {}
    if not path.exists():
        return load
    for line in path.read_text().splitlines():
        parts = line.split("\t")
        if len(parts) < 3:
            continue
        if parts[1] == "rc":
            load.setdefault(parts[0], {})["rc"] = int(parts[2])
            continue
        m = re.search(r"load average:\s*([\d.]+)", parts[2])
        if m and parts[1] in ("before", "after"):
            load.setdefault(parts[0], {})[parts[1]] = float(m.group(1))
    return load


def parse_python(path):
    """The medians (ms) that bench/python_overhead.py prints, by the first words of its line."""
    medians = {}
    for line in path.read_text().splitlines():
        m = re.match(r"(.*?)\s+median\s+([\d.]+) ms", line)
        if m:
            medians[m.group(1).split(" (")[0].strip()] = float(m.group(2))
    return medians


def parse_ctrl_c(path):
    """(KeyboardInterrupt, stop) in seconds after the SIGINT at 0.3 s, from the test's printed line."""
    m = re.search(r"KeyboardInterrupt at ([\d.]+) s, computation stopped at ([\d.]+) s", path.read_text())
    if not m:
        raise KeyError("ctrl_c")
    return float(m.group(1)) - 0.3, float(m.group(2)) - 0.3


def fmt(value, unit):
    if isinstance(value, str):
        return value
    text = f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return f"{text} {unit}".strip() if unit != "×" else f"{text}×"


def load_text(measured, step):
    entry = measured.load.get(step, {})
    if "before" not in entry or "after" not in entry:
        return ""
    busy = " (busy)" if max(entry["before"], entry["after"]) > 1.5 else ""
    return f"{entry['before']:.2f} → {entry['after']:.2f}{busy}"


def exit_text(measured, step):
    """' (exit N)' when the step that measured a figure did not exit 0 (see its log_STEP.txt)."""
    rc = measured.load.get(step, {}).get("rc", 0)
    return f" (exit {rc}, log_{step}.txt)" if rc else ""


def rows(measured):
    seen = set()
    for label, spec, target in TARGETS:
        if spec[0].startswith("gb"):
            seen.update(spec[1:])
        try:
            value, unit, step = measured.get(spec)
        except (KeyError, FileNotFoundError, ZeroDivisionError):
            yield label, "not measured", target_text(target, spec), "—", ""
            continue
        verdict = "—" if target is None else ("met" if OPS[target[0]](value, target[1]) else "not met")
        yield (label, fmt(value, unit) + exit_text(measured, step), target_text(target, spec), verdict,
               load_text(measured, step))
    for name in sorted(set(measured.gb) - seen):  # every other benchmark, for the areas' sections
        b, step = measured.gb[name]
        value, _ = measured.gb_value(name, False)
        text = fmt(value * 1e6, "ns") if name.startswith("BM_EstimatorUpdate") else fmt(value, "ms")
        if "per_sample" in b:
            text += f" ({fmt(measured.gb_value(name, True)[0], 'ns')} per sample)"
        yield name, text, "—", "—", load_text(measured, step)


def target_text(target, spec):
    if target is None:
        return "—"
    op, bound = target
    if op == "==":
        return f"{bound}"
    unit = {"gb_ms": " ms", "gb_ns": " ns", "gb_ns_sample": " ns", "wall": " s", "rss": " MB",
            "rss_per_sample": " B", "ctrl_c": " s"}.get(spec[0], "×")
    sign = {"<=": "≤", ">=": "≥"}[op]
    return f"{sign} {bound:g}{unit}" if unit != "×" else f"{sign} {bound:g}×"


def main(argv):
    if len(argv) != 2:
        sys.exit(__doc__)
    out = Path(argv[1])
    measured = Measured(out)
    machine = (out / "machine.txt").read_text() if (out / "machine.txt").exists() else ""
    for line in machine.splitlines():
        print(f"<!-- {line} -->")
    if "smoke: 1" in machine:
        print("<!-- SMOKE RUN: tiny runs, the figures mean nothing -->")
    print("| figure | measured (median) | target | met | load before → after |")
    print("|---|---|---|---|---|")
    for row in rows(measured):
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main(sys.argv)

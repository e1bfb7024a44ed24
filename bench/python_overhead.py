"""Wall time of `hysid.identify` (NumPy arrays in, results out) against `hysid identify` on the same
40001-sample CSV. Usage: PYTHONPATH=build/python python3 bench/python_overhead.py build/bin/hysid DATA.csv"""
import statistics
import subprocess
import sys
import time

import numpy as np

import hysid

binary, data = sys.argv[1], sys.argv[2]
repeats = 15
y = np.loadtxt(data, delimiter=",", skiprows=1)[:, 4:6]
model = hysid.Model("impact-msd")


def timed(f):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return statistics.median(times), min(times)


cli = timed(lambda: subprocess.run([binary, "identify", "--data", data, "--detector", "paper", "--refine", "none"], check=True, capture_output=True))
py = timed(lambda: hysid.identify(model, y, dt=5e-4, detector="paper", refine="none", trace=False))
py_trace = timed(lambda: hysid.identify(model, y, dt=5e-4, detector="paper", refine="none", trace=True))
for name, (median, best) in [("cli (whole process: start, CSV, identify, print)", cli),
                             ("python hysid.identify, trace=False", py),
                             ("python hysid.identify, trace=True", py_trace)]:
    print(f"{name:52s} median {1e3 * median:7.2f} ms  min {1e3 * best:7.2f} ms  ({median / cli[0]:.3f} x cli)")

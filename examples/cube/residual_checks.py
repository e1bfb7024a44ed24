#!/usr/bin/python3
"""The free-flight fit of README.md by weighted least squares, with its residual checks and the
toss-clustered standard error of g.

The model of free-flight.toml is linear in (z0, vz0) per toss and g shared: vz(t) = vz0 - g t,
z(t) = z0 + vz0 t - g (t^2/2 + (dt/2) t), t from each toss's first sample. With the weights 1/sigma^2
of `hysid identify --sigma 3.75e-5 0.00614` its least-squares fit is the maximum-likelihood fit hysid
makes (the same g and white-noise standard error). Prints, for the heights and velocities together
and for the heights alone:
  g and its white-noise standard error (the inverse information),
  the lag-1 autocorrelation of the normalised residuals within tosses as hysid's check computes it
    (sum over states of sum_k r_k r_{k-1} / sigma^2 over sum of r_k^2 / sigma^2; heights alone: the
    heights' residuals of that fit),
  the toss-clustered (sandwich) standard error of g: the tosses' scores summed within each toss,
    so errors correlated within a toss count as such, times G / (G - 1) for G tosses,
  the unweighted mean of per-toss estimates and std/sqrt(G);
and for the heights and velocities, and for the velocities alone, with quadratic drag,
vz' = -g - k |vz| vz as in free-flight-quadratic-drag.toml: g and k with both standard errors, the model linearised in k at
k = 0 along each toss's drag-free fitted run (k changes vz by about 0.5 % over a toss; hysid fits
the nonlinear model, and the two agree to 1e-4 in k).

Run: /usr/bin/python3 examples/cube/residual_checks.py [examples/cube/data/free_flight.csv]
"""
import os
import sys

import numpy as np

DT = 0.006742570          # the frame step of free_flight.csv (its header)
SIGMA = (3.75e-5, 0.00614)  # --sigma of README.md's identification: z, vz


def read(path):
    with open(path) as f:
        lines = [ln for ln in f if not ln.startswith("#")]
    names = lines[0].strip().split(",")
    body = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    data = {n: body[:, i] for i, n in enumerate(names)}
    tosses = []
    for run in np.unique(data["run"]):
        rows = data["run"] == run
        t = data["t"][rows]
        tosses.append((t - t[0], data["z"][rows], data["vz"][rows]))
    return tosses


def design(t, use_v):
    """Rows (z then vz) of one toss over (z0, vz0, g), and which rows are heights."""
    hz = np.column_stack([np.ones_like(t), t, -(t * t / 2 + DT / 2 * t)])
    if not use_v:
        return hz, np.ones(t.size, bool)
    hv = np.column_stack([np.zeros_like(t), np.ones_like(t), -t])
    return np.vstack([hz, hv]), np.r_[np.ones(t.size, bool), np.zeros(t.size, bool)]


def fit(tosses, use_v):
    """Weighted least squares with g shared: g, its white-noise se, the clustered se, the lag-1 value
    of the pooled normalised residuals and of the heights' alone."""
    # Per toss: the weighted rows with its own (z0, vz0) projected out, so g's normal equation is
    # sum_i a_i' a_i g = sum_i a_i' b_i.
    parts = []
    for t, z, v in tosses:
        x, is_z = design(t, use_v)
        y = np.r_[z, v] if use_v else z
        w = np.where(is_z, 1 / SIGMA[0], 1 / SIGMA[1])
        xw, yw = x * w[:, None], y * w
        q, _ = np.linalg.qr(xw[:, :2])
        a = xw[:, 2] - q @ (q.T @ xw[:, 2])
        b = yw - q @ (q.T @ yw)
        parts.append((a, b, is_z, t.size))
    info = sum(a @ a for a, _, _, _ in parts)
    g = sum(a @ b for a, b, _, _ in parts) / info
    scores = np.array([a @ (b - a * g) for a, b, _, _ in parts])  # each toss's score at ĝ
    n_tosses = len(parts)
    clustered = np.sqrt(n_tosses / (n_tosses - 1) * np.sum(scores ** 2)) / info if n_tosses > 1 else np.nan
    lag = {"pooled": [0.0, 0.0], "z": [0.0, 0.0]}
    for a, b, is_z, n in parts:
        r = b - a * g  # normalised residuals, z rows then vz rows
        for key, rows in (("pooled", [r[is_z]] + ([r[~is_z]] if use_v else [])), ("z", [r[is_z]])):
            for s in rows:
                lag[key][0] += s[1:] @ s[:-1]
                lag[key][1] += s @ s
    return {"g": g, "se_white": 1 / np.sqrt(info), "se_clustered": clustered, "tosses": n_tosses,
            "lag1_pooled": lag["pooled"][0] / lag["pooled"][1], "lag1_z": lag["z"][0] / lag["z"][1]}


def drag_column(t, vz0, g):
    """d(z, vz)/dk at k = 0 along vz(s) = vz0 - g s: vz' gains -k |vz| vz, z' = vz - (dt/2) g does not."""
    fine = 64
    s = np.linspace(0, t[-1], fine * (t.size - 1) + 1)
    v = vz0 - g * s
    f = np.abs(v) * v
    dv = np.r_[0, np.cumsum((f[1:] + f[:-1]) / 2 * np.diff(s))]
    dz = np.r_[0, np.cumsum((dv[1:] + dv[:-1]) / 2 * np.diff(s))]
    return -dz[::fine], -dv[::fine]


def drag_fit(tosses, use_z=True):
    """Heights and velocities (or velocities alone), (g, k) shared, (z0, vz0) per toss, k linearised
    at 0 along the runs of fit(tosses, True): estimates, white-noise and toss-clustered standard errors."""
    g0 = fit(tosses, True)["g"]
    parts = []
    for t, z, v in tosses:
        x, is_z = design(t, True)
        y = np.r_[z, v]
        w = np.where(is_z, 1 / SIGMA[0] if use_z else 0.0, 1 / SIGMA[1])
        xw, yw = x * w[:, None], y * w
        z0v0, *_ = np.linalg.lstsq(xw[:, :2], yw - xw[:, 2] * g0, rcond=None)
        kz, kv = drag_column(t, z0v0[1], g0)
        a = np.column_stack([xw[:, 2], np.r_[kz, kv] * w])
        nuisance = xw[:, :2] if use_z else xw[:, 1:2]  # without heights z0 is no unknown
        q, _ = np.linalg.qr(nuisance)
        parts.append((a - q @ (q.T @ a), yw - q @ (q.T @ yw)))
    info = sum(a.T @ a for a, _ in parts)
    theta = np.linalg.solve(info, sum(a.T @ b for a, b in parts))
    scores = np.array([a.T @ (b - a @ theta) for a, b in parts])
    cov = np.linalg.inv(info)
    meat = len(parts) / (len(parts) - 1) * scores.T @ scores
    return {"g": theta[0], "k": theta[1], "se_white": np.sqrt(np.diag(cov)),
            "se_clustered": np.sqrt(np.diag(cov @ meat @ cov))}


def per_toss(tosses):
    """g of each toss alone (heights and velocities, same weights): mean and std/sqrt(N)."""
    gs = np.array([fit([toss], True)["g"] if toss[0].size >= 3 else np.nan for toss in tosses])
    gs = gs[np.isfinite(gs)]
    return gs.mean(), gs.std(ddof=1) / np.sqrt(gs.size)


def main(argv):
    path = argv[1] if len(argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "data",
                                                      "free_flight.csv")
    tosses = read(path)
    print(f"{path}: {len(tosses)} tosses, {sum(t.size for t, _, _ in tosses)} samples; sigma = {SIGMA}")
    for label, use_v in (("heights and velocities", True), ("heights alone", False)):
        f = fit(tosses, use_v)
        print(f"{label}: g = {f['g']:.6f}, se {f['se_white']:.6f} (white noise), "
              f"{f['se_clustered']:.6f} (toss-clustered); lag-1 of the normalised residuals within tosses: "
              f"{f['lag1_pooled']:.3f} pooled over the fitted states, {f['lag1_z']:.3f} heights alone")
    mean, sem = per_toss(tosses)
    print(f"each toss alone (heights and velocities): mean g = {mean:.4f}, std/sqrt(N) = {sem:.4f}")
    for label, use_z in (("heights and velocities", True), ("velocities alone", False)):
        d = drag_fit(tosses, use_z)
        print(f"{label} with quadratic drag (linearised in k): g = {d['g']:.4f}, se {d['se_white'][0]:.4f} "
              f"(white noise), {d['se_clustered'][0]:.4f} (toss-clustered); k = {d['k']:.4f} 1/m, "
              f"se {d['se_white'][1]:.4f} (white noise), {d['se_clustered'][1]:.4f} (toss-clustered)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

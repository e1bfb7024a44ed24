#!/usr/bin/python3
"""Converts the ContactNets cube tosses of DAIRLab/dair_pll into hysid multi-run CSV files.

The recording: assets/contactnets_cube/N.pt (N = 0..549) of https://github.com/DAIRLab/dair_pll
(BSD-3-Clause, the repository's LICENSE), each one toss of a 0.37 kg cube of edge 0.1048 m
(assets/contactnets_cube.urdf) onto a table, one row per camera frame (AprilTag tracking, about
148 Hz) with 13 columns: unit quaternion (w, x, y, z), position (x, y, z) of the cube's centre in
the table's frame (m, z up, table top near z = 0), angular velocity in body axes (rad/s), linear
velocity in world axes (m/s). The order is dair_pll's FloatingBaseSpace (dair_pll/state_space.py:
"4 quaternion + 3 world-axes position configuration coordinates and 3 body-axes angular velocity + 3
world-axes linear velocity"). The files hold no time stamps; the velocities are backward differences
of the positions over each frame's time stamp step, median-filtered over 3 samples (checked below).

A .pt file is a zip holding a pickle and raw little-endian float64 storage; it is read here with
zipfile and a restricted unpickler (no PyTorch; any class other than the tensor rebuild, the float
storages and OrderedDict is refused).

The .pt files are read from a directory (--pt-dir; by default $HYSID_DAIR_PLL_DIR, else
../shared/data/dair_pll/assets/contactnets_cube beside this repository: README.md, "Data") or from
a git clone of dair_pll (--repo); either way they must be those of commit 523d372 (checked by a
digest of their sha256sum list). Writes into --out (a build directory; see README.md for the rules
and why):
  free_flight.csv  run,t,z,vz   each toss's free flight before its first contact with the table
  whole_tosses.csv run,t,z,vz   the whole tosses of the first WHOLE_TOSSES files, impacts included
and prints the frame step recovered from the data and what was kept.

Usage: convert.py [--pt-dir DIR | --repo GIT_DIR] --out DIR [--dt SECONDS] [--margin METRES]
Exit codes: 0 written, 2 the recording is missing or not the expected one (the message says which).
"""

import argparse
import collections
import hashlib
import io
import os
import pickle
import subprocess
import sys
import zipfile

import numpy as np

COMMIT = "523d372d8c2b50ea5ce77082d4f08879c753d963"
TOSSES = 550
# sha256 of the output of `sha256sum 0.pt 1.pt ... 549.pt` (two spaces, one line a file) at COMMIT
TOSSES_DIGEST = "81ee89b75d5266b6e97ab962d789d92de0b007a72b5b581d05cafe7217fc3c55"
DATA_ENV = "HYSID_DAIR_PLL_DIR"
REPO_ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
HALF_EDGE = 0.1048 / 2  # m, assets/contactnets_cube.urdf: <box size="0.1048 0.1048 0.1048"/>
CONTACT_MARGIN = 0.005  # m above the toss's resting level of the lowest corner: contact
REST_SAMPLES = 10       # the last samples of a toss (the cube at rest) give the resting level
MIN_FLIGHT = 6          # a toss with fewer free-flight samples is left out (the refinement needs 6)
FIRST_KEPT = 2          # the first free-flight sample kept (see README.md)
WHOLE_TOSSES = 40       # whole_tosses.csv: files 0..WHOLE_TOSSES-1
STEP_WINDOW = (0.0062, 0.0073)  # s: a recovered step outside this is not a frame step

_STORAGES = {"DoubleStorage": np.float64, "FloatStorage": np.float32}


def _rebuild_tensor(storage, offset, size, stride, *unused):
    item = storage.dtype.itemsize
    view = np.lib.stride_tricks.as_strided(storage[offset:], shape=tuple(size),
                                           strides=tuple(s * item for s in stride))
    return np.array(view)


class _StorageType:
    def __init__(self, name):
        self.dtype = np.dtype(_STORAGES[name]).newbyteorder("<")


class _TensorUnpickler(pickle.Unpickler):
    """Unpickles a torch.save zip: tensors become numpy arrays; nothing else is constructed."""

    def __init__(self, archive, prefix):
        super().__init__(io.BytesIO(archive.read(prefix + "/data.pkl")))
        self.archive, self.prefix = archive, prefix

    def find_class(self, module, name):
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor
        if module == "torch" and name in _STORAGES:
            return _StorageType(name)
        if (module, name) == ("collections", "OrderedDict"):
            return collections.OrderedDict
        raise pickle.UnpicklingError(f"refusing to load {module}.{name}")

    def persistent_load(self, pid):
        kind, storage_type, key, _location, numel = pid
        if kind != "storage" or not isinstance(storage_type, _StorageType):
            raise pickle.UnpicklingError(f"unexpected persistent id {pid!r}")
        raw = self.archive.read(f"{self.prefix}/data/{key}")
        return np.frombuffer(raw, dtype=storage_type.dtype, count=numel)


def load_pt(data):
    """The tensor in a torch.save file (bytes) as a numpy array."""
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        pickles = [n for n in archive.namelist() if n.endswith("/data.pkl")]
        if len(pickles) != 1:
            raise ValueError("not a torch.save zip: no single data.pkl")
        return _TensorUnpickler(archive, pickles[0][: -len("/data.pkl")]).load()


class MissingRecording(Exception):
    """The recording is absent or not the files of COMMIT; the message says what and where."""


def default_pt_dir():
    """$HYSID_DAIR_PLL_DIR if set, else the shared data folder beside this repository."""
    return os.environ.get(DATA_ENV) or os.path.normpath(os.path.join(
        REPO_ROOT, "..", "shared", "data", "dair_pll", "assets", "contactnets_cube"))


def read_blobs_from_dir(pt_dir):
    """The bytes of pt_dir/0.pt … pt_dir/549.pt."""
    if not os.path.isdir(pt_dir):
        raise MissingRecording(f"{pt_dir}: no such directory (the ContactNets cube recording, "
                               "examples/cube/README.md, section \"Data\")")
    blobs = []
    for index in range(TOSSES):
        path = os.path.join(pt_dir, f"{index}.pt")
        if not os.path.isfile(path):
            raise MissingRecording(f"{path}: missing (the recording has the {TOSSES} files "
                                   f"0.pt … {TOSSES - 1}.pt)")
        with open(path, "rb") as f:
            blobs.append(f.read())
    return blobs


def read_blobs_from_git(repo, commit):
    """The bytes of assets/contactnets_cube/N.pt at `commit` of the git directory `repo`."""
    blobs = []
    for index in range(TOSSES):
        path = f"{commit}:assets/contactnets_cube/{index}.pt"
        run = subprocess.run(["git", "-C", repo, "show", path], capture_output=True)
        if run.returncode != 0:
            raise MissingRecording(f"{repo}: git show {path} failed: {run.stderr.decode().strip()}")
        blobs.append(run.stdout)
    return blobs


def check_digest(blobs, where):
    """Refuses files other than those of COMMIT (the digest of their sha256sum list)."""
    listing = "".join(f"{hashlib.sha256(b).hexdigest()}  {i}.pt\n" for i, b in enumerate(blobs))
    digest = hashlib.sha256(listing.encode("ascii")).hexdigest()
    if digest != TOSSES_DIGEST:
        raise MissingRecording(f"{where}: the {TOSSES} .pt files are not those of dair_pll {COMMIT} "
                               f"(digest of their sha256sum list {digest}, expected {TOSSES_DIGEST})")


def parse_toss(blob, index):
    toss = load_pt(blob).reshape(-1, 13)
    if not np.all(np.isfinite(toss)):
        raise ValueError(f"toss {index}: non-finite values")
    return toss


def lowest_corner_height(toss):
    """Height of the cube's lowest corner per sample, from the quaternion, the centre and the edge."""
    w, x, y, z = toss[:, 0:4].T
    # third row of the rotation matrix (body to world): the world z of each body axis
    r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    # the lowest corner's depth below the centre
    reach = HALF_EDGE * (np.abs(r20) + np.abs(r21) + np.abs(r22))
    return toss[:, 6] - reach


def first_contact(toss, margin):
    """Index of the first sample in contact: the lowest corner within `margin` of its resting level."""
    height = lowest_corner_height(toss)
    rest = np.median(height[-REST_SAMPLES:])
    below = np.flatnonzero(height < rest + margin)
    return (int(below[0]) if below.size else len(toss)), rest


def recovered_steps(toss, first, end):
    """Frame steps Δt_k = (z_k − z_{k−1}) / vz_k of the samples k = first … end − 1 (first ≥ 1).

    Over free-flight samples whose median window lies in the flight, Δz_k/Δt_k decreases
    monotonically (by g·Δt ≈ 0.066 m/s a step, the noise being about 0.01 m/s), so the 3-sample
    median filter keeps each sample's own difference and the ratio is that frame's time stamp step."""
    dz = np.diff(toss[first - 1:end, 6])
    vz = toss[first:end, 12]
    with np.errstate(divide="ignore", invalid="ignore"):
        steps = dz / vz
    return steps[(steps > STEP_WINDOW[0]) & (steps < STEP_WINDOW[1])]


def pooled_fit(runs, times, column, degree):
    """Least squares with one shared coefficient of t^degree/degree! (−g) and, per run, a free
    polynomial of lower degree (z: z0 + v0 t; vz: v0); times(toss) gives a run's sample times.
    Returns ĝ, its white-noise standard error and the residual RMS (degrees of freedom counted)."""
    num = den = 0.0
    parts = []
    for _, toss in runs:
        t = times(toss)
        basis = np.vander(t, degree, increasing=True)
        project = np.eye(len(t)) - basis @ np.linalg.pinv(basis)
        u = project @ (-t**degree / (2 if degree == 2 else 1))
        w = project @ toss[:, column]
        num, den = num + u @ w, den + u @ u
        parts.append((u, w))
    g = num / den
    residual = np.concatenate([w - g * u for u, w in parts])
    rms = np.sqrt(residual @ residual / (residual.size - degree * len(runs) - 1))
    return g, rms / np.sqrt(den), rms


def per_toss_g(runs, dt):
    """ĝ of each toss alone (a parabola through its heights), its white-noise standard error, and
    the residual RMS of these parabolas (pooled over the tosses, degrees of freedom counted)."""
    g, unit_se, squares, dof = [], [], 0.0, 0
    for _, toss in runs:
        basis = np.vander(np.arange(len(toss)) * dt, 3)
        coefficients, residual, _, _ = np.linalg.lstsq(basis, toss[:, 6], rcond=None)
        g.append(-2 * coefficients[0])
        unit_se.append(2 * np.sqrt(np.linalg.inv(basis.T @ basis)[0, 0]))
        squares, dof = squares + residual.sum(), dof + len(toss) - 3
    sigma = np.sqrt(squares / dof)
    return np.array(g), sigma * np.array(unit_se), sigma


def stamp_times(toss, dt):
    """The frame times from the recovered steps Δz_k/vz_k (dt where a step is not recovered)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        steps = np.diff(toss[:, 6]) / toss[1:, 12]
    steps[~((steps > STEP_WINDOW[0]) & (steps < STEP_WINDOW[1]))] = dt
    return np.concatenate([[0.0], np.cumsum(steps)])


def report_checks(flights, dt):
    grid = lambda toss: np.arange(len(toss)) * dt  # noqa: E731
    g, se, sigma_z = pooled_fit(flights, grid, 6, 2)
    print(f"heights only (least squares, g shared, z0 and v0 per toss): g = {g:.4f} +- {se:.4f} "
          f"(white noise), residual RMS sigma_z = {sigma_z * 1e6:.1f} um")
    g_s, se_s, sigma_s = pooled_fit(flights, lambda toss: stamp_times(toss, dt), 6, 2)
    print(f"the same at the recovered time stamps instead of k*dt: g = {g_s:.4f} +- {se_s:.4f}, "
          f"residual RMS {sigma_s * 1e6:.1f} um")
    g_v, se_v, sigma_v = pooled_fit(flights, grid, 12, 1)
    print(f"velocities only (least squares, g shared, v0 per toss): g = {g_v:.4f} +- {se_v:.4f} "
          f"(white noise), residual RMS sigma_vz = {sigma_v:.5f} m/s")
    each, each_se, sigma_each = per_toss_g(flights, dt)
    weights = 1 / each_se**2
    mean = np.sum(weights * each) / np.sum(weights)
    chi2 = np.sum(weights * (each - mean)**2) / (each.size - 1)
    print(f"each toss alone: mean g = {each.mean():.4f}, std {each.std(ddof=1):.4f} over {each.size} "
          f"tosses (std/sqrt(N) = {each.std(ddof=1) / np.sqrt(each.size):.4f}); residual RMS of the "
          f"parabolas {sigma_each * 1e6:.1f} um; the tosses' g scatter {np.sqrt(chi2):.2f} times "
          f"their standard errors (chi2/dof = {chi2:.2f})")


def write_runs(path, runs, dt, header):
    with open(path, "w", encoding="ascii") as out:
        for line in header:
            out.write(f"# {line}\n")
        out.write("run,t,z,vz\n")
        for index, toss in runs:
            for k, row in enumerate(toss):
                out.write(f"{index},{k * dt:.6f},{row[6]:.6f},{row[12]:.5f}\n")


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--pt-dir", help="directory holding 0.pt … 549.pt (default: $HYSID_DAIR_PLL_DIR, "
                                         "else ../shared/data/dair_pll/assets/contactnets_cube beside "
                                         "this repository)")
    source.add_argument("--repo", help=f"instead: a clone of DAIRLab/dair_pll (its git directory), "
                                       f"read at commit {COMMIT}")
    parser.add_argument("--out", required=True, help="directory for the two CSV files (made if absent)")
    parser.add_argument("--dt", type=float, help="time step of the files (default: recovered from the data)")
    parser.add_argument("--margin", type=float, default=CONTACT_MARGIN,
                        help="m: contact when the lowest corner comes this close to its resting level "
                             f"(default {CONTACT_MARGIN})")
    return parser.parse_args(argv)


def load_tosses(args):
    """The 550 tosses, from --repo or from --pt-dir (or its default); MissingRecording if absent."""
    if args.repo is not None:
        blobs, where = read_blobs_from_git(args.repo, COMMIT), args.repo
    else:
        where = args.pt_dir or default_pt_dir()
        blobs = read_blobs_from_dir(where)
    check_digest(blobs, where)
    return [parse_toss(blob, index) for index, blob in enumerate(blobs)]


def free_flights(tosses, margin):
    """Each toss's kept free-flight samples (tosses with at least MIN_FLIGHT), the recovered frame
    steps, and the tosses left out with their sample counts."""
    flights, steps, short = [], [], []
    for index, toss in enumerate(tosses):
        flight, _rest = first_contact(toss, margin)
        end = max(flight - 1, FIRST_KEPT)  # the last sample before contact has contact in its window
        steps.append(recovered_steps(toss, FIRST_KEPT, end))
        kept = toss[FIRST_KEPT:end]
        if len(kept) < MIN_FLIGHT:
            short.append((index, len(kept)))
            continue
        flights.append((index, kept))
    return flights, np.concatenate(steps), short


def write_files(out, tosses, flights, dt, args):
    os.makedirs(out, exist_ok=True)
    source = (f"DAIRLab/dair_pll {COMMIT} assets/contactnets_cube/N.pt (BSD-3-Clause, "
              "dair_pll's LICENSE); run = N")
    step_source = "the mean frame step recovered from the data" if args.dt is None else "given"
    common = [source,
              f"t = k * {dt:.9f} s ({step_source}); z, vz: the recording's "
              "columns 7 and 13 (centre height, m; vertical velocity, m/s)"]
    write_runs(os.path.join(out, "free_flight.csv"), flights, dt,
               common + [f"free flight: the samples before the lowest corner first comes within "
                         f"{args.margin * 1e3:g} mm of its resting level, less the toss's first two "
                         f"samples and the last before contact; tosses with at least {MIN_FLIGHT} "
                         "such samples"])
    write_runs(os.path.join(out, "whole_tosses.csv"), list(enumerate(tosses[:WHOLE_TOSSES])), dt,
               common + [f"whole tosses 0..{WHOLE_TOSSES - 1}, impacts and rest included"])


def main(argv):
    args = parse_args(argv)
    try:
        tosses = load_tosses(args)
    except MissingRecording as error:
        print(f"convert.py: {error}", file=sys.stderr)
        return 2
    flights, steps, short = free_flights(tosses, args.margin)
    dt = float(np.mean(steps))
    print(f"frame step: {steps.size} recovered steps, mean {dt * 1e3:.5f} ms ({1 / dt:.3f} Hz), "
          f"std {np.std(steps) * 1e6:.1f} us, median {np.median(steps) * 1e3:.5f} ms")
    if args.dt is not None:
        dt = args.dt
        print(f"files written with the step given: {dt * 1e3:.5f} ms")
    print(f"free flight: {len(flights)} tosses, {sum(len(f) for _, f in flights)} samples "
          f"(left out, fewer than {MIN_FLIGHT} samples: {len(short)} tosses {short})")
    report_checks(flights, dt)
    rest_z = [np.median(toss[-REST_SAMPLES:, 6]) for toss in tosses]
    print(f"resting centre height (median of each toss's last {REST_SAMPLES} samples): median "
          f"{np.median(rest_z) * 1e3:.2f} mm over {len(rest_z)} tosses "
          f"(half the edge: {HALF_EDGE * 1e3:.1f} mm); "
          f"largest |vz| in the free flight: {max(np.abs(f[:, 12]).max() for _, f in flights):.2f} m/s")
    write_files(args.out, tosses, flights, dt, args)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

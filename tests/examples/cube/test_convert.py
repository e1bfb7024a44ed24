"""examples/cube/convert.py against closed forms: the torch.save reader, the lowest corner of the
cube, the frame steps recovered from backward-differenced, median-filtered velocities, and where and
how it finds the recording (which refusals need no recording)."""
import hashlib
import io
import math
import os
import pickle
import sys
import types
import zipfile

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "..", "examples", "cube"))
import convert  # noqa: E402


class _FakeTorch:
    """Stand-ins named like torch's classes, so that pickle writes the globals torch.save writes."""

    def __init__(self):
        self.torch = types.ModuleType("torch")
        self.utils = types.ModuleType("torch._utils")

        def _rebuild_tensor_v2(*args):
            raise AssertionError("never called while pickling")

        _rebuild_tensor_v2.__module__ = "torch._utils"
        _rebuild_tensor_v2.__qualname__ = "_rebuild_tensor_v2"
        self.utils._rebuild_tensor_v2 = _rebuild_tensor_v2
        self.torch.DoubleStorage = type("DoubleStorage", (), {"__module__": "torch"})

    def __enter__(self):
        self.saved = {k: sys.modules.get(k) for k in ("torch", "torch._utils")}
        sys.modules["torch"], sys.modules["torch._utils"] = self.torch, self.utils
        return self

    def __exit__(self, *exc):
        for k, v in self.saved.items():
            if v is None:
                sys.modules.pop(k)
            else:
                sys.modules[k] = v


class _Tensor:
    def __init__(self, fake, size, stride):
        self.fake, self.size, self.stride = fake, size, stride

    def __reduce__(self):
        storage = ("storage", self.fake.torch.DoubleStorage, "0", "cpu", 6)
        return (self.fake.utils._rebuild_tensor_v2, (storage, 0, self.size, self.stride, False, {}))


def _torch_save_bytes(values, size, stride):
    """A zip laid out as torch.save writes one float64 tensor over the storage `values`."""
    with _FakeTorch() as fake:
        class Pickler(pickle.Pickler):
            def persistent_id(self, obj):
                return obj if isinstance(obj, tuple) and obj[:1] == ("storage",) else None

        buffer = io.BytesIO()
        Pickler(buffer, protocol=2).dump(_Tensor(fake, size, stride))
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("archive/data.pkl", buffer.getvalue())
        z.writestr("archive/data/0", np.asarray(values, dtype="<f8").tobytes())
        z.writestr("archive/version", "3\n")
    return archive.getvalue()


def test_reads_a_tensor_with_its_strides():
    storage = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    np.testing.assert_array_equal(convert.load_pt(_torch_save_bytes(storage, (2, 3), (3, 1))),
                                  [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(convert.load_pt(_torch_save_bytes(storage, (3, 2), (1, 3))),
                                  [[1, 4], [2, 5], [3, 6]])


def test_refuses_any_other_class():
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("archive/data.pkl", pickle.dumps(print, protocol=2))
    with pytest.raises(pickle.UnpicklingError, match="refusing to load .*print"):
        convert.load_pt(archive.getvalue())


def _toss(quaternion, z):
    row = np.zeros(13)
    row[0:4], row[6] = quaternion, z
    return row[None, :]


def test_lowest_corner_flat_on_an_edge_and_on_a_corner():
    h = convert.HALF_EDGE
    assert convert.lowest_corner_height(_toss([1, 0, 0, 0], 0.3))[0] == pytest.approx(0.3 - h, abs=1e-15)
    half = math.pi / 8  # 45° about x: the cube stands on an edge
    edge = convert.lowest_corner_height(_toss([math.cos(half), math.sin(half), 0, 0], 0.3))[0]
    assert edge == pytest.approx(0.3 - h * math.sqrt(2), abs=1e-15)
    # the body diagonal (1, 1, 1) turned onto the vertical: the cube stands on a corner
    axis = np.cross([1, 1, 1], [0, 0, 1]) / np.linalg.norm(np.cross([1, 1, 1], [0, 0, 1]))
    angle = math.acos(1 / math.sqrt(3))
    q = [math.cos(angle / 2), *(math.sin(angle / 2) * axis)]
    corner = convert.lowest_corner_height(_toss(q, 0.3))[0]
    assert corner == pytest.approx(0.3 - h * math.sqrt(3), abs=1e-14)


def test_recovers_the_frame_steps_of_a_free_fall():
    rng = np.random.default_rng(7)
    steps = 0.0067 + 40e-6 * rng.standard_normal(30)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    z = 0.3 + 0.4 * t - 0.5 * 9.81 * t**2 + 15e-6 * rng.standard_normal(t.size)
    v = np.concatenate([[np.nan], np.diff(z) / steps])  # v[k]: backward difference over steps[k-1]
    filtered = np.median(np.stack([v[:-2], v[1:-1], v[2:]]), axis=0)  # 3-sample median at k = 1..N-1
    rows = np.arange(2, t.size - 1)                     # the samples whose median window is complete
    toss = np.zeros((rows.size, 13))
    toss[:, 6], toss[:, 12] = z[rows], filtered[rows - 1]
    # toss row j is sample j + 2: its step is steps[j + 1]
    np.testing.assert_allclose(convert.recovered_steps(toss, 1, rows.size), steps[2:rows.size + 1], rtol=1e-12)
    np.testing.assert_allclose(convert.recovered_steps(toss, 3, 10), steps[4:11], rtol=1e-12)


def test_finds_the_recording_from_the_environment_else_beside_the_repository(monkeypatch):
    monkeypatch.setenv(convert.DATA_ENV, "/somewhere/contactnets_cube")
    assert convert.default_pt_dir() == "/somewhere/contactnets_cube"
    monkeypatch.delenv(convert.DATA_ENV)
    repo = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
    assert convert.default_pt_dir() == os.path.join(os.path.dirname(repo), "shared", "data", "dair_pll",
                                                    "assets", "contactnets_cube")


def test_refuses_an_absent_incomplete_or_different_recording(tmp_path, capsys):
    with pytest.raises(convert.MissingRecording, match=f"{tmp_path}/none: no such directory"):
        convert.read_blobs_from_dir(str(tmp_path / "none"))
    for index in range(convert.TOSSES - 1):
        (tmp_path / f"{index}.pt").write_bytes(b"")
    with pytest.raises(convert.MissingRecording, match=f"{tmp_path}/549.pt: missing"):
        convert.read_blobs_from_dir(str(tmp_path))
    (tmp_path / "549.pt").write_bytes(b"")
    # 550 empty files: their sha256sum list is not that of dair_pll's commit
    with pytest.raises(convert.MissingRecording, match="not those of dair_pll 523d372d8c2b"):
        convert.check_digest(convert.read_blobs_from_dir(str(tmp_path)), str(tmp_path))
    out = tmp_path / "out"
    assert convert.main(["--pt-dir", str(tmp_path), "--out", str(out)]) == 2
    assert "not those of dair_pll" in capsys.readouterr().err and not out.exists()


def test_the_digest_is_that_of_a_sha256sum_list(monkeypatch):
    # what `sha256sum 0.pt 1.pt | sha256sum` prints for files holding "a" and "bc"
    listing = (f"{hashlib.sha256(b'a').hexdigest()}  0.pt\n"
               f"{hashlib.sha256(b'bc').hexdigest()}  1.pt\n")
    monkeypatch.setattr(convert, "TOSSES_DIGEST", hashlib.sha256(listing.encode()).hexdigest())
    convert.check_digest([b"a", b"bc"], "here")
    with pytest.raises(convert.MissingRecording):
        convert.check_digest([b"a", b"bd"], "here")

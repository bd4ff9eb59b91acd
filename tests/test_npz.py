import hashlib

import numpy as np
import pytest

import follicle
from follicle import FormatError, HairCurves


def _curves():
    rng = np.random.default_rng(3)
    return HairCurves.from_array(
        rng.normal(size=(5, 4, 3)),
        point_data={
            "width": rng.random(20).astype(np.float32),
            "color": rng.random((20, 3)).astype(np.float32),
        },
        curve_data={"hair_id": np.arange(5), "root_uv": rng.random((5, 2)).astype(np.float32)},
    )


def test_roundtrip_is_lossless_with_documented_keys(tmp_path):
    c = _curves()
    path = follicle.save(c, tmp_path / "x.npz")
    back = follicle.load_curves(path)
    assert back == c
    assert back.point_data["color"].dtype == np.float32
    with np.load(path) as npz:
        assert set(npz.files) == {
            "format_version",
            "points",
            "offsets",
            "point_data.width",
            "point_data.color",
            "curve_data.hair_id",
            "curve_data.root_uv",
        }
        assert int(npz["format_version"]) == 1


def test_same_curves_give_same_bytes(tmp_path):
    a = follicle.save(_curves(), tmp_path / "a.npz")
    b = follicle.save(_curves(), tmp_path / "b.npz")
    assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()


def test_missing_truncated_and_foreign_files_are_format_errors(tmp_path):
    with pytest.raises(FormatError, match="no such file"):
        follicle.load_curves(tmp_path / "nope.npz")
    good = follicle.save(_curves(), tmp_path / "good.npz")
    bad = tmp_path / "trunc.npz"
    bad.write_bytes(good.read_bytes()[:200])
    with pytest.raises(FormatError, match="trunc.npz"):
        follicle.load_curves(bad)
    other = tmp_path / "other.npz"
    np.savez(other, something=np.zeros(3))
    with pytest.raises(FormatError, match="missing array 'format_version'"):
        follicle.load_curves(other)


def test_inconsistent_archive_names_the_problem(tmp_path):
    path = tmp_path / "broken.npz"
    np.savez(
        path,
        format_version=np.array(1),
        points=np.zeros((3, 3), np.float32),
        offsets=np.array([0, 2]),
    )
    with pytest.raises(FormatError, match="broken.npz: offsets"):
        follicle.load_curves(path)


def test_unknown_extension_lists_supported(tmp_path):
    with pytest.raises(FormatError, match=r"cannot write '\.xyz' files; use \.npz"):
        follicle.save(_curves(), tmp_path / "x.xyz")
    assert not (tmp_path / "x.xyz").exists()


def test_failed_write_leaves_no_file(tmp_path, monkeypatch):
    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(np.lib.format, "write_array", boom)
    with pytest.raises(RuntimeError):
        follicle.save(_curves(), tmp_path / "x.npz")
    assert list(tmp_path.iterdir()) == []


def test_written_files_get_the_usual_permissions(tmp_path):
    import os

    mask = os.umask(0o022)
    try:
        path = follicle.save(_curves(), tmp_path / "x.npz")
    finally:
        os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o644

"""follicle's native lossless format: a NumPy ``.npz`` archive of a HairCurves.

Keys: ``format_version``, ``points``, ``offsets``, ``point_data.<name>`` and
``curve_data.<name>``. Arrays are stored as they are (dtype and shape kept), so a
load gives back an equal HairCurves. Written uncompressed with fixed member
timestamps, so the same curves give the same bytes.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from ..curves import HairCurves
from ..errors import FormatError, InputError
from .atomic import atomic_path
from .stream import Curves, as_chunks

__all__ = ["FORMAT_VERSION", "save_npz", "load_npz", "save_arrays"]

FORMAT_VERSION = 1
_FIXED_DATE = (1980, 1, 1, 0, 0, 0)


def save_npz(curves: Curves, path: str | os.PathLike[str]) -> Path:
    """Write ``curves`` (HairCurves or chunks, joined in memory: .npz is not a streaming
    format) to ``path``, atomically and byte-reproducibly."""
    chunks = list(as_chunks(curves))
    curves = chunks[0] if len(chunks) == 1 else HairCurves.concatenate(chunks)
    arrays: dict[str, np.ndarray] = {
        "format_version": np.array(FORMAT_VERSION, dtype=np.int64),
        "points": curves.points,
        "offsets": curves.offsets,
    }
    for kind, data in (("point_data", curves.point_data), ("curve_data", curves.curve_data)):
        for name, arr in sorted(data.items()):
            if "/" in name or not name:
                raise InputError(f"{kind}: attribute name {name!r} cannot be stored")
            arrays[f"{kind}.{name}"] = arr
    return save_arrays(path, arrays)


def save_arrays(path: str | os.PathLike[str], arrays: dict[str, np.ndarray]) -> Path:
    """Write named arrays as an uncompressed ``.npz`` that ``np.load`` reads, atomically
    and with fixed member timestamps (``np.savez`` stamps the time: same arrays, other bytes).
    """
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", zipfile.ZIP_STORED) as zf:
        for key, arr in arrays.items():
            info = zipfile.ZipInfo(f"{key}.npy", date_time=_FIXED_DATE)
            with zf.open(info, "w") as fh:
                np.lib.format.write_array(fh, np.require(arr, requirements="C"), allow_pickle=False)
    return Path(path)


def load_arrays(path: str | os.PathLike[str]) -> tuple[Path, dict[str, np.ndarray]]:
    """Every array of an .npz archive (no pickles), or FormatError naming the file."""
    p = Path(path)
    if not p.is_file():
        raise FormatError(f"{p}: no such file")
    try:
        with np.load(p, allow_pickle=False) as npz:
            return p, {k: npz[k] for k in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise FormatError(f"{p}: not a readable .npz archive ({exc})") from None


def load_npz(path: str | os.PathLike[str]) -> HairCurves:
    """Read a HairCurves written by :func:`save_npz`."""
    p, data = load_arrays(path)
    for key in ("format_version", "points", "offsets"):
        if key not in data:
            raise FormatError(f"{p}: missing array '{key}'; is this a follicle curves file?")
    version = int(data.pop("format_version"))
    if version > FORMAT_VERSION:
        raise FormatError(
            f"{p}: format_version {version} is newer than this follicle reads"
            f" ({FORMAT_VERSION}); upgrade follicle"
        )
    point_data = {k.split(".", 1)[1]: v for k, v in data.items() if k.startswith("point_data.")}
    curve_data = {k.split(".", 1)[1]: v for k, v in data.items() if k.startswith("curve_data.")}
    try:
        return HairCurves(data["points"], data["offsets"], point_data, curve_data)
    except InputError as exc:
        raise FormatError(f"{p}: {exc}") from None

"""MP4 output: H.264 video of rendered frames through imageio-ffmpeg's bundled ffmpeg.

yuv420p, the pixel format every player decodes, halves the chroma resolution and so
needs even width and height: an odd-sized frame gets its last column and/or row
repeated once (padding by one pixel, nothing cropped). Frames stream to ffmpeg one by
one, so memory stays at one frame; the file is written to a temporary name beside the
target and renamed when complete.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..io.atomic import atomic_path

__all__ = ["write_mp4"]


def _ffmpeg():
    try:
        import imageio_ffmpeg
    except ImportError:
        raise InputError(
            "MP4 output needs imageio-ffmpeg; install the video extra:"
            " pip install 'follicle[video]'"
        ) from None
    return imageio_ffmpeg


def _even(frame: np.ndarray) -> np.ndarray:
    """The frame with its last row/column repeated where height/width is odd."""
    h, w = frame.shape[:2]
    return np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")


def _rgb(frame: object, index: int, size: tuple[int, ...] | None) -> np.ndarray:
    """The frame as contiguous, even-sized RGB, checked to be (H, W) = ``size``."""
    arr = np.asarray(frame)
    if arr.dtype != np.uint8 or arr.ndim != 3 or arr.shape[2] not in (3, 4) or 0 in arr.shape:
        raise InputError(
            f"frame {index}: expected an (H, W, 3|4) uint8 sRGB image, got {arr.dtype}"
            f" {arr.shape}"
        )
    if size is not None and arr.shape[:2] != size:
        raise InputError(
            f"frame {index}: size {arr.shape[1]}×{arr.shape[0]} differs from frame 0's"
            f" {size[1]}×{size[0]}; every frame of a video has the same size"
        )
    return np.ascontiguousarray(_even(arr[..., :3]))


def write_mp4(
    frames: Iterable[np.ndarray], path: str | os.PathLike[str], fps: float
) -> Path:
    """Encode ``frames`` ((H, W, 3|4) uint8 sRGB, alpha dropped) as H.264 MP4 at ``fps``.

    Returns the path written. Nothing is left at ``path`` (or beside it) when a frame
    is bad, there are none, or the file cannot be written.
    """
    target = Path(path)
    if target.suffix.lower() != ".mp4":
        raise FormatError(f"{target}: a video must end in .mp4")
    if isinstance(fps, bool) or not isinstance(fps, (int, float, np.integer, np.floating)) \
            or not 0 < fps < math.inf:  # fmt: skip
        raise InputError(f"fps: expected a finite number > 0, got {fps!r}")
    ffmpeg = _ffmpeg()
    it = iter(frames)
    try:
        raw = np.asarray(next(it))
    except StopIteration:
        raise InputError(f"{target}: no frames to write") from None
    first = _rgb(raw, 0, None)
    size = raw.shape[:2]
    h, w = first.shape[:2]
    try:
        with atomic_path(target) as tmp:
            writer = ffmpeg.write_frames(
                str(tmp), (w, h), fps=float(fps), codec="libx264", pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p", macro_block_size=1, ffmpeg_log_level="error",
            )  # fmt: skip
            writer.send(None)
            try:
                writer.send(first)
                for i, frame in enumerate(it, 1):
                    writer.send(_rgb(frame, i, size))
            finally:
                writer.close()
    except (OSError, RuntimeError) as exc:
        raise FormatError(f"{target}: cannot write the video: {exc}") from None
    return target

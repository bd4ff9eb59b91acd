"""MP4 output: H.264 video of rendered frames through imageio-ffmpeg's bundled ffmpeg.

yuv420p, the pixel format every player decodes, halves the chroma resolution and so
needs even width and height: an odd-sized frame gets its last column and/or row
repeated once (padding by one pixel, nothing cropped). Frames stream to ffmpeg one by
one, so memory stays at one frame; the file is written in a temporary folder beside the
target and renamed onto it when complete.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Generator, Iterable, Iterator
from pathlib import Path

import numpy as np

from ..atomic import temporary_folder
from ..errors import FormatError, InputError
from ..validate import positive

__all__ = ["Mp4Writer", "write_mp4"]


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
            f"frame {index}: expected an (H, W, 3|4) uint8 sRGB image, got {arr.dtype} {arr.shape}"
        )
    if size is not None and arr.shape[:2] != size:
        raise InputError(
            f"frame {index}: size {arr.shape[1]}×{arr.shape[0]} differs from frame 0's"
            f" {size[1]}×{size[0]}; every frame of a video has the same size"
        )
    return np.ascontiguousarray(_even(arr[..., :3]))


def _mp4_path(path: str | os.PathLike[str]) -> Path:
    target = Path(path)
    if target.suffix.lower() != ".mp4":
        raise FormatError(f"{target}: a video must end in .mp4")
    return target


class Mp4Writer:
    """An H.264 MP4 at ``path`` written frame by frame (:meth:`write`), for frames that
    come one at a time (a live viewer). :meth:`close` finishes the file; :meth:`abort`
    (or leaving a ``with`` block by an exception) drops it. Until :meth:`close` the
    video is in a temporary folder beside ``path``; nothing is left at or beside ``path``
    when there are no frames, a frame is bad, or the file cannot be written.
    """

    def __init__(self, path: str | os.PathLike[str], fps: float) -> None:
        self.path = _mp4_path(path)
        self.fps = positive(fps, "fps")
        self._ffmpeg = _ffmpeg()
        self.frames = 0  # frames written so far
        self._size: tuple[int, ...] | None = None  # frame 0's (H, W)
        # started by the first frame, which fixes the size
        self._encoder: Generator[None, np.ndarray | None, None] | None = None

    def __enter__(self) -> Mp4Writer:
        return self

    def __exit__(self, kind: object, *exc: object) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()

    def write(self, frame: np.ndarray) -> None:
        """Encode ``frame`` ((H, W, 3|4) uint8 sRGB, alpha dropped; every frame the size
        of the first). A bad frame raises InputError and drops the video."""
        try:
            rgb = _rgb(frame, self.frames, self._size)
        except InputError:
            self.abort()
            raise
        with self._failing():
            if self._encoder is None:
                self._size = np.asarray(frame).shape[:2]
                self._encoder = self._encode(rgb)
                next(self._encoder)
            else:
                self._encoder.send(rgb)
        self.frames += 1

    def close(self) -> Path:
        """Finish the video and move it to ``path``; returns ``path``. InputError when
        no frame was written (nothing is left at ``path``)."""
        if self._encoder is None:
            raise InputError(f"{self.path}: no frames to write")
        encoder, self._encoder = self._encoder, None
        with self._failing():
            try:
                encoder.send(None)
            except StopIteration:
                pass
        return self.path

    def abort(self) -> None:
        """Stop encoding and remove the unfinished video."""
        encoder, self._encoder = self._encoder, None
        if encoder is not None:
            encoder.close()

    @contextlib.contextmanager
    def _failing(self) -> Iterator[None]:
        """An operating-system or ffmpeg failure: the video dropped, one FormatError."""
        try:
            yield
        except (OSError, RuntimeError) as exc:
            self.abort()
            raise FormatError(f"{self.path}: cannot write the video: {exc}") from None

    def _encode(self, first: np.ndarray) -> Generator[None, np.ndarray | None, None]:
        """Encode ``first``, then each frame sent, into a temporary file renamed onto
        the path when None is sent; closed early (:meth:`abort`), it is removed. The
        file is in a temporary folder of its own, which a signal's handler removes
        (:func:`follicle.atomic.remove_pending`): ffmpeg, a process of its own that
        opens the file by name once started, then finds no folder to write in, where
        a temporary file removed before it opened it would be made again."""
        h, w = first.shape[:2]
        with temporary_folder(self.path, "video") as folder:
            tmp = folder / self.path.name
            writer = self._ffmpeg.write_frames(
                str(tmp),
                (w, h),
                fps=self.fps,
                codec="libx264",
                pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p",
                macro_block_size=1,
                ffmpeg_log_level="error",
            )
            writer.send(None)
            try:
                frame: np.ndarray | None = first
                while frame is not None:
                    writer.send(frame)
                    frame = yield
            finally:
                writer.close()
            os.replace(tmp, self.path)


def write_mp4(frames: Iterable[np.ndarray], path: str | os.PathLike[str], fps: float) -> Path:
    """Encode ``frames`` ((H, W, 3|4) uint8 sRGB, alpha dropped) as H.264 MP4 at ``fps``.

    Returns the path written. Nothing is left at ``path`` (or beside it) when a frame
    is bad, there are none, or the file cannot be written.
    """
    with Mp4Writer(path, fps) as video:
        for frame in frames:
            video.write(frame)
    return video.path

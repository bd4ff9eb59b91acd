"""Input paths checked before anything reads them: a regular file, or one clear refusal.

A FIFO would block a reader forever, a device (``/dev/zero``) would feed it without end
and a folder cannot be parsed, so every reader, the scene loader and the mesh and
texture loaders take their path through :func:`input_file` first.

An input may also be a URL (``https://…``, ``s3://…``, ``gs://…``, ``file://…``: any
protocol fsspec knows), so that every worker of a cluster reads a scene's mesh, guides
and textures from one place: :func:`input_file` fetches it once into a local cache
(:func:`cache_folder`), keyed by the URL and the file's size and modification stamp,
and hands the readers that copy. A fetch is watched: a server that sends less than
16 KiB in any :func:`url_timeout` seconds (headers that never end, a body that trickles)
is left with one error, and a download stops at the reader's size limit
(:func:`max_download` for readers without one) instead of filling the disk.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import stat
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeGuard

from .atomic import atomic_path
from .errors import ConfigError, FileAccessError, FormatError, InputError
from .validate import file_path

__all__ = [
    "base_folder",
    "cache_folder",
    "check_apart",
    "default_output",
    "input_file",
    "is_remote",
    "is_url",
    "local_file",
    "max_download",
    "remote_reach",
    "url_timeout",
]

_URL = re.compile(r"[A-Za-z][A-Za-z0-9+.-]+://")
# the package a protocol's fsspec backend needs, as the error says it
_BACKENDS = {"http": "aiohttp", "https": "aiohttp", "s3": "s3fs", "gs": "gcsfs", "gcs": "gcsfs"}
_BLOCK = 1 << 20
_CHUNK = 1 << 16  # bytes a streamed read asks for; it returns what has arrived
_MIN_BYTES = 16 << 10  # a fetch that gets less than this in url_timeout() seconds is left
_DEFAULT_TIMEOUT = 30.0
_DEFAULT_MAX_DOWNLOAD = 4 << 30
_KEEP_FREE = 1 << 30  # a download never leaves less than this free on the cache's disk


def is_url(path: object) -> TypeGuard[str]:
    """Whether ``path`` is a URL (``protocol://…``), not a file name."""
    return isinstance(path, str) and _URL.match(path) is not None


def is_remote(path: object) -> bool:
    """Whether ``path`` is a URL of another machine (``https://…``, ``s3://…``): any URL
    but ``file://``."""
    return is_url(path) and not str(path).lower().startswith("file://")


def local_file(path: str | os.PathLike[str]) -> Path | None:
    """The file of this machine that ``path`` names, absolute: a path, or the path of a
    ``file://`` URL; None for a remote URL or a ``builtin:`` name."""
    text = os.fspath(path)
    if isinstance(text, bytes) or text.startswith("builtin:") or is_remote(text):
        return None
    if is_url(text):
        from urllib.parse import unquote, urlsplit

        text = unquote(urlsplit(text).path)
    return Path(os.path.abspath(text))


def _real(path: Path) -> Path:
    """``path`` with every symbolic link on the way resolved (it need not exist)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):  # a loop of links: compare it as written
        return path


def check_apart(
    outputs: Iterable[str | os.PathLike[str]],
    inputs: Iterable[tuple[str, str | os.PathLike[str]]],
    folders: Iterable[str | os.PathLike[str]] = (),
    what: str = "the output",
    fix: str = "write it elsewhere, or under another name",
) -> None:
    """InputError, before anything is read or written, when an output of a run would
    replace one of its inputs: an output file that is an input (symbolic links
    followed; written whole under a temporary name, it would be renamed onto it), or a
    folder of ``folders`` (an output replaced whole, such as a payloads folder) that is
    or holds one. ``inputs`` are (label, path) pairs, the label naming the input in the
    message ("the scene's [mesh].path"); builtins and remote URLs are never replaced."""
    read: dict[Path, tuple[str, str]] = {}
    for label, path in inputs:
        local = local_file(path)
        if local is not None:
            read.setdefault(_real(local), (label, os.fspath(path)))
    for out in outputs:
        hit = read.get(_real(Path(os.path.abspath(out))))
        if hit is not None:
            raise InputError(f"{out}: {what} would replace {' '.join(hit)}; {fix}")
    for folder in folders:
        whole = _real(Path(os.path.abspath(folder)))
        for src, (label, path) in read.items():
            if src.is_relative_to(whole):
                raise InputError(
                    f"{folder}: {what} replaces this folder, which holds {label} {path}; {fix}"
                )


def default_output(source: str | os.PathLike[str], tail: str) -> str:
    """Where a command writes the output named after ``source`` when no -o names it: the
    source's file name stem + ``tail`` (``.png``, ``_frames``) beside it, or, for a
    source on another machine (a URL), in the current folder."""
    if is_remote(source):
        from urllib.parse import unquote, urlsplit

        stem = Path(unquote(urlsplit(str(source)).path)).stem or "out"
        return f"{stem}{tail}"
    local = local_file(source) if is_url(source) else Path(source)
    assert local is not None
    return str(local.with_name(f"{local.stem}{tail}"))


def remote_reach(base: str, path: str) -> str | None:
    """Why the scene at the URL ``base`` may not name ``path`` (None when it may):
    a remote scene names files beside it on its own server (relative paths, builtins,
    or URLs on its own server), never a file of this machine nor of another server."""
    if path.startswith("builtin:"):
        return None
    if not is_url(path):
        if os.path.isabs(path):
            return "a path of this machine"
        return None
    from urllib.parse import urlsplit

    here, there = urlsplit(base), urlsplit(path)
    if (here.scheme.lower(), here.netloc.lower()) == (there.scheme.lower(), there.netloc.lower()):
        return None
    return f"a file of {there.scheme}://{there.netloc}, not of its own server"


def base_folder(text: str) -> Path | str:
    """A scene's folder as stored in text (a task's argument, a frame file): a URL stays
    text, so that paths join onto it with ``/``; anything else is a Path."""
    return text if is_url(text) else Path(text)


def cache_folder() -> Path:
    """Where fetched URLs are kept: ``$FOLLICLE_CACHE``, else ``follicle/urls`` under
    ``$XDG_CACHE_HOME`` (``~/.cache``)."""
    if os.environ.get("FOLLICLE_CACHE"):
        return Path(os.environ["FOLLICLE_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "follicle" / "urls"


def input_file(path: str | os.PathLike[str], what: str = "file", limit: int | None = None) -> Path:
    """``path`` if it names a regular file (symbolic links followed), else FormatError
    naming it and saying what it is instead; ``what`` says what was expected. A URL
    gives the local copy :func:`fetched` keeps of it, fetching at most ``limit`` bytes
    (the reader's own size limit; default :func:`max_download`)."""
    path = file_path(path, "path")
    if is_url(path):
        return fetched(path, what, limit)
    p = Path(path)
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        raise FileAccessError(f"{p}: no such file") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        reason = getattr(exc, "strerror", None) or exc
        raise FileAccessError(f"{p!s:.200}: cannot be read ({reason}); give {_a(what)}") from None
    if stat.S_ISDIR(mode):
        raise FormatError(f"{p}: is a folder, not a file; give {_a(what)}")
    if not stat.S_ISREG(mode):
        kind = (
            "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
        )
        raise FormatError(f"{p}: is {kind}, not a regular file; give {_a(what)}")
    return p


def url_timeout() -> float:
    """Seconds a fetch waits for a server's next 16 KiB (its answer's headers included):
    ``$FOLLICLE_URL_TIMEOUT``, default 30."""
    return _positive_env("FOLLICLE_URL_TIMEOUT", _DEFAULT_TIMEOUT, "a number of seconds, e.g. 60")


def max_download() -> int:
    """The largest file fetched from a URL for a reader without a size limit of its own:
    ``$FOLLICLE_MAX_DOWNLOAD`` bytes, default 4 GiB."""
    return int(_positive_env("FOLLICLE_MAX_DOWNLOAD", _DEFAULT_MAX_DOWNLOAD, "bytes, e.g. 4e9"))


def _positive_env(name: str, default: float, example: str) -> float:
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value > 0 and value < float("inf")):
        raise ConfigError(f"${name}={text[:40]!r}: give {example}")
    return value


def fetched(url: str, what: str = "file", limit: int | None = None) -> Path:
    """A local copy of the file at ``url``, fetched through fsspec into
    :func:`cache_folder` unless a copy of the same URL, size and modification stamp is
    there (written whole, under a temporary name, so that workers fetching at once each
    see a whole file); it keeps the URL's file name, so readers see its extension.
    ``file://`` URLs are read in place. At most ``limit`` bytes (default
    :func:`max_download`) are fetched, and a server slower than 16 KiB in
    :func:`url_timeout` seconds is left. ConfigError when fsspec or the protocol's
    package is missing; FormatError or FileAccessError naming the URL when it is not
    there, is a folder, is too large, too slow or cannot be read."""
    try:
        import fsspec
    except ImportError:
        raise ConfigError(f"{url}: reading URLs needs fsspec; pip install fsspec") from None
    protocol = url.split("://", 1)[0].lower()
    try:
        fs, path = fsspec.core.url_to_fs(url)
    except ImportError:
        need = _BACKENDS.get(protocol, f"the fsspec backend for {protocol}://")
        raise ConfigError(
            f"{url}: reading {protocol}:// URLs needs {need}; pip install it"
        ) from None
    except ValueError as exc:  # an unknown protocol
        raise FormatError(f"{url}: {exc}; give a path or a URL fsspec reads") from None
    if protocol == "file":
        return input_file(path, what)
    cap = max_download() if limit is None else limit
    window = url_timeout()
    try:
        info = _watched(url, window, lambda got, stop: fs.info(path))
    except FileNotFoundError as exc:
        cause = exc.__cause__  # fsspec's HTTP says "not found" for a server that is down too
        if cause is None or isinstance(cause, FileNotFoundError) or _status(cause) in (404, 410):
            raise FileAccessError(f"{url}: no such file") from None
        raise FileAccessError(
            f"{url}: cannot be read ({_reason(cause)}); give {_a(what)}"
        ) from None
    except FileAccessError:
        raise
    except Exception as exc:  # backends raise their own (aiohttp, botocore)
        raise FileAccessError(f"{url}: cannot be read ({_reason(exc)}); give {_a(what)}") from None
    if info.get("type") == "directory":
        raise FormatError(f"{url}: is a folder, not a file; give {_a(what)}")
    size = info.get("size")
    if isinstance(size, int) and size > cap:
        raise FormatError(_too_large(url, size, cap, what))
    stamp = [info.get(k) for k in ("size", "mtime", "LastModified", "ETag", "etag", "md5Hash")]
    key = hashlib.sha256(repr((url, stamp)).encode()).hexdigest()[:32]
    name = os.path.basename(path.rstrip("/")) or "file"
    copy = cache_folder() / key / name
    if copy.is_file():
        return copy
    room = _free_bytes(copy.parent) - _KEEP_FREE  # what the cache's disk can take
    full = (
        f"{url}: {{}} the disk of {copy.parent} would keep less than 1 GiB free; free"
        " space there, or set $FOLLICLE_CACHE to a folder on a larger disk"
    )
    if isinstance(size, int) and size > room:
        raise FileAccessError(full.format(f"{size:,} bytes:"))
    # streamed over HTTP (a read returns what has arrived, so the watch sees a trickle)
    options = {"block_size": 0} if protocol in ("http", "https") else {}
    try:
        with atomic_path(copy) as tmp:
            _watched(
                url,
                window,
                lambda got, stop: _copy(
                    fs.open(path, "rb", **options), tmp, min(cap, room), got, stop
                ),
            )
    except _TooLarge:
        if cap <= room:
            raise FormatError(_too_large(url, None, cap, what)) from None
        raise FileAccessError(full.format(f"past {max(room, 0):,} bytes,")) from None
    except FileAccessError:
        raise
    except Exception as exc:  # as above, or the cache's disk is full
        raise FormatError(
            f"{url}: cannot be fetched into {copy.parent} ({_reason(exc)}); give {_a(what)}"
        ) from None
    if size is not None and copy.stat().st_size != size:
        copy.unlink(missing_ok=True)
        raise FormatError(f"{url}: the download stopped short of its {size:,} bytes; fetch again")
    return copy


def _free_bytes(folder: Path) -> int:
    """Free bytes on the disk of ``folder`` (or of its nearest existing parent)."""
    for where in (folder, *folder.parents):
        try:
            return shutil.disk_usage(where).free
        except OSError:
            continue
    return 0


class _TooLarge(Exception):
    """A download passed its size limit."""


def _too_large(url: str, size: int | None, cap: int, what: str) -> str:
    fix = "" if cap != max_download() else "; $FOLLICLE_MAX_DOWNLOAD raises the limit"
    said = "" if size is None else f"{size:,} bytes, "
    return f"{url}: {said}more than the {cap:,} bytes {_a(what)} may be; give a smaller one{fix}"


def _a(what: str) -> str:
    """``what`` with its indefinite article, by its sound: "a scene file", "an Alembic
    file", "a USD file", "an STL file"."""
    word = what.split(" ", 1)[0].strip(".,(")
    acronym = len(word) > 1 and word.isupper()
    vowel = word[:1].upper() in ("AEFHILMNORSX" if acronym else "AEIOU")
    return f"{'an' if vowel else 'a'} {what}"


def _copy(
    src: Any, tmp: str | os.PathLike[str], cap: int, got: list[int], stop: threading.Event
) -> None:
    """Copy the open remote file ``src`` into ``tmp``, counting bytes into ``got[0]``,
    until its end, past ``cap`` bytes (then _TooLarge) or ``stop`` (then ``tmp`` is removed:
    the watcher has given up on it)."""
    try:
        with src, open(tmp, "wb") as dst:
            while not stop.is_set():
                chunk = src.read(_CHUNK)
                if not chunk:
                    return
                got[0] += len(chunk)
                if got[0] > cap:
                    raise _TooLarge
                dst.write(chunk)
    finally:
        if stop.is_set():
            Path(tmp).unlink(missing_ok=True)


def _watched(url: str, window: float, work: Callable[[list[int], threading.Event], Any]) -> Any:
    """``work(got, stop)`` run in a thread while this one watches the bytes it counts in
    ``got[0]``: FileAccessError when fewer than 16 KiB arrive in any ``window`` seconds
    (the thread is told to stop and left to end)."""
    got, stop, result = [0], threading.Event(), []

    def run() -> None:
        try:
            result.append((True, work(got, stop)))
        except BaseException as exc:  # handed to the caller below
            result.append((False, exc))

    thread = threading.Thread(target=run, name="follicle-fetch", daemon=True)
    thread.start()
    mark, seen = time.monotonic(), 0
    while thread.is_alive():
        thread.join(min(0.25, window / 4))
        now = time.monotonic()
        if thread.is_alive() and now - mark >= window:
            if got[0] - seen < _MIN_BYTES:
                stop.set()
                sent = "nothing" if got[0] == seen else f"{got[0] - seen:,} bytes"
                raise FileAccessError(
                    f"{url}: the server sent {sent} in {window:g} s, too slow or not"
                    " answering; try again, or set $FOLLICLE_URL_TIMEOUT (seconds)"
                )
            mark, seen = now, got[0]
    done, value = result[0]
    if done:
        return value
    raise value


def _status(exc: BaseException) -> int | None:
    """The HTTP status an fsspec backend's exception carries, if any."""
    status = getattr(exc, "status", None)
    return status if isinstance(status, int) else None


def _reason(exc: BaseException) -> str:
    """An exception in a few words, for one error line."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    return f"{type(exc).__name__}: {text[:160]}" if text else type(exc).__name__

"""Where a kernel's machine code is kept between runs: numba's cache of this machine,
written on first use, and the kernels shipped in the wheel, compiled when it was built
for a CPU level that every machine of the architecture from that level up has.

numba's own cache (``cache=True``) keeps one folder, which it reads and writes. Three
things it does not do, and that a fresh install needs:

- **Read kernels compiled elsewhere.** A wheel carries ``follicle/_kernels/<level>/``,
  compiled by its build for a named CPU level (``x86-64-v3``: AVX2 and FMA, every x86-64
  CPU since 2013–2015; ``generic``). numba keys an entry by the compiling machine's CPU
  name and features, so an entry from the build would never match here; the shipped
  entries are looked up under the level's key when this machine has every feature of
  the level (:func:`shipped_level`).
- **Survive damaged files.** numba unpickles an index or data file as it finds it, so a
  cut or flipped file ends the process, or runs code that is not the kernel's. Here each
  data file is named and checked by its SHA-256, and anything that cannot be read whole
  is a miss: the kernel is compiled again.
- **Two writers at once.** numba's index is read, changed and written back, and its data
  files are numbered by what the writer last read, so two processes compiling one kernel
  can leave an index entry that points at the other's code. Here a data file's name is
  its content's hash, and the index is changed under a lock.

An entry's key is numba's: the argument types, the codegen (target triple, CPU name and
features) and hashes of the function's bytecode and closure; an index is kept only while
its numba version and the sources' SHA-256 are the ones it was written with: for
follicle's kernels every source file of the package (a kernel inlines what it calls from
other files), for another's its own file (:func:`kernel_stamp`).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import json
import logging
import os
import pickle
import platform
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Protocol, cast

import numba
from numba.core import config as _numba_config
from numba.core.caching import CompileResultCacheImpl, _Cache, _CacheLocator
from numba.core.serialize import dumps
from numba.misc.appdirs import AppDirs

__all__ = [
    "KernelCache",
    "SHIPPED",
    "BUILD_ENV",
    "LEVEL_FEATURES",
    "shipped_level",
    "shipped_manifest",
    "source_digest",
    "kernel_stamp",
]

log = logging.getLogger("follicle")


class NumbaConfig(Protocol):
    """The settings of ``numba.core.config`` that follicle reads: numba makes them at run
    time from its NUMBA_* variables, so its module declares none of them."""

    CPU_NAME: str | None
    CACHE_DIR: str
    NUMBA_NUM_THREADS: int


config = cast(NumbaConfig, _numba_config)  # the module itself, typed

PACKAGE = Path(__file__).resolve().parent.parent  # src/follicle, or site-packages/follicle
SHIPPED = PACKAGE / "_kernels"  # <level>/<folder of the source>/<kernel>.nbi + .nbc
BUILD_ENV = "FOLLICLE_KERNELS_BUILD"  # a folder: compile into it, as a wheel ships them
MAX_INDEX_BYTES = 64 << 20  # an index is a few kB; a larger one is not ours
MAX_DATA_BYTES = 512 << 20
_FORMAT = ("follicle-kernels", 1)

# The CPU levels a wheel may ship, by the LLVM features each needs (x86-64 psABI levels;
# LLVM's names: "sahf" is LAHF/SAHF, "bmi" is BMI1). "generic" needs nothing.
_V2 = ("cx16", "popcnt", "sahf", "sse3", "sse4.1", "sse4.2", "ssse3")
_V3 = (*_V2, "avx", "avx2", "bmi", "bmi2", "f16c", "fma", "lzcnt", "movbe", "xsave")
_V4 = (*_V3, "avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl")
LEVEL_FEATURES: dict[str, tuple[str, ...]] = {
    "generic": (),
    "x86-64-v2": _V2,
    "x86-64-v3": _V3,
    "x86-64-v4": _V4,
}


@functools.cache
def source_digest(path: str) -> str:
    """SHA-256 of a source file's bytes: what an index is kept for (numba ≤ 0.60 used the
    file's time stamp, which an install changes)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def sources_digest(package: Path) -> str:
    """SHA-256 over every ``.py`` file of the package (names and bytes): a kernel's code
    includes what it calls from other files, so shipped kernels are kept only with the
    very sources they were built from."""
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package).as_posix()
        if rel.startswith("_kernels/"):
            continue
        digest.update(rel.encode() + b"\0" + hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()


def kernel_stamp(source: str, package: Path = PACKAGE) -> str:
    """What a kernel's index is kept for: for a kernel of the ``package`` (follicle), the
    digest of all its sources (:func:`sources_digest`), because a kernel's machine code
    holds the functions it calls from other files, inlined, and an edit there must
    compile it again (keyed by its own file only, an upgrade or an edit of a callee left
    it running the old code); for any other kernel, its own file's
    (:func:`source_digest`)."""
    path = Path(source).resolve()
    if path.is_relative_to(package.resolve()):
        return _package_digest(package.resolve())
    return source_digest(source)


@functools.lru_cache(maxsize=4)
def _package_digest(package: Path) -> str:
    """:func:`sources_digest` of ``package``, read once a process (a kernel module's
    sources do not change while it runs)."""
    return sources_digest(package)


@functools.lru_cache(maxsize=1)
def shipped_manifest() -> dict[str, Any] | None:
    """The shipped kernels' ``manifest.json`` (numba and Python versions, machine, CPU
    levels), or None when this install has none or they were built for another numba,
    Python or machine."""
    try:
        manifest = json.loads((SHIPPED / "manifest.json").read_text())
    except (OSError, ValueError):
        return None
    here = {
        "numba": numba.__version__,
        "python": f"{sys.version_info[0]}.{sys.version_info[1]}",
        "machine": platform.machine(),
    }
    if not isinstance(manifest, dict) or any(manifest.get(k) != v for k, v in here.items()):
        return None
    return manifest if manifest.get("sources") == sources_digest(PACKAGE) else None


@functools.lru_cache(maxsize=1)
def shipped_level() -> str | None:
    """The CPU level whose shipped kernels this machine runs: the first the wheel ships
    (best first) whose every feature this CPU has, or the one named by NUMBA_CPU_NAME
    when that is set. None: compile here."""
    manifest = shipped_manifest()
    if manifest is None:
        return None
    levels = [str(level) for level in manifest.get("levels", [])]
    if config.CPU_NAME is not None:
        return config.CPU_NAME if config.CPU_NAME in levels else None
    import llvmlite.binding as ll

    have = {name for name, on in ll.get_host_cpu_features().items() if on}
    for level in levels:
        needs = LEVEL_FEATURES.get(level)
        if needs is not None and have.issuperset(needs):
            return level
    return None


def _write(path: Path, data: bytes) -> None:
    """``data`` to ``path`` whole: a temporary file beside it, then renamed."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` (made if need be) between processes, where the
    platform has one (POSIX)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: names by content still keep it right
        yield
        return
    with open(path, "ab") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _read(path: Path, limit: int) -> bytes | None:
    """The bytes of ``path``, or None when it is missing, unreadable or over ``limit``."""
    try:
        with open(path, "rb") as handle:
            size = os.fstat(handle.fileno()).st_size
            if size > limit:
                return None
            # read(n) reserves n bytes first: ask for the file's size, not the limit, so
            # a process under a memory limit can load a small kernel
            data = handle.read(size + 1)
    except OSError:
        return None
    return data if len(data) <= limit else None


class _Store:
    """One kernel's entries in one folder: ``<base>.nbi``, an index from keys to data
    files, and the data files ``<base>.<sha256>.nbc``."""

    def __init__(self, folder: Path, base: str, stamp: str) -> None:
        self.folder = folder
        self.base = base
        self.stamp = stamp
        self.index = folder / f"{base}.nbi"

    def _entries(self) -> dict:
        data = _read(self.index, MAX_INDEX_BYTES)
        if data is None:
            return {}
        try:  # in memory, so a damaged length cannot ask for more than the file holds
            head, stamp, entries = pickle.loads(data)
        except Exception:
            log.debug("kernel index %s cannot be read; compiling again", self.index)
            return {}
        if head != (*_FORMAT, numba.__version__) or stamp != self.stamp:
            return {}  # another numba, or an older source: rewritten on the next save
        return entries if isinstance(entries, dict) else {}

    def load(self, key: object) -> Any | None:
        """The payload saved under ``key``, or None (absent, damaged or stale)."""
        try:
            entry = self._entries().get(key)
        except Exception:  # a key of the index that does not compare (damage)
            return None
        if not (isinstance(entry, tuple) and len(entry) == 2):
            return None
        name, digest = entry
        data = _read(self.folder / str(name), MAX_DATA_BYTES)
        if data is None or hashlib.sha256(data).hexdigest() != digest:
            if data is not None:
                log.debug("kernel data %s is damaged; compiling again", self.folder / name)
            return None
        try:
            return pickle.loads(data)
        except Exception:
            return None

    def save(self, key: object, payload: object) -> None:
        data = dumps(payload)
        digest = hashlib.sha256(data).hexdigest()
        name = f"{self.base}.{digest[:24]}.nbc"
        self.folder.mkdir(parents=True, exist_ok=True)
        if not (self.folder / name).exists():
            _write(self.folder / name, data)
        with _locked(self.folder / ".follicle-kernels.lock"):
            entries = self._entries()
            entries[key] = (name, digest)
            _write(self.index, pickle.dumps(((*_FORMAT, numba.__version__), self.stamp, entries)))


def _folders(source: str) -> list[Path]:
    """Where this machine's compilations of a kernel may be kept, in numba's order for
    its own cache: NUMBA_CACHE_DIR, ``__pycache__`` beside the source, the user's cache
    folder. Nothing is made here (a run that compiles nothing writes nothing)."""
    subpath = _CacheLocator.get_suitable_cache_subpath(source)
    folders = [Path(config.CACHE_DIR) / subpath] if config.CACHE_DIR else []
    folders.append(Path(source).parent / "__pycache__")
    folders.append(Path(AppDirs(appname="numba", appauthor=False).user_cache_dir) / subpath)
    return folders


def _writable(folder: Path) -> bool:
    """Whether ``folder`` is, or can be made, a folder this process writes to."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


class KernelCache(_Cache):
    """A kernel's cache (numba's ``_Cache`` interface, installed on its dispatcher by
    :func:`follicle.kernels.kernel`): this machine's compilations first, then the shipped
    kernels of :func:`shipped_level`; ``compiling(name)`` is told before numba compiles
    the kernel (:func:`follicle.kernels.compiling`). Set up on first use, so importing a
    module of kernels touches no file.

    With ``FOLLICLE_KERNELS_BUILD`` set (a wheel's build, :mod:`follicle.prebuild.build`),
    kernels are read from and written to that folder only, under the level named by
    NUMBA_CPU_NAME, laid out as a wheel ships them.
    """

    def __init__(self, py_func: Any, compiling: Callable[[str], None]) -> None:
        self._py_func = py_func
        self._compiling = compiling  # called with the kernel's name before numba compiles it
        self._enabled = True
        self._ready = False

    def _setup(self) -> None:
        if self._ready:
            return
        func = self._py_func
        source = os.path.abspath(func.__code__.co_filename)
        self._impl = _Impl(func)
        stamp = kernel_stamp(source)
        base = self._impl.filename_base
        try:
            where = Path(source).parent.relative_to(PACKAGE)
        except ValueError:
            where = None  # not one of follicle's files: no shipped copy
        build = os.environ.get(BUILD_ENV)
        self._shipped: _Store | None = None
        if build:
            if config.CPU_NAME is None or where is None:
                raise RuntimeError(f"{BUILD_ENV} needs NUMBA_CPU_NAME and a follicle kernel")
            self._mine = [_Store(Path(build) / config.CPU_NAME / where, base, stamp)]
        else:
            self._mine = [_Store(folder, base, stamp) for folder in _folders(source)]
            level = shipped_level()
            if level is not None and where is not None:
                self._shipped = _Store(SHIPPED / level / where, base, stamp)
                self._level = level
        self._ready = True

    def _keeper(self) -> _Store | None:
        """Where a new compilation goes: the first of the folders that can be written."""
        self._setup()
        return next((store for store in self._mine if _writable(store.folder)), None)

    @property
    def cache_path(self) -> str:
        keeper = self._keeper()
        return "" if keeper is None else str(keeper.folder)

    def enable(self) -> None:
        self._enabled = True

    def disable(self) -> None:
        self._enabled = False

    def flush(self) -> None:
        keeper = self._keeper()
        if keeper is not None:
            with contextlib.suppress(OSError):
                keeper.index.unlink()

    def _key(self, sig: object, magic: tuple) -> tuple:
        """numba's index key: argument types, codegen, bytecode and closure hashes."""
        code = self._py_func.__code__.co_code
        closure = self._py_func.__closure__
        cells = b"" if closure is None else dumps(tuple(c.cell_contents for c in closure))
        digests = (hashlib.sha256(code).hexdigest(), hashlib.sha256(cells).hexdigest())
        return (sig, magic, digests)

    def load_overload(self, sig: object, target_context: Any) -> Any | None:
        """The compiled kernel for ``sig`` from a cache, or None to compile it."""
        if not self._enabled:
            return None
        self._setup()
        target_context.refresh()
        codegen = target_context.codegen()
        looks = [(store, codegen.magic_tuple()) for store in self._mine if store.folder.is_dir()]
        if self._shipped is not None:
            triple = codegen.magic_tuple()[0]
            looks.append((self._shipped, (triple, self._level, "")))
        for store, magic in looks:
            payload = store.load(self._key(sig, magic))
            if payload is None:
                continue
            try:
                return self._impl.rebuild(target_context, payload)
            except Exception:
                log.debug("kernel %s from %s cannot be loaded", self._impl.name, store.folder)
        self._compiling(self._impl.name)
        return None

    def save_overload(self, sig: object, data: Any) -> None:
        """Keep a new compilation; a folder that cannot be written keeps nothing."""
        if not self._enabled or not self._impl.check_cachable(data):
            return
        keeper = self._keeper()
        if keeper is None:
            log.debug("kernel %s not kept: no cache folder can be written", self._impl.name)
            return
        try:
            keeper.save(self._key(sig, data.codegen.magic_tuple()), self._impl.reduce(data))
        except OSError as exc:
            log.debug("kernel %s not kept in %s: %s", self._impl.name, keeper.folder, exc)


class _Impl(CompileResultCacheImpl):
    """numba's (de)serialisation of compile results and its file names, without its
    search for a folder at construction (:class:`KernelCache` chooses the folders)."""

    def __init__(self, py_func: Any) -> None:
        self._lineno = py_func.__code__.co_firstlineno
        qualname = getattr(py_func, "__qualname__", py_func.__name__)
        modname = Path(py_func.__code__.co_filename).stem
        self.name = f"{py_func.__module__}.{qualname}"
        self._py_file = py_func.__code__.co_filename
        fixed = f"{modname}.{qualname}".replace("<", "").replace(">", "")
        abiflags = getattr(sys, "abiflags", "")
        self._filename_base = (
            f"{fixed}-{self._lineno}.py{sys.version_info[0]}{sys.version_info[1]}{abiflags}"
        )

    def check_cachable(self, cres: Any) -> bool:
        return not (any(not x.can_cache for x in cres.lifted) or cres.library.has_dynamic_globals)

"""follicle's numba kernels: made by one decorator, compiled once per machine, shipped
prebuilt in the wheel so that a fresh install compiles nothing, and not even made until
they run, so that importing follicle imports no numba.

Every hot loop is a ``@kernel`` function (``numba.njit`` with the same options, and
``prange`` from here) over plain arrays. A kernel is a :class:`Kernel` until it is first
called or inspected; then numba's dispatcher is made, with the cache of
:class:`~follicle.kernels.cache.KernelCache` (this machine's compilations, then the
kernels a wheel ships for a CPU level: :mod:`follicle.prebuild.build` compiles them when
the wheel is built, by running :mod:`follicle.prebuild.workload`), and put in place of
the :class:`Kernel` wherever the kernel's code names other kernels, so that numba sees
dispatchers when it compiles it. What still has to be compiled (a source install,
another numba, an older CPU, argument types no command uses) says so once, on the
``follicle`` logger, before the wait: never a silent minute.
"""

from __future__ import annotations

import contextlib
import logging
import platform
import sys
import types
from collections.abc import Callable, Iterator
from typing import Any, overload

__all__ = [
    "kernel",
    "prange",
    "Kernel",
    "KERNELS",
    "compiling",
    "compile_count",
    "compile_listener",
]

KERNELS: list[Kernel] = []  # every kernel, in the order their modules define them
_compiled: list[str] = []  # kernels compiled (not loaded) in this process
_listeners: list[Callable[[str, int], None]] = []
log = logging.getLogger("follicle")

# Kernels loop with ``prange``: Python's ``range`` until the kernel is made, numba's in it.
prange = range


class Kernel:
    """A numba kernel not made yet: the function and its ``njit`` options. Calling it, or
    reading any dispatcher attribute (``signatures``, ``py_func`` …), makes it."""

    __slots__ = ("py_func", "options", "_dispatcher", "__dict__")

    def __init__(self, func: Callable[..., Any], options: dict[str, Any]) -> None:
        self.py_func = func
        self.options = options
        self._dispatcher: Any = None
        self.__dict__.update(
            {k: getattr(func, k) for k in ("__name__", "__qualname__", "__module__", "__doc__")}
        )

    @property
    def inline(self) -> bool:
        """Whether numba inlines it into its callers (it is then not compiled alone)."""
        return self.options.get("inline", "never") == "always"

    def dispatcher(self) -> Any:
        """numba's dispatcher of this kernel, made on first use, with follicle's cache."""
        if self._dispatcher is None:
            import numba

            from .cache import KernelCache

            made = numba.njit(**self.options)(self.py_func)
            made._cache = KernelCache(made.py_func, compiling)  # what enable_caching() sets
            self._dispatcher = made
            _bind(self.py_func)
        return self._dispatcher

    def __call__(self, *args: Any) -> Any:
        return self.dispatcher()(*args)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):  # what inspect, pickle or pytest look for: not a reason
            raise AttributeError(name)
        return getattr(self.dispatcher(), name)

    def __repr__(self) -> str:
        state = "made" if self._dispatcher is not None else "not made yet"
        return f"<follicle kernel {self.__module__}.{self.__qualname__} ({state})>"


def _names(code: types.CodeType) -> Iterator[str]:
    yield from code.co_names
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            yield from _names(const)


def _bind(func: Callable[..., Any]) -> None:
    """Put dispatchers in ``func``'s module in place of the kernels its code names, and
    numba's ``prange`` in place of this module's, before numba compiles it."""
    import numba

    space = func.__globals__
    for name in set(_names(func.__code__)):
        value = space.get(name)
        if isinstance(value, Kernel):
            space[name] = value.dispatcher()
        elif name == "prange" and value is range:
            space[name] = numba.prange


@overload
def kernel(fn: Callable[..., Any], /) -> Kernel: ...
@overload
def kernel(fn: None = None, /, **options: Any) -> Callable[[Callable[..., Any]], Kernel]: ...
def kernel(
    fn: Callable[..., Any] | None = None, /, **options: Any
) -> Kernel | Callable[[Callable[..., Any]], Kernel]:
    """``numba.njit(**options)`` with follicle's cache, made on first use: ``@kernel`` or
    ``@kernel(parallel=True, nogil=True)``."""

    def make(f: Callable[..., Any]) -> Kernel:
        made = Kernel(f, options)
        KERNELS.append(made)
        return made

    return make if fn is None else make(fn)


def _reason() -> str:
    import json

    import numba

    from .cache import LEVEL_FEATURES, SHIPPED, shipped_level, shipped_manifest

    manifest = shipped_manifest()
    if manifest is None:
        try:
            built = json.loads((SHIPPED / "manifest.json").read_text())
        except (OSError, ValueError):
            return "this install has no prebuilt kernels: a source install"
        if not isinstance(built, dict):
            return "its prebuilt kernels' manifest is damaged"
        here = (numba.__version__, f"{sys.version_info[0]}.{sys.version_info[1]}")
        if (built.get("numba"), built.get("python"), built.get("machine")) == (
            *here,
            platform.machine(),
        ):
            return "its prebuilt kernels were built from other sources: the code has changed"
        return (
            f"its prebuilt kernels were built for numba {built.get('numba')}, Python"
            f" {built.get('python')} on {built.get('machine')}, and these sources; this is"
            f" numba {numba.__version__} on {platform.machine()}"
        )
    if shipped_level() is None:
        from .cache import config

        levels = ", ".join(str(lv) for lv in manifest.get("levels", []) if lv in LEVEL_FEATURES)
        if config.CPU_NAME is not None:
            return f"NUMBA_CPU_NAME is {config.CPU_NAME}; the prebuilt kernels are for {levels}"
        return f"this CPU lacks the features of the prebuilt kernels ({levels})"
    return ""


def compiling(name: str) -> None:
    """Called by the cache just before numba compiles kernel ``name``: the first time in a
    process, one line on the ``follicle`` logger saying what happens and why."""
    _compiled.append(name)
    for listener in _listeners:
        listener(name, len(_compiled))
    if len(_compiled) > 1:
        return
    reason = _reason()
    if reason:
        log.warning(
            "compiling follicle's kernels for this machine, once (%s): about a minute for"
            " a command's first run, then cached. `follicle warm` compiles all of them now.",
            reason,
        )
    else:
        log.warning(
            "compiling %s for this machine, once: no usable prebuilt copy for these"
            " argument types (seconds; then cached)",
            name,
        )


@contextlib.contextmanager
def compile_listener(listener: Callable[[str, int], None]) -> Iterator[None]:
    """Within the block, ``listener(name, count)`` is called as each kernel starts to
    compile (``count``: kernels compiled in this process so far), e.g. to show it on a
    progress bar."""
    _listeners.append(listener)
    try:
        yield
    finally:
        _listeners.remove(listener)


def compile_count() -> int:
    """How many kernels this process has compiled rather than loaded."""
    return len(_compiled)

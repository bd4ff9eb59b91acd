"""Checks of single values at the public boundary, one wording for every module.

Each function returns the value in its plain Python type or raises :class:`InputError`
naming the argument, what was expected and what was given::

    number(0.0, "period", lo=0, lo_open=True, unit="s")
    # InputError: period: must be > 0 s (got 0.0)
    whole(0, "spp", 1, 65536)
    # InputError: spp: expected a whole number in 1..65536 (got 0)

A bool is never a number here (``True`` as a size is a typo, not 1), nor is a string
(``"1"``): callers that parse text convert it first. NumPy scalars are numbers.
Bounds are inclusive unless ``lo_open``/``hi_open``; ranges read ``≥ 0``, ``> 0``,
``in [0, 1]`` and, for whole numbers, ``in 1..16``. ``allow_none=True`` lets an optional
argument be None (returned as it is) and says "or None" when the value is refused::

    whole(-1, "hair_limit", 0, allow_none=True)
    # InputError: hair_limit: expected a whole number ≥ 0 or None (got -1)
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from numbers import Integral, Real
from pathlib import Path
from typing import TYPE_CHECKING, Literal, TypeGuard, overload

from .errors import FormatError, InputError

if TYPE_CHECKING:
    import numpy as np

__all__ = ["file_path", "number", "positive", "whole", "is_whole", "check_suffix"]

_SHOWN = 60  # characters of a given value's repr kept in a message


def _show(value: object) -> str:
    """``repr(value)``, cut short so that a huge input cannot flood the message."""
    text = repr(value)
    return text if len(text) <= _SHOWN else text[: _SHOWN - 3] + "..."


def _bound(x: float) -> str:
    """A bound as written in a message: 0, 1, 0.5, 1e-06."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else f"{x:g}"


def _range(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> str:
    if lo is not None and hi is not None:
        left, right = "(" if lo_open else "[", ")" if hi_open else "]"
        return f"in {left}{_bound(lo)}, {_bound(hi)}{right}"
    if lo is not None:
        return f"{'>' if lo_open else '≥'} {_bound(lo)}"
    if hi is not None:
        return f"{'<' if hi_open else '≤'} {_bound(hi)}"
    return ""


def is_whole(value: object) -> TypeGuard[int | np.integer]:
    """True for an int or NumPy integer (not a bool)."""
    return isinstance(value, Integral) and not isinstance(value, bool)


@overload
def number(
    value: object,
    name: str,
    *,
    lo: float | None = ...,
    hi: float | None = ...,
    lo_open: bool = ...,
    hi_open: bool = ...,
    unit: str = ...,
    allow_none: Literal[False] = ...,
) -> float: ...
@overload
def number(
    value: object,
    name: str,
    *,
    lo: float | None = ...,
    hi: float | None = ...,
    lo_open: bool = ...,
    hi_open: bool = ...,
    unit: str = ...,
    allow_none: bool,
) -> float | None: ...
def number(
    value: object,
    name: str,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    allow_none: bool = False,
) -> float | None:
    """``value`` as a finite float within the bounds, else an InputError naming ``name``.

    ``unit`` (e.g. ``"s"``) follows the range in the message. The messages are
    ``name: expected a number ≥ 0 s (got '1')`` (not a real number, or a bool),
    ``name: must be finite (got nan)`` and ``name: must be ≥ 0 s (got -0.5)``.
    With ``allow_none`` None is returned as it is and the first reads
    ``expected a number ≥ 0 s or None``.
    """
    if value is None and allow_none:
        return None
    want = _range(lo, hi, lo_open, hi_open)
    want_unit = f"{want} {unit}" if want and unit else want
    if isinstance(value, bool) or not isinstance(value, Real):
        expected = f"a number {want_unit}" if want_unit else "a number"
        expected += " or None" if allow_none else ""
        raise InputError(f"{name}: expected {expected} (got {_show(value)})")
    try:
        x = float(value)
    except OverflowError:  # an int past float's range
        x, shown = math.nan, _show(value)
    else:
        shown = str(x)
    if not math.isfinite(x):
        also = f" and {want_unit}" if want_unit else ""
        raise InputError(f"{name}: must be finite{also} (got {shown})")
    low = lo is not None and (x <= lo if lo_open else x < lo)
    if low or (hi is not None and (x >= hi if hi_open else x > hi)):
        raise InputError(f"{name}: must be {want_unit} (got {x})")
    return x


def positive(value: object, name: str, allow_zero: bool = False, *, unit: str = "") -> float:
    """``value`` as a finite float > 0 (≥ 0 with ``allow_zero``): :func:`number`'s checks."""
    return number(value, name, lo=0.0, lo_open=not allow_zero, unit=unit)


@overload
def whole(
    value: object,
    name: str,
    lo: int | None = ...,
    hi: int | None = ...,
    *,
    what: str = ...,
    allow_none: Literal[False] = ...,
) -> int: ...
@overload
def whole(
    value: object,
    name: str,
    lo: int | None = ...,
    hi: int | None = ...,
    *,
    what: str = ...,
    allow_none: bool,
) -> int | None: ...
def whole(
    value: object,
    name: str,
    lo: int | None = None,
    hi: int | None = None,
    *,
    what: str = "a whole number",
    allow_none: bool = False,
) -> int | None:
    """``value`` as an int in ``lo..hi`` (either bound may be None), else an InputError.

    An int or NumPy integer only: 2.0 and True are refused. The message is
    ``name: expected a whole number in 1..16 (got 2.5)`` (or ``≥ 1`` with one bound);
    ``what`` replaces "a whole number", e.g. "a whole number of texels". With
    ``allow_none`` None is returned as it is and the message ends the range with
    "or None".
    """
    if value is None and allow_none:
        return None
    if is_whole(value) and (lo is None or value >= lo) and (hi is None or value <= hi):
        return int(value)
    if lo is not None and hi is not None:
        want = f" in {lo}..{hi}"
    elif lo is not None:
        want = f" ≥ {lo}"
    else:
        want = "" if hi is None else f" ≤ {hi}"
    want += " or None" if allow_none else ""
    raise InputError(f"{name}: expected {what}{want} (got {_show(value)})")


def file_path(value: object, name: str = "path") -> str | os.PathLike[str]:
    """``value`` as it is when it names a file: a ``str`` (a path, a URL or a
    ``builtin:`` name) or an ``os.PathLike`` giving one; else an InputError naming
    ``name`` (None, a number, bytes, a list: what ``open`` would refuse with a
    TypeError)."""
    if isinstance(value, str):
        return value
    if isinstance(value, os.PathLike):
        try:
            text = os.fspath(value)
        except TypeError:
            text = None
        if isinstance(text, str):
            return value
    raise InputError(f"{name}: expected a file path (str or os.PathLike), got {_show(value)}")


def check_suffix(path: str | os.PathLike[str], allowed: Sequence[str]) -> None:
    """FormatError naming ``path`` unless its extension is one of ``allowed``: an output
    checked before any work is done for it."""
    if Path(path).suffix.lower() not in allowed:
        raise FormatError(f"{path}: output must end in {' or '.join(allowed)}")

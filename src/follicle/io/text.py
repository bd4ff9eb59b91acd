"""Numbers as text at array speed, for the OBJ, Mitsuba and PBRT modules.

Python formats a float in ~200 ns and a per-vertex loop costs more again, so 1 M hairs
× 16 vertices would take tens of seconds as text. These numba kernels write and read
the digits directly. A float32 is written in at most 9 significant digits, the fewest
that read back as the same float32 (trailing zeros dropped), in fixed notation for
1e-5 ≤ |x| < 1e10 and scientific otherwise; reading gives a float64 within an ulp,
which rounds to the float32 that was written.

Speed note: a numba call that passes an array costs ~15 ns (reference counting), so
the kernels write bytes in their own loops and call only scalar helpers per value;
readers call :func:`parse_number` once per number and scan bytes inline.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import BinaryIO

import numpy as np

from ..kernels import kernel

__all__ = ["write_values", "parse_number", "join_continued", "line_at"]

_POW10 = np.array([10.0**k for k in range(23)])  # exact in float64
_SCALE = np.array([10.0**k for k in range(-64, 65)])  # 10^k for |k| ≤ 64, within an ulp
_HALF = np.array([2.0 ** (b - 151) for b in range(256)])  # half a float32 ulp, by exponent
_BLOCK = 1 << 20  # values formatted per kernel call, so the buffer stays small


@kernel
def _ndigits(v: int) -> int:
    n = 1
    while v >= 10:
        v //= 10
        n += 1
    return n


@kernel
def _shortest(x: float, bits: int) -> tuple[int, int]:
    """(m, k) with x ≈ m · 10^-k: the fewest digits (≤ 9) that read back as the float32
    ``x`` (> 0, finite; ``bits`` its IEEE-754 bits), m without trailing zeros."""
    # half the float32 spacing at x (the smaller side's at a power of two): a decimal
    # nearer than that to x reads back as x
    biased = (bits >> 23) & 0xFF
    power_of_two = (bits & 0x7FFFFF) == 0
    half = _HALF[max(biased - 1 if power_of_two else biased, 1)]
    e = int(math.floor((biased - 127) * 0.3010299956639812))  # ≈ the decimal exponent
    while x >= _SCALE[e + 65]:
        e += 1
    while x < _SCALE[e + 64]:
        e -= 1
    m, k = 0, 0
    for d in range(6, 10):  # a float32 that fits in fewer digits shows them with zeros
        # stripped below: its 6-digit rounding is those digits exactly
        k = d - 1 - e
        y = x * _SCALE[k + 64]
        m = int(y + 0.5)
        if abs(m - y) < 0.999999 * half * _SCALE[k + 64]:  # a margin for rounding in y
            break
    while m % 10 == 0:
        m //= 10
        k -= 1
    return m, k


@kernel
def _format_floats(
    values: np.ndarray,
    ends: np.ndarray,
    table: np.ndarray,
    table_offsets: np.ndarray,
    buf: np.ndarray,
) -> int:
    pos = 0
    bits = values.view(np.uint32)
    for i in range(values.shape[0]):
        x = np.float64(values[i])
        if x == 0.0:
            buf[pos] = 48
            pos += 1
        else:
            if x < 0.0:
                buf[pos] = 45
                pos += 1
                x = -x
            m, k = _shortest(x, bits[i])
            nd = _ndigits(m)
            lead = nd - 1 - k  # decimal exponent of the first digit
            scientific = lead < -5 or lead >= 10
            if scientific or 0 <= lead < nd - 1:  # d.ddd or ddd.ddd: a point after digit `at`
                at = 0 if scientific else lead
                width = nd + (1 if nd > at + 1 else 0)
                start = pos
            elif lead < 0:  # 0.000ddd
                buf[pos] = 48
                buf[pos + 1] = 46
                for j in range(pos + 2, pos + 1 - lead):
                    buf[j] = 48
                at, width, start = nd, nd, pos + 1 - lead
            else:  # an integer: digits, then zeros
                for j in range(pos + nd, pos + nd - k):
                    buf[j] = 48
                at, width, start = nd, nd - k, pos
            for j in range(nd - 1, -1, -1):  # the digits, last first, skipping the point
                buf[start + j + (1 if j > at else 0)] = 48 + m % 10
                m //= 10
            if nd > at + 1:
                buf[start + at + 1] = 46
            pos = start + width
            if scientific:
                a = abs(lead)
                buf[pos] = 101
                buf[pos + 1] = 45 if lead < 0 else 43
                buf[pos + 2] = 48 + a // 10
                buf[pos + 3] = 48 + a % 10
                pos += 4
        for j in range(table_offsets[ends[i]], table_offsets[ends[i] + 1]):
            buf[pos] = table[j]
            pos += 1
    return pos


@kernel
def _format_ints(
    values: np.ndarray,
    ends: np.ndarray,
    table: np.ndarray,
    table_offsets: np.ndarray,
    buf: np.ndarray,
) -> int:
    pos = 0
    for i in range(values.shape[0]):
        v = values[i]
        if v < 0:
            buf[pos] = 45
            pos += 1
            v = -v
        nd = _ndigits(v)
        for j in range(pos + nd - 1, pos - 1, -1):
            buf[j] = 48 + v % 10
            v //= 10
        pos += nd
        for j in range(table_offsets[ends[i]], table_offsets[ends[i] + 1]):
            buf[pos] = table[j]
            pos += 1
    return pos


def write_values(
    fh: BinaryIO, values: np.ndarray, ends: np.ndarray, table: Sequence[bytes]
) -> None:
    """Write each of ``values`` (1-D float32, or integers) followed by the literal
    ``table[ends[i]]`` to the binary file ``fh``, as ASCII text."""
    lengths = np.array([0] + [len(t) for t in table], dtype=np.int64)
    offsets = np.cumsum(lengths)
    literals = np.frombuffer(b"".join(table), dtype=np.uint8)
    if values.dtype.kind in "iu":
        values, kernel = values.astype(np.int64, copy=False), _format_ints
    else:
        values, kernel = np.ascontiguousarray(values, dtype=np.float32), _format_floats
    width = 24 + int(lengths.max())  # "-0.0000123456789" or "-1.23456789e-38", a literal
    buf = np.empty(min(len(values), _BLOCK) * width, dtype=np.uint8)
    for a in range(0, len(values), _BLOCK):
        n = kernel(values[a : a + _BLOCK], ends[a : a + _BLOCK], literals, offsets, buf)
        fh.write(buf.data[:n])  # buf: 1-D uint8


# ------------------------------------------------------------------ reading
@kernel
def parse_number(buf: np.ndarray, i: int, n: int) -> tuple[float, int, bool]:
    """The decimal number at ``buf[i:]``: (value float64, next index, ok)."""
    neg = False
    if i < n and (buf[i] == 45 or buf[i] == 43):
        neg = buf[i] == 45
        i += 1
    mant, exp10, digits, sig = 0, 0, 0, 0
    fraction = False
    while i < n:
        c = buf[i]
        if c == 46 and not fraction:
            fraction = True
        elif 48 <= c <= 57:
            digits += 1
            if sig < 18 and (mant > 0 or c > 48):
                mant = mant * 10 + (c - 48)
                sig += 1
                exp10 -= 1 if fraction else 0
            elif sig >= 18 and not fraction:
                exp10 += 1
            elif sig == 0 and fraction:
                exp10 -= 1
        else:
            break
        i += 1
    if digits == 0:
        return 0.0, i, False
    if i < n and (buf[i] == 101 or buf[i] == 69):
        j, eneg, e = i + 1, False, 0
        if j < n and (buf[j] == 45 or buf[j] == 43):
            eneg = buf[j] == 45
            j += 1
        if j >= n or not 48 <= buf[j] <= 57:
            return 0.0, j, False
        while j < n and 48 <= buf[j] <= 57:
            e = min(e * 10 + (buf[j] - 48), 100000)
            j += 1
        exp10 += -e if eneg else e
        i = j
    value = float(mant)
    if mant == 0:
        value = 0.0
    elif 0 < exp10 <= 22:
        value *= _POW10[exp10]
    elif -22 <= exp10 < 0:
        value /= _POW10[-exp10]
    elif exp10 != 0:
        value *= 10.0**exp10
    return (-value if neg else value), i, True


def join_continued(buf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``buf`` with each line continuation (backslash, optional CR, newline) made one
    blank, and the positions in the result where the removed newlines were (for
    :func:`line_at`)."""
    slashes = np.flatnonzero(buf[:-1] == 92)
    if not slashes.size:
        return buf, slashes
    nxt = buf[slashes + 1]
    crlf = (nxt == 13) & (slashes + 2 < len(buf))
    crlf[crlf] = buf[slashes[crlf] + 2] == 10
    slashes, crlf = slashes[(nxt == 10) | crlf], crlf[(nxt == 10) | crlf]
    drop = np.concatenate([slashes + 1, slashes[crlf] + 2])
    keep = np.ones(len(buf), dtype=bool)
    keep[drop] = False
    out = buf.copy()
    out[slashes] = 32
    out = out[keep]
    before = np.cumsum(~keep)  # bytes dropped up to and including each position
    return out, slashes - before[slashes] + 1


def line_at(buf: np.ndarray, joined: np.ndarray, pos: int) -> int:
    """The 1-based line of the original file at position ``pos`` of ``buf`` as returned
    by :func:`join_continued` (``joined``: its second result)."""
    return (
        1 + int(np.count_nonzero(buf[:pos] == 10)) + int(np.searchsorted(joined, pos, side="right"))
    )

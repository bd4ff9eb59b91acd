"""An independent reader of Alembic's Ogawa files, in pure Python and numpy, for the tests.

follicle writes and reads its Alembic files with one library (alembic3d); this module
decodes the bytes without it, from the format as Alembic's C++ sources lay it out
(Ogawa's IStreams / IGroup / IData, AbcCoreOgawa's ArImpl, OrData, CprData, ReadUtil,
WriteUtil), so a test can check that the file says what another reader (Unreal's groom
importer) will find in it. It reads; it never writes.

The container (Ogawa)
    A 16-byte header: ``b"Ogawa"``, a frozen byte (0xff once the writer closed the file),
    a big-endian uint16 version (1) and the little-endian uint64 position of the root
    group. A *group* at position p is a uint64 count n and n uint64 child references; a
    reference with the top bit set is a *data* block (its position in the other 63 bits),
    otherwise a group; position 0 is the empty group or the empty data. A data block is a
    uint64 size and that many bytes.

The archive (AbcCoreOgawa)
    The root group holds: data 0, the archive version (int32, 0); data 1, the Alembic
    library version (int32, e.g. 10712); group 2, the top object; data 3, the archive's
    metadata; data 4, the time samplings; data 5, the indexed metadata (strings of at
    most 255 bytes, each prefixed by its length; index 0 is the empty metadata).

    An object group holds its properties (a compound group) first, then one group per
    child object, then a data block of the children's headers (uint32 name length, name,
    a metadata index byte; 0xff: a uint32 length and the metadata inline) followed by
    two 16-byte hashes.

    A compound group holds one group per property and, last, a data block of the
    properties' headers: a uint32 ``info`` (bits 0-1 the kind: 0 compound, 1 scalar, 2/3
    array; bits 2-3 the byte width of the numbers that follow, 1, 2 or 4; bits 4-7 the
    POD; bit 8 a time sampling index follows; bit 9 first / last changed indices follow;
    bit 10 every sample has the same size; bit 11 every sample equals the first; bits
    12-19 the extent; bits 20-27 the metadata index), then for a scalar or an array the
    number of samples, the optional first / last changed indices and time sampling
    index, then the name's length and the name, then (index 0xff) the metadata inline.
    Metadata is ``key=value`` pairs joined by ``;``.

    A scalar property's group holds one data block per *stored* sample, an array
    property's two (the values, then the dimensions, empty for one dimension). Every
    values block starts with the sample's 16-byte digest. A run of samples equal to the
    one before is not stored again: sample i reads stored sample 0 before the first
    changed index, stored sample ``i - first + 1`` between the first and the last
    changed index, and the last stored sample after it (all of them 0 for a constant
    property).

Every position, size and count is checked against the file before it is followed: a
file that is truncated or corrupt raises ValueError (never IndexError, never a hang).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = [
    "Archive",
    "Object",
    "Compound",
    "Property",
    "TimeSampling",
    "POD_NAMES",
    "parse_metadata",
]

_MAGIC = b"Ogawa"
_HEADER = 16
_DATA_BIT = 1 << 63
_KEY = 16  # the digest before each stored sample's values
_OGAWA_FILE_VERSION = 0  # the archive version AbcCoreOgawa writes (and the newest it reads)
_MIN_LIBRARY_VERSION = 9999  # AbcCoreOgawa refuses an archive written by an older library

# Alembic's PlainOldDataType, in its enum order: (name, numpy dtype)
_PODS: tuple[tuple[str, str | None], ...] = (
    ("bool", "u1"),
    ("uint8", "u1"),
    ("int8", "i1"),
    ("uint16", "<u2"),
    ("int16", "<i2"),
    ("uint32", "<u4"),
    ("int32", "<i4"),
    ("uint64", "<u8"),
    ("int64", "<i8"),
    ("float16", "<f2"),
    ("float32", "<f4"),
    ("float64", "<f8"),
    ("string", None),
    ("wstring", None),
)
POD_NAMES = tuple(name for name, _ in _PODS)
_DTYPES = dict(_PODS)
_KINDS = {0: "compound", 1: "scalar", 2: "array", 3: "array"}


def _fail(message: str) -> ValueError:
    return ValueError(f"malformed Ogawa file: {message}")


def parse_metadata(text: str) -> dict[str, str]:
    """Alembic metadata (``key=value`` pairs joined by ``;``) as a dict; a pair without
    ``=`` is ignored, as Alembic's TokenMap does."""
    out = {}
    for pair in text.split(";"):
        key, sep, value = pair.partition("=")
        if sep:
            out[key] = value
    return out


@dataclass(frozen=True)
class TimeSampling:
    """One of the archive's time samplings: the most samples a property of it holds,
    the time per cycle in seconds (Alembic's huge marker value when acyclic) and the
    stored times (one cycle's, or every sample's when acyclic)."""

    max_samples: int
    time_per_cycle: float
    times: tuple[float, ...]


# ------------------------------------------------------------------ the container
class _Ogawa:
    """The Ogawa container over the file's bytes: groups and data blocks by reference,
    every read bounds-checked."""

    def __init__(self, buf: bytes) -> None:
        self.buf = memoryview(buf)
        self.size = len(buf)
        self._groups: dict[int, tuple[int, ...]] = {}
        if self.size < _HEADER:
            raise _fail(f"{self.size} bytes, shorter than the {_HEADER}-byte header")
        if bytes(self.buf[:5]) != _MAGIC:
            raise _fail(f"magic {bytes(self.buf[:5])!r}, expected {_MAGIC!r}")
        self.frozen = self.buf[5] == 0xFF
        self.version = int.from_bytes(self.buf[6:8], "big")
        self.root = self.u64(8)
        if not self.frozen:
            raise _fail("not frozen: the writer did not close it")
        if self.version != 1:
            raise _fail(f"Ogawa version {self.version}, expected 1")

    def u64(self, pos: int) -> int:
        """The little-endian uint64 at ``pos``."""
        if pos < 0 or pos + 8 > self.size:
            raise _fail(f"reading 8 bytes at {pos}, past the end ({self.size} bytes)")
        return int.from_bytes(self.buf[pos : pos + 8], "little")

    def group(self, ref: int) -> tuple[int, ...]:
        """The child references of the group ``ref`` (empty for the empty group)."""
        if ref & _DATA_BIT:
            raise _fail(f"reference {ref:#x} is data where a group belongs")
        if ref == 0:
            return ()
        if ref in self._groups:
            return self._groups[ref]
        if ref < _HEADER:
            raise _fail(f"group at {ref}, inside the header")
        count = self.u64(ref)
        if count > (self.size - ref - 8) // 8:
            raise _fail(f"group at {ref} claims {count} children, past the end of the file")
        children: tuple[int, ...] = ()  # a count of 0: the empty group, as Ogawa reads it
        if count:
            children = tuple(np.frombuffer(self.buf, "<u8", count, ref + 8).tolist())
        self._groups[ref] = children
        return children

    def data(self, ref: int) -> memoryview:
        """The bytes of the data block ``ref`` (empty for the empty data)."""
        if not ref & _DATA_BIT:
            raise _fail(f"reference {ref:#x} is a group where data belongs")
        pos = ref & ~_DATA_BIT
        if pos == 0:
            return self.buf[0:0]
        if pos < _HEADER:
            raise _fail(f"data at {pos}, inside the header")
        size = self.u64(pos)
        if size > self.size - pos - 8:
            raise _fail(f"data at {pos} claims {size} bytes, past the end of the file")
        return self.buf[pos + 8 : pos + 8 + size]

    def child(self, children: tuple[int, ...], i: int, what: str) -> int:
        """``children[i]``, ValueError naming ``what`` when the group is too short."""
        if not 0 <= i < len(children):
            raise _fail(f"{what}: child {i} of a group of {len(children)}")
        return children[i]


class _Reader:
    """Sequential reads from a header block, bounds-checked."""

    def __init__(self, buf: memoryview, what: str) -> None:
        self.buf, self.pos, self.what = buf, 0, what

    def more(self) -> bool:
        return self.pos < len(self.buf)

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > len(self.buf):
            raise _fail(f"{self.what}: {n} bytes at {self.pos} run past its {len(self.buf)} bytes")
        out = bytes(self.buf[self.pos : self.pos + n])
        self.pos += n
        return out

    def uint(self, width: int) -> int:
        return int.from_bytes(self.take(width), "little")

    def text(self, n: int) -> str:
        try:
            return self.take(n).decode("utf-8")
        except UnicodeDecodeError as err:
            raise _fail(f"{self.what}: a name or metadata is not UTF-8 ({err})") from None


# ------------------------------------------------------------------ properties
class Compound:
    """A compound property: named child properties (compound, scalar or array)."""

    kind = "compound"

    def __init__(
        self,
        archive: Archive,
        ref: int,
        name: str,
        metadata: dict[str, str],
        full_name: str,
        ancestors: frozenset[int] = frozenset(),
    ) -> None:
        self.archive, self.name, self.metadata = archive, name, metadata
        self.full_name = full_name
        self._ref = ref
        self._ancestors = ancestors | {ref} if ref else ancestors
        self._children: dict[str, Compound | Property] | None = None

    def __repr__(self) -> str:
        return f"Compound({self.full_name!r}, {len(self.children)} properties)"

    @property
    def children(self) -> dict[str, Compound | Property]:
        """Name → property, in the order the file lists them."""
        if self._children is None:
            self._children = self._read_children()
        return self._children

    def _read_children(self) -> dict[str, Compound | Property]:
        ogawa = self.archive._ogawa
        refs = ogawa.group(self._ref)
        if not refs or not refs[-1] & _DATA_BIT:
            return {}
        out: dict[str, Compound | Property] = {}
        for i, header in enumerate(self._headers(ogawa.data(refs[-1]))):
            ref = ogawa.child(refs[:-1], i, f"property {header['name']!r} of {self.full_name}")
            name = header["name"]
            if name in out:
                raise _fail(f"{self.full_name}: two properties named {name!r}")
            full = f"{self.full_name}/{name}"
            if header["kind"] == "compound":
                if ref & _DATA_BIT or ref in self._ancestors:
                    raise _fail(f"{full}: compound property is not a fresh group")
                out[name] = Compound(
                    self.archive, ref, name, header["metadata"], full, self._ancestors
                )
            else:
                if ref & _DATA_BIT:
                    raise _fail(f"{full}: property is data where a group belongs")
                out[name] = Property(self.archive, ref, full, **header)
        return out

    def _headers(self, block: memoryview) -> Iterator[dict]:
        """The property headers of a compound's last data block, one dict each."""
        r = _Reader(block, f"property headers of {self.full_name}")
        while r.more():
            info = r.uint(4)
            kind = _KINDS[info & 0x3]
            hint = (info >> 2) & 0x3
            if hint == 3:
                raise _fail(f"{r.what}: size hint 3 (1, 2 or 4 bytes: 0-2)")
            width = (1, 2, 4)[hint]
            header: dict = {"kind": kind}
            if kind != "compound":
                pod = (info >> 4) & 0xF
                if pod >= len(_PODS):
                    raise _fail(f"{r.what}: POD {pod}")
                extent = (info >> 12) & 0xFF
                if extent == 0:
                    raise _fail(f"{r.what}: extent 0")
                count = r.uint(width)
                if info & 0x200:
                    first, last = r.uint(width), r.uint(width)
                elif info & 0x800:
                    first = last = 0
                else:
                    first, last = 1, count - 1
                sampling = r.uint(width) if info & 0x100 else 0
                if not (first <= last <= count or first == 1 and count <= 1):
                    raise _fail(f"{r.what}: changed indices {first}..{last} of {count} samples")
                if sampling >= len(self.archive.time_samplings):
                    raise _fail(
                        f"{r.what}: time sampling {sampling} of {len(self.archive.time_samplings)}"
                    )
                header.update(
                    pod=POD_NAMES[pod],
                    extent=extent,
                    num_samples=count,
                    first_changed=first,
                    last_changed=last,
                    time_sampling=sampling,
                    homogenous=bool(info & 0x400),
                )
            header["name"] = r.text(r.uint(width))
            index = (info >> 20) & 0xFF
            if index == 0xFF:
                header["metadata"] = parse_metadata(r.text(r.uint(width)))
            else:
                header["metadata"] = self.archive._indexed(index, r.what)
            yield header

    def find(self, path: str) -> Compound | Property:
        """The property at ``path`` below this compound, names joined by ``/`` (e.g.
        ``".geom/.arbGeomParams/groom_id"``); KeyError when there is none."""
        node: Compound | Property = self
        for part in path.strip("/").split("/"):
            if not isinstance(node, Compound) or part not in node.children:
                raise KeyError(f"{self.full_name}: no property {path!r}")
            node = node.children[part]
        return node

    def __contains__(self, path: str) -> bool:
        try:
            self.find(path)
        except KeyError:
            return False
        return True

    def walk(self) -> Iterator[Compound | Property]:
        """Every property below this compound, depth first."""
        for child in self.children.values():
            yield child
            if isinstance(child, Compound):
                yield from child.walk()


class Property:
    """A scalar or array property: its type (``pod``, ``extent``), metadata (e.g.
    ``geoScope``, ``interpretation``) and samples."""

    def __init__(
        self,
        archive: Archive,
        ref: int,
        full_name: str,
        *,
        kind: str,
        name: str,
        metadata: dict[str, str],
        pod: str,
        extent: int,
        num_samples: int,
        first_changed: int,
        last_changed: int,
        time_sampling: int,
        homogenous: bool,
    ) -> None:
        self.archive, self.full_name, self.kind, self.name = archive, full_name, kind, name
        self.metadata, self.pod, self.extent = metadata, pod, extent
        self.num_samples, self.time_sampling = num_samples, time_sampling
        self.homogenous = homogenous
        self.first_changed, self.last_changed = first_changed, last_changed
        self._ref = ref

    def __repr__(self) -> str:
        return (
            f"Property({self.full_name!r}, {self.kind} {self.pod}[{self.extent}],"
            f" {self.num_samples} samples)"
        )

    @property
    def is_constant(self) -> bool:
        """Every sample equals the first (only one is stored)."""
        return self.first_changed == 0 and self.last_changed == 0

    def stored_index(self, i: int) -> int:
        """The stored sample that sample ``i`` reads (repeats are stored once);
        IndexError for an ``i`` outside the property's samples."""
        if not 0 <= i < self.num_samples:
            raise IndexError(f"{self.full_name}: sample {i} of {self.num_samples}")
        first, last = self.first_changed, self.last_changed
        if i < first or first == last == 0:
            return 0
        if i >= last:
            return last - first + 1
        return i - first + 1

    def _blocks(self, i: int) -> tuple[memoryview, memoryview | None]:
        """(values block, dimensions block or None for a scalar) of sample ``i``."""
        ogawa = self.archive._ogawa
        refs = ogawa.group(self._ref)
        s = self.stored_index(i)
        if self.kind == "scalar":
            return ogawa.data(ogawa.child(refs, s, self.full_name)), None
        values = ogawa.data(ogawa.child(refs, 2 * s, self.full_name))
        return values, ogawa.data(ogawa.child(refs, 2 * s + 1, self.full_name))

    def digest(self, i: int = 0) -> bytes:
        """The 16-byte digest stored before sample ``i``'s values (empty if none)."""
        return bytes(self._blocks(i)[0][:_KEY])

    def value(self, i: int = 0) -> np.ndarray:
        """Sample ``i``: an array property as (n, extent) rows, or (n,) for extent 1
        (more dimensions if the sample has them); a scalar property as (extent,).
        Strings come as an object array of str."""
        values, dims = self._blocks(i)
        if len(values) and len(values) < _KEY:
            raise _fail(f"{self.full_name}: sample of {len(values)} bytes, shorter than its key")
        payload = values[_KEY:]
        shape = self._dims(dims) if dims is not None else None
        dtype = _DTYPES[self.pod]
        if dtype is None:
            return self._strings(payload, shape)
        item = np.dtype(dtype).itemsize * self.extent
        if self.kind == "scalar" and len(payload) != item:
            raise _fail(
                f"{self.full_name}: scalar sample of {len(payload)} bytes, its type takes {item}"
            )
        if len(payload) % item:
            raise _fail(
                f"{self.full_name}: {len(payload)} bytes are not whole"
                f" {self.pod}[{self.extent}] values"
            )
        n = len(payload) // item
        arr = np.frombuffer(payload, dtype, n * self.extent).copy()
        if self.pod == "bool":
            arr = arr != 0
        if self.kind == "scalar":
            return arr
        if shape is None:
            shape = (n,)
        elif math.prod(shape) != n:
            raise _fail(f"{self.full_name}: dimensions {shape} for {n} values")
        return arr.reshape(shape + ((self.extent,) if self.extent > 1 else ()))

    def _dims(self, block: memoryview) -> tuple[int, ...] | None:
        """An array sample's dimensions (None: one dimension, from the data's size)."""
        if not len(block):
            return None
        if len(block) % 8:
            raise _fail(f"{self.full_name}: dimensions of {len(block)} bytes")
        return tuple(np.frombuffer(block, "<u8").tolist())

    def _strings(self, payload: memoryview, shape: tuple[int, ...] | None) -> np.ndarray:
        """NUL-terminated strings (UTF-8, or UTF-32 code points for wstring)."""
        if self.pod == "string":
            raw = bytes(payload)
            if raw and not raw.endswith(b"\0"):
                raise _fail(f"{self.full_name}: string not NUL-terminated")
            try:
                texts = [t.decode("utf-8") for t in raw.split(b"\0")[:-1]]
            except UnicodeDecodeError as err:
                raise _fail(f"{self.full_name}: string not UTF-8 ({err})") from None
        else:
            if len(payload) % 4:
                raise _fail(f"{self.full_name}: wstring of {len(payload)} bytes")
            codes = np.frombuffer(payload, "<u4").tolist()
            if codes and codes[-1] != 0:
                raise _fail(f"{self.full_name}: wstring not NUL-terminated")
            texts, cur = [], []
            for c in codes:
                if c == 0:
                    texts.append("".join(map(chr, cur)))
                    cur = []
                elif c > 0x10FFFF:
                    raise _fail(f"{self.full_name}: code point {c:#x}")
                else:
                    cur.append(c)
        arr = np.empty(len(texts), dtype=object)
        arr[:] = texts
        if self.kind == "scalar":
            n = self.extent
        elif shape is not None:
            n = math.prod(shape) * self.extent
        else:
            n = len(texts) - len(texts) % self.extent
        if n != len(texts):
            raise _fail(f"{self.full_name}: {len(texts)} strings, its dimensions say {n}")
        if self.kind == "scalar":
            return arr
        rows = shape if shape is not None else (len(texts) // self.extent,)
        return arr.reshape(rows + ((self.extent,) if self.extent > 1 else ()))


# ------------------------------------------------------------------ objects
class Object:
    """An object of the archive: its name, metadata (``schema``: e.g.
    ``AbcGeom_Curve_v2``), child objects and properties."""

    def __init__(
        self,
        archive: Archive,
        ref: int,
        name: str,
        full_name: str,
        metadata: dict[str, str],
        ancestors: frozenset[int] = frozenset(),
    ) -> None:
        self.archive, self.name, self.full_name = archive, name, full_name
        self.metadata = metadata
        self._ref = ref
        self._ancestors = ancestors | {ref} if ref else ancestors
        self._children: list[Object] | None = None
        self._properties: Compound | None = None

    def __repr__(self) -> str:
        return f"Object({self.full_name!r}, {self.schema})"

    @property
    def schema(self) -> str | None:
        """The object's schema (``AbcGeom_Xform_v3``, ``AbcGeom_Curve_v2``, …) or None."""
        return self.metadata.get("schema")

    @property
    def properties(self) -> Compound:
        """The object's top compound property (``.xform``, ``.geom``, …)."""
        if self._properties is None:
            refs = self.archive._ogawa.group(self._ref)
            ref = refs[0] if refs else 0
            if ref & _DATA_BIT:
                raise _fail(f"{self.full_name}: properties are data where a group belongs")
            if ref and ref in self._ancestors:
                raise _fail(f"{self.full_name}: properties loop back to an ancestor")
            self._properties = Compound(
                self.archive, ref, "", {}, self.full_name.rstrip("/"), self._ancestors
            )
        return self._properties

    @property
    def children(self) -> list[Object]:
        """The child objects, in archive order."""
        if self._children is None:
            self._children = self._read_children()
        return self._children

    def _read_children(self) -> list[Object]:
        ogawa = self.archive._ogawa
        refs = ogawa.group(self._ref)
        if not refs or not refs[-1] & _DATA_BIT:
            return []
        block = ogawa.data(refs[-1])
        if len(block) <= 32:  # only the two hashes: no children
            return []
        r = _Reader(block[:-32], f"object headers of {self.full_name}")
        out, names = [], set()
        prefix = "" if self.full_name == "/" else self.full_name
        while r.more():
            name = r.text(r.uint(4))
            index = r.uint(1)
            if index == 0xFF:
                metadata = parse_metadata(r.text(r.uint(4)))
            else:
                metadata = self.archive._indexed(index, r.what)
            if not name or "/" in name or name in names:
                raise _fail(f"{r.what}: bad or repeated object name {name!r}")
            names.add(name)
            ref = ogawa.child(refs[:-1], len(out) + 1, f"object {prefix}/{name}")
            if ref & _DATA_BIT or ref and ref in self._ancestors:
                raise _fail(f"{prefix}/{name}: object is not a fresh group")
            out.append(
                Object(self.archive, ref, name, f"{prefix}/{name}", metadata, self._ancestors)
            )
        return out

    def child(self, name: str) -> Object:
        """The child object called ``name``; KeyError when there is none."""
        for c in self.children:
            if c.name == name:
                return c
        raise KeyError(f"{self.full_name}: no child {name!r}")

    def find(self, path: str) -> Compound | Property:
        """The property at ``path`` in this object's properties (``Compound.find``)."""
        return self.properties.find(path)


# ------------------------------------------------------------------ the archive
class Archive:
    """An Alembic (Ogawa) file read whole into memory and decoded lazily.

    ``top`` is the top object (``/``), :meth:`walk` every object depth first,
    :meth:`object` one by its full name. ``metadata`` is the archive's (the writing
    application, Alembic version…), ``time_samplings`` its time samplings,
    ``library_version`` the Alembic library that wrote it."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._ogawa = _Ogawa(self.path.read_bytes())
        self.ogawa_version = self._ogawa.version
        root = self._ogawa.group(self._ogawa.root)
        kinds = [bool(ref & _DATA_BIT) for ref in root[:6]]
        if len(root) < 6 or kinds != [True, True, False, True, True, True]:
            raise _fail(
                "the root group is not an Alembic archive (data, data, group, data, data, data)"
            )
        self.archive_version = self._int32(root[0], "archive version")
        self.library_version = self._int32(root[1], "library version")
        if not 0 <= self.archive_version <= _OGAWA_FILE_VERSION:
            raise _fail(f"archive version {self.archive_version}")
        if self.library_version < _MIN_LIBRARY_VERSION:
            raise _fail(f"Alembic library version {self.library_version}")
        self.time_samplings = self._time_samplings(self._ogawa.data(root[4]))
        self._metadata_table = self._indexed_metadata(self._ogawa.data(root[5]))
        block = self._ogawa.data(root[3])
        self.metadata = parse_metadata(_Reader(block, "archive metadata").text(len(block)))
        self.top = Object(self, root[2], "ABC", "/", self.metadata)

    def __repr__(self) -> str:
        return f"Archive({str(self.path)!r})"

    def _int32(self, ref: int, what: str) -> int:
        block = self._ogawa.data(ref)
        if len(block) != 4:
            raise _fail(f"{what}: {len(block)} bytes, expected 4")
        return int.from_bytes(block, "little", signed=True)

    @staticmethod
    def _time_samplings(block: memoryview) -> list[TimeSampling]:
        r = _Reader(block, "time samplings")
        out = []
        while r.more():
            max_samples = r.uint(4)
            per_cycle = float(np.frombuffer(r.take(8), "<f8")[0])
            count = r.uint(4)
            times = np.frombuffer(r.take(8 * count), "<f8").tolist()
            out.append(TimeSampling(max_samples, per_cycle, tuple(times)))
        return out  # Alembic writes at least the identity one; none: no property reads

    @staticmethod
    def _indexed_metadata(block: memoryview) -> list[dict[str, str]]:
        r = _Reader(block, "indexed metadata")
        out: list[dict[str, str]] = [{}]
        while r.more():
            out.append(parse_metadata(r.text(r.uint(1))))
        return out

    def _indexed(self, index: int, what: str) -> dict[str, str]:
        if index >= len(self._metadata_table):
            raise _fail(f"{what}: metadata index {index} of {len(self._metadata_table)}")
        return dict(self._metadata_table[index])

    def walk(self) -> Iterator[Object]:
        """Every object below the top, depth first in archive order."""
        budget = self._ogawa.size  # a file cannot hold more objects than bytes
        stack = list(reversed(self.top.children))
        while stack:
            obj = stack.pop()
            budget -= 1
            if budget < 0:
                raise _fail("more objects than the file could hold")
            yield obj
            stack.extend(reversed(obj.children))

    def object(self, path: str) -> Object:
        """The object whose full name is ``path`` (e.g. ``"/Groom/Guides"``); KeyError
        when there is none."""
        obj = self.top
        for part in path.strip("/").split("/"):
            if part:
                obj = obj.child(part)
        return obj

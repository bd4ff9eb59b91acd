"""Unreal's groom schema, checked in the bytes of follicle's ``--target unreal`` Alembic
files with an independent decoder (:mod:`ogawa`, pure Python and numpy), not with the
library that wrote them.

Unreal's "Alembic for Grooms" specification (dev.epicgames.com, "using alembic for
grooms in unreal engine"): property names lower case and prefixed ``groom_``;
``groom_version_major`` 1 / ``groom_version_minor`` 5, int16, on the topmost IXform or
the ICurves (Unreal's translator reads them from user properties, or an Xform's
arbGeomParams; a curves object's arbGeomParams are its strands' attributes); per curve
(uniform scope) ``groom_id`` int32, ``groom_root_uv`` float2, ``groom_guide`` int (1: a
guide) and, computed outside Unreal, ``groom_closest_guides`` int32×3 (the ``groom_id``
of guides) and ``groom_guide_weights`` float×3; per vertex ``groom_color`` float3;
widths from the curves' ``width`` in centimetres (Unreal's unit); at most 255 points a
curve (its builder keeps a curve's point count in a byte and trims the rest).

The decoder itself is checked against alembic3d on every property and sample of these
files (animated ones too, whose repeated samples Ogawa stores once), and against
truncated and corrupted files, which it must refuse with ValueError.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass
from pathlib import Path

import imath
import numpy as np
import pytest
from alembic3d import Abc, AbcCoreAbstract
from click.testing import CliRunner

from follicle.cli import main
from follicle.curves import HairCurves
from follicle.groom.generator import Groom
from follicle.io.alembic import save_abc, save_abc_cache
from follicle.io.attributes import DEFAULT_WIDTH
from follicle.io.targets import GUIDE_ID_BASE
from follicle.pipeline import groom_scene
from follicle.scene import load_scene
from ogawa import POD_NAMES, Archive, Compound, Object, Property, parse_metadata

CM = 100.0  # Unreal's unit, per metre
NAME = re.compile(r"groom_[a-z0-9_]+")  # the spec's naming convention
SCENE = "[groom]\ncount = 150\nseed = 3\n"


@dataclass
class Reference:
    """What a groom was before it was written: hair, guides and the guide binding."""

    groom: Groom
    hair: HairCurves
    guides: HairCurves
    closest: np.ndarray  # (hairs, 3) guide indices
    weights: np.ndarray  # (hairs, 3)


def _run(*args: object) -> None:
    result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert result.exit_code == 0, result.output


def _bound(ref: Reference, hair: HairCurves) -> HairCurves:
    """``hair`` with the binding the CLI gives Unreal hair (closest_guides, guide_weights)."""
    index, weight = ref.groom.guide_binding(hair.curve_data["hair_id"])
    return HairCurves(
        hair.points,
        hair.offsets,
        hair.point_data,
        {**hair.curve_data, "closest_guides": index, "guide_weights": weight},
    )


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("unreal")


@pytest.fixture(scope="module")
def scene_path(files) -> Path:
    path = files / "scene.toml"
    path.write_text(SCENE)
    return path


@pytest.fixture(scope="module")
def reference(scene_path) -> Reference:
    groom = groom_scene(load_scene(scene_path))
    hair = groom.generate()
    closest, weights = groom.guide_binding(hair.curve_data["hair_id"])
    return Reference(groom, hair, groom.guides.curves, closest, weights)


@pytest.fixture(scope="module")
def grown(files, scene_path) -> Path:
    """`follicle grow --target unreal`, as a user runs it: hair, guides and skin."""
    path = files / "grown.abc"
    _run("grow", scene_path, "-o", path, "--target", "unreal")
    return path


@pytest.fixture(scope="module")
def chunked(files, reference) -> Path:
    """The same hair written as two chunks (two curves objects), without the skin."""
    ref, n = reference, reference.hair.curve_count
    chunks = [_bound(ref, ref.hair[np.arange(0, 70)]), _bound(ref, ref.hair[np.arange(70, n)])]
    return save_abc(chunks, files / "chunked.abc", guides=ref.groom.guides, target="unreal")


@pytest.fixture(scope="module")
def long_curves() -> HairCurves:
    """Three curves of 300, 255 and 10 points (a helix), widths tapering."""
    counts = [300, 255, 10]
    t = np.concatenate([np.linspace(0.0, 1.0, c) for c in counts])
    points = np.stack([0.01 * np.cos(8 * t), 0.2 * t, 0.01 * np.sin(8 * t)], axis=1)
    points += np.repeat([[0.0, 0, 0], [0.05, 0, 0], [0.1, 0, 0]], counts, axis=0)
    width = (1e-4 - 5e-5 * t).astype(np.float32)
    return HairCurves(
        points.astype(np.float32),
        np.concatenate([[0], np.cumsum(counts)]),
        {"width": width},
        {"hair_id": np.arange(3, dtype=np.int64)},
    )


@pytest.fixture(scope="module")
def long_file(files, long_curves) -> Path:
    return save_abc(long_curves, files / "long.abc", target="unreal")


FRAME_SHIFTS = (0.0, 0.0, 0.01, 0.02, 0.02, 0.02)  # metres: frames 0-1, 3-5 repeat


@pytest.fixture(scope="module")
def animated(files, reference) -> tuple[Path, list[HairCurves]]:
    """Six frames of three hairs, equal frames in runs (stored once), the head moving on
    frames 2 and 3 and still after."""
    base = np.random.default_rng(1).normal(size=(3, 6, 3)).astype(np.float32) * 0.1
    width = {"width": np.full(18, 1e-4, np.float32)}
    frames = [HairCurves.from_array(base + np.float32(d), point_data=width) for d in FRAME_SHIFTS]
    moves = np.stack([np.eye(4)] * len(frames))
    moves[2:, 0, 3], moves[3:, 1, 3] = 0.5, 0.25
    path = save_abc_cache(
        frames,
        files / "animated.abc",
        fps=24,
        mesh=reference.groom.mesh,
        transforms=moves,
        target="unreal",
    )
    return path, frames


def _write_kinds(path: Path) -> None:
    """An archive of one object holding a property of each kind follicle does not write
    (strings, wide strings, bools, int64, half floats, a nested compound) and two
    animated scalars, one with repeats; written and closed by alembic3d."""
    archive = Abc.OArchive(str(path))
    props = Abc.OObject(archive.getTop(), "thing").getProperties()
    Abc.OStringProperty(props, "s").setValue("héllo")
    Abc.OWstringProperty(props, "w").setValue("wide ✓")
    strings, flags = imath.StringArray(3), imath.BoolArray(3)
    for i, (text, flag) in enumerate([("a", True), ("", False), ("ccc", True)]):
        strings[i], flags[i] = text, flag
    Abc.OStringArrayProperty(props, "sa").setValue(strings)
    Abc.OBoolArrayProperty(props, "ba").setValue(flags)
    Abc.OInt64Property(props, "i64").setValue(-5)
    Abc.OHalfProperty(props, "h").setValue(1.5)
    every = archive.addTimeSampling(AbcCoreAbstract.TimeSampling(1 / 24, 0))
    for name, values in (("f", (1, 2, 2, 3, 3)), ("g", (1, 2, 3))):
        prop = Abc.OFloatProperty(props, name, every)
        for v in values:
            prop.setValue(v)
    Abc.OUInt32ArrayProperty(Abc.OCompoundProperty(props, "sub"), "u").setValue(
        imath.UnsignedIntArray(2)
    )


@pytest.fixture(scope="module")
def kinds(files) -> Path:
    path = files / "kinds.abc"
    _write_kinds(path)  # returns once alembic3d has closed the archive
    return path


# ------------------------------------------------------------------ helpers
def _curves(archive: Archive) -> tuple[Object, list[Object]]:
    """(guides, hair) curves objects, found by schema: the guides are the one under
    /Groom/Guides."""
    curves = [o for o in archive.walk() if o.schema == "AbcGeom_Curve_v2"]
    guides = [o for o in curves if o.full_name.startswith("/Groom/Guides")]
    assert len(guides) == 1, [o.full_name for o in curves]
    return guides[0], [o for o in curves if o is not guides[0]]


def _param(obj: Object, name: str, pod: str, extent: int, scope: str) -> np.ndarray:
    """The arbGeomParam ``name`` of a curves object, checked to be an array property of
    ``pod``[``extent``] in ``scope``, as its values."""
    prop = obj.find(f".geom/.arbGeomParams/{name}")
    assert isinstance(prop, Property) and prop.kind == "array", prop
    assert (prop.pod, prop.extent, prop.metadata.get("geoScope")) == (pod, extent, scope), prop
    return prop.value()


def _geom(obj: Object, name: str) -> np.ndarray:
    prop = obj.find(f".geom/{name}")
    assert isinstance(prop, Property)
    return prop.value()


def _joined(objects: list[Object], name: str) -> np.ndarray:
    return np.concatenate([_param(o, name, *_SPEC[name]) for o in objects])


# name -> (pod, extent, geoScope) as the spec types them (int: follicle writes int32)
_SPEC = {
    "groom_id": ("int32", 1, "uni"),
    "groom_guide": ("int32", 1, "uni"),
    "groom_group_id": ("int32", 1, "uni"),
    "groom_root_uv": ("float32", 2, "uni"),
    "groom_color": ("float32", 3, "vtx"),
    "groom_closest_guides": ("int32", 3, "uni"),
    "groom_guide_weights": ("float32", 3, "uni"),
}
VERSION = {"groom_version_major": 1, "groom_version_minor": 5}
GUIDE_PARAMS = {"groom_guide", "groom_id", "groom_root_uv", "groom_group_id"}


def _decode_everything(path: Path) -> int:
    """Open ``path`` and read every object, property and sample; the samples read."""
    archive, read = Archive(path), 0
    for obj in archive.walk():
        for prop in obj.properties.walk():
            if isinstance(prop, Property):
                for i in range(prop.num_samples):
                    prop.value(i)
                    read += 1
    return read


def _theirs(value: object) -> np.ndarray:
    """An alembic3d sample (imath array, box, matrix, colour array, string, plain value)
    as a flat numpy array."""
    if isinstance(value, str):
        return np.array([value], dtype=object)
    with contextlib.suppress(TypeError, ValueError):
        return np.array(memoryview(value)).reshape(-1)
    if callable(getattr(value, "min", None)) and callable(getattr(value, "max", None)):
        return np.array([*value.min(), *value.max()], np.float64)  # a Box
    channels = [getattr(value, c) for c in "rgba" if hasattr(value, c)]
    if channels and not np.isscalar(channels[0]):  # C3fArray: one buffer per channel
        return np.stack([np.array(memoryview(c)) for c in channels], axis=1).reshape(-1)
    try:
        items = list(value)
    except TypeError:
        return np.asarray(value).reshape(-1)
    if items and isinstance(items[0], str):
        return np.array(items, dtype=object)
    return np.array(
        [list(r) if hasattr(r, "__len__") else r for r in items], dtype=np.float64
    ).reshape(-1)


def _compare(theirs: Abc.ICompoundProperty, ours: Compound) -> int:
    """Assert that the compound property read by alembic3d (``theirs``) and by the
    decoder (``ours``) hold the same properties, types, metadata and samples; the
    samples compared."""
    names = [theirs.getPropertyHeader(i).getName() for i in range(theirs.getNumProperties())]
    assert names == list(ours.children), ours.full_name
    compared = 0
    for name in names:
        header, mine = theirs.getPropertyHeader(name), ours.children[name]
        assert parse_metadata(header.getMetaData().serialize()) == mine.metadata, mine
        if header.isCompound():
            assert isinstance(mine, Compound)
            compared += _compare(Abc.ICompoundProperty(theirs, name), mine)
            continue
        assert isinstance(mine, Property)
        assert mine.kind == ("array" if header.isArray() else "scalar"), mine
        kind = header.getDataType()
        assert (mine.pod, mine.extent) == (POD_NAMES[int(kind.getPod())], kind.getExtent())
        prop = theirs.getProperty(name)
        assert prop.getNumSamples() == mine.num_samples, mine
        for i, sample in enumerate(prop.samples):  # by index (ISampleSelector(int) is a time)
            expected = _theirs(sample)
            got = mine.value(i).reshape(-1)
            assert got.shape == expected.shape, (mine, i)
            np.testing.assert_array_equal(got, expected.astype(got.dtype), err_msg=str(mine))
            compared += 1
    return compared


# ------------------------------------------------------------------ the decoder
@pytest.mark.slow
def test_the_decoder_reads_the_archive_header(grown):
    archive = Archive(grown)
    assert (archive.ogawa_version, archive.archive_version) == (1, 0)
    assert archive.library_version >= 10700  # Alembic 1.7 or later
    assert archive.metadata["_ai_AlembicVersion"].startswith("Alembic 1.")
    assert archive.top.full_name == "/" and archive.top.name == "ABC"
    assert [o.full_name for o in archive.top.children] == ["/Groom"]
    assert archive.object("/Groom").schema == "AbcGeom_Xform_v3"
    with pytest.raises(KeyError):
        archive.object("/Groom/Nothing")


@pytest.mark.parametrize("which", ["grown", "chunked", "long_file", "animated"])
@pytest.mark.slow
def test_the_decoder_agrees_with_alembic3d_on_every_property(which, request):
    path = request.getfixturevalue(which)
    path = path[0] if isinstance(path, tuple) else path
    ours, theirs = Archive(path), Abc.IArchive(str(path))
    objects, stack = [], list(theirs.getTop().children)[::-1]
    while stack:
        obj = stack.pop()
        objects.append(obj)
        stack.extend(list(obj.children)[::-1])
    assert [o.full_name for o in ours.walk()] == [o.getFullName() for o in objects]
    compared = 0
    for obj in objects:
        mine = ours.object(obj.getFullName())
        assert mine.metadata == parse_metadata(obj.getMetaData().serialize())
        compared += _compare(obj.getProperties(), mine.properties)
    assert compared >= 5
    assert len(ours.time_samplings) == theirs.getNumTimeSamplings()
    for i, sampling in enumerate(ours.time_samplings):
        ts = theirs.getTimeSampling(i)
        assert sampling.times == tuple(ts.getStoredTimes())
        assert sampling.time_per_cycle == ts.getTimeSamplingType().getTimePerCycle()
        assert sampling.max_samples == theirs.getMaxNumSamplesForTimeSamplingIndex(i)


@pytest.mark.slow
def test_repeated_samples_read_the_sample_they_repeat(animated):
    path, frames = animated
    archive = Archive(path)
    (hair,) = [o for o in archive.walk() if o.schema == "AbcGeom_Curve_v2"]
    points = hair.find(".geom/P")
    assert points.num_samples == len(frames) == 6
    # frames 0-1 equal, then 2, then 3-5 equal: stored once each
    assert (points.first_changed, points.last_changed) == (2, 3)
    assert [points.stored_index(i) for i in range(6)] == [0, 0, 1, 2, 2, 2]
    assert points.digest(0) == points.digest(1) != points.digest(2) != points.digest(3)
    for i, frame in enumerate(frames):
        np.testing.assert_allclose(
            points.value(i), frame.points.astype(np.float64) * CM, rtol=1e-6, atol=1e-5
        )
    speeds = hair.find(".geom/.velocities")  # cm/s from each frame to the next
    steps = np.diff(FRAME_SHIFTS + (FRAME_SHIFTS[-1],)) * 24 * CM
    for i, step in enumerate(steps):
        np.testing.assert_allclose(speeds.value(i), np.full((18, 3), step), atol=1e-3)
    assert hair.find(".geom/width").is_constant
    (head,) = [
        o.find(".xform/.vals")
        for o in archive.walk()
        if ".xform/.vals" in o.properties and o.find(".xform/.vals").num_samples > 1
    ]  # the moving head's Xform
    # its matrix: a scalar, 4x4 row-major (Alembic's row vectors: translation last row)
    assert head.kind == "scalar" and [head.stored_index(i) for i in range(6)] == [0, 0, 1, 2, 2, 2]
    assert head.value(5).reshape(4, 4)[3, :3].tolist() == [50.0, 25.0, 0.0]


def test_the_decoder_reads_every_kind_of_property(kinds):
    archive = Archive(kinds)
    thing = archive.object("/thing")
    assert (
        _compare(Abc.IArchive(str(kinds)).getTop().children[0].getProperties(), thing.properties)
        == 15
    )
    values = {p.name: p.value() for p in thing.properties.walk() if isinstance(p, Property)}
    assert values["s"].tolist() == ["héllo"] and values["w"].tolist() == ["wide ✓"]
    assert values["sa"].tolist() == ["a", "", "ccc"]
    assert values["ba"].dtype == np.bool_ and values["ba"].tolist() == [True, False, True]
    assert values["i64"].dtype == np.int64 and values["i64"].tolist() == [-5]
    assert values["h"].dtype == np.float16 and values["h"].tolist() == [1.5]
    assert values["u"].dtype == np.uint32 and values["u"].shape == (2,)
    for name, expected, changed in (("f", [1, 2, 2, 3, 3], (1, 3)), ("g", [1, 2, 3], (1, 2))):
        prop = thing.find(name)
        assert [prop.value(i).tolist() for i in range(prop.num_samples)] == [[v] for v in expected]
        assert (prop.first_changed, prop.last_changed) == changed
        assert archive.time_samplings[prop.time_sampling].time_per_cycle == 1 / 24


def _field_offsets(path: Path) -> dict[str, tuple[int, int]]:
    """(offset, byte within the 8-byte field) of position and size fields to corrupt: the
    header's root position, the root group's count and children, the top object's and a
    curves object's group references, the P property's data reference and the P data
    block's size."""
    archive = Archive(path)
    ogawa = archive._ogawa
    root = ogawa.root
    curves = next(o for o in archive.walk() if o.schema == "AbcGeom_Curve_v2")
    points = curves.find(".geom/P")
    data = ogawa.group(points._ref)[0] & ~(1 << 63)
    parent = archive.object(curves.full_name.rsplit("/", 1)[0])
    slot = [c.name for c in parent.children].index(curves.name) + 1
    return {
        "root position": (8, 4),
        "root count": (root, 5),
        "root child 0": (root + 8, 4),
        "top object (kind bit)": (root + 8 + 2 * 8, 7),
        "top object": (root + 8 + 2 * 8, 4),
        "curves object": (parent._ref + 8 + 8 * slot, 4),
        "curves object (kind bit)": (parent._ref + 8 + 8 * slot, 7),
        "P data reference": (points._ref + 8, 5),
        "P data (kind bit)": (points._ref + 8, 7),
        "P data size": (data, 4),
    }


@pytest.mark.parametrize("cut", [0, 10, 15, 16, 100, 0.5, -8, -1])
def test_the_decoder_refuses_a_truncated_file(long_file, tmp_path, cut):
    data = long_file.read_bytes()
    assert _decode_everything(long_file) > 0
    end = int(len(data) * cut) if isinstance(cut, float) else cut if cut >= 0 else len(data) + cut
    bad = tmp_path / "cut.abc"
    bad.write_bytes(data[:end])
    with pytest.raises(ValueError, match="malformed Ogawa file"):
        _decode_everything(bad)


FIELDS = [
    "root position",
    "root count",
    "root child 0",
    "top object (kind bit)",
    "top object",
    "curves object",
    "curves object (kind bit)",
    "P data reference",
    "P data (kind bit)",
    "P data size",
]


@pytest.mark.parametrize("field", FIELDS)
def test_the_decoder_refuses_a_corrupt_position(long_file, tmp_path, field):
    offset, byte = _field_offsets(long_file)[field]
    data = bytearray(long_file.read_bytes())
    data[offset + byte] ^= 0x80 if byte == 7 else 0xFF
    bad = tmp_path / "flipped.abc"
    bad.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="malformed Ogawa file"):
        _decode_everything(bad)


@pytest.mark.parametrize("offset, value", [(0, ord("X")), (5, 0), (7, 2)])
def test_the_decoder_refuses_a_bad_header(long_file, tmp_path, offset, value):
    data = bytearray(long_file.read_bytes())
    data[offset] = value  # the magic, the frozen byte, the version
    bad = tmp_path / "header.abc"
    bad.write_bytes(bytes(data))
    with pytest.raises(ValueError, match="malformed Ogawa file"):
        Archive(bad)


# ------------------------------------------------------------------ Unreal's schema
@pytest.mark.slow
def test_curves_are_icurves_guides_apart_and_named_as_unreal_reads_them(grown, reference):
    archive = Archive(grown)
    guides, hair = _curves(archive)
    assert len(hair) == 1 and hair[0].full_name.startswith("/Groom/")
    # no mesh: Unreal's groom translator refuses a file with any PolyMesh (CanTranslate)
    assert not [o for o in archive.walk() if o.schema == "AbcGeom_PolyMesh_v1"]
    for obj in (guides, *hair):
        params = obj.find(".geom/.arbGeomParams")
        assert isinstance(params, Compound) and params.children
        assert all(NAME.fullmatch(n) for n in params.children), list(params.children)
        # linear, non-periodic, no basis: the stored points are the strand's points
        assert _geom(obj, "curveBasisAndType").tolist() == [1, 0, 0, 0]
        assert ".geom/uv" not in obj.properties and ".geom/N" not in obj.properties
    assert set(guides.find(".geom/.arbGeomParams").children) == GUIDE_PARAMS
    assert set(hair[0].find(".geom/.arbGeomParams").children) == set(_SPEC)


def test_the_groom_schema_version_is_where_unreals_importer_reads_it(grown):
    """``groom_version_major`` 1 and ``_minor`` 5, int16 scalars among the user
    properties of the topmost Xform, where Unreal's translator reads groom-wide values
    (and its own exporter writes them); not among a curves object's arbGeomParams,
    which it takes for the strands' attributes."""
    archive = Archive(grown)
    (top,) = [o for o in archive.top.children if o.schema == "AbcGeom_Xform_v3"]
    for key, number in VERSION.items():
        prop = top.find(f".xform/.userProperties/{key}")
        assert isinstance(prop, Property) and prop.kind == "scalar"
        assert (prop.pod, prop.extent, prop.value().tolist()) == ("int16", 1, [number])
    guides, hair = _curves(archive)
    for obj in (guides, *hair):
        assert not set(VERSION) & set(obj.find(".geom/.arbGeomParams").children)


def test_points_widths_and_counts_are_centimetres_of_the_groom(grown, reference):
    guides, (hair,) = _curves(Archive(grown))
    ref = reference
    assert _geom(hair, "nVertices").tolist() == ref.hair.counts.tolist()
    np.testing.assert_allclose(
        _geom(hair, "P"), ref.hair.points.astype(np.float64) * CM, rtol=1e-6, atol=1e-5
    )
    width = hair.find(".geom/width")
    assert (width.pod, width.extent, width.metadata["geoScope"]) == ("float32", 1, "vtx")
    np.testing.assert_allclose(
        width.value(), ref.hair.point_data["width"] * np.float32(CM), rtol=1e-6
    )
    assert 0.001 < width.value().min() and width.value().max() < 0.1  # 10 µm - 1 mm, in cm
    assert _geom(guides, "nVertices").tolist() == ref.guides.counts.tolist()
    np.testing.assert_allclose(
        _geom(guides, "P"), ref.guides.points.astype(np.float64) * CM, rtol=1e-6, atol=1e-5
    )
    np.testing.assert_allclose(_geom(guides, "width"), DEFAULT_WIDTH * CM, rtol=1e-6)


def test_groom_id_root_uv_and_colour_are_the_hairs(grown, reference):
    guides, (hair,) = _curves(Archive(grown))
    ref = reference
    ids = _param(hair, "groom_id", *_SPEC["groom_id"])
    assert ids.tolist() == ref.hair.curve_data["hair_id"].tolist() and ids.min() >= 0
    guide_ids = _param(guides, "groom_id", *_SPEC["groom_id"])
    # what closest names, apart from every hair's id
    assert guide_ids.tolist() == list(range(GUIDE_ID_BASE, GUIDE_ID_BASE + ref.guides.curve_count))
    assert not set(guide_ids.tolist()) & set(ids.tolist())
    assert len(set(guide_ids.tolist())) == len(guide_ids) and guide_ids.min() >= 0
    for obj, curves in ((hair, ref.hair), (guides, ref.guides)):
        np.testing.assert_array_equal(
            _param(obj, "groom_root_uv", *_SPEC["groom_root_uv"]), curves.curve_data["root_uv"]
        )
    color = _param(hair, "groom_color", *_SPEC["groom_color"])
    np.testing.assert_array_equal(color, ref.hair.point_data["color"])
    assert (
        color.min() >= 0
        and hair.find(".geom/.arbGeomParams/groom_color").metadata["interpretation"] == "rgb"
    )


def test_groom_guide_flags_guides_1_and_hair_0(grown):
    guides, (hair,) = _curves(Archive(grown))
    flags = _param(guides, "groom_guide", *_SPEC["groom_guide"])
    assert len(flags) == len(_geom(guides, "nVertices")) and set(flags.tolist()) == {1}
    flags = _param(hair, "groom_guide", *_SPEC["groom_guide"])
    assert len(flags) == len(_geom(hair, "nVertices")) and set(flags.tolist()) == {0}


def test_closest_guides_name_guides_by_groom_id_and_weights_sum_to_1(grown, reference):
    guides, (hair,) = _curves(Archive(grown))
    closest = _param(hair, "groom_closest_guides", *_SPEC["groom_closest_guides"])
    weights = _param(hair, "groom_guide_weights", *_SPEC["groom_guide_weights"])
    np.testing.assert_array_equal(closest, GUIDE_ID_BASE + reference.closest)
    np.testing.assert_array_equal(weights, reference.weights)
    # Unreal looks each one up among the guides' groom_id (GroomIDToIndex)
    guide_ids = _param(guides, "groom_id", *_SPEC["groom_id"])
    assert np.isin(closest, guide_ids).all() and closest.min() >= 0
    assert weights.min() >= 0
    np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-5)


def test_every_chunk_is_an_icurves_of_the_schema(chunked, reference):
    guides, hair = _curves(Archive(chunked))
    assert len(hair) == 2
    assert [len(_geom(o, "nVertices")) for o in hair] == [70, reference.hair.curve_count - 70]
    assert _joined(hair, "groom_id").tolist() == reference.hair.curve_data["hair_id"].tolist()
    np.testing.assert_array_equal(
        _joined(hair, "groom_closest_guides"), GUIDE_ID_BASE + reference.closest
    )
    assert set(_joined(hair, "groom_guide").tolist()) == {0}
    np.testing.assert_allclose(
        np.concatenate([_geom(o, "P") for o in hair]),
        reference.hair.points.astype(np.float64) * CM,
        rtol=1e-6,
        atol=1e-5,
    )


def test_no_curve_has_more_than_255_points(long_file, long_curves):
    (hair,) = [o for o in Archive(long_file).walk() if o.schema == "AbcGeom_Curve_v2"]
    counts = _geom(hair, "nVertices")
    assert counts.tolist() == [255, 255, 10]
    points, width = _geom(hair, "P"), _geom(hair, "width")
    assert len(points) == len(width) == counts.sum()
    ends = np.concatenate([[0], np.cumsum(counts)])
    source = long_curves.points.astype(np.float64) * CM
    np.testing.assert_allclose(points[ends[1] :], source[300:], rtol=1e-6, atol=1e-5)  # kept
    # the 300-point curve resampled: same ends, same helix
    np.testing.assert_allclose(points[[0, 254]], source[[0, 299]], atol=1e-3)
    np.testing.assert_allclose(np.hypot(points[:255, 0], points[:255, 2]), 1.0, atol=1e-3)
    assert np.all(np.diff(width[:255]) <= 1e-9)  # still tapering, in cm
    np.testing.assert_allclose(width[[0, 254]], [1e-2, 5e-3], rtol=1e-4)

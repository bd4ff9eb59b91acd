"""Hair cards (follicle.cards): the atlas's packing, the strips against their hairs, the
.glb read back by trimesh and by the glTF 2.0 spec's own layout, the cards' silhouette
against the strand render of the same groom, bad input, and same bytes twice."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import follicle
from follicle.cards import CardParams, make_cards, write_cards
from follicle.cards.atlas import lod_bands, pack
from follicle.errors import ConfigError, InputError

HAIRS = 2000
COUNTS = (300, 90, 25)
ATLAS = 1024


@pytest.fixture(scope="module")
def groom() -> tuple:
    """2,000 hairs of the default scene (the bust, long guides) and its mesh."""
    from follicle.pipeline import grow
    from follicle.scene import parse_scene

    return grow(parse_scene({"groom": {"count": HAIRS}}, "test"))


@pytest.fixture(scope="module")
def made(groom: tuple):
    mesh, curves = groom
    return make_cards(curves, mesh, CardParams(counts=COUNTS, atlas=ATLAS))


def _apart(a: np.ndarray, b: np.ndarray, gap: int) -> bool:
    """Whether rectangles a and b (x, y, w, h) are at least ``gap`` texels apart."""
    return bool(
        a[0] + a[2] + gap <= b[0]
        or b[0] + b[2] + gap <= a[0]
        or a[1] + a[3] + gap <= b[1]
        or b[1] + b[3] + gap <= a[1]
    )


def _check_packing(rects: list[np.ndarray], bands: list, size: int, padding: int) -> None:
    every = np.concatenate(rects)
    for lod, (r, (y0, y1)) in enumerate(zip(rects, bands, strict=True)):
        assert np.all(r[:, 0] >= padding) and np.all(r[:, 0] + r[:, 2] <= size - padding), lod
        assert np.all(r[:, 1] >= y0 + padding) and np.all(r[:, 1] + r[:, 3] <= y1 - padding), lod
    for i in range(len(every)):  # pairwise, every rectangle against every later one
        for j in range(i + 1, len(every)):
            assert _apart(every[i], every[j], 2 * padding), (every[i], every[j])


def test_packing_has_no_overlaps_and_keeps_the_padding() -> None:
    rng = np.random.default_rng(3)
    size, padding = 512, 3
    bands = lod_bands(size, 3, 0.5)
    assert bands == [(0, 256), (256, 384), (384, 512)]
    rects = []
    for lod, k in enumerate((120, 40, 10)):
        width = rng.uniform(0.005, 0.03, k)
        length = rng.uniform(0.05, 0.3, k)
        r = pack(width, length, size, bands[lod], padding, lod)
        # one texel density for the level: sizes in proportion to the cards' (to rounding)
        density = r[:, 3] / length
        assert density.max() / density.min() < 1.2
        rects.append(r)
    _check_packing(rects, bands, size, padding)


def test_the_cards_atlas_is_packed_without_overlaps(made) -> None:
    bands = lod_bands(ATLAS, 3, made.params.reserve)
    _check_packing(made.rects, bands, ATLAS, made.params.padding)
    # each card's hairs were drawn inside its own rectangle: no coverage outside them
    inside = np.zeros((ATLAS, ATLAS), bool)
    for x, y, w, h in np.concatenate(made.rects):
        inside[y : y + h, x : x + w] = True
    cov = made.maps["coverage"]
    assert cov[~inside].max() == 0.0
    assert cov[inside].mean() > 0.2  # and they fill them
    # the colour is padded out from the hairs: a texel beside a covered one, covered or
    # not, has a hair's colour (no black halo for a filtered lookup to blend in)
    hair = cov > 0
    beside = np.zeros_like(hair)
    beside[1:-1, 1:-1] = hair[:-2, 1:-1] | hair[2:, 1:-1] | hair[1:-1, :-2] | hair[1:-1, 2:]
    color = made.maps["color"]
    assert color[beside & ~hair].min(axis=1).min() > 0.0
    assert np.all(color[beside & ~hair].max(axis=1) <= color[hair].max(axis=1).max())


def _nearest_on_polyline(points: np.ndarray, line: np.ndarray) -> tuple:
    """Each point's nearest point on the polyline ``line``, its segment and the
    fraction along it."""
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.einsum("psd,sd->ps", points[:, None] - a[None], ab) / np.sum(ab * ab, axis=1)
    t = np.clip(t, 0.0, 1.0)
    nearest = a[None] + t[..., None] * ab[None]
    seg = np.argmin(np.linalg.norm(points[:, None] - nearest, axis=2), axis=1)
    rows = np.arange(len(points))
    return nearest[rows, seg], seg, t[rows, seg]


def test_each_strip_lies_along_its_hairs(groom, made) -> None:
    """Every member's control points lie across its card within the strip's half width
    (measured on the written mesh: the offset from the nearest point of the strip's
    centre line along the strip's across direction there), up to a tolerance for the
    strip's straight segments cutting the hairs' bends; and the strip is no wider than
    its hairs spread: the farthest member reaches near its edge."""
    _, curves = groom
    labels = made.labels[0]
    m = made.meshes[0]
    per = 2 * (made.params.segments + 1)
    beyond = []
    for card in range(0, len(made.rects[0]), 3):
        pairs = m.positions[card * per : (card + 1) * per].reshape(-1, 2, 3).astype(np.float64)
        half = 0.5 * np.linalg.norm(pairs[0, 1] - pairs[0, 0])
        mid = pairs.mean(axis=1)
        across = pairs[:, 1] - pairs[:, 0]
        across /= np.linalg.norm(across, axis=1)[:, None]
        members = np.flatnonzero(labels == card)
        pts = np.concatenate([curves.curve(i) for i in members]).astype(np.float64)
        nearest, seg, t = _nearest_on_polyline(pts, mid)
        side = across[seg] * (1 - t)[:, None] + across[seg + 1] * t[:, None]
        offset = np.abs(np.sum((pts - nearest) * side, axis=1))
        beyond.append(np.quantile(offset, 0.95) / half)
        assert offset.max() > 0.6 * half, (card, offset.max(), half)
    beyond = np.array(beyond)
    assert np.median(beyond) < 1.0, np.round(beyond, 2)
    assert np.quantile(beyond, 0.9) < 1.2, np.round(beyond, 2)


def _glb(path: Path) -> tuple[dict, bytes]:
    """The JSON and BIN chunks of a .glb, read by the spec's layout (§4.4)."""
    data = path.read_bytes()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, length) == (b"glTF", 2, len(data))
    n, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON" and n % 4 == 0
    doc = json.loads(data[20 : 20 + n])
    m, kind = struct.unpack_from("<I4s", data, 20 + n)
    assert kind == b"BIN\0" and 28 + n + m == len(data)
    return doc, data[28 + n :]


def test_the_glb_reads_back(made, tmp_path: Path) -> None:
    import io

    import trimesh
    from PIL import Image

    path = write_cards(made, tmp_path / "cards.glb")
    doc, blob = _glb(path)
    assert len(doc["meshes"]) == 3
    material = doc["materials"][0]
    assert material["alphaMode"] == "MASK" and material["doubleSided"] is True
    names = [t["name"] for t in doc["textures"]]
    assert names == ["color", "depth", "attribute", "tangent"]
    for image in doc["images"]:
        view = doc["bufferViews"][image["bufferView"]]
        png = blob[view["byteOffset"] : view["byteOffset"] + view["byteLength"]]
        assert Image.open(io.BytesIO(png)).size == (ATLAS, ATLAS)
    # trimesh, a reader of its own: a mesh per level, 2 (segments + 1) vertices a card
    scene = trimesh.load(path)
    per_card = 2 * (made.params.segments + 1)
    for lod, count in enumerate(COUNTS):
        mesh = scene.geometry[f"cards_LOD{lod}"]
        assert len(mesh.vertices) == per_card * count
        assert len(mesh.faces) == 2 * made.params.segments * count
        assert mesh.visual.material.alphaMode == "MASK"
        texture = mesh.visual.material.baseColorTexture
        assert texture.size == (ATLAS, ATLAS) and texture.mode == "RGBA"
        assert np.all((mesh.visual.uv >= 0) & (mesh.visual.uv <= 1))


def _strand_alpha(curves, camera, size: int) -> np.ndarray:
    """The strand render's coverage: the CPU engine over black and over white, in linear
    light the difference is the transmittance."""
    from follicle.render.cpu import CpuRenderer
    from follicle.render.image import srgb_to_linear

    over = []
    for background in ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)):
        image = CpuRenderer((size, size), msaa=1, background=background).draw(curves, None, camera)
        over.append(srgb_to_linear(image[..., :3] / 255.0).mean(axis=2))
    return 1.0 - (over[1] - over[0])


def _mip_levels(coverage: np.ndarray) -> list[np.ndarray]:
    """The coverage and its 2 × 2 box-filtered halvings down to one texel."""
    levels = [coverage]
    while levels[-1].shape[0] > 1:
        half = levels[-1].shape[0] // 2
        levels.append(levels[-1].reshape(half, 2, half, 2).mean(axis=(1, 3)))
    return levels


def _card_mask(made, lod: int, camera, size: int) -> np.ndarray:
    """The cards seen through ``camera``: each triangle rasterized at the pixel centres,
    its UV interpolated perspective-correctly, kept where the atlas's coverage passes
    the material's alpha test; the coverage read (nearest texel) from the mip level
    whose texels are the size of the triangle's pixels, as a mip-mapped sampler does."""
    m = made.meshes[lod]
    xy, depth = camera.project(m.positions, (size, size))
    levels = _mip_levels(made.maps["coverage"])
    mask = np.zeros((size, size), bool)
    yy, xx = np.mgrid[0:size, 0:size] + 0.5
    for tri in m.indices:
        p, w, uv = xy[tri], 1.0 / depth[tri], m.uvs[tri]
        x0, y0 = np.maximum(np.floor(p.min(axis=0)).astype(int), 0)
        x1, y1 = np.minimum(np.ceil(p.max(axis=0)).astype(int), size)
        if x0 >= x1 or y0 >= y1:
            continue
        (ax, ay), (bx, by), (cx, cy) = p
        den = (by - cy) * (ax - cx) + (cx - bx) * (ay - cy)  # twice the pixel area
        if abs(den) < 1e-12:
            continue
        t = uv * levels[0].shape[0]
        texels = abs(
            (t[1, 0] - t[0, 0]) * (t[2, 1] - t[0, 1]) - (t[2, 0] - t[0, 0]) * (t[1, 1] - t[0, 1])
        )
        level = int(
            np.clip(np.floor(0.5 * np.log2(max(texels / abs(den), 1.0))), 0, len(levels) - 1)
        )
        cov = levels[level]
        n = cov.shape[0]
        px, py = xx[y0:y1, x0:x1], yy[y0:y1, x0:x1]
        l0 = ((by - cy) * (px - cx) + (cx - bx) * (py - cy)) / den
        l1 = ((cy - ay) * (px - cx) + (ax - cx) * (py - cy)) / den
        l2 = 1.0 - l0 - l1
        inside = (l0 >= 0) & (l1 >= 0) & (l2 >= 0)
        q = np.stack([l0 * w[0], l1 * w[1], l2 * w[2]], axis=-1)
        q /= q.sum(axis=-1, keepdims=True)
        tx = np.clip(((q @ uv[:, 0]) * n).astype(int), 0, n - 1)
        ty = np.clip(((q @ uv[:, 1]) * n).astype(int), 0, n - 1)
        mask[y0:y1, x0:x1] |= inside & (cov[ty, tx] >= made.params.alpha_cutoff)
    return mask


VIEWS = [
    ("front", (0, 0, 1), (0, 1, 0)),
    ("side", (1, 0, 0), (0, 1, 0)),
    ("top", (0, 1, 1e-3), (0, 0, -1)),
]


def _iou(curves, made, direction, up, size: int) -> float:
    """LOD 0's alpha-tested pixels against the strands' pixels of coverage ≥ ½."""
    from follicle.render.camera import fit_camera

    camera = fit_camera(curves.points[::5], direction=direction, up=up)
    strands = _strand_alpha(curves, camera, size) >= 0.5
    cards = _card_mask(made, 0, camera, size)
    assert strands.mean() > 0.2  # the hair fills a good part of the picture
    return float((strands & cards).sum() / (strands | cards).sum())


@pytest.fixture(scope="module")
def default_cards() -> tuple:
    """The default 20,000-hair groom and its cards, every setting the default."""
    from follicle.pipeline import grow
    from follicle.scene import parse_scene

    mesh, curves = grow(parse_scene({"groom": {"count": 20000}}, "test"))
    return curves, make_cards(curves, mesh)


@pytest.mark.slow  # 20,000 hairs into 2,750 cards, 72,000 triangles rasterized in Python
@pytest.mark.parametrize("view, direction, up", VIEWS)
def test_default_cards_silhouette_matches_the_strands(default_cards, view, direction, up):
    """The default groom's LOD 0 through a mip-mapped sampler (as an engine samples it)
    from three views against the strand render; Blender's render of the same cards is
    held to the issue's 0.9 in test_blender_cards."""
    curves, made = default_cards
    iou = _iou(curves, made, direction, up, 240)
    # measured 0.912 front, 0.916 side, 0.918 top
    assert iou >= 0.88, f"{view}: IoU {iou:.3f}"


@pytest.mark.parametrize("view, direction, up", VIEWS)
def test_sparse_cards_silhouette_matches_the_strands(groom, view, direction, up) -> None:
    """A sparse groom — 2,000 hairs drawn four times as wide, a handful of hairs a card —
    through a mip-mapped sampler: a card's texels there average to less than the default
    cutoff of ½ and would vanish at a distance, so such a groom takes a lower
    ``alpha_cutoff`` (docs: Hair cards); at 0.2 the silhouettes match."""
    mesh, curves = groom
    thick = follicle.HairCurves(
        curves.points,
        curves.offsets,
        point_data={**curves.point_data, "width": curves.point_data["width"] * 4},
        curve_data=curves.curve_data,
    )
    params = CardParams(counts=(300,), lods=1, atlas=2048, alpha_cutoff=0.2, strand_texels=1.0)
    iou = _iou(thick, make_cards(thick, mesh, params), direction, up, 160)
    # measured 0.86 front, 0.88 side, 0.82 top (0.55, 0.59, 0.67 at the default cutoff)
    assert iou >= 0.8, f"{view}: IoU {iou:.3f}"


def test_bad_input_names_the_option(groom) -> None:
    mesh, curves = groom
    with pytest.raises(ConfigError, match=r"counts"):
        CardParams(counts=(0, 10, 5))
    with pytest.raises(ConfigError, match=r"--counts.*--lods"):
        CardParams(counts=(100, 10))
    with pytest.raises(InputError, match=r"counts: 3,000 cards for 2,000 hairs"):
        make_cards(curves, mesh, CardParams(counts=(3000,), lods=1))
    with pytest.raises(InputError, match=r"--atlas\) 64: .*--atlas 128.*--counts"):
        make_cards(curves, mesh, CardParams(counts=(1500,), lods=1, atlas=64))
    with pytest.raises(InputError, match=r"\.glb.*\.usda"):
        write_cards(make_cards(curves[:50], mesh, CardParams(counts=(5,), lods=1)), "x.gltf")
    with pytest.raises(InputError, match="two or more points"):
        make_cards(curves[:0], mesh)


def test_same_bytes_twice(groom, tmp_path: Path) -> None:
    mesh, curves = groom
    params = CardParams(counts=(60, 20), lods=2, atlas=256)
    a = follicle.cards(curves[:600], mesh, out=tmp_path / "a.glb", params=params)
    follicle.cards(curves[:600], mesh, out=tmp_path / "b.glb", params=params)
    assert (tmp_path / "a.glb").read_bytes() == (tmp_path / "b.glb").read_bytes()
    assert [len(r) for r in a.rects] == [60, 20]
    assert not list(tmp_path.glob(".*"))  # no temporary file left beside them


def test_cli_writes_cards_and_refuses_a_small_atlas(tmp_path: Path) -> None:
    from follicle.cli import main

    scene = tmp_path / "scene.toml"
    scene.write_text('[groom]\ncount = 400\n[guides]\npath = "builtin:long"\n')
    out = tmp_path / "hair_cards.glb"
    args = ["cards", str(scene), "-o", str(out), "--counts", "40,12,4", "--atlas", "256"]
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 0, result.output
    assert "400 hairs → 40 / 12 / 4 cards" in result.output
    doc, _ = _glb(out)
    assert [m["name"] for m in doc["meshes"]] == ["cards_LOD0", "cards_LOD1", "cards_LOD2"]
    bad = CliRunner().invoke(main, [*args[:4], "--counts", "390,12,4", "--atlas", "64"])
    assert bad.exit_code == 2
    lines = bad.output.strip().splitlines()
    assert len(lines) == 1 and "--atlas" in lines[0], bad.output
    assert isinstance(bad.exception, SystemExit)
    # a wrong output name is refused before any hair is grown: here the scene's mesh is
    # missing too, and the error is the output's
    nomesh = tmp_path / "nomesh.toml"
    nomesh.write_text('[mesh]\npath = "missing.obj"\n')
    wrong = CliRunner().invoke(main, ["cards", str(nomesh), "-o", str(tmp_path / "c.obj")])
    assert wrong.exit_code == 2 and "c.obj: cards are written as glTF" in wrong.output, wrong.output
    assert not list(tmp_path.glob("c*"))


def test_follicle_cards_is_the_package_and_calling_it_makes_cards(groom) -> None:
    import follicle.cards

    mesh, curves = groom
    made = follicle.cards(curves[:300], mesh, counts=(30,), lods=1, atlas=128)
    assert isinstance(made, follicle.cards.HairCards) and len(made.rects[0]) == 30


def test_default_counts_fit_small_grooms() -> None:
    from follicle.cards.settings import default_counts

    assert default_counts(3, 20_000) == (2000, 600, 150)
    assert default_counts(3, 300) == (75, 37, 18)
    assert default_counts(5, 100_000) == (2000, 600, 150, 37, 9)
    assert default_counts(2, 3) == (1, 1)


def test_the_usd_reads_back(made, tmp_path: Path) -> None:
    """usd-core reads the stage: a mesh per level with the written triangles and UVs
    (v flipped: USD's st counts up from the bottom), a material alpha-masked by the
    colour PNG beside the stage, the same picture as the .glb's colour."""
    from PIL import Image
    from pxr import Usd, UsdGeom, UsdShade

    path = write_cards(made, tmp_path / "cards.usda")
    stage = Usd.Stage.Open(str(path))
    assert UsdGeom.GetStageUpAxis(stage) == "Y"
    for lod, mesh in enumerate(made.meshes):
        prim = UsdGeom.Mesh(stage.GetPrimAtPath(f"/Cards/LOD{lod}"))
        points = np.array(prim.GetPointsAttr().Get())
        assert np.array_equal(points, mesh.positions)
        assert list(prim.GetFaceVertexIndicesAttr().Get()) == mesh.indices.reshape(-1).tolist()
        st = np.array(UsdGeom.PrimvarsAPI(prim).GetPrimvar("st").Get())
        assert np.allclose(st[:, 1], 1.0 - mesh.uvs[:, 1])
        bound = UsdShade.MaterialBindingAPI(prim.GetPrim()).ComputeBoundMaterial()[0]
        assert bound.GetPath() == "/Cards/Looks/hair_cards"
    surface = UsdShade.Shader(stage.GetPrimAtPath("/Cards/Looks/hair_cards/surface"))
    assert surface.GetInput("opacityThreshold").Get() == pytest.approx(made.params.alpha_cutoff)
    file = UsdShade.Shader(stage.GetPrimAtPath("/Cards/Looks/hair_cards/color")).GetInput("file")
    png = tmp_path / file.Get().path
    assert png.name == "cards_color.png"
    assert Image.open(png).size == (ATLAS, ATLAS) and Image.open(png).mode == "RGBA"
    for name in ("depth", "attribute", "tangent"):
        assert (tmp_path / f"cards_{name}.png").is_file()


def test_clusters_keep_clumps_whole_and_follow_the_seed(groom) -> None:
    """With ``clump_id`` on the curves, every clump's hairs share one card; without, the
    clusters come from the hairs' shape, the same for a seed and not for another."""
    from follicle.cards.clusters import cluster_hairs

    _, curves = groom
    roots = curves.points[curves.offsets[:-1]]
    clumps = np.floor(roots[:, 0] / 0.01).astype(np.int64) * 1000 + np.floor(roots[:, 2] / 0.01)
    tagged = follicle.HairCurves(
        curves.points,
        curves.offsets,
        point_data=curves.point_data,
        curve_data={**curves.curve_data, "clump_id": clumps.astype(np.int64)},
    )
    n_clumps = len(np.unique(clumps))
    assert n_clumps > 100
    labels = cluster_hairs(tagged, 100, seed=1)
    assert len(np.unique(labels)) == 100
    for clump in np.unique(clumps):
        assert len(np.unique(labels[clumps == clump])) == 1
    plain = cluster_hairs(curves, 100, seed=1)
    assert np.array_equal(plain, cluster_hairs(curves, 100, seed=1))
    assert not np.array_equal(plain, cluster_hairs(curves, 100, seed=2))
    # each hair's card is the one whose hairs it runs beside: its nearest card centre
    # by root is its own for most hairs
    centres = np.stack([roots[plain == k].mean(axis=0) for k in range(100)])
    nearest = np.argmin(np.linalg.norm(roots[:, None] - centres[None], axis=2), axis=1)
    assert np.mean(nearest == plain) > 0.6


def test_unreal_layout_is_what_its_card_shaders_read(groom, made, tmp_path: Path) -> None:
    """``target = "unreal"``: beside the .glb, a PNG per groom cards texture slot in the
    channels Unreal's card shaders sample (HairCardsAttributeCommon.ush): Coverage R,
    the colour's alpha; Attribute RG the roots' UV on the skin (checked against the
    card's hairs' own root UVs), B the coordinate along the hair (against the texel's
    row in its card), A a seed; Tangent RGB along the card's V; Depth R centimetres
    behind the card."""
    from PIL import Image

    mesh, curves = groom
    made = make_cards(curves, mesh, made.params.replace("cards", target="unreal"))
    path = write_cards(made, tmp_path / "hair_cards.glb")
    doc, _ = _glb(path)
    slots = {n: np.asarray(Image.open(tmp_path / f"hair_cards_{n}.png")) for n in
             ("color", "coverage", "attribute", "tangent", "depth")}  # fmt: skip
    assert sorted(i["name"] for i in doc["images"]) == sorted(slots)
    cov = slots["coverage"]
    assert cov.shape == (ATLAS, ATLAS) and np.array_equal(cov, slots["color"][..., 3])
    attr = slots["attribute"].astype(np.float64) / 255.0
    assert attr.shape == (ATLAS, ATLAS, 4)
    hair = cov >= 128
    tan = slots["tangent"].astype(np.float64) / 127.5 - 1.0
    assert np.mean(tan[hair, 1]) > 0.8  # hairs run down the card, root to tip
    depth = slots["depth"]
    assert np.mean(depth[cov == 0] == 0) > 0.99 and np.any(depth[hair] > 0)
    root_uv = curves.curve_data["root_uv"]
    rows = np.arange(ATLAS)[:, None] * np.ones((1, ATLAS))
    far = []
    for k, (x, y, w, h) in enumerate(made.rects[0]):
        inside = hair[y : y + h, x : x + w]
        if inside.sum() < 4:
            continue
        along = (rows[y : y + h, x : x + w] + 0.5 - y) / h
        assert np.abs(attr[y : y + h, x : x + w, 2][inside] - along[inside]).max() < 0.1
        mine = root_uv[made.labels[0] == k]
        got = attr[y : y + h, x : x + w, :2][inside].mean(axis=0)
        far.append(np.abs(got - mine.mean(axis=0)).max())
    assert np.median(far) < 0.01 and np.quantile(far, 0.95) < 0.05


def test_the_scene_cards_section_and_the_options_over_it(tmp_path: Path) -> None:
    """[cards] in the scene sets what `follicle cards` makes; an option overrides its
    key; an unknown key names the section and what was meant."""
    from follicle.cli import main

    scene = tmp_path / "scene.toml"
    scene.write_text(
        "[groom]\ncount = 400\n[cards]\ncounts = [40, 12]\nlods = 2\natlas = 256\n"
        'target = "unreal"\n'
    )
    out = tmp_path / "hair_cards.glb"
    result = CliRunner().invoke(main, ["cards", str(scene), "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert "400 hairs → 40 / 12 cards, 256² atlas" in result.output
    assert (tmp_path / "hair_cards_attribute.png").is_file()
    result = CliRunner().invoke(main, ["cards", str(scene), "-o", str(out), "--atlas", "512"])
    assert "512² atlas" in result.output, result.output
    scene.write_text("[cards]\natlass = 256\n")
    bad = CliRunner().invoke(main, ["cards", str(scene), "-o", str(out)])
    assert bad.exit_code == 2 and "[cards]" in bad.output and "atlas" in bad.output, bad.output

"""Starter guides on any mesh (issue 46): [guides] generate, the guides a scene with its
own mesh and no [guides] gets, and `follicle guides`.

The oracles are independent of follicle's own geometry: inside/outside by the exact
winding number of the closed trimesh (Jacobson et al. 2013), coverage and root normals
from the trimesh's own faces through a k-d tree, lengths from the polylines' segments.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from PIL import Image
from scipy.spatial import cKDTree

import follicle
from follicle.errors import ConfigError, FollicleError
from follicle.pipeline import grow, scene_guides
from follicle.scene import GuidesParams, Scene, load_scene, scene_from_toml, scene_to_toml
from hostile import run_cli, screen


def winding_inside(points: np.ndarray, mesh: trimesh.Trimesh) -> np.ndarray:
    """Points strictly inside the closed ``mesh``: generalized winding number > 1/2 (the
    solid angle of each triangle, Van Oosterom & Strackee 1983)."""
    tri = mesh.vertices[mesh.faces]
    out = np.empty(len(points), dtype=bool)
    for s in range(0, len(points), 256):
        p = points[s : s + 256, None, None, :]
        a, b, c = (tri[None, :, k] - p[:, :, 0] for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
        det = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
        dot = lambda u, v: np.einsum("ptk,ptk->pt", u, v)  # noqa: E731
        div = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb
        w = np.arctan2(det, div).sum(axis=1) / (2 * np.pi)
        out[s : s + 256] = w > 0.5
    return out


def creature(spacing=(0.02, 0.03, 0.025)) -> trimesh.Trimesh:
    """A creature as a modelling tool might give one: a blob body, a head and four legs
    (smooth union of an ellipsoid, a sphere and capsules), meshed by marching cubes on
    an anisotropic grid, so its triangles are of unequal sizes. Metres, +Y up."""
    from skimage.measure import marching_cubes

    lo, hi = np.array([-0.45, -0.35, -0.25]), np.array([0.5, 0.3, 0.25])
    axes = [np.arange(lo[k], hi[k], spacing[k]) for k in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    body = np.sqrt((x / 0.3) ** 2 + (y / 0.14) ** 2 + (z / 0.15) ** 2) - 1.0
    body *= 0.14
    head = np.sqrt((x - 0.33) ** 2 + (y - 0.1) ** 2 + z**2) - 0.1

    def leg(px, pz):  # a capsule from (px, 0, pz) down to (px, -0.28, pz), radius 0.045
        yy = np.clip(y, -0.28, 0.0)
        return np.sqrt((x - px) ** 2 + (y - yy) ** 2 + (z - pz) ** 2) - 0.045

    d = body
    for part in (head, leg(-0.18, -0.08), leg(-0.18, 0.08), leg(0.18, -0.08), leg(0.18, 0.08)):
        h = np.clip(0.5 + 0.5 * (part - d) / 0.04, 0, 1)  # smooth minimum, k = 4 cm
        d = part * (1 - h) + d * h - 0.04 * h * (1 - h)
    verts, faces, _, _ = marching_cubes(d, 0.0, spacing=spacing)
    mesh = trimesh.Trimesh(verts + lo, faces)
    if mesh.volume < 0:
        mesh.invert()
    # the legs modelled finer than the body, as an artist adds loops where things bend
    return mesh.subdivide(np.flatnonzero(mesh.triangles_center[:, 1] < -0.12))


def _mesh_file(folder, name, mesh: trimesh.Trimesh) -> str:
    mesh.export(folder / name)
    return name


def _root_normals(mesh: trimesh.Trimesh, roots: np.ndarray) -> np.ndarray:
    """The normal of the trimesh face nearest each root (by face centre)."""
    _, face = cKDTree(mesh.triangles_center).query(roots)
    return mesh.face_normals[face]


def _coverage(mesh: trimesh.Trimesh, roots: np.ndarray, reach: float) -> float:
    """The share of the mesh's area whose faces have a root within ``reach``."""
    dist, _ = cKDTree(roots).query(mesh.triangles_center)
    return float(mesh.area_faces[dist < reach].sum() / mesh.area)


def _off_root(curves) -> np.ndarray:
    """Every vertex but the roots (which lie on the skin, winding number ½), float64."""
    keep = np.ones(curves.point_count, dtype=bool)
    keep[curves.offsets[:-1]] = False
    return curves.points[keep].astype(np.float64)


def _polyline_lengths(curves) -> np.ndarray:
    seg = np.linalg.norm(np.diff(curves.points.astype(np.float64), axis=0), axis=1)
    within = np.ones(len(seg), dtype=bool)
    within[curves.offsets[1:-1] - 1] = False  # the step from one curve to the next
    starts = curves.offsets[:-1] - np.arange(curves.curve_count)
    return np.add.reduceat(seg[within], starts)


def _check_fur(
    mesh: trimesh.Trimesh, scene: Scene, hairs: int, length: float, leak: float = 0.0
) -> None:
    """Grown hair covers the mesh, leaves it along its normals, stays out of it, and has
    about ``length``. The guides never enter the mesh; the hairs interpolated between
    them are kept off it by the groom's skin collision on a grid SDF ([groom].
    skin_collision), which in a crease (a leg meeting the body) may leave a vertex a
    few mm inside: at most the share ``leak`` of them."""
    skin = follicle.load_mesh(scene.resolve(scene.mesh.path), units=scene.mesh.units)
    guides = scene_guides(scene, skin)
    assert not winding_inside(_off_root(guides.curves), mesh).any()
    _, curves = grow(scene)
    assert curves.curve_count == hairs
    roots = curves.points[curves.offsets[:-1]].astype(np.float64)
    spacing = np.sqrt(mesh.area / hairs)
    assert _coverage(mesh, roots, 3 * spacing) > 0.97
    first = curves.points[curves.offsets[:-1] + 1].astype(np.float64) - roots
    first /= np.linalg.norm(first, axis=1, keepdims=True)
    assert np.mean(np.sum(first * _root_normals(mesh, roots), axis=1)) > 0.8
    assert winding_inside(_off_root(curves), mesh).mean() <= leak
    assert np.median(_polyline_lengths(curves)) == pytest.approx(length, rel=0.05)
    assert _polyline_lengths(guides.curves) == pytest.approx(length, rel=1e-4)


def test_fur_on_a_torus_with_no_guides_given(tmp_path):
    torus = trimesh.creation.torus(1.0, 0.3)
    _mesh_file(tmp_path, "torus.obj", torus)
    (tmp_path / "s.toml").write_text('[mesh]\npath = "torus.obj"\n[groom]\ncount = 2000\n')
    scene = load_scene(tmp_path / "s.toml")
    assert scene.guides.generate == "normal" and scene.guides.is_implied
    diagonal = np.linalg.norm(torus.bounds[1] - torus.bounds[0])
    _check_fur(torus, scene, 2000, 0.08 * diagonal)


def test_fur_on_a_creature_with_no_guides_given(tmp_path):
    body = creature()
    areas = body.area_faces
    assert areas.max() > 3 * np.median(areas)  # unequal triangles, as modelled meshes have
    _mesh_file(tmp_path, "creature.obj", body)
    (tmp_path / "s.toml").write_text('[mesh]\npath = "creature.obj"\n[groom]\ncount = 1500\n')
    diagonal = np.linalg.norm(body.bounds[1] - body.bounds[0])
    _check_fur(body, load_scene(tmp_path / "s.toml"), 1500, 0.08 * diagonal, leak=5e-4)


@pytest.mark.slow  # Blender (bpy) in its own venv, in a subprocess
def test_fur_on_a_creature_modelled_in_blender(tmp_path):
    """A creature made in Blender itself (metaballs converted to a mesh, exported as OBJ
    with the default settings: blender_scripts/make_creature.py) grows fur with no
    guides given, as the one made here does."""
    from blender_env import blender_python, run_blender

    found = run_blender(blender_python(), "make_creature.py", tmp_path, tmp_path / "found.json")
    made = trimesh.load(tmp_path / found["file"], force="mesh")
    assert made.is_watertight and made.body_count == 1  # one closed body: inside is defined
    (tmp_path / "s.toml").write_text(f'[mesh]\npath = "{found["file"]}"\n[groom]\ncount = 2000\n')
    scene = load_scene(tmp_path / "s.toml")
    assert scene.guides.generate == "normal" and scene.guides.is_implied
    diagonal = np.linalg.norm(made.bounds[1] - made.bounds[0])
    _check_fur(made, scene, 2000, 0.08 * diagonal, leak=5e-4)


def test_fur_on_a_mesh_in_centimetres(tmp_path):
    """A body modelled in cm: the scene's units make it metres, and so are the fur's
    length and the checks."""
    body = trimesh.creation.capsule(height=16.0, radius=4.0, count=[24, 24])  # cm
    _mesh_file(tmp_path, "body.obj", body)
    (tmp_path / "s.toml").write_text(
        '[mesh]\npath = "body.obj"\nunits = "cm"\n[guides]\ngenerate = "normal"\n'
        "length = 0.015\n[groom]\ncount = 2000\n"
    )
    metres = body.copy()
    metres.apply_scale(0.01)
    _check_fur(metres, load_scene(tmp_path / "s.toml"), 2000, 0.015)


def _torus_skin(tmp_path):
    torus = trimesh.creation.torus(1.0, 0.3)
    _mesh_file(tmp_path, "torus.obj", torus)
    return torus, follicle.load_mesh(tmp_path / "torus.obj")


def test_comb_lies_along_the_comb_direction_and_gravity_bends_down(tmp_path):
    torus, skin = _torus_skin(tmp_path)
    comb = np.array([1.0, 0.0, 0.0])
    lifted = follicle.generate_guides(skin, "comb", comb=comb, lift=20.0, length=0.2)
    shapes = lifted.rest_shapes(12).astype(np.float64)
    roots = lifted.root_positions
    n = _root_normals(torus, roots)
    first = shapes[:, 1] / np.linalg.norm(shapes[:, 1], axis=1, keepdims=True)
    along = first - np.sum(first * n, axis=1, keepdims=True) * n
    want = comb - (n @ comb)[:, None] * n
    some = np.linalg.norm(want, axis=1) > 0.3  # the comb has a part in the tangent plane
    cos = (
        np.sum(along * want, axis=1) / np.linalg.norm(along, axis=1) / np.linalg.norm(want, axis=1)
    )
    assert some.sum() > 100 and np.mean(cos[some]) > 0.9
    # lifted 20° off the skin: the first segment's normal part is sin 20°
    assert np.median(np.sum(first * n, axis=1)) == pytest.approx(np.sin(np.radians(20)), abs=0.05)
    hanging = follicle.generate_guides(skin, "normal", gravity=1.0, length=0.2)
    tips = hanging.rest_shapes(12).astype(np.float64)
    last = tips[:, -1] - tips[:, -2]
    last /= np.linalg.norm(last, axis=1, keepdims=True)
    # every tip hangs down but those held by the skin beneath (under the torus)
    assert np.median(last[:, 1]) < -0.95
    straight = follicle.generate_guides(skin, "normal", gravity=0.0, length=0.2)
    assert hanging.curves.points[:, 1].mean() < straight.curves.points[:, 1].mean() - 0.05
    for guides in (lifted, hanging):
        assert not winding_inside(_off_root(guides.curves), torus).any()
        assert _polyline_lengths(guides.curves) == pytest.approx(0.2, rel=1e-4)


def test_same_inputs_and_seed_give_the_same_bytes_and_another_seed_other_roots(tmp_path):
    _, skin = _torus_skin(tmp_path)
    a = follicle.generate_guides(skin, "comb", gravity=0.5, seed=3)
    b = follicle.generate_guides(skin, "comb", gravity=0.5, seed=3)
    c = follicle.generate_guides(skin, "comb", gravity=0.5, seed=4)
    assert a.curves.points.tobytes() == b.curves.points.tobytes()
    assert not np.allclose(a.root_positions, c.root_positions)


def test_a_length_texture_masks_and_scales_the_guides(tmp_path):
    """value × texture (Šik 2012 §2.2.2): a black half grows no guide, a grey quarter
    128/255 of the length. On the built-in bust, which has UVs."""
    img = np.zeros((8, 64), dtype=np.uint8)
    img[:, 32:] = 255
    img[:, 48:] = 128
    Image.fromarray(img).save(tmp_path / "len.png")
    (tmp_path / "s.toml").write_text(
        '[guides]\ngenerate = "normal"\ncount = 800\n'
        'length = {value = 0.1, texture = "len.png", wrap = "clamp"}\n'
    )
    scene = load_scene(tmp_path / "s.toml")
    guides = scene_guides(scene, follicle.load_mesh("builtin:bust"))
    u = guides.curves.curve_data["root_uv"][:, 0]
    lengths = _polyline_lengths(guides.curves)
    assert 0 < guides.count < 800 and u.min() > 0.5 - 1 / 64
    white = (u > 0.5 + 1 / 64) & (u < 0.75 - 1 / 64)
    grey = u > 0.75 + 1 / 64
    assert white.sum() > 20 and grey.sum() > 10
    assert lengths[white] == pytest.approx(0.1, rel=1e-4)
    assert lengths[grey] == pytest.approx(0.1 * 128 / 255, rel=1e-4)


@pytest.mark.parametrize(
    "guides, names",
    [
        ('path = "builtin:long"\ngenerate = "normal"', ["generate", "path", "remove"]),
        ('generate = "comb"\nunits = "cm"', ["generate", "units"]),
        ('generate = "normal"\nlength = -0.1', ["[guides].length", "> 0"]),
        ('generate = "normal"\nlength = 0.0', ["[guides].length", "> 0"]),
        ('generate = "normal"\ncount = 0', ["[guides].count", "1"]),
        ('generate = "normal"\nvertices = 1', ["[guides].vertices"]),
        ('generate = "normal"\ngravity = 2.0', ["[guides].gravity"]),
        ('generate = "comb"\nlift = 120.0', ["[guides].lift"]),
        ('generate = "sideways"', ["[guides].generate", "normal", "comb"]),
    ],
)
def test_bad_guide_settings_name_the_key(guides, names):
    with pytest.raises(ConfigError) as err:
        scene_from_toml(f"[guides]\n{guides}\n", "s.toml")
    message = str(err.value)
    assert "\n" not in message
    for name in names:
        assert name in message


def test_a_missing_length_texture_or_one_on_a_mesh_without_uvs_names_the_key(tmp_path):
    _torus_skin(tmp_path)
    (tmp_path / "a.toml").write_text(
        '[guides]\ngenerate = "normal"\nlength = {value = 0.1, texture = "nope.png"}\n'
    )
    with pytest.raises(FollicleError, match=r"\[guides\]\.length.*nope\.png"):
        scene_guides(load_scene(tmp_path / "a.toml"), follicle.load_mesh("builtin:bust"))
    Image.fromarray(np.full((4, 4), 255, np.uint8)).save(tmp_path / "white.png")
    (tmp_path / "b.toml").write_text(
        '[mesh]\npath = "torus.obj"\n[guides]\ngenerate = "normal"\nlength = "white.png"\n'
    )
    scene = load_scene(tmp_path / "b.toml")
    with pytest.raises(FollicleError, match=r"\[guides\]\.length.*no(ne)? UVs|has none"):
        scene_guides(scene, follicle.load_mesh(tmp_path / "torus.obj"))


def test_the_built_in_meshes_keep_the_built_in_guides_and_toml_round_trips(tmp_path):
    assert Scene().guides == GuidesParams() and Scene().guides.generate is None
    own = scene_from_toml('[mesh]\npath = "torus.obj"\n[guides]\npath = "builtin:short"\n', "s")
    assert own.guides.path == "builtin:short" and own.guides.generate is None
    bust = scene_from_toml('[mesh]\npath = "builtin:head"\n', "s")
    assert bust.guides.path == "builtin:long" and bust.guides.generate is None
    implied = scene_from_toml('[mesh]\npath = "torus.obj"\n', "s")
    text = scene_to_toml(implied)
    assert 'generate = "normal"' in text and '# path = "builtin:long"' in text
    back = scene_from_toml(text, "s")  # as a Dask worker reads it: the same guides
    assert back.guides.model_dump() == implied.guides.model_dump()
    assert not back.guides.is_implied
    plain = scene_to_toml(Scene())
    assert '\npath = "builtin:long"' in plain and "# count = 300" in plain
    assert scene_from_toml(plain, "s").guides == Scene().guides


def test_the_implied_guides_are_said_in_one_line_and_follicle_guides_round_trips(tmp_path):
    _torus_skin(tmp_path)
    (tmp_path / "s.toml").write_text('[mesh]\npath = "torus.obj"\n')
    for name in ("g.npz", "g.usda"):
        out = run_cli("guides", "s.toml", "-o", name, cwd=tmp_path, timeout=300)
        assert out.rc == 0, out.stderr
        lines = [line for line in out.stderr.splitlines() if line.strip()]
        note = [line for line in lines if "[guides]" in line]
        assert note == [
            "follicle: [mesh] has no [guides]: 300 guides generated along the normals,"
            " 29.8 cm long; set [guides] to choose"
        ], out.stderr
        assert out.stdout.strip() == f"300 guides × 12 vertices → {name}"
        (tmp_path / "back.toml").write_text(
            f'[mesh]\npath = "torus.obj"\n[guides]\npath = "{name}"\n'
        )
        scene = load_scene(tmp_path / "s.toml")
        skin = follicle.load_mesh(tmp_path / "torus.obj")
        made = scene_guides(scene, skin)
        read = scene_guides(load_scene(tmp_path / "back.toml"), skin)
        assert read.count == made.count
        np.testing.assert_allclose(read.root_positions, made.root_positions, atol=1e-6)
        np.testing.assert_allclose(read.rest_shapes(12), made.rest_shapes(12), atol=1e-6)
    # an explicit [guides] says nothing
    (tmp_path / "e.toml").write_text('[mesh]\npath = "torus.obj"\n[guides]\ngenerate = "comb"\n')
    out = run_cli("guides", "e.toml", "-o", "e.npz", cwd=tmp_path, timeout=300)
    assert out.rc == 0 and "[guides]" not in out.stderr, out.stderr


def test_follicle_guides_under_a_terminal_and_its_refusals(tmp_path):
    _torus_skin(tmp_path)
    (tmp_path / "s.toml").write_text('[mesh]\npath = "torus.obj"\n[guides]\ngenerate = "comb"\n')
    out = run_cli("guides", "s.toml", "-o", "g.usda", cwd=tmp_path, tty=True, timeout=300)
    assert out.rc == 0, out.stdout
    shown = [line.strip() for line in screen(out.stdout) if line.strip()]
    assert shown[-1] == "300 guides × 12 vertices → g.usda", out.stdout
    (tmp_path / "bad.toml").write_text('[guides]\ngenerate = "normal"\npath = "g.usda"\n')
    for args, names in (
        (["guides", "bad.toml", "-o", "x.npz"], ["generate", "path"]),
        (["guides", "s.toml", "-o", "x.png"], [".png"]),
        (["guides", "s.toml", "-o", "torus.obj"], ["torus.obj", "[mesh].path"]),
    ):
        bad = run_cli(*args, cwd=tmp_path, timeout=300)
        assert bad.rc == 2 and "Traceback" not in bad.stderr, bad.stderr
        line = bad.stderr.strip()
        assert "\n" not in line and all(name in line for name in names), line
    assert not (tmp_path / "x.npz").exists() and not (tmp_path / "x.png").exists()


def test_a_scene_given_its_own_mesh_in_python_gets_generated_guides_too():
    """Scene.replace(mesh=…) as a Python user builds a scene: guides the scene did not
    choose follow the mesh as a scene file's do; guides the user chose stay."""
    from follicle.scene import MeshParams, parse_scene

    bust = parse_scene({}, "test")
    own = bust.replace(mesh=MeshParams(path="torus.obj"))
    assert own.guides.generate == "normal" and own.guides.is_implied
    back = own.replace(mesh=MeshParams())
    assert back.guides.generate is None and back.guides.path == "builtin:long"
    chosen = parse_scene({"guides": {"path": "builtin:short"}}, "test")
    kept = chosen.replace(mesh=MeshParams(path="torus.obj"))
    assert kept.guides.path == "builtin:short" and kept.guides.generate is None
    comb = parse_scene({"guides": {"generate": "comb"}}, "test")
    assert not comb.replace(mesh=MeshParams(path="torus.obj")).guides.is_implied

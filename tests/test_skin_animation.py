"""Skin animation from files (issue: production dynamics, deliverable 4): a USD or
Alembic mesh with time-sampled points drives `follicle simulate`; the roots follow the
deforming skin through their binding, the cache carries the skin, and exports write it
sampled per frame where usd-core and alembic3d read it. Bad animation files are one
clean refusal naming the file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

import follicle
from abcfiles import add_animated_mesh, write
from follicle.errors import FollicleError, FormatError, InputError
from follicle.io.sim_cache import load_cache
from follicle.io.skin_animation import load_skin_animation
from follicle.pipeline import groom_scene, simulate_scene
from follicle.scene import Scene, load_scene
from hostile import assert_cli_refused, byte_damage, run_cli, warm

FPS = 24
SAMPLES = 13  # 0 … 0.5 s


def _deform(rest: np.ndarray, t: float) -> np.ndarray:
    """The rest vertices at ``t`` s of a non-rigid animation: a yaw swing about the neck
    and a vertical squash (5 %), as a baked character's head moves."""
    low = rest.min(axis=0)
    a = 0.35 * np.sin(2 * np.pi * t)
    c, s = np.cos(a), np.sin(a)
    turn = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    p = (rest - [0, low[1], 0]) @ turn.T + [0, low[1], 0]
    p[:, 1] = low[1] + (p[:, 1] - low[1]) * (1 + 0.05 * np.sin(4 * np.pi * t))
    return p


def _frames(rest: np.ndarray, samples: int = SAMPLES) -> np.ndarray:
    return np.stack([_deform(rest, k / FPS) for k in range(samples)])


def _usd(path, frames: np.ndarray, faces: np.ndarray, meters_per_unit: float = 0.01):
    """A USD Mesh /Char/Head whose points are sampled at FPS time codes per second, in
    units of ``meters_per_unit`` (centimetres by default), as Maya or Blender bake one."""
    from pxr import Usd, UsdGeom, Vt

    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, meters_per_unit)
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    stage.SetTimeCodesPerSecond(FPS)
    mesh = UsdGeom.Mesh.Define(stage, "/Char/Head")
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(faces)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray(faces.reshape(-1).tolist()))
    points = mesh.CreatePointsAttr()
    if len(frames) == 1:
        points.Set(Vt.Vec3fArray.FromNumpy((frames[0] / meters_per_unit).astype(np.float32)))
    for k, p in enumerate(frames if len(frames) > 1 else []):
        points.Set(
            Vt.Vec3fArray.FromNumpy((p / meters_per_unit).astype(np.float32)), Usd.TimeCode(k)
        )
    stage.GetRootLayer().Save()
    return path


def _abc(path, frames: np.ndarray, faces: np.ndarray, scale: float = 100.0):
    """An Alembic PolyMesh /Head with P sampled at FPS, in centimetres (``scale`` × the
    metres), faces wound clockwise as Alembic's are."""
    counts = np.full(len(faces), 3, np.int32)
    indices = np.ascontiguousarray(faces[:, ::-1]).reshape(-1).astype(np.int32)
    cm = (frames * scale).astype(np.float32)
    return write(path, lambda top: [add_animated_mesh(top, "Head", cm, indices, counts, FPS)])


@pytest.fixture(scope="module")
def head():
    return follicle.load_mesh("builtin:head")


@pytest.fixture(scope="module")
def files(tmp_path_factory, head):
    folder = tmp_path_factory.mktemp("anim")
    frames = _frames(head.rest_vertices)
    return {
        "usd": _usd(folder / "anim.usdc", frames, head.faces),
        "abc": _abc(folder / "anim.abc", frames, head.faces),
        "frames": frames,
    }


# ------------------------------------------------------------------ reading
def test_a_usd_animation_reads_in_metres_in_the_skin_order(files, head):
    anim = load_skin_animation(files["usd"], head)
    np.testing.assert_allclose(anim.times, np.arange(SAMPLES) / FPS, atol=1e-12)
    assert anim.vertices.shape == (SAMPLES, *head.rest_vertices.shape)
    # the centimetre points come back in metres (float32 in the file: ~1e-7 m)
    np.testing.assert_allclose(anim.vertices, files["frames"], atol=2e-6)
    assert anim.duration == pytest.approx(0.5)
    # linear between samples, held outside them
    mid = anim.at(1.5 / FPS)
    np.testing.assert_allclose(mid, 0.5 * (anim.vertices[1] + anim.vertices[2]), atol=1e-12)
    np.testing.assert_array_equal(anim.at(-1.0), anim.vertices[0])
    np.testing.assert_array_equal(anim.at(10.0), anim.vertices[-1])


def test_an_alembic_animation_takes_the_units_it_is_given(files, head):
    anim = load_skin_animation(files["abc"], head, units="cm")
    np.testing.assert_allclose(anim.times, np.arange(SAMPLES) / FPS, atol=1e-12)
    np.testing.assert_allclose(anim.vertices, files["frames"], atol=2e-6)
    with pytest.raises(InputError, match=r"anim\.abc.*(100|units)"):
        load_skin_animation(files["abc"], head)  # read as metres: 100× the skin


def test_the_animated_file_is_its_own_skin(files):
    """[mesh].path may name the animation itself: its first sample is the rest skin."""
    skin = follicle.load_mesh(files["usd"])
    anim = load_skin_animation(files["usd"], skin)
    np.testing.assert_allclose(skin.rest_vertices, anim.vertices[0], atol=1e-12)


def test_an_animation_of_another_mesh_is_refused(tmp_path, head):
    other = _usd(tmp_path / "other.usda", _frames(head.rest_vertices)[:, :-1], head.faces[:-50])
    with pytest.raises(InputError, match=r"other\.usda.*must move the skin mesh"):
        load_skin_animation(other, head)
    # the same points, other triangles
    shuffled = head.faces.copy()
    shuffled[[0, 1]] = shuffled[[1, 0]][:, ::-1]
    swapped = _usd(tmp_path / "wound.usda", _frames(head.rest_vertices), shuffled)
    with pytest.raises(InputError, match="must move the skin mesh"):
        load_skin_animation(swapped, head)


def test_files_that_are_no_animation_are_refused(tmp_path, head):
    still = _usd(tmp_path / "still.usda", _frames(head.rest_vertices, 1), head.faces)
    with pytest.raises(FormatError, match=r"still\.usda.*two times or more"):
        load_skin_animation(still, head)
    with pytest.raises(FormatError, match=r"missing\.usdc.*does not exist"):
        load_skin_animation(tmp_path / "missing.usdc", head)
    (tmp_path / "anim.obj").write_text("v 0 0 0\n")
    with pytest.raises(FormatError, match=r"anim\.obj.*USD"):
        load_skin_animation(tmp_path / "anim.obj", head)
    from pxr import Usd, UsdGeom, Vt

    changing = _usd(tmp_path / "changing.usda", _frames(head.rest_vertices, 2), head.faces)
    stage = Usd.Stage.Open(str(changing))
    points = UsdGeom.Mesh(stage.GetPrimAtPath("/Char/Head")).GetPointsAttr()
    points.Set(Vt.Vec3fArray.FromNumpy(np.zeros((10, 3), np.float32)), Usd.TimeCode(1))
    stage.GetRootLayer().Save()
    with pytest.raises(FormatError, match=r"changing\.usda.*points"):
        load_skin_animation(changing, head)
    frames = _frames(head.rest_vertices)
    frames[3, 7] = np.nan
    broken = _usd(tmp_path / "nan.usda", frames, head.faces, meters_per_unit=1.0)
    with pytest.raises(FollicleError, match=r"nan\.usda"):
        load_skin_animation(broken, head)


# ------------------------------------------------------------------ simulating
SCENE = """\
[mesh]
path = "builtin:head"
[groom]
count = 200
[sim]
skin_animation = "{anim}"
[render]
size = [64, 64]
msaa = 0
"""


@pytest.fixture(scope="module")
def simulated(tmp_path_factory, files):
    """The built-in head's guides simulated over the USD animation, 13 frames."""
    folder = tmp_path_factory.mktemp("sim")
    (folder / "scene.toml").write_text(SCENE.format(anim=files["usd"]))
    scene = load_scene(folder / "scene.toml")
    cache, stats = simulate_scene(scene, frames=SAMPLES, fps=FPS)
    return folder, scene, cache, stats


@pytest.mark.slow
def test_the_roots_ride_the_deforming_skin(simulated, files):
    _, scene, cache, stats = simulated
    groom = groom_scene(scene)
    tri, bary = groom.guides.triangles, groom.guides.bary
    np.testing.assert_allclose(cache.skin_vertices, files["frames"], atol=2e-6)
    np.testing.assert_array_equal(cache.transforms, np.repeat(np.eye(4)[None], SAMPLES, 0))
    travel = 0.0
    for f in range(SAMPLES):
        posed = groom.mesh.posed(vertices=cache.skin_vertices[f].astype(np.float64))
        want = posed.evaluate(tri, bary, pose="current").position
        np.testing.assert_allclose(cache.positions[f, :, 0], want, atol=2e-6)
        travel = max(travel, float(np.abs(want - cache.positions[0, :, 0]).max()))
    assert travel > 0.03  # the skin did carry them: several centimetres
    assert stats["max_stretch"] <= 1e-3 and stats["max_penetration"] <= 2e-3


@pytest.mark.slow
def test_the_cache_keeps_the_skin_and_says_so(simulated, tmp_path):
    from follicle.io.sim_cache import write_cache
    from follicle.pipeline import describe_cache

    _, _, cache, _ = simulated
    path = write_cache(cache, tmp_path / "sim.npz")
    back = load_cache(path)
    np.testing.assert_array_equal(back.skin_vertices, cache.skin_vertices)
    with np.load(path) as npz:
        assert int(npz["version"]) == 2
    assert f"the skin animated ({cache.skin_vertices.shape[1]:,} vertices a frame)" in (
        describe_cache(path)
    )


@pytest.fixture(scope="module")
def cli_sim(tmp_path_factory, files):
    """`follicle simulate scene.toml --skin-animation anim.usdc` under a pseudo-terminal
    (where the progress bar runs), 6 frames."""
    folder = tmp_path_factory.mktemp("cli")
    (folder / "scene.toml").write_text(SCENE.replace('skin_animation = "{anim}"\n', ""))
    warm()
    out = run_cli(
        "simulate",
        "scene.toml",
        "--skin-animation",
        files["usd"],
        "--frames",
        6,
        "-o",
        "sim.npz",
        cwd=folder,
        tty=True,
        timeout=300,
    )
    assert out.rc == 0, out.stdout + out.stderr
    return folder, out


@pytest.mark.slow
def test_the_cli_simulates_a_skin_animation_in_a_terminal(cli_sim, files):
    folder, out = cli_sim
    assert "skin animation" in out.stdout
    cache = load_cache(folder / "sim.npz")
    assert cache.frame_count == 6
    np.testing.assert_allclose(cache.skin_vertices, files["frames"][:6], atol=2e-6)


@pytest.mark.slow
def test_exports_sample_the_skin_per_frame(cli_sim, files, head):
    """usd-core reads /Groom/Skin's points per time code; alembic3d its P per sample,
    and reading the export back as a skin animation gives the cache's skin."""
    from pxr import Usd, UsdGeom

    folder, _ = cli_sim
    cache = load_cache(folder / "sim.npz")
    for name in ("anim_out.usdc", "anim_out.abc"):
        out = run_cli("export", "sim.npz", "-o", name, cwd=folder, timeout=300)
        assert out.rc == 0, out.stdout + out.stderr
        assert "with the deforming skin" in out.stdout
    stage = Usd.Stage.Open(str(folder / "anim_out.usdc"))
    skin = UsdGeom.Mesh(stage.GetPrimAtPath("/Groom/Skin"))
    points = skin.GetPointsAttr()
    assert points.GetNumTimeSamples() == 6
    for f in range(6):
        np.testing.assert_array_equal(np.array(points.Get(f)), cache.skin_vertices[f])
        lo, hi = np.array(skin.GetExtentAttr().Get(f))
        np.testing.assert_allclose(lo, cache.skin_vertices[f].min(axis=0), atol=1e-7)
        np.testing.assert_allclose(hi, cache.skin_vertices[f].max(axis=0), atol=1e-7)
    for name in ("anim_out.usdc", "anim_out.abc"):
        back = load_skin_animation(folder / name, head)
        np.testing.assert_allclose(back.times, np.arange(6) / FPS, atol=1e-9)
        np.testing.assert_allclose(back.vertices, cache.skin_vertices, atol=1e-7)


@pytest.mark.parametrize(
    "extra, anim, names",
    [
        ([], "missing.usdc", ["missing.usdc", "does not exist"]),
        ([], "other.usda", ["other.usda", "must move the skin mesh"]),
        (["--motion", "shake"], "anim", ["skin_animation", "motion"]),
        ([], "anim.abc", ["anim.abc", "units"]),
    ],
)
@pytest.mark.slow
def test_bad_skin_animations_are_one_line_and_no_file(tmp_path, files, head, extra, anim, names):
    (tmp_path / "scene.toml").write_text(SCENE.replace('skin_animation = "{anim}"\n', ""))
    if anim == "other.usda":
        _usd(tmp_path / anim, _frames(head.rest_vertices, 3)[:, :-1], head.faces[:-50])
    elif anim != "missing.usdc":
        anim = str(files["usd" if anim == "anim" else "abc"])
    warm()
    before = {p.name for p in tmp_path.iterdir()}
    out = run_cli(
        "simulate", "scene.toml", "--skin-animation", anim, "--frames", 3, *extra, cwd=tmp_path
    )
    assert_cli_refused(out, *names)
    assert {p.name for p in tmp_path.iterdir()} == before


# ------------------------------------------------------------------ hostile files
@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A small animated sphere in USD (crate) and Alembic, its own skin."""
    import trimesh

    folder = tmp_path_factory.mktemp("small")
    sphere = trimesh.creation.icosphere(subdivisions=1, radius=0.1)
    frames = np.stack([sphere.vertices * (1 + 0.1 * k) for k in range(4)])
    usd = _usd(folder / "s.usdc", frames, np.asarray(sphere.faces))
    abc = _abc(folder / "s.abc", frames, np.asarray(sphere.faces), scale=1.0)
    return {"usdc": usd.read_bytes(), "abc": abc.read_bytes(), "skin": follicle.load_mesh(usd)}


@pytest.mark.parametrize("ext", ["usdc", "abc"])
def test_damaged_animations_load_or_refuse(tmp_path, small, ext):
    """Mutated files (read in the guarded child of their format) give an animation of
    the skin or one FollicleError naming the file: never a crash or a hang."""
    path = tmp_path / f"fuzz.{ext}"

    @settings(
        max_examples=30,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )
    @given(byte_damage(small[ext]))
    def check(data):
        path.write_bytes(data)
        try:
            anim = load_skin_animation(path, small["skin"])
        except FollicleError as exc:
            assert str(path) in str(exc) and "\n" not in str(exc), str(exc)
        else:
            assert anim.vertices.shape[1:] == small["skin"].rest_vertices.shape
            assert np.isfinite(anim.vertices).all() and (np.diff(anim.times) > 0).all()

    check()


# ------------------------------------------------------------------ the skin's field
@pytest.mark.slow
def test_the_field_follows_a_rigid_skin_unbuilt_and_a_deforming_one_rebuilt(head):
    """Posed by vertices that only turn, the skin SDF is the last one built, moved by the
    fitted rigid motion (distances as the transform's own field gives them); once the
    skin deforms beyond 0.1 voxel it is rebuilt on the new vertices."""
    from follicle.mesh.sdf import SDF
    from follicle.sim.simulator import Simulator

    groom = groom_scene(Scene(mesh={"path": "builtin:head"}))  # the skin the frames move
    sim = Simulator(groom.guides, mesh=groom.mesh)
    built = sim.sdf.values
    rest = head.rest_vertices
    low = rest.min(axis=0)
    squashed = _deform(rest, 0.2)  # t = 0.2 s: the yaw and a squash
    a = 0.35 * np.sin(2 * np.pi * 0.2)
    c, s = np.cos(a), np.sin(a)
    m = np.eye(4)
    m[:3, :3] = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    m[:3, 3] = [0, low[1], 0] - m[:3, :3] @ [0, low[1], 0]
    sim.set_pose(vertices=rest @ m[:3, :3].T + m[:3, 3])
    assert sim.sdf.values is built  # moved, not rebuilt
    np.testing.assert_allclose(sim.sdf.transform, m, atol=1e-9)
    probe = rest[::50] @ m[:3, :3].T + m[:3, 3] + 0.01
    exact = SDF.from_mesh(rest, head.faces).with_transform(m).distance(probe)
    np.testing.assert_allclose(sim.sdf.distance(probe), exact, atol=1e-6)
    sim.set_pose(vertices=squashed)
    assert sim.sdf.values is not built  # squashed 5 %: a new field
    rebuilt = SDF.from_mesh(squashed, head.faces)
    np.testing.assert_array_equal(sim.sdf.values, rebuilt.values)

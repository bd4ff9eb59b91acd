"""Head animations (sim.motion) and simulation cache files (io.sim_cache)."""

import zipfile

import numpy as np
import pytest

from follicle.errors import FormatError, InputError
from follicle.io.npz import save_arrays
from follicle.io.sim_cache import SimCache, is_cache, load_cache, save_cache
from follicle.pipeline import cache_scene
from follicle.scene import Scene, scene_to_toml
from follicle.sim.motion import MOTIONS, head_motion, motion_angle, motion_pivot

MOVING = ("turn", "nod", "shake")
PIVOT = np.array([0.01, -0.23, 0.002])


def rotation_angle(m):
    return np.degrees(np.arccos(np.clip((np.trace(m[:3, :3]) - 1) / 2, -1, 1)))


# ---------------------------------------------------------------------- motion
@pytest.mark.parametrize("kind", MOTIONS)
def test_identity_and_at_rest_at_the_start(kind):
    assert np.array_equal(head_motion(kind, 0.0, pivot=PIVOT), np.eye(4))
    h = 1e-5  # velocity, and acceleration, vanish at t = 0: no jolt when the sim starts
    for t in (h, 2 * h):
        assert np.abs(head_motion(kind, t, 40, 2, PIVOT) - np.eye(4)).max() < 1e-9
    assert motion_angle(kind, 1e-3, 40, 2) < 1e-4  # ~t³: acceleration too


@pytest.mark.parametrize("kind", MOTIONS)
@pytest.mark.parametrize("t", [0.05, 0.3, 0.77, 1.0, 1.5, 1.99, 3.0])
def test_rigid_about_a_fixed_pivot(kind, t):
    m = head_motion(kind, t, 40.0, 2.0, PIVOT)
    r = m[:3, :3]
    assert np.allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(r), 1.0)
    assert np.array_equal(m[3], [0, 0, 0, 1])
    assert np.allclose(m[:3, :3] @ PIVOT + m[:3, 3], PIVOT, atol=1e-15)


def test_axes_and_directions():
    turn = head_motion("turn", 1.0, 40, 2)  # mid-period: held at +amplitude
    assert np.allclose(turn[:3, :3] @ [0, 1, 0], [0, 1, 0])  # yaw about up
    assert turn[:3, :3] @ np.array([0, 0, 1.0]) @ [1, 0, 0] > 0.6  # the face turns to +x
    nod = head_motion("nod", 1.0, 40, 2)
    assert np.allclose(nod[:3, :3] @ [1, 0, 0], [1, 0, 0])  # pitch about +x
    assert (nod[:3, :3] @ [0, 0, 1.0])[1] < -0.6  # the face looks down
    shake = head_motion("shake", 0.5, 40, 2)
    assert np.allclose(shake[:3, :3] @ [0, 1, 0], [0, 1, 0])


@pytest.mark.parametrize("kind", MOVING)
def test_reaches_the_amplitude_and_ends_still(kind):
    t = np.linspace(0, 2.0, 4001)
    angle = np.array([motion_angle(kind, x, 30.0, 2.0) for x in t])
    assert np.isclose(angle.max(), 30.0, atol=1e-6)
    assert np.isclose(rotation_angle(head_motion(kind, t[angle.argmax()], 30, 2)), 30.0)
    if kind == "shake":  # both ways, then fading: later swings are smaller
        assert np.isclose(angle.min(), -30.0, atol=1e-6)
        assert np.abs(angle[t > 1.2]).max() < 0.7 * 30
    speed = np.abs(np.gradient(angle, t))
    assert speed.max() < 1.875 * 2 * 30 / (0.22 * 2.0) + 1  # the fastest swing's min-jerk peak
    for late in (2.0, 2.5, 10.0):
        assert np.array_equal(head_motion(kind, late, 30, 2, PIVOT), np.eye(4))
    assert speed[-2:].max() < 0.01  # deg/s: arrives at rest


@pytest.mark.parametrize("kind", MOVING)
def test_smooth_everywhere(kind):
    t = np.linspace(0, 2.4, 24001)
    angle = np.array([motion_angle(kind, x, 40.0, 2.0) for x in t])
    speed = np.gradient(angle, t)
    accel = np.gradient(speed, t)
    assert np.abs(np.diff(speed)).max() < 0.5  # deg/s per 0.1 ms: no velocity jumps
    assert np.abs(np.diff(accel)).max() < 150  # nor acceleration jumps (min-jerk joins)


def test_amplitude_and_period_scale():
    assert np.isclose(motion_angle("turn", 2.0, 20, 4), motion_angle("turn", 1.0, 20, 2))
    assert np.isclose(motion_angle("nod", 0.9, -10, 2), -motion_angle("nod", 0.9, 10, 2))
    assert motion_angle("none", 0.7, 40, 2) == 0.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("spin", 0.0), "unknown kind 'spin'; use one of none, turn, nod, shake"),
        (("turn", -0.1), "time: must be ≥ 0"),
        (("turn", float("nan")), "time: must be finite"),
        (("turn", "1"), "time: expected a number"),
        (("turn", 0.5, 40, 0.0), "period: must be > 0"),
        (("turn", 0.5, 40, -2.0), "period: must be > 0"),
        (("turn", 0.5, 40, float("nan")), "period: must be finite"),
        (("turn", 0.5, float("inf")), "amplitude: must be finite"),
        (("turn", 0.5, 40, 2, (0, 0)), "pivot: expected 3 finite numbers"),
        (("turn", 0.5, 40, 2, (0, np.nan, 0)), "pivot: expected 3 finite numbers"),
    ],
)
def test_bad_arguments(args, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        head_motion(*args)


def test_default_pivot_is_the_neck():
    class Box:
        def bounds(self, which):
            assert which == "rest"
            return np.array([-1.0, -2.0, -3.0]), np.array([1.0, 4.0, 5.0])

    assert np.array_equal(motion_pivot(Box()), [0.0, -2.0, 1.0])


# ---------------------------------------------------------------------- cache
def frames(count=3, strands=4, vertices=5):
    rng = np.random.default_rng(1)
    pos = rng.normal(size=(count, strands, vertices, 3)).astype(np.float32)
    tr = np.stack([head_motion("turn", f / 24, 40, 0.5, PIVOT) for f in range(count)])
    return pos, tr


TOML = scene_to_toml(Scene(), comments=False)


def test_round_trip_same_bytes_and_read_only(tmp_path):
    pos, tr = frames()
    save_cache(tmp_path / "a.npz", pos, tr, 24, TOML, "/some/dir")
    save_cache(tmp_path / "b.npz", pos.astype(np.float64), tr, 24.0, TOML, "/some/dir")
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    cache = load_cache(tmp_path / "a.npz")
    assert isinstance(cache, SimCache)
    assert np.array_equal(cache.positions, pos) and cache.positions.dtype == np.float32
    assert np.array_equal(cache.transforms, tr) and cache.transforms.dtype == np.float64
    assert cache.fps == 24.0 and cache.scene_toml == TOML and cache.base_dir == "/some/dir"
    assert (cache.frame_count, cache.strand_count, cache.vertex_count) == (3, 4, 5)
    assert not cache.positions.flags.writeable
    with pytest.raises(AttributeError):
        cache.fps = 30
    scene = cache_scene(cache)
    assert scene.model_dump() == Scene().model_dump() and str(scene.base_dir) == "/some/dir"
    with np.load(tmp_path / "a.npz") as npz:  # a plain npz: numpy reads it
        assert str(npz["format"]) == "follicle-sim-cache" and int(npz["version"]) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.npz", "b.npz"]


def test_is_cache(tmp_path):
    import follicle

    pos, tr = frames()
    save_cache(tmp_path / "c.npz", pos, tr, 24, TOML, ".")
    curves = follicle.HairCurves(np.zeros((4, 3)), np.array([0, 4]))
    follicle.save(curves, tmp_path / "h.npz")
    (tmp_path / "t.npz").write_text("not a zip")
    save_arrays(tmp_path / "o.npz", {"format": np.array("something else")})
    assert is_cache(tmp_path / "c.npz")
    for name in ("h.npz", "t.npz", "o.npz", "missing.npz"):
        assert not is_cache(tmp_path / name), name


def write(path, **changes):
    """A cache with some keys replaced (None: removed), written past save_cache's checks."""
    pos, tr = frames()
    arrays = {
        "format": np.array("follicle-sim-cache"),
        "version": np.array(1),
        "positions": pos,
        "transforms": tr,
        "fps": np.array(24.0),
        "scene_toml": np.array(TOML),
        "base_dir": np.array("."),
    }
    arrays.update(changes)
    save_arrays(path, {k: v for k, v in arrays.items() if v is not None})
    return path


def _nan_frame():
    pos = frames()[0]
    pos[2, 1, 3, 0] = np.nan
    return pos


def _inf_frame():
    tr = frames()[1]
    tr[2, 0, 3] = np.inf
    return tr


def _nan_skin():
    skin = np.zeros((3, 5, 3), np.float32)
    skin[1, 2, 0] = np.nan
    return skin


def _scaled():
    tr = frames()[1]
    tr[1, :3, :3] *= 1.1
    return tr


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"format": None}, "not a simulation cache"),
        ({"format": np.array("follicle-curves")}, "not a simulation cache"),
        ({"version": np.array(3)}, "cache version 3; this follicle reads versions 1 to 2: up"),
        ({"version": np.array(0)}, "cache version 0"),
        ({"version": np.array(1.0)}, "version: expected an integer"),
        ({"positions": None}, "missing array\\(s\\) positions"),
        ({"transforms": None, "fps": None}, "missing array\\(s\\) transforms, fps"),
        ({"positions": frames()[0].astype(np.float64)}, "positions: expected a float32"),
        ({"positions": frames()[0][0]}, "positions: expected a float32 \\(F, S, N, 3\\)"),
        ({"positions": frames(vertices=1)[0]}, "N ≥ 2"),
        ({"positions": _nan_frame()}, "positions: frame 2 contains NaN or inf"),
        ({"transforms": frames()[1][:2]}, "3 frames of positions but 2 transforms"),
        ({"transforms": frames()[1].astype(np.float32)}, "transforms: expected a float64"),
        ({"transforms": frames()[1][:, :3]}, "transforms: expected a float64 \\(F, 4, 4\\)"),
        ({"transforms": _scaled()}, "transforms: frame 1: not rigid"),
        ({"transforms": _inf_frame()}, "transforms: frame 2: expected a finite"),
        ({"skin_vertices": np.zeros((3, 5, 3))}, "skin_vertices: expected a float32"),
        ({"skin_vertices": np.zeros((2, 5, 3), np.float32)}, "expected \\(3, V ≥ 3, 3\\)"),
        ({"skin_vertices": _nan_skin()}, "skin_vertices: frame 1 contains NaN"),
        ({"fps": np.array(0.0)}, "fps: must be > 0 \\(got 0.0\\)"),
        ({"fps": np.array(np.nan)}, "fps: must be finite and > 0 \\(got nan\\)"),
        ({"fps": np.array([24.0])}, "fps: expected a float, got float64 array of shape \\(1,\\)"),
        ({"scene_toml": np.array(3)}, "scene_toml: expected a text string"),
        ({"base_dir": np.array(["a", "b"])}, "base_dir: expected a text string"),
    ],
)
def test_load_names_the_file_and_what_is_wrong(tmp_path, changes, message):
    path = write(tmp_path / "bad.npz", **changes)
    with pytest.raises(FormatError, match=message) as err:
        load_cache(path)
    assert str(err.value).startswith(str(path) + ": ")


def test_unreadable_files(tmp_path):
    with pytest.raises(FormatError, match="no such file"):
        load_cache(tmp_path / "missing.npz")
    (tmp_path / "t.npz").write_text("text")
    with pytest.raises(FormatError, match="not a readable .npz archive"):
        load_cache(tmp_path / "t.npz")
    path = write(tmp_path / "cut.npz")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError, match="cut.npz: not a readable"):
        load_cache(path)
    with zipfile.ZipFile(write(tmp_path / "ok.npz")) as zf:
        assert "positions.npy" in zf.namelist()


def test_stored_scene_errors_name_the_cache(tmp_path):
    cache = load_cache(write(tmp_path / "s.npz", scene_toml=np.array("[groom\n")))
    with pytest.raises(FormatError, match="s.npz: stored scene: TOML syntax error"):
        cache_scene(cache)
    cache = load_cache(write(tmp_path / "k.npz", scene_toml=np.array("[groom]\ncuont = 1\n")))
    with pytest.raises(FormatError, match=r"k.npz: stored scene: \[groom\].cuont: unknown key"):
        cache_scene(cache)


def test_save_refuses_bad_input_and_writes_nothing(tmp_path):
    pos, tr = frames()
    with pytest.raises(FormatError, match="must end in .npz"):
        save_cache(tmp_path / "c.abc", pos, tr, 24, TOML, ".")
    with pytest.raises(InputError, match="frame counts differ"):
        save_cache(tmp_path / "c.npz", pos, tr[:1], 24, TOML, ".")
    with pytest.raises(InputError, match="fps"):
        save_cache(tmp_path / "c.npz", pos, tr, -1, TOML, ".")
    with pytest.raises(InputError, match="numeric"):
        save_cache(tmp_path / "c.npz", "xyz", tr, 24, TOML, ".")
    with pytest.raises(InputError, match="scene_toml: expected a text string"):
        save_cache(tmp_path / "c.npz", pos, tr, 24, None, ".")
    assert list(tmp_path.iterdir()) == []


def test_stored_scene_keeps_colliders(tmp_path):
    from follicle.scene import ColliderParams

    scene = Scene()
    collider = ColliderParams(kind="capsule", a=(0, -0.2, 0), b=(0, -0.3, 0.01))
    scene = scene.replace(sim=scene.sim.replace(colliders=[collider]))
    pos, tr = frames()
    save_cache(tmp_path / "c.npz", pos, tr, 24, scene_to_toml(scene), str(tmp_path))
    again = cache_scene(load_cache(tmp_path / "c.npz"))
    assert again.model_dump() == scene.model_dump()

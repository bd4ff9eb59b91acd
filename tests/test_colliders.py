"""Colliders as one table (sphere, capsule, plane rows) and the plane collider: hair
that falls onto a floor lies on it, a plane that follows the head turns with it, and a
scene file's [[sim.colliders]] plane reaches the solver."""

from __future__ import annotations

import numpy as np
import pytest

from follicle.curves import HairCurves
from follicle.errors import ConfigError
from follicle.scene import ColliderParams, SimParams, scene_from_toml
from follicle.sim import Simulator
from follicle.sim.collision import clearance, colliders
from follicle.sim.settings import SHAPES

FLOOR = -0.12  # m: below the roots, above where the strands would hang
LIMP = {"bend_stiffness": 0.0, "shape_local": 0.0, "shape_global": 0.0}  # they hang straight


def _hanging(count: int = 4, n: int = 16, length: float = 0.3) -> HairCurves:
    """``count`` horizontal strands of ``length`` m rooted at y = 0, which gravity swings
    down through y = FLOOR."""
    pts = np.zeros((count, n, 3))
    pts[:, :, 0] = np.linspace(0.0, length, n)
    pts[:, :, 2] = np.arange(count)[:, None] * 0.05
    return HairCurves.from_array(pts)


def _run(sim: Simulator, seconds: float, rate: float = 60.0) -> None:
    for _ in range(round(seconds * rate)):
        sim.step(1.0 / rate)


def test_the_table_has_a_row_a_shape_in_the_order_given():
    shapes = [
        ColliderParams(kind="capsule", a=(0, 0, 0), b=(1, 0, 0), radius=0.2),
        ColliderParams(kind="plane", centre=(0, -0.5, 0), normal=(0, 2, 0)),
        ColliderParams(kind="sphere", centre=(1, 2, 3), radius=0.5),
    ]
    table = colliders(shapes).shapes
    kinds = tuple(SHAPES)
    assert [kinds[int(k)] for k in table[:, 0]] == ["capsule", "plane", "sphere"]
    np.testing.assert_array_equal(table[0, 1:8], [0, 0, 0, 1, 0, 0, 0.2])
    np.testing.assert_array_equal(table[1, 1:7], [0, -0.5, 0, 0, 1, 0])  # unit normal
    np.testing.assert_array_equal(table[2, 1:5], [1, 2, 3, 0.5])


@pytest.mark.parametrize("kind", list(SHAPES))
def test_every_shape_of_the_schema_has_a_kernel(kind):
    """A kind in SHAPES whose kernel collide() does not call would be skipped silently:
    a point just inside each default shape is found inside, one far off is found clear."""
    shape = ColliderParams(kind=kind, a=(0, 0, 0), b=(0.2, 0, 0))
    inside = {"sphere": (0.05, 0, 0), "capsule": (0.1, 0.05, 0), "plane": (0.3, -0.05, 0.2)}
    x = np.array([[inside[kind], (0.0, 50.0, 0.0)]])
    d = clearance(x, colliders([shape]))
    assert d[0, 0] < 0.0 and 0.0 < d[0, 1] < np.inf


def test_plane_clearance_is_the_signed_distance_along_the_normal():
    # the plane x + y = 1 (normal (1, 1, 0) / √2): distances exact on both sides
    plane = ColliderParams(kind="plane", centre=(1, 0, 0), normal=(1, 1, 0))
    x = np.array([[[2.0, 1.0, 5.0], [0.0, 0.0, -3.0], [0.5, 0.5, 0.0]]])
    d = clearance(x, colliders([plane]))
    np.testing.assert_allclose(d, [[2 / np.sqrt(2), -1 / np.sqrt(2), 0.0]], atol=1e-12)


def test_a_plane_that_follows_the_head_moves_and_turns_with_it():
    a = np.pi / 2  # 90° about z, then 1 m up
    turn = np.array([[np.cos(a), -np.sin(a), 0, 0], [np.sin(a), np.cos(a), 0, 1], [0, 0, 1, 0]])
    turn = np.vstack([turn, [0, 0, 0, 1]])
    moving = ColliderParams(kind="plane", centre=(1, 0, 0), normal=(1, 0, 0))
    fixed = moving.replace(follow=False)
    table = colliders([moving, fixed], transform=turn).shapes
    np.testing.assert_allclose(table[0, 1:7], [0, 2, 0, 0, 1, 0], atol=1e-12)
    np.testing.assert_array_equal(table[1, 1:7], [1, 0, 0, 1, 0, 0])


@pytest.mark.parametrize("solver", ["pbd", "dftl"])
@pytest.mark.slow
def test_hair_falling_onto_a_floor_lies_on_it(solver):
    floor = ColliderParams(kind="plane", centre=(0, FLOOR, 0), normal=(0, 1, 0))
    margin = 0.002
    sim = Simulator(
        _hanging(),
        params=SimParams(colliders=[floor], collision_margin=margin, solver=solver, **LIMP),
    )
    _run(sim, 2.0)
    y = sim.positions[:, :, 1]
    assert y.min() >= FLOOR + margin - 1e-5  # nothing below the floor and its margin
    assert (y[:, -1] <= FLOOR + margin + 1e-3).all()  # the tips lie on it
    assert sim.stats["max_penetration"] == 0.0
    free = Simulator(_hanging(), params=SimParams(solver=solver, **LIMP))
    _run(free, 2.0)
    assert free.positions[:, :, 1].min() < FLOOR - 0.1  # without it they hang through


def test_a_tilted_floor_in_a_scene_file_holds_the_hair(tmp_path):
    scene = scene_from_toml(
        """
[sim]
collision_margin = 0.0
bend_stiffness = 0.0
shape_local = 0.0
shape_global = 0.0
[[sim.colliders]]
kind = "plane"
centre = [0.0, -0.12, 0.0]
normal = [0.3, 1.0, 0.0]
follow = false
""",
        "tilted.toml",
        tmp_path,
    )
    (plane,) = scene.sim.colliders
    sim = Simulator(_hanging(), params=scene.sim)
    _run(sim, 2.0)
    n = np.array(plane.normal) / np.linalg.norm(plane.normal)
    height = (sim.positions - np.array(plane.centre)) @ n
    assert height.min() >= -1e-5
    assert height[:, -1].max() <= 2e-3  # lying on the slope


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ('kind = "plane"\nnormal = [0, 0, 0]', "non-zero normal"),
        ('kind = "box"', "'sphere', 'capsule' or 'plane'"),
        ('kind = "plane"\nnormal = [0, 1]', "normal"),
        # too short to make unit length (its square underflows): not blamed on substep later
        ('kind = "plane"\nnormal = [1e-200, 0, 0]', r"normal: .*length at least"),
        ('kind = "plane"\nnormal = [0, 1e-12, 0]', r"normal: .*length at least"),
    ],
)
def test_bad_plane_colliders_are_refused_naming_the_key(tmp_path, body, needle):
    with pytest.raises(ConfigError, match=needle) as caught:
        scene_from_toml(f"[[sim.colliders]]\n{body}\n", "bad.toml", tmp_path)
    assert "bad.toml" in str(caught.value) and "colliders" in str(caught.value)


def test_a_tiny_normal_is_refused_by_the_settings_and_by_the_table():
    """A 1e-200 normal is refused where it is given, naming the collider's normal, and a
    shape that bypasses the settings (any object with the fields) by the table: never a
    simulation that blows up and blames [sim].substep."""
    from types import SimpleNamespace

    from follicle.errors import InputError

    with pytest.raises(ConfigError, match=r"normal: a plane needs a non-zero normal"):
        ColliderParams(kind="plane", normal=(1e-200, 0, 0))
    with pytest.raises(ConfigError, match=r"\[sim\]\.colliders\.0: normal"):
        SimParams().replace(colliders=[{"kind": "plane", "normal": [0, 0, 1e-200]}])
    shape = SimpleNamespace(kind="plane", centre=(0, 0, 0), normal=(1e-200, 0, 0), follow=True)
    with pytest.raises(InputError, match="plane normal"):
        colliders([shape])
    ColliderParams(kind="plane", normal=(0, 1e-6, 0))  # short, and still a direction

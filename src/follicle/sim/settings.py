"""[sim]: guide-strand dynamics, and the colliders of ``[[sim.colliders]]``."""

from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal, get_args

from pydantic import Field, model_validator

from ..settings import StrictSection, Unit, Vec3, measured_in

__all__ = ["SimParams", "ColliderParams", "MAX_ACCELERATION", "MIN_NORMAL", "SHAPES"]

# an acceleration on the hair (gravity, wind): beyond ±100 m/s² (10 g) the skin's
# collisions and the strands' lengths fight and segments stretch (docs: How-to › Dynamics)
MAX_ACCELERATION = 100.0
# a plane's normal is a direction, made unit length: one shorter than this is a typo
# (or would underflow when squared), not a direction
MIN_NORMAL = 1e-9
Accel = Annotated[float, Field(ge=-MAX_ACCELERATION, le=MAX_ACCELERATION)]
Acceleration = Annotated[tuple[Accel, Accel, Accel], Field(strict=False)]


# The collider shapes: each one's fields in the order the kernels read them, each a
# point (moved with the head), a direction (turned with it) or a scalar (kept). A
# shape's kind is its place here; :mod:`follicle.sim.collision` has a kernel for each
# (a new shape: an entry here and in ShapeKind, its fields on ColliderParams, one
# kernel there).
ShapeKind = Literal["sphere", "capsule", "plane"]
SHAPES: dict[str, tuple[tuple[str, str], ...]] = {
    "sphere": (("centre", "point"), ("radius", "scalar")),
    "capsule": (("a", "point"), ("b", "point"), ("radius", "scalar")),
    "plane": (("centre", "point"), ("normal", "direction")),
}
# ShapeKind spells SHAPES' names out for the type checker (a Literal cannot be made
# from them); the two must not drift apart
if get_args(ShapeKind) != tuple(SHAPES):  # pragma: no cover - a programming error
    raise RuntimeError(f"ShapeKind {get_args(ShapeKind)} is not SHAPES' {tuple(SHAPES)}")


class ColliderParams(StrictSection):
    """A sphere (centre, radius), capsule (a, b, radius) or plane (centre: a point on it,
    normal: the side the hair stays on) that the hair cannot enter."""

    kind: ShapeKind = Field("sphere", description=" or ".join(SHAPES))
    centre: Vec3 = Field(
        (0.0, 0.0, 0.0),
        description="sphere centre, or a point on the plane",
        json_schema_extra=measured_in("m"),
    )
    a: Vec3 = Field(
        (0.0, 0.0, 0.0), description="capsule axis start", json_schema_extra=measured_in("m")
    )
    b: Vec3 = Field(
        (0.0, 0.0, 0.0), description="capsule axis end", json_schema_extra=measured_in("m")
    )
    radius: float = Field(
        0.1, gt=0, le=100, description="radius", json_schema_extra=measured_in("m")
    )
    normal: Vec3 = Field(
        (0.0, 1.0, 0.0), description="plane normal, towards the side the hair stays on"
    )
    follow: bool = Field(
        True, description="moves with the transform given to set_pose (the head); false: fixed"
    )

    @model_validator(mode="after")
    def _normal_has_a_direction(self) -> ColliderParams:
        # the solver makes it unit length: its squared length must not underflow to 0
        if self.kind == "plane" and not math.fsum(c * c for c in self.normal) >= MIN_NORMAL**2:
            raise ValueError(
                f"normal: a plane needs a non-zero normal, of length at least {MIN_NORMAL:g}"
                f" (got {list(self.normal)}), e.g. (0, 1, 0)"
            )
        return self


class SimParams(StrictSection):
    """Guide-strand dynamics (Almeida 2014 §3, Le Muzic 2012 §5.1.2–5.1.3)."""

    _section: ClassVar[str] = "sim"
    _owner: ClassVar[str] = "Simulator.params"

    solver: Literal["pbd", "dftl"] = Field(
        "pbd", description="inextensibility: PBD distance constraints or Dynamic Follow-The-Leader"
    )
    integrator: Literal["verlet", "euler"] = Field(
        "verlet", description="Verlet (Le Muzic 2012 eq. 5.1) or semi-implicit Euler"
    )
    substep: float = Field(
        1 / 120,
        gt=0,
        le=1 / 30,
        description="internal fixed time step"
        " (at most 1/30: longer steps let the skin sweep through the hair)",
        json_schema_extra=measured_in("s"),
    )
    iterations: int = Field(8, ge=1, le=200, description="constraint iterations per substep")
    vertices: int | None = Field(
        None, ge=2, le=256, description="vertices per simulated strand; unset = the guides'"
    )
    gravity: Acceleration = Field(
        (0.0, -9.81, 0.0),
        description="gravity (each component within ±100, about 10 g)",
        json_schema_extra=measured_in("m/s²"),
    )
    damping: float = Field(
        0.5,
        ge=0,
        le=100,
        description="velocity damping: speed × exp(−damping·t)",
        json_schema_extra=measured_in("1/s"),
    )
    drag: float = Field(
        0.0,
        ge=0,
        le=1000,
        description="air drag b of −b·v (Le Muzic 2012 eq. 5.3)",
        json_schema_extra=measured_in("1/s"),
    )
    wind: Acceleration = Field(
        (0.0, 0.0, 0.0),
        description="wind acceleration w of Le Muzic 2012 eq. 5.2 (each component within ±100)",
        json_schema_extra=measured_in("m/s²"),
    )
    wind_turbulence: float = Field(
        0.5, ge=0, le=10, description="noise added to the wind, relative to its strength"
    )
    wind_frequency: float = Field(
        4.0, ge=0, le=1000, description="turbulence frequency", json_schema_extra=measured_in("1/m")
    )
    wind_drift: Vec3 = Field(
        (1.0, 0.0, 0.0),
        description="speed the turbulence pattern drifts with",
        json_schema_extra=measured_in("m/s"),
    )
    wind_gust: float = Field(
        0.0,
        ge=0,
        le=100,
        description="gusts: the wind × (1 + gust·g(t)), g a smooth noise in [0, 1]; 0 = steady",
    )
    wind_gust_period: float = Field(
        2.0, gt=0, le=1000, description="typical gust length", json_schema_extra=measured_in("s")
    )
    stretch_stiffness: Unit = Field(1.0, description="PBD distance constraint stiffness")
    stretch_limit: float | None = Field(
        1e-4,
        ge=0,
        le=1,
        description="PBD: afterwards no segment longer than (1 + limit) × rest; unset = off",
    )
    stretch_limit_damping: Unit = Field(
        0.8,
        description="PBD: the limit's moves leave velocities like DFTL's (Almeida 2014 eq. 3.1)",
    )
    bend_stiffness: Unit = Field(0.2, description="bending (Le Muzic 2012 eq. 5.6) stiffness")
    bend_scale: float = Field(
        1.0,
        ge=0.5,
        le=10,
        description="bending rest distances × scale (> 1 stiffens; below"
        " 0.5 the rest distances pull the strand into its root and fight inextensibility)",
    )
    bend_attenuation: float = Field(
        1.0, ge=0, le=100, description="bending weakens along the strand: k / (1 + att·(i−1))"
    )
    cone_angle: float = Field(
        180.0,
        gt=0,
        le=180,
        description="largest turn between segments; 180 = off",
        json_schema_extra=measured_in("degrees"),
    )
    shape_local: Unit = Field(
        0.0, description="stiffness towards each segment's rest direction (local shape)"
    )
    shape_global: Unit = Field(
        0.05,
        description="stiffness towards the skinned rest pose (0.05 keeps a groom's"
        " style under gravity and still lets it swing; 0 = hair falls freely)",
    )
    shape_global_range: Annotated[tuple[Unit, Unit], Field(strict=False)] = Field(
        (0.0, 1.0),
        description="global shape: full up to the first, zero from the second"
        " (root-to-tip fractions)",
    )
    shape_hold: float = Field(
        0.12,
        ge=0,
        le=10,
        description="style length: how long a strand stands out level and keeps its"
        " groomed shape (it sags a tenth of this at its tip; longer strands sag as"
        " (length / this)³, so long hair falls and swings). What trades style for"
        " softness: lower is softer; 0 = off",
        json_schema_extra=measured_in("m"),
    )
    dftl_damping: Unit = Field(0.9, description="DFTL velocity correction s (Almeida 2014 eq. 3.1)")
    collision_margin: float = Field(
        0.002,
        ge=0,
        le=1,
        description="distance kept from colliders",
        json_schema_extra=measured_in("m"),
    )
    friction: Unit = Field(0.3, description="share of tangential speed lost in contact")
    colliders: list[ColliderParams] = Field(
        default_factory=list,
        description="spheres, capsules and planes: [[sim.colliders]] tables",
    )
    skin_collision: bool = Field(
        True, description="collide with the skin mesh through its signed distance field"
    )
    skin_voxel: float | None = Field(
        None,
        gt=0,
        le=1,
        description="skin SDF voxel size; unset = the mesh's longest side / 64",
        json_schema_extra=measured_in("m"),
    )
    volume_friction: Unit = Field(
        0.05,
        description="hair-hair friction: velocities pulled to the grid's (Almeida 2014 eq. 3.4)",
    )
    volume_repulsion: float = Field(
        0.0,
        ge=0,
        le=1,
        description="hair-hair repulsion down the density gradient, voxels"
        " per substep (Almeida 2014 eq. 3.5–3.7)",
    )
    volume_resolution: int = Field(
        32, ge=2, le=128, description="hair volume grid: cells along the hair's longest side"
    )
    volume_blur: int = Field(1, ge=0, le=8, description="box-blur passes on the volume grid")
    motion: Literal["none", "turn", "nod", "shake"] = Field(
        "none", description="`follicle simulate`: the built-in head animation"
    )
    motion_amplitude: float = Field(
        40.0,
        ge=0,
        le=180,
        description="head animation angle",
        json_schema_extra=measured_in("degrees"),
    )
    motion_period: float = Field(
        2.0, gt=0, le=100, description="head animation period", json_schema_extra=measured_in("s")
    )
    motion_pivot: Vec3 | None = Field(
        None,
        description="head animation pivot; unset = the neck (bottom centre of the mesh)",
        json_schema_extra=measured_in("m"),
    )
    skin_animation: str | None = Field(
        None,
        description="`follicle simulate`: a USD or Alembic file animating the skin mesh"
        " (time-sampled points); the roots follow it. Instead of motion",
    )

    @model_validator(mode="after")
    def _one_animation(self) -> SimParams:
        if self.skin_animation is not None and self.motion != "none":
            raise ValueError(
                'motion and skin_animation both move the skin: give one (motion = "none"'
                " with a skin animation)"
            )
        return self

    @model_validator(mode="after")
    def _range_ordered(self) -> SimParams:
        if self.shape_global_range[0] > self.shape_global_range[1]:
            raise ValueError("shape_global_range: the start must not exceed the end")
        return self

    @model_validator(mode="after")
    def _wind_bounded(self) -> SimParams:
        """Gusts and turbulence scale the wind: its peak, like gravity, stays ≤ 100 m/s²."""
        peak = max(map(abs, self.wind)) * (1 + self.wind_gust) * (1 + self.wind_turbulence)
        if peak > MAX_ACCELERATION:
            raise ValueError(
                f"wind × (1 + wind_gust) × (1 + wind_turbulence) peaks at {peak:.4g} m/s²; at"
                f" most {MAX_ACCELERATION:g} (10 g): lower wind, wind_gust or wind_turbulence"
            )
        return self

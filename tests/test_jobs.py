"""The commands' work called from Python: ``follicle.plan_grow``, ``plan_export``,
``plan_render``, ``plan_simulate`` and ``plan_batch`` check everything before any work,
say where they will write, and their ``run`` writes what the command writes."""

import contextlib

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

import follicle
from follicle.cli import main
from follicle.errors import FollicleError, FormatError, InputError
from follicle.io.sim_cache import load_cache

SCENE = """\
[guides]
path = "builtin:short"
[groom]
count = 400
[sim]
motion = "nod"
motion_period = 0.5
[render]
size = [48, 40]
msaa = 0
engine = "cpu"
"""


class Stages:
    """A :class:`follicle.progress.Stage` that records each stage's label and the last
    progress it heard."""

    def __init__(self):
        self.labels, self.last = [], {}

    @contextlib.contextmanager
    def __call__(self, label):
        self.labels.append(label)
        yield lambda done, total: self.last.__setitem__(label, (done, total))


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


def test_the_plans_are_public_names():
    from follicle.distributed.batch import plan_batch
    from follicle.export import plan_export, plan_grow, plan_settle
    from follicle.render_job import plan_render
    from follicle.simulate_job import plan_simulate

    assert follicle.plan_grow is plan_grow and follicle.plan_export is plan_export
    assert follicle.plan_render is plan_render and follicle.plan_simulate is plan_simulate
    assert follicle.plan_batch is plan_batch and follicle.plan_settle is plan_settle


def test_a_settle_of_zero_seconds_is_refused_before_any_simulation(scene, tmp_path):
    with pytest.raises(InputError, match=r"\[groom\]\.settle: 0 s leaves the guides"):
        follicle.plan_settle(str(scene), tmp_path / "g.npz")
    with pytest.raises(FormatError, match="output must end in"):
        follicle.plan_settle(str(scene), tmp_path / "g.png", seconds=1)
    job = follicle.plan_settle(str(scene), tmp_path / "g.npz", seconds=0.5)
    assert job.scene.groom.settle == 0.5 and job.path == str(tmp_path / "g.npz")
    assert not (tmp_path / "g.npz").exists()  # planned, not run


def test_a_grow_planned_in_python_writes_what_the_command_writes(scene, tmp_path):
    job = follicle.plan_grow(str(scene), tmp_path / "lib.npz", count=300, seed=4)
    assert job.path == str(tmp_path / "lib.npz") and job.scene.groom.count == 300
    assert not (tmp_path / "lib.npz").exists()  # planning writes nothing
    stages = Stages()
    hairs, points = job.run(stages)
    assert stages.labels == ["growing hair"] and hairs == 300
    result = CliRunner().invoke(
        main, ["grow", str(scene), "-o", str(tmp_path / "cli.npz"), "--count", "300", "--seed", "4"]
    )
    assert result.exit_code == 0, result.output
    ours, theirs = (
        follicle.load_curves(tmp_path / "lib.npz"),
        follicle.load_curves(tmp_path / "cli.npz"),
    )
    assert ours.point_count == points == theirs.point_count
    np.testing.assert_array_equal(ours.points, theirs.points)


@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        ({"out": "x.npz", "target": "unreal"}, FormatError, "--target unreal is for USD"),
        ({"out": "x.xyz"}, FormatError, "output must end in .npz"),
        ({"out": "x.npz", "chunk": 10}, InputError, "--chunk: sizes the Dask tasks"),
        ({"out": "x.npz", "chunk": 0}, InputError, "--chunk 0"),
        ({"out": "scene.toml"}, FormatError, "output must end in"),
    ],
)
def test_a_grow_that_does_not_fit_is_refused_before_any_hair(scene, kwargs, error, words):
    out = scene.parent / kwargs.pop("out")
    before = sorted(p.name for p in scene.parent.iterdir())
    with pytest.raises(error, match=words):
        follicle.plan_grow(str(scene), out, **kwargs)
    assert sorted(p.name for p in scene.parent.iterdir()) == before
    assert scene.read_text() == SCENE


def test_a_grow_onto_its_own_mesh_is_refused(tmp_path):
    mesh = tmp_path / "skin.obj"
    follicle.plan_export(["builtin:head"], mesh).run()
    scene = tmp_path / "s.toml"
    scene.write_text(f'[mesh]\npath = "{mesh}"\n[groom]\ncount = 10\n')
    before = mesh.read_bytes()
    with pytest.raises(InputError, match=r"would replace the scene's \[mesh\]\.path"):
        follicle.plan_grow(str(scene), mesh.with_suffix(".obj"))
    assert mesh.read_bytes() == before


def test_an_export_is_planned_by_what_it_reads_and_writes(scene, tmp_path):
    mesh = follicle.plan_export(["builtin:head"], tmp_path / "head.ply")
    assert mesh.kind == "mesh" and mesh.targets == (str(tmp_path / "head.ply"),)
    written = mesh.run()
    assert written.mesh is not None and len(written.mesh.faces) > 1000
    assert (tmp_path / "head.ply").stat().st_size > 0

    follicle.plan_grow(str(scene), tmp_path / "a.npz", count=50).run()
    follicle.plan_grow(str(scene), tmp_path / "b.npz", count=70).run()
    many = follicle.plan_export(
        [str(tmp_path / "a.npz"), str(tmp_path / "b.npz")], tmp_path / "out", suffix="hair"
    )
    assert many.kind == "curves"
    assert many.targets == (str(tmp_path / "out" / "a.hair"), str(tmp_path / "out" / "b.hair"))
    stages = Stages()
    done = many.run(stages)
    assert [hairs for hairs, _ in done.counts] == [50, 70]
    assert stages.labels == ["converting files"] and stages.last["converting files"] == (2, 2)
    assert follicle.load_curves(tmp_path / "out" / "b.hair").curve_count == 70

    with pytest.raises(InputError, match="give --to SUFFIX"):
        follicle.plan_export([str(tmp_path / "a.npz"), str(tmp_path / "b.npz")], tmp_path / "x")
    with pytest.raises(InputError, match="would replace its own input"):
        follicle.plan_export([str(tmp_path / "a.npz")], tmp_path / "a.npz")


def test_a_scene_render_grows_then_draws(scene, tmp_path):
    job = follicle.plan_render(str(scene), tmp_path / "hair.png", size=(40, 32))
    assert job.kind == "scene" and job.engine.name == "cpu" and job.outputs == [job.target]
    stages = Stages()
    done = job.run(stages)
    assert stages.labels == ["growing hair", "rendering"]
    assert stages.last["growing hair"] == (400, 400)
    assert done.paths == (tmp_path / "hair.png",) and done.frames is None
    image = np.asarray(Image.open(tmp_path / "hair.png"))
    assert image.shape[:2] == (32, 40) and np.ptp(image[..., :3]) > 0  # something drawn


def test_a_curves_render_reads_the_file_and_defaults_beside_it(scene, tmp_path):
    follicle.plan_grow(str(scene), tmp_path / "g.npz", count=100).run()
    job = follicle.plan_render(
        str(tmp_path / "g.npz"), mesh="builtin:head", engine="cpu", size=(32, 32)
    )
    assert job.kind == "curves" and job.target == tmp_path / "g.png"
    job.run()
    assert Image.open(tmp_path / "g.png").size == (32, 32)


@pytest.mark.parametrize(
    ("source", "kwargs", "words"),
    [
        ("scene", {"frames": "0:2"}, "--frames does not apply to a scene"),
        ("scene", {"engine": "cpu", "spp": 4}, "--spp does not apply to --engine cpu"),
        ("scene", {"engine": "mitsuba", "msaa": 4}, "--msaa does not apply to --engine mitsuba"),
        ("scene", {"frames_per_task": 2}, "--frames-per-task: sizes the Dask tasks"),
        ("scene", {"out": "x.jpg"}, "output must end in .png"),
        ("curves", {"count": 5}, "--count does not apply to a curves file"),
        ("cache", {"mesh": "builtin:head"}, "--mesh does not apply to a simulation cache"),
        ("cache", {"engine": "mitsuba"}, "--engine mitsuba renders stills"),
        ("cache", {"frames": "2:9"}, "the cache has 3 frames"),
        ("cache", {"frames": "x"}, "expected START:STOP"),
        ("cache", {"out": "one.png"}, "renders to a folder of frame_0000.png"),
    ],
)
def test_a_render_that_does_not_fit_is_refused_before_any_work(
    scene, tmp_path, sim_cache, source, kwargs, words
):
    sources = {"scene": str(scene), "curves": str(tmp_path / "c.npz"), "cache": str(sim_cache)}
    if source == "curves":
        follicle.plan_grow(str(scene), tmp_path / "c.npz", count=10).run()
    out = kwargs.pop("out", None)
    with pytest.raises(FollicleError, match=words):
        follicle.plan_render(sources[source], None if out is None else tmp_path / out, **kwargs)
    assert not any(p.suffix == ".png" for p in tmp_path.iterdir())


@pytest.fixture(scope="module")
def sim_cache(tmp_path_factory):
    """A 3-frame simulation of 400 hairs, planned and run from Python."""
    folder = tmp_path_factory.mktemp("cache")
    (folder / "scene.toml").write_text(SCENE)
    job = follicle.plan_simulate([str(folder / "scene.toml")], frames=3, fps=12, count=400)
    assert job.targets == (str(folder / "sim.npz"),)
    stages = Stages()
    [(scene, run, path)] = list(job.run(stages))
    assert stages.labels == ["simulating", "saving"] and stages.last["simulating"] == (3, 3)
    assert run.frames == 3 and path == str(folder / "sim.npz") and scene.groom.count == 400
    return folder / "sim.npz"


def test_a_cache_render_draws_the_frames_asked_for(sim_cache, tmp_path):
    job = follicle.plan_render(str(sim_cache), tmp_path / "frames", frames="1:3", size=(24, 20))
    assert job.kind == "cache" and not job.video and job.frames == range(1, 3)
    assert job.outputs == [
        tmp_path / "frames" / "frame_0001.png",
        tmp_path / "frames" / "frame_0002.png",
    ]
    done = job.run()
    assert done.paths == tuple(job.outputs) and done.hairs == 400 and done.size == (24, 20)
    assert sorted(p.name for p in (tmp_path / "frames").iterdir()) == [
        "frame_0001.png",
        "frame_0002.png",
    ]
    assert load_cache(sim_cache).frame_count == 3


def test_several_scenes_simulate_into_a_folder_by_name(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    for path in (tmp_path / "a" / "s.toml", tmp_path / "b" / "s.toml", tmp_path / "t.toml"):
        path.write_text(SCENE)
    job = follicle.plan_simulate(
        [str(tmp_path / "a" / "s.toml"), str(tmp_path / "t.toml")], tmp_path / "caches"
    )
    assert job.targets == (str(tmp_path / "caches" / "s.npz"), str(tmp_path / "caches" / "t.npz"))
    clash = [str(tmp_path / "a" / "s.toml"), str(tmp_path / "b" / "s.toml")]
    with pytest.raises(InputError, match="would both write"):
        follicle.plan_simulate(clash, tmp_path / "caches")
    with pytest.raises(InputError, match="give -o FOLDER"):
        follicle.plan_simulate(clash)
    with pytest.raises(InputError, match="give -o a folder"):
        follicle.plan_simulate(clash, tmp_path / "c.npz")
    skin = follicle.plan_simulate([str(tmp_path / "t.toml")], skin_animation="anim.usdc")
    assert skin.scenes[0].sim.motion == "none"
    assert skin.scenes[0].sim.skin_animation.endswith("anim.usdc")


def test_a_batch_is_planned_variant_by_variant(scene, tmp_path):
    job = follicle.plan_batch(
        [str(scene)],
        tmp_path / "batch",
        vary=["groom.curl_radius=0.002:0.006:3"],
        seeds="5:7",
        count=20,
        curves="usdc",
        image=False,
    )
    assert len(job.variants) == 6 and job.outputs.curves == ".usdc"
    assert [v.seed for v in job.variants[:2]] == [5, 6]
    radii = [v.scene.groom.curl_radius for v in job.variants[::2]]
    assert radii == pytest.approx([0.002, 0.004, 0.006])
    assert {v.scene.groom.count for v in job.variants} == {20}
    none = follicle.plan_batch(
        [], tmp_path / "b2", count=50, curves="none", size=(16, 16), engine="cpu"
    )
    assert none.outputs.curves is None and none.variants[0].source == "default"
    assert none.variants[0].scene.render.size == (16, 16)
    stages = Stages()
    manifest = none.run(stages)
    assert stages.labels == ["making 1 variant"] and manifest.name == "manifest.csv"
    assert (tmp_path / "b2" / "v00000" / "hair.png").exists()

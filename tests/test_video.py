"""MP4 output: write_mp4 (frame count, fps, even sizes, atomic failures) and
`follicle render CACHE -o out.mp4`."""

import numpy as np
import pytest
from click.testing import CliRunner

from follicle.cli import main
from follicle.errors import FollicleError, FormatError, InputError
from follicle.io.sim_cache import save_cache
from follicle.pipeline import simulate_scene
from follicle.render.video import write_mp4
from follicle.scene import parse_scene
from glmark import gl

# imageio-ffmpeg is the optional video extra; the test extra installs it, so CI runs these
imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")


def read_back(path):
    """(metadata, frames as (H, W, 3) uint8) of an MP4."""
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    w, h = meta["size"]
    return meta, [np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in reader]


def greys(n, h=21, w=33):
    return [np.full((h, w, 4), 30 + 40 * i, np.uint8) for i in range(n)]


def test_frames_fps_and_odd_sizes_padded(tmp_path):
    path = write_mp4(iter(greys(5)), tmp_path / "a.mp4", 12.5)
    assert path == tmp_path / "a.mp4"
    meta, frames = read_back(path)
    assert len(frames) == 5
    assert meta["fps"] == 12.5 and meta["codec"] == "h264"
    assert meta["pix_fmt"].startswith("yuv420p")
    assert meta["size"] == (34, 22)  # 33×21 padded by one column and one row
    levels = [float(f.mean()) for f in frames]
    np.testing.assert_allclose(levels, [30 + 40 * i for i in range(5)], atol=3)
    assert [p.name for p in tmp_path.iterdir()] == ["a.mp4"]


def test_even_sizes_kept_and_rgb_accepted(tmp_path):
    frame = np.zeros((16, 24, 3), np.uint8)
    frame[:, 12:] = 200
    meta, frames = read_back(write_mp4([frame] * 2, tmp_path / "b.MP4", 24))
    assert meta["size"] == (24, 16) and len(frames) == 2
    assert frames[0][:, :10].max() < 20 and frames[0][:, 14:].min() > 180


@pytest.mark.parametrize(
    "name, error", [("a.avi", FormatError), ("dir.mp4", FormatError), ("file/x.mp4", FormatError)]
)
def test_bad_paths_fail_and_leave_nothing(tmp_path, name, error):
    (tmp_path / "dir.mp4").mkdir()
    (tmp_path / "file").write_text("not a folder")
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(error) as exc:
        write_mp4(greys(2), tmp_path / name, 24)
    assert isinstance(exc.value, FollicleError)
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert not any((tmp_path / "dir.mp4").iterdir())


@pytest.mark.parametrize(
    "frames, fps, match",
    [
        ([], 24, "no frames"),
        (greys(2), 0, "fps"),
        (greys(2), float("nan"), "fps"),
        (greys(2) + [np.zeros((20, 33, 4), np.uint8)], 24, "frame 2: size 33×20 differs"),
        ([np.zeros((8, 8, 4), np.float32)], 24, "frame 0: expected an .* uint8"),
        ([np.zeros((8, 8), np.uint8)], 24, "frame 0"),
    ],
)
def test_bad_frames_fail_and_leave_nothing(tmp_path, frames, fps, match):
    with pytest.raises(InputError, match=match):
        write_mp4(iter(frames), tmp_path / "v.mp4", fps)
    assert list(tmp_path.iterdir()) == []


SCENE = {
    "guides": {"path": "builtin:short"},
    "groom": {"count": 300},
    "sim": {"motion": "turn", "motion_amplitude": 50, "motion_period": 0.5},
    "render": {"size": [33, 21], "msaa": 0},
}


@pytest.fixture(scope="module")
def cache_path(tmp_path_factory):
    """A 3-frame turn of the head at 12 fps, simulated and saved as a cache."""
    folder = tmp_path_factory.mktemp("video")
    cache, _ = simulate_scene(parse_scene(SCENE, "video test", folder), frames=3, fps=12.0)
    path = folder / "sim.npz"
    save_cache(path, cache.positions, cache.transforms, cache.fps, cache.scene_toml, cache.base_dir)
    return path


def render(*args):
    return CliRunner().invoke(main, ["render", *map(str, args)])


@gl
@pytest.mark.slow
def test_render_cache_to_mp4(cache_path, tmp_path):
    out = tmp_path / "clip" / "anim.mp4"
    result = render(cache_path, "-o", out)
    assert result.exit_code == 0, result.output
    assert result.output.startswith("3 frames (0–2) of 300 hairs, 33×21, ")
    assert result.output.strip().endswith("anim.mp4")
    meta, frames = read_back(out)
    assert len(frames) == 3 and meta["fps"] == 12.0 and meta["size"] == (34, 22)
    assert [p.name for p in out.parent.iterdir()] == ["anim.mp4"]
    assert frames[0].std() > 1  # hair and head on the background, not a blank frame
    assert np.abs(frames[2].astype(int) - frames[0]).mean() > 0.1  # the head turned

    result = render(cache_path, "--frames", "1:", "-o", tmp_path / "part.mp4")
    assert result.exit_code == 0, result.output
    assert len(read_back(tmp_path / "part.mp4")[1]) == 2


@gl
@pytest.mark.slow
def test_render_cache_to_a_folder_named_mp4_fails_cleanly(cache_path, tmp_path):
    (tmp_path / "taken.mp4").mkdir()
    result = render(cache_path, "-o", tmp_path / "taken.mp4")
    assert result.exit_code == 2 and "cannot write the video" in result.output
    assert [p.name for p in tmp_path.iterdir()] == ["taken.mp4"]
    assert not any((tmp_path / "taken.mp4").iterdir())


@pytest.mark.slow
def test_render_cache_to_png_is_refused(cache_path, tmp_path):
    result = render(cache_path, "-o", tmp_path / "a.png")
    assert result.exit_code == 2
    assert "a folder of frame_0000.png, … or to an .mp4 video" in result.output
    assert list(tmp_path.iterdir()) == []

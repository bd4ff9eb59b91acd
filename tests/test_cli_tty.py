"""The follicle command in a real terminal: every command under a pseudo-terminal (where
progress bars draw) finishes with exit 0, draws its bar and prints its result line."""

import pytest

import follicle
from hostile import run_cli, warm

pytestmark = pytest.mark.slow  # every command in a subprocess on a pseudo-terminal

SCENE = '[groom]\ncount = 300\n[guides]\npath = "builtin:short"\n[render]\nsize = [96, 72]\n'


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    warm()
    tmp = tmp_path_factory.mktemp("tty")
    (tmp / "s.toml").write_text(SCENE)
    return tmp


def tty(folder, *args):
    out = run_cli(*args, cwd=folder, tty=True, timeout=300)
    assert not out.timed_out and out.rc == 0, out.stdout[-3000:]
    assert "Traceback" not in out.stdout and "Error" not in out.stdout, out.stdout[-3000:]
    return out.stdout


# (arguments, what the bar says, what the result line says); in order: simulate makes the
# cache that the cache commands read
COMMANDS = [
    (
        ["demo", "--out", "demo", "--count", "400", "--size", "64", "64"],
        "growing hair",
        "400 hairs → demo/demo.png",
    ),
    (["grow", "s.toml", "-o", "h.npz"], "growing hair", "300 hairs"),
    (["settle", "s.toml", "--seconds", "0.2", "-o", "g.npz"], "settling guides", "→ g.npz"),
    (["grow", "s.toml", "-o", "h.hair"], "growing hair", "→ h.hair"),
    (
        ["cards", "s.toml", "-o", "c.glb", "--counts", "30,10,3", "--atlas", "256"],
        "growing hair",
        "→ c.glb",
    ),
    (["render", "s.toml", "-o", "s.png"], "rendering", "→ s.png"),
    (
        ["render", "s.toml", "--engine", "mitsuba", "--spp", "2", "-o", "m.png"],
        "path tracing",
        "→ m.png",
    ),
    (["simulate", "s.toml", "--frames", "3", "-o", "sim.npz"], "simulating", "3 frames at 24 fps"),
    (["render", "sim.npz", "-o", "frames", "--count", "50"], "rendering frames", "3 frames (0–2)"),
    (["render", "sim.npz", "-o", "sim.mp4", "--count", "50"], "rendering frames", "→ sim.mp4"),
    (["export", "sim.npz", "-o", "sim.usda"], "writing frames", "3 frames of"),
    (["export-rib", "s.toml", "-o", "f.rib", "--voxels", "2"], "bounding voxels", "→ f.rib"),
]


@pytest.mark.parametrize("args,bar,result", COMMANDS, ids=[" ".join(c[0][:2]) for c in COMMANDS])
def test_every_command_draws_its_progress_on_a_terminal(folder, args, bar, result):
    shown = tty(folder, *args)
    assert bar in shown, shown[-2000:]
    assert "\x1b[" in shown  # the bar is drawn with terminal control sequences
    assert result in shown, shown[-2000:]


def test_the_outputs_a_terminal_run_writes_are_whole(folder):
    assert follicle.load_curves(folder / "h.npz").curve_count == 300
    assert sorted(p.name for p in (folder / "frames").iterdir()) == [
        f"frame_000{i}.png" for i in range(3)
    ]
    assert not [p for p in folder.rglob(".*") if p.is_file()]  # no temporary file left


def test_a_first_run_says_it_is_compiling(folder, tmp_path):
    """With nothing usable cached (an empty numba cache, and NUMBA_CPU_NAME naming a CPU
    the prebuilt kernels were not built for) the run says what the wait is, on its first
    frame, with the reason; the run is stopped there: compiling everything would take
    minutes. A run with its kernels at hand says nothing of compiling."""
    (tmp_path / "s.toml").write_text(SCENE)
    cache = tmp_path / "numba"
    cache.mkdir()
    out = run_cli(
        "grow",
        "s.toml",
        "-o",
        "h.npz",
        cwd=tmp_path,
        tty=True,
        timeout=20,
        env={"NUMBA_CACHE_DIR": str(cache), "NUMBA_CPU_NAME": "generic"},
    )
    text = " ".join(out.stdout.split())  # the terminal wraps the line
    assert "compiling follicle's kernels for this machine, once" in text, out.stdout[-2000:]
    assert "follicle warm" in text
    warm_run = tty(folder, "grow", "s.toml", "-o", "again.npz")
    assert "growing hair" in warm_run and "compiling" not in warm_run


def _frames(shown: str) -> list[str]:
    """The bar's frames as a terminal shows them: split where rich redraws, control
    sequences removed."""
    import re

    frames = re.split(r"\r|\x1b\[2K|\x1b\[1A", shown)
    return [re.sub(r"\x1b\[[0-9;?]*[a-zA-Z]", "", f).strip() for f in frames]


def test_a_phase_without_a_count_shows_no_count(folder):
    """Before its first count a bar shows its spinner, label and time, not a literal 0
    (issue 46: "growing hair ━━━ 0 0:00:01" while the hairs grew): drawn under a
    pseudo-terminal, every frame of the bar either has done/total or no number between
    the bar and the time."""
    import re

    (folder / "big.toml").write_text(SCENE.replace("count = 300", "count = 20000"))
    frames = [f for f in _frames(tty(folder, "grow", "big.toml", "-o", "big.npz")) if "━" in f]
    # what each frame shows between the bar and the time (a frame may run on into a
    # line printed after it, such as a kernel's compiling note)
    shown = [m[1] for m in (re.search(r"━\s+(.*?)\s*\d+:\d\d:\d\d", f) for f in frames) if m]
    assert len(shown) == len(frames), frames
    assert "20,000/20,000" in shown, frames
    assert "" in shown, frames  # growing 20,000 hairs takes several of rich's 0.1 s frames
    assert [x for x in shown if x and not re.fullmatch(r"[\d,]+/[\d,]+", x)] == [], frames

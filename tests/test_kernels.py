"""follicle's kernel cache (follicle.kernels): what a first run compiles is kept, and a
cache that is damaged, written by another numba or for another CPU, unwritable, or
written by two processes at once is ignored or rebuilt — never a crash, never a wrong
result. Importing follicle imports no numba and compiles nothing.

Each case runs a small module of two kernels in a fresh process (numba keeps what it
loaded for the life of a process), with its own NUMBA_CACHE_DIR; the child prints its
results and how many kernels it compiled rather than loaded.
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from imports import modules_after

MODULE = """
import numpy as np
from follicle.kernels import kernel, prange


@kernel(inline="always")
def _square(x):
    return x * x


@kernel(parallel=True)
def sum_of_squares(values):
    total = 0.0
    for i in prange(values.shape[0]):
        total += _square(values[i])
    return total


@kernel
def scaled(values, k):
    out = np.empty_like(values)
    for i in range(values.shape[0]):
        out[i] = values[i] * k
    return out
"""

CHILD = """
import json, sys
import numpy as np
import kernmod
from follicle.kernels import compile_count
values = np.arange(10.0)
print(json.dumps({
    "sum": kernmod.sum_of_squares(values),
    "scaled": kernmod.scaled(values, 3.0).tolist(),
    "compiled": compile_count(),
}))
"""


def _run(folder: Path, cache: Path, **env: str) -> dict:
    """The child's results, run in ``folder`` (where kernmod.py is) with ``cache``."""
    full = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(folder), **env}
    out = subprocess.run(
        [sys.executable, "-c", CHILD], cwd=folder, env=full, capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr[-3000:]
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result["sum"] == 285.0 and result["scaled"] == [3.0 * i for i in range(10)]
    return {**result, "stderr": out.stderr}


@pytest.fixture
def module(tmp_path: Path) -> Path:
    folder = tmp_path / "mod"
    folder.mkdir()
    (folder / "kernmod.py").write_text(textwrap.dedent(MODULE))
    return folder


def _indexes(cache: Path) -> list[Path]:
    return sorted(cache.rglob("*.nbi"))


@pytest.mark.slow
def test_a_first_run_compiles_says_so_and_a_second_loads(module, tmp_path):
    cache = tmp_path / "cache"
    first = _run(module, cache)
    assert first["compiled"] == 2  # the inlined helper is not compiled on its own
    notice = [line for line in first["stderr"].splitlines() if line.startswith("compiling")]
    assert len(notice) == 1 and "for this machine, once" in notice[0]  # one line, not two
    assert [p.name.split("-")[0] for p in _indexes(cache)] == [
        "kernmod.scaled",
        "kernmod.sum_of_squares",
    ]
    second = _run(module, cache)
    assert second["compiled"] == 0 and "compiling" not in second["stderr"]


@pytest.mark.parametrize("damage", ["truncate", "garbage", "flip"])
@pytest.mark.slow
def test_a_damaged_index_or_data_file_is_compiled_again(module, tmp_path, damage):
    cache = tmp_path / "cache"
    _run(module, cache)
    data = sorted(cache.rglob("kernmod.sum_of_squares*.nbc"))
    index = sorted(cache.rglob("kernmod.scaled*.nbi"))
    assert len(data) == 1 and len(index) == 1
    for path in (data[0], index[0]):
        raw = bytearray(path.read_bytes())
        if damage == "truncate":
            raw = raw[: len(raw) // 2]
        elif damage == "garbage":
            raw = bytearray(os.urandom(len(raw)))
        else:
            raw[len(raw) // 2] ^= 0xFF
        path.write_bytes(bytes(raw))
    again = _run(module, cache)
    assert again["compiled"] == 2  # both rebuilt, right results (checked in _run)
    assert _run(module, cache)["compiled"] == 0  # and kept


@pytest.mark.slow
def test_a_data_file_swapped_for_another_kernels_is_not_run(module, tmp_path):
    """An index entry names its data file by content hash: another kernel's code under
    that name is refused, not run with the wrong arguments."""
    cache = tmp_path / "cache"
    _run(module, cache)
    mine = next(cache.rglob("kernmod.scaled*.nbc"))
    other = next(cache.rglob("kernmod.sum_of_squares*.nbc"))
    mine.write_bytes(other.read_bytes())
    assert _run(module, cache)["compiled"] == 1


@pytest.mark.slow
def test_another_numba_version_or_cpu_is_not_loaded(module, tmp_path):
    cache = tmp_path / "cache"
    _run(module, cache)
    for index in _indexes(cache):
        head, stamp, entries = pickle.loads(index.read_bytes())
        index.write_bytes(pickle.dumps(((*head[:2], "0.1.0"), stamp, entries)))
    assert _run(module, cache)["compiled"] == 2  # another numba's: ignored, rewritten
    generic = _run(module, cache, NUMBA_CPU_NAME="generic")
    assert generic["compiled"] == 2  # another CPU: compiled for it, beside this one's
    assert _run(module, cache)["compiled"] == 0
    assert _run(module, cache, NUMBA_CPU_NAME="generic")["compiled"] == 0


@pytest.mark.slow
def test_an_edited_source_is_compiled_again(module, tmp_path):
    cache = tmp_path / "cache"
    _run(module, cache)
    source = module / "kernmod.py"
    source.write_text(source.read_text() + "\n# edited\n")
    assert _run(module, cache)["compiled"] == 2


@pytest.mark.slow
def test_an_unwritable_cache_folder_falls_back_to_one_that_is(module, tmp_path):
    """NUMBA_CACHE_DIR under a file cannot be made: the kernels go beside the source
    (``__pycache__``); where that cannot be made either, to the user's cache folder."""
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    cache = blocker / "cache"
    assert _run(module, cache)["compiled"] == 2
    assert _indexes(module / "__pycache__")
    assert _run(module, cache)["compiled"] == 0
    for path in (module / "__pycache__").iterdir():
        path.unlink()
    (module / "__pycache__").rmdir()
    (module / "__pycache__").write_text("a file where the folder would go")
    home = tmp_path / "home"
    env = {"HOME": str(home), "XDG_CACHE_HOME": str(home / ".cache")}
    assert _run(module, cache, **env)["compiled"] == 2
    assert _indexes(home / ".cache")
    assert _run(module, cache, **env)["compiled"] == 0


@pytest.mark.slow
def test_two_processes_compiling_at_once_leave_one_good_cache(module, tmp_path):
    cache = tmp_path / "cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(module)}
    children = [
        subprocess.Popen(
            [sys.executable, "-c", CHILD], cwd=module, env=env, stdout=subprocess.PIPE, text=True
        )
        for _ in range(3)
    ]
    for child in children:
        out, _ = child.communicate(timeout=600)
        assert child.returncode == 0
        assert json.loads(out.strip().splitlines()[-1])["sum"] == 285.0
    assert _run(module, cache)["compiled"] == 0
    assert not list(cache.rglob("*.tmp*")) and not [p for p in cache.rglob(".*.nbi.*")]


@pytest.mark.slow
def test_import_follicle_and_help_load_no_heavy_library():
    assert modules_after("import follicle; follicle.HairCurves; follicle.render") == []
    help_ = (
        "from follicle.cli import main\n"
        "try:\n    main.main(['--help'], prog_name='follicle')\nexcept SystemExit:\n    pass"
    )
    assert modules_after(help_) == []
    # `follicle --help` lists the commands: no settings model, no array is needed for that
    assert modules_after(help_, ("numpy", "pydantic", "scipy", "trimesh")) == []
    for command in ("grow", "render", "simulate", "view", "export", "warm"):
        sub = help_.replace("['--help']", f"[{command!r}, '--help']")
        assert modules_after(sub) == [], command


@pytest.mark.slow
def test_importing_every_module_compiles_nothing_and_loads_no_numba():
    """No kernel runs at import: every module of follicle imported, no dispatcher made."""
    code = textwrap.dedent(
        """
        import importlib, pkgutil, follicle
        skip = ("follicle.__main__", "follicle.prebuild.__main__", "follicle.kernels.cache")
        for info in pkgutil.walk_packages(follicle.__path__, "follicle."):
            if info.name not in skip:
                importlib.import_module(info.name)
        from follicle.kernels import KERNELS
        assert len(KERNELS) > 150, len(KERNELS)
        made = [k.__qualname__ for k in KERNELS if k._dispatcher is not None]
        assert not made, made
        """
    )
    heavy = modules_after(code)
    assert "numba" not in heavy and "llvmlite" not in heavy, heavy


def test_a_package_kernel_is_kept_for_all_the_package_sources(tmp_path):
    """A kernel inlines what it calls from other files: for the package's kernels the
    index's stamp covers every source, so editing a callee's file compiles the caller
    again; another module's kernel is kept for its own file."""
    from follicle.kernels.cache import PACKAGE, kernel_stamp, source_digest, sources_digest

    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    caller, callee = package / "caller.py", package / "sub" / "callee.py"
    caller.write_text("from .sub.callee import f\n")
    callee.write_text("def f(x):\n    return x\n")
    before = kernel_stamp(str(caller), package)
    assert before == sources_digest(package)
    callee.write_text("def f(x):\n    return 2 * x\n")
    from follicle.kernels import cache

    cache._package_digest.cache_clear()  # a new process reads the sources again
    assert kernel_stamp(str(caller), package) != before
    outside = tmp_path / "kernmod.py"
    outside.write_text("x = 1\n")
    assert kernel_stamp(str(outside), package) == source_digest(str(outside))
    own = PACKAGE / "render" / "cpu" / "steps.py"
    assert kernel_stamp(str(own)) == sources_digest(PACKAGE)

"""Imports run one way, downwards (docs/architecture.md, Layers): no module imports a
layer above its own, at module level or inside a function, and within one layer the
packages import each other without cycles."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest

import follicle

ROOT = Path(follicle.__file__).parent
# lowest first; a module may import its own layer and those below it
LAYERS = [
    {
        "errors",
        "arrays",
        "settings",
        "validate",
        "inputs",
        "atomic",
        "units",
        "curves",
        "spline",
        "frames",
        "noise",
        "color",
        "melanin",
        "rng",
        "threads",
        "kernels",
        "lazy",
        "progress",
        "docs_location",  # where the docs are (the CLI's `follicle docs`): imports nothing of ours
    },
    {"mesh"},
    {"io"},
    {"groom", "sim", "render"},
    # editing: guides brushed through a camera (groom and render); cards: hair baked into
    # an atlas by the CPU engine's strand kernels (render)
    {"scene", "editing", "cards"},
    {"pipeline", "distributed", "export", "render_job", "simulate_job"},
    {"cli", "view", "apps", "__init__", "__main__"},
    {"prebuild"},  # runs the commands (cli) to compile every kernel; started as a process
]
# a string naming a follicle module, alone or as "module:attribute" (the lazy tables of
# follicle/__init__.py, follicle.render and the format and engine registries)
LAZY_NAME = re.compile(r"(?P<module>follicle(\.[a-z_0-9]+)+)(:[A-Za-z_][A-Za-z_0-9]*)?")
LAYER = {name: k for k, names in enumerate(LAYERS) for name in names}


def _unit(module: Path) -> str:
    """The layer unit of a module: its package under follicle/, or its own name."""
    rel = module.relative_to(ROOT)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _imports(module: Path, stub: bool = True) -> list[tuple[list[str], list[str]]]:
    """What ``module`` imports of follicle anywhere in its body (relative or absolute, or
    a string naming a module, which importlib imports; with ``stub``, also the imports
    of its ``.pyi`` stub, the names it imports lazily on first use): (the path under
    follicle/, the names imported from it) for each import. A module a process is
    started with (``[python, "-m", "follicle.prebuild"]``) is not imported."""
    sources = [module, module.with_suffix(".pyi")] if stub else [module]
    trees = [ast.parse(source.read_text("utf-8")) for source in sources if source.is_file()]
    package = list(module.relative_to(ROOT).parts[:-1])
    started = {  # the string after "-m" in a command line
        id(after)
        for tree in trees
        for node in ast.walk(tree)
        if isinstance(node, ast.List)
        for before, after in zip(node.elts, node.elts[1:], strict=False)
        if isinstance(before, ast.Constant) and before.value == "-m"
    }
    out = []
    for node in (node for tree in trees for node in ast.walk(tree)):
        if isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the module's package
                base = package[: len(package) - (node.level - 1)]
                parts = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "follicle":
                parts = node.module.split(".")[1:]
            else:
                continue
            out.append((parts, [alias.name for alias in node.names]))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == "follicle" and len(parts) > 1:
                    out.append((parts[1:], []))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            named = LAZY_NAME.fullmatch(node.value)
            if named and id(node) not in started:
                out.append((named["module"].split(".")[1:], []))
    return out


def _imported_units(module: Path) -> set[str]:
    """The units ``module`` imports (`from . import x` at the top: x is the unit)."""
    out = set()
    for parts, names in _imports(module):
        out.update([parts[0]] if parts else names)
    return out


def _is_module(parts: list[str]) -> bool:
    path = ROOT.joinpath(*parts)
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def _module_name(module: Path) -> str:
    """``render.cpu.engine`` for follicle/render/cpu/engine.py, ``render`` for its
    package's __init__.py."""
    parts = module.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported_modules(module: Path) -> set[str]:
    """The modules ``module`` imports: `from .x import y` imports x, or x.y where y is
    a module."""
    out = set()
    for parts, names in _imports(module, stub=False):  # a stub's imports wait for use
        base = list(parts)
        while base and not _is_module(base):  # `from .x.f import g`: f is not a module
            base.pop()
        for name in names or [""]:
            sub = [*base, name]
            out.add(".".join(sub if name and base == parts and _is_module(sub) else base))
    return out - {"", _module_name(module)}


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle of ``graph`` (its nodes in order, the first repeated last), or []."""
    state: dict[str, int] = {}  # 1 on the current path, 2 done

    def visit(node: str, path: list[str]) -> list[str]:
        state[node] = 1
        for other in sorted(graph.get(node, ())):
            if state.get(other) == 1:
                return [*path[path.index(other) :], other] if other in path else [other]
            if other not in state:
                found = visit(other, [*path, other])
                if found:
                    return found
        state[node] = 2
        return []

    for node in sorted(graph):
        if node not in state:
            found = visit(node, [node])
            if found:
                return found
    return []


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for module in ROOT.rglob("*.py"):
        unit = _unit(module)
        graph.setdefault(unit, set()).update(_imported_units(module) - {unit})
    return graph


@pytest.mark.slow
def test_every_unit_has_a_layer():
    assert set(_graph()) <= set(LAYER), sorted(set(_graph()) - set(LAYER))


@pytest.mark.slow
def test_no_import_runs_up_a_layer():
    upward = [
        f"{unit} → {other}"
        for unit, imports in sorted(_graph().items())
        for other in sorted(imports)
        if other in LAYER and LAYER[other] > LAYER[unit]
    ]
    assert upward == []


@pytest.mark.slow
def test_packages_of_one_layer_import_each_other_without_a_cycle():
    graph = _graph()
    seen: dict[str, int] = {}  # 1 on the current path, 2 done

    def visit(unit: str, path: list[str]) -> None:
        seen[unit] = 1
        for other in sorted(graph.get(unit, ())):
            if LAYER.get(other) != LAYER.get(unit):
                continue
            assert seen.get(other) != 1, " → ".join([*path, unit, other])
            if other not in seen:
                visit(other, [*path, unit])
        seen[unit] = 2

    for unit in sorted(graph):
        if unit not in seen:
            visit(unit, [])


def test_the_check_sees_an_upward_import(tmp_path, monkeypatch):
    """The walk finds a function-level import of a higher layer (it is not vacuous)."""
    fake = tmp_path / "follicle"
    (fake / "mesh").mkdir(parents=True)
    (fake / "mesh" / "skin.py").write_text("def f():\n    from ..pipeline import groom_scene\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", fake)
    assert _graph() == {"mesh": {"pipeline"}}
    assert LAYER["pipeline"] > LAYER["mesh"]


def _module_graph() -> dict[str, set[str]]:
    return {_module_name(m): _imported_modules(m) for m in ROOT.rglob("*.py")}


@pytest.mark.slow
def test_no_modules_import_each_other_in_a_cycle():
    """Not even two modules of one package, nor through an import inside a function."""
    assert _cycle(_module_graph()) == []


def test_the_check_sees_a_cycle_within_a_package(tmp_path, monkeypatch):
    fake = tmp_path / "follicle"
    (fake / "groom").mkdir(parents=True)
    (fake / "groom" / "__init__.py").write_text("")
    (fake / "groom" / "editor.py").write_text("from .strokes import load\n")
    (fake / "groom" / "strokes.py").write_text("def f():\n    from .editor import Editor\n")
    (fake / "groom" / "guides.py").write_text("from follicle.groom import editor\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", fake)
    assert _module_graph() == {
        "groom": set(),
        "groom.editor": {"groom.strokes"},
        "groom.strokes": {"groom.editor"},
        "groom.guides": {"groom.editor"},
    }
    assert _cycle(_module_graph()) == ["groom.editor", "groom.strokes", "groom.editor"]

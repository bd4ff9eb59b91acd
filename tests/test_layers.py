"""Imports run one way, downwards (docs/architecture.md, Layers): no module imports a
layer above its own, at module level or inside a function, and within one layer the
packages import each other without cycles."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

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
        "rng",
        "threads",
        "kernels",
    },
    {"mesh"},
    {"io"},
    {"groom", "sim", "render"},
    {"scene"},
    {"pipeline", "distributed", "distributed_sim", "distributed_export", "batch"},
    {"cli", "view", "apps", "__init__"},
    {"prebuild"},  # runs the commands (cli) to compile every kernel; started as a process
]
LAYER = {name: k for k, names in enumerate(LAYERS) for name in names}


def _unit(module: Path) -> str:
    """The layer unit of a module: its package under follicle/, or its own name."""
    rel = module.relative_to(ROOT)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _imported_units(module: Path) -> set[str]:
    """The units ``module`` imports anywhere in its body (relative or absolute)."""
    tree = ast.parse(module.read_text("utf-8"))
    package = module.relative_to(ROOT).parts[:-1]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the module's package
                base = list(package[: len(package) - (node.level - 1)])
                parts = base + (node.module.split(".") if node.module else [])
                if not parts:  # `from . import x` at the top: x is the unit
                    out.update(alias.name for alias in node.names)
                    continue
            elif node.module and node.module.split(".")[0] == "follicle":
                parts = node.module.split(".")[1:]
                if not parts:
                    out.update(alias.name for alias in node.names)
                    continue
            else:
                continue
            out.add(parts[0])
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == "follicle" and len(parts) > 1:
                    out.add(parts[1])
    return out


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for module in ROOT.rglob("*.py"):
        unit = _unit(module)
        graph.setdefault(unit, set()).update(_imported_units(module) - {unit})
    return graph


def test_every_unit_has_a_layer():
    assert set(_graph()) <= set(LAYER), sorted(set(_graph()) - set(LAYER))


def test_no_import_runs_up_a_layer():
    upward = [
        f"{unit} → {other}"
        for unit, imports in sorted(_graph().items())
        for other in sorted(imports)
        if other in LAYER and LAYER[other] > LAYER[unit]
    ]
    assert upward == []


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

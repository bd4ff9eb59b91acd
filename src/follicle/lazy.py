"""Lazy package attributes read from the package's type stub (scikit-image's
``lazy_loader.attach_stub`` pattern).

A package's ``__init__.pyi`` lists its public names as imports (``from .curves import
HairCurves as HairCurves``): type checkers and editors read it as the package's
interface, and :func:`attach_stub` reads the same lines to import each name on its first
use, so ``import follicle`` loads none of numba, USD, Alembic, OpenGL or Dask, and the
stub cannot drift from what the package serves.
"""

from __future__ import annotations

import ast
import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["attach_stub"]


def _stub_names(package: str, stub: Path) -> dict[str, str]:
    """``{name: module}`` of every ``from .x import name as name`` in ``stub`` (relative
    imports resolved against ``package``); ``import .x as x`` style submodules too."""
    names: dict[str, str] = {}
    for node in ast.parse(stub.read_text("utf-8")).body:
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            module = f"{package}.{node.module}" if node.module else package
            for alias in node.names:
                names[alias.asname or alias.name] = (
                    module if node.module else f"{package}.{alias.name}"
                )
    return names


def attach_stub(
    package: str, init_file: str
) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """``(__getattr__, __dir__, __all__)`` for ``package``, whose ``__init__.py`` is
    ``init_file``: the names its ``__init__.pyi`` imports, each imported on first use and
    kept in the package's namespace. A name imported ``from . import sub`` is the
    submodule ``sub``."""
    names = _stub_names(package, Path(init_file).with_suffix(".pyi"))
    submodules = {name for name, module in names.items() if module == f"{package}.{name}"}

    def __getattr__(name: str) -> Any:  # noqa: N807 (a module's __getattr__)
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = importlib.import_module(names[name])
        value = module if name in submodules else getattr(module, name)
        vars(importlib.import_module(package))[name] = value
        return value

    public = [name for name in names if name not in submodules]

    def __dir__() -> list[str]:  # noqa: N807
        return sorted({*public, *submodules})

    return __getattr__, __dir__, public

"""follicle's build backend: setuptools', with the prebuilt kernels in a wheel.

A wheel carries follicle's numba kernels compiled for a CPU level (``setup.py``'s
``build_py`` runs ``python -m follicle.prebuild build``), so that a fresh install
compiles nothing on first use. Compiling them runs follicle, so a wheel's build needs
follicle's own dependencies; an editable install or an sdist does not compile anything
and needs only setuptools. ``FOLLICLE_KERNELS=0`` builds a wheel without kernels
(pure Python, compiled on first use).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import *  # noqa: F401,F403 - sdist, editable and metadata hooks

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib


def _dependencies() -> list[str]:
    project = tomllib.loads(Path("pyproject.toml").read_text(encoding="utf-8"))["project"]
    return list(project["dependencies"])


def get_requires_for_build_wheel(config_settings: dict | None = None) -> list[str]:
    needs = list(_setuptools.get_requires_for_build_wheel(config_settings))
    if os.environ.get("FOLLICLE_KERNELS") != "0":
        needs += _dependencies()
    return needs

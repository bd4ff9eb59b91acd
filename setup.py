"""setuptools commands for the prebuilt kernels, and the package's description; the
project's metadata is in pyproject.toml.

The description is README.md with its relative links made absolute
(``build_support/readme_links.py``): a package index shows it without the repository
around it (pyproject's ``dynamic = ["readme"]``).

``build_py`` compiles follicle's numba kernels into the wheel (``follicle/_kernels``, by
``python -m follicle.prebuild build`` run on the copied sources), or copies the source
tree's ``src/follicle/_kernels`` when it was built for these very sources, numba, Python
and CPU levels (``python -m follicle.prebuild build``; the tests' set-up makes it). Not
for an editable install, nor with ``FOLLICLE_KERNELS=0``. A wheel with kernels is tied to
this Python and machine, and says so in its tags.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "build_support"))
from readme_links import long_description  # noqa: E402  (build_support/ is not a package)


def _kernels_wanted() -> bool:
    return os.environ.get("FOLLICLE_KERNELS") != "0"


class BuildWithKernels(build_py):
    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False) or not _kernels_wanted():
            return
        lib = Path(self.build_lib).resolve()
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [str(lib), os.environ.get("PYTHONPATH")])),
        }
        subprocess.run(
            [
                sys.executable,
                "-m",
                "follicle.prebuild",
                "build",
                str(lib / "follicle" / "_kernels"),
                "--reuse",
                str(HERE / "src" / "follicle" / "_kernels"),
            ],
            env=env,
            check=True,
        )


class WithKernels(Distribution):
    """Machine code inside, as with an extension module: the wheel is installed into
    platlib and tagged for this Python and platform (cpXY-cpXY-<platform>)."""

    def has_ext_modules(self) -> bool:
        return _kernels_wanted()


setup(
    cmdclass={"build_py": BuildWithKernels},
    distclass=WithKernels,
    long_description=long_description(HERE),
    long_description_content_type="text/markdown",
)

"""follicle: grow, simulate and render hair and fur.

The public API, imported lazily so that ``import follicle`` stays quick (no numba,
USD, Alembic, OpenGL or Dask until they are used)::

    mesh = follicle.load_mesh("builtin:head")
    guides = follicle.load_guides("builtin:long", mesh)
    curves = follicle.Groom(mesh, guides).generate(count=20000)
    follicle.render_image(curves, mesh=mesh, out="hair.png")
    follicle.save(curves, "hair.npz")

The names and the modules they come from are listed once, in ``__init__.pyi``
(:mod:`follicle.lazy`); the errors are imported at once (every layer raises them).
"""

from __future__ import annotations

from .errors import ConfigError as ConfigError
from .errors import FileAccessError as FileAccessError
from .errors import FollicleError as FollicleError
from .errors import FormatError as FormatError
from .errors import InputError as InputError
from .errors import ResourceError as ResourceError
from .errors import SimulationError as SimulationError
from .lazy import attach_stub

__version__ = "0.1.0"

__getattr__, __dir__, __all__ = attach_stub(__name__, __file__)

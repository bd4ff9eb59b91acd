"""follicle: grow, simulate and render hair and fur."""

from .curves import HairCurves
from .errors import ConfigError, FollicleError, FormatError, InputError

__version__ = "0.1.0"
__all__ = ["HairCurves", "FollicleError", "InputError", "FormatError", "ConfigError"]

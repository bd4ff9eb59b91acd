"""follicle's own strand rasterizer, the CPU engine (see :mod:`.engine`)."""

from .engine import CpuRenderer

__all__ = ["CpuRenderer"]

"""Rendering: camera and lights, the OpenGL and CPU hair engines, PNG output."""

from .camera import Camera, Light, default_lights, fit_camera, frame_camera
from .cpu import CpuRenderer
from .engines import make_renderer, render
from .image import linear_to_srgb, save_png, srgb_to_linear
from .opengl import Renderer

__all__ = [
    "render",
    "Camera",
    "Light",
    "Renderer",
    "CpuRenderer",
    "make_renderer",
    "default_lights",
    "fit_camera",
    "frame_camera",
    "save_png",
    "linear_to_srgb",
    "srgb_to_linear",
]

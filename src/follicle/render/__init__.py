"""Rendering: camera and lights, the OpenGL hair renderer, PNG output."""

from .camera import Camera, Light, default_lights, frame_camera
from .image import linear_to_srgb, save_png, srgb_to_linear
from .opengl import Renderer, render

__all__ = [
    "render",
    "Camera",
    "Light",
    "Renderer",
    "default_lights",
    "frame_camera",
    "save_png",
    "linear_to_srgb",
    "srgb_to_linear",
]

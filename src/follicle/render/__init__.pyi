# follicle.render's names: what type checkers see, and the table follicle/render/__init__.py
# imports each from on its first use (follicle.lazy).
from .backends import render_image as render_image
from .camera import Camera as Camera
from .camera import Light as Light
from .camera import default_lights as default_lights
from .camera import fit_camera as fit_camera
from .camera import frame_camera as frame_camera
from .cpu import CpuRenderer as CpuRenderer
from .engines import make_renderer as make_renderer
from .image import linear_to_srgb as linear_to_srgb
from .image import save_png as save_png
from .image import srgb_to_linear as srgb_to_linear
from .opengl import Renderer as Renderer

# The public API of follicle: what type checkers and editors see, and the table
# follicle/__init__.py imports each name from on its first use (follicle.lazy).
from . import cards as cards
from . import render as render
from .curves import HairCurves as HairCurves
from .distributed.batch import plan_batch as plan_batch
from .editing.editor import GuideEditor as GuideEditor
from .errors import ConfigError as ConfigError
from .errors import FileAccessError as FileAccessError
from .errors import FollicleError as FollicleError
from .errors import FormatError as FormatError
from .errors import InputError as InputError
from .errors import ResourceError as ResourceError
from .errors import SimulationError as SimulationError
from .export import plan_export as plan_export
from .export import plan_grow as plan_grow
from .export import plan_settle as plan_settle
from .groom.generator import Groom as Groom
from .groom.guides import Guides as Guides
from .groom.guides import load_guides as load_guides
from .groom.starter import generate_guides as generate_guides
from .io.dispatch import load_curves as load_curves
from .io.dispatch import save as save
from .io.mesh_load import load_mesh as load_mesh
from .mesh.displacement import displace as displace
from .mesh.property import PropertyMap as PropertyMap
from .mesh.sampling import DensitySampler as DensitySampler
from .mesh.skin import SkinMesh as SkinMesh
from .mesh.texture import Texture as Texture
from .pipeline import grow as grow
from .render.backends import render_image as render_image
from .render.camera import Camera as Camera
from .render.camera import Light as Light
from .render_job import plan_render as plan_render
from .scene import Scene as Scene
from .scene import load_scene as load_scene
from .sim.simulator import Simulator as Simulator
from .simulate_job import plan_simulate as plan_simulate

__version__: str

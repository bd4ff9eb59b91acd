"""The interactive viewer: live simulation and rendering of a scene with a parameter
panel (``follicle view``). :class:`Controller` holds the state and actions without a
window; :func:`view` runs the loop in a GLFW window with an ImGui panel, or offscreen."""

from .app import view
from .controller import Controller

__all__ = ["Controller", "view"]

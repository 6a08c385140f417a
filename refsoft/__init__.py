"""refsoft: the CPU reference implementation of curved-mirror reflections by per-vertex
reflection-point search in screen space (Estalella et al., EGSR 2006)."""

from .camera import Camera
from .errors import CameraError, LimitError, MeshError, RefsoftError, SceneError
from .mesh import Mesh, load_mesh
from .scene import Animation, Scene, SceneObject, Transform
from .scenes import builtin_names, load_scene
from . import primitives, raster, search
from .render import FrameDriver, RenderOptions, render  # noqa: E402  (the function shadows the module name,
from .truth import TruthRenderer, truth  # noqa: E402     as refsoft.render(...) is the API; import submodules by name)

__version__ = "0.1.0"

__all__ = ["Camera", "Mesh", "Scene", "SceneObject", "Transform", "Animation", "load_scene", "load_mesh",
           "builtin_names", "primitives", "raster", "RefsoftError", "SceneError", "MeshError",
           "CameraError", "LimitError", "search", "render", "RenderOptions", "FrameDriver", "truth",
           "TruthRenderer", "__version__"]

"""refsoft: the CPU reference implementation of curved-mirror reflections by per-vertex
reflection-point search in screen space (Estalella et al., EGSR 2006).

The packages follow the pipeline: :mod:`refsoft.scene` (input), :mod:`refsoft.raster` (the exact
rasterizer), :mod:`refsoft.search` (the vertex-search reflection method), :mod:`refsoft.frame`
(the frame driver and its outputs), :mod:`refsoft.truth` (ray-traced truth and metrics),
:mod:`refsoft.conformance` (golden set and checks for ports), :mod:`refsoft.bench` and
:mod:`refsoft.cli`.
"""

from .errors import CameraError, LimitError, MeshError, RefsoftError, SceneError
from .scene import (Animation, Camera, Mesh, Scene, SceneObject, Transform, builtin_names, load_mesh, load_scene,
                    primitives)
from . import raster, search
from .frame import FrameDriver, render
from .options import RenderOptions
from .truth import TruthRenderer, render_truth

__version__ = "0.1.0"

__all__ = ["Camera", "Mesh", "Scene", "SceneObject", "Transform", "Animation", "load_scene", "load_mesh",
           "builtin_names", "primitives", "raster", "RefsoftError", "SceneError", "MeshError",
           "CameraError", "LimitError", "search", "render", "RenderOptions", "FrameDriver", "render_truth",
           "TruthRenderer", "__version__"]

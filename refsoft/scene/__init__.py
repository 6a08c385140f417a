"""Scene input (spec section 3): cameras, meshes, procedural primitives, the scene model with
its keyframed animation, TOML scene files, loader subdivision of long triangles and the built-in
scenes.

Everything downstream reads a :class:`Scene`: its objects' world meshes at a frame
(:meth:`Scene.world_mesh`) and its camera at a frame (:meth:`Scene.camera_at`).
"""

from . import primitives
from .builtin import BUILTIN_SCENES, builtin_names, load_scene
from .camera import Camera
from .mesh import Mesh, load_mesh
from .model import Animation, Scene, SceneObject, Transform, scene_vertices
from .subdivide import apply_subdivision, counts_before_after

__all__ = ["Camera", "Mesh", "load_mesh", "Scene", "SceneObject", "Transform", "Animation", "primitives",
           "load_scene", "builtin_names", "BUILTIN_SCENES", "scene_vertices", "apply_subdivision",
           "counts_before_after"]

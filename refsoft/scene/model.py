"""The scene model: objects, camera and optional keyframed animation (spec section 3).

Object ids are 1-based in scene order (0 is the background). An object's world mesh at a frame
is its local mesh under ``translate @ rotate @ scale``, where the rotation is XYZ Euler angles in
degrees: about x first, then y, then z (``R = Rz @ Ry @ Rx``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .camera import Camera
from .. import linalg, validate
from ..errors import SceneError
from .mesh import Mesh


def euler_xyz_matrix(rotate_deg) -> np.ndarray:
    """Rotation matrix, shape (3, 3), for XYZ Euler angles in degrees (x applied first)."""
    ax, ay, az = np.radians(np.asarray(rotate_deg, dtype=np.float64))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return linalg.matmul(linalg.matmul(rz, ry), rx)


@dataclass(frozen=True)
class Transform:
    """Scale, then XYZ Euler rotation, then translation."""

    translate: tuple = (0.0, 0.0, 0.0)
    rotate_deg: tuple = (0.0, 0.0, 0.0)
    scale: tuple = (1.0, 1.0, 1.0)

    def __post_init__(self):
        t = np.asarray(self.translate, dtype=np.float64)
        r = np.asarray(self.rotate_deg, dtype=np.float64)
        s = np.broadcast_to(np.asarray(self.scale, dtype=np.float64), (3,)).copy()
        for name, arr in (("translate", t), ("rotate_deg", r), ("scale", s)):
            if arr.shape != (3,) or not np.all(np.isfinite(arr)):
                raise SceneError(f"transform {name} must be 3 finite numbers, got {np.asarray(arr).tolist()}")
        if np.any(s <= 0):
            raise SceneError(f"transform scale must be positive, got {s.tolist()}")
        object.__setattr__(self, "translate", tuple(t))
        object.__setattr__(self, "rotate_deg", tuple(r))
        object.__setattr__(self, "scale", tuple(s))

    def matrix(self) -> np.ndarray:
        """The 4x4 affine matrix ``T @ R @ S``, float64."""
        m = np.eye(4)
        m[:3, :3] = linalg.matmul(euler_xyz_matrix(self.rotate_deg), np.diag(self.scale))
        m[:3, 3] = self.translate
        return m


@dataclass(frozen=True, eq=False)
class SceneObject:
    """One object of a scene.

    Parameters
    ----------
    name : str
    mesh : Mesh
        Local-space mesh (drawn; stencilled when a reflector).
    color : tuple of 3 floats in [0, 1]
    transform : Transform
    reflector : bool
    closed_proxy : Mesh, optional
        Watertight mesh for the G-buffer and the search of an open reflector.
    reflectivity : float
        Blend weight of the virtual scene at this reflector's pixels (spec section 5).
    open : bool
        Search an open reflector's own mesh (a flat mirror, the inside of a bowl). An open
        reflector needs either this or a ``closed_proxy`` (Estalella section 5.3): without
        either, an open mesh is most likely a modelling mistake, and is refused.
    subdivide : float, optional
        Loader subdivision: split triangles until no edge is longer than this many world units
        (:func:`refsoft.scene.subdivide.apply_subdivision`, applied when a scene is loaded).
        None or 0: off.
    source_counts : tuple of 2 ints, optional
        (vertices, triangles) of the mesh as given, set when it has been subdivided.
    """

    name: str
    mesh: Mesh
    color: tuple = (0.8, 0.8, 0.8)
    transform: Transform = field(default_factory=Transform)
    reflector: bool = False
    closed_proxy: Mesh | None = None
    reflectivity: float = 1.0
    open: bool = False
    subdivide: float | None = None
    source_counts: tuple | None = None

    def __post_init__(self):
        c = np.asarray(self.color, dtype=np.float64)
        if c.shape != (3,) or not np.all(np.isfinite(c)) or np.any(c < 0) or np.any(c > 1):
            raise SceneError(f"object {self.name!r}: color must be 3 numbers in [0, 1], got {np.asarray(self.color).tolist()}")
        object.__setattr__(self, "color", tuple(c))
        if not validate.is_flag(self.reflector):
            raise SceneError(f"object {self.name!r}: reflector must be true or false")
        if not (isinstance(self.reflectivity, (int, float)) and 0.0 <= self.reflectivity <= 1.0):
            raise SceneError(f"object {self.name!r}: reflectivity must be in [0, 1], got {self.reflectivity!r}")
        if self.closed_proxy is not None and not self.reflector:
            raise SceneError(f"object {self.name!r}: closed_proxy given but the object is not a reflector")
        if not validate.is_flag(self.open):
            raise SceneError(f"object {self.name!r}: open must be true or false")
        if self.open and not self.reflector:
            raise SceneError(f"object {self.name!r}: open is only for reflectors")
        sub = self.subdivide
        if sub is not None:
            if not validate.is_number(sub) or sub < 0:
                raise SceneError(f"object {self.name!r}: subdivide must be a finite number >= 0 (0 = off), got {sub!r}")
            object.__setattr__(self, "subdivide", float(sub))
        if self.source_counts is not None:
            c = self.source_counts
            if (not isinstance(c, tuple) or len(c) != 2
                    or not all(validate.is_integer(x) and x > 0 for x in c)):
                raise SceneError(f"object {self.name!r}: source_counts must be (vertices, triangles), got {c!r}")
            object.__setattr__(self, "source_counts", (int(c[0]), int(c[1])))
        if self.closed_proxy is not None:
            n = self.closed_proxy.boundary_edges()
            if n:
                raise SceneError(f"object {self.name!r}: closed_proxy is not closed ({n} boundary edges)")
        elif self.reflector and not self.open:
            n = self.mesh.boundary_edges()
            if n:
                raise SceneError(f"object {self.name!r}: the reflector is an open mesh ({n} boundary edges) with no "
                                 "closed_proxy; give one, or set open = true to search the open mesh itself")


@dataclass(frozen=True)
class Animation:
    """Keyframed animation of the camera and object transforms, linear between keys.

    Parameters
    ----------
    frames : int
        Number of frames.
    camera_keys : list of (int, dict)
        ``(frame, {"eye": ..., "target": ..., "up": ..., "fov_y": ...})``; missing fields keep
        the scene camera's. Frames strictly increasing.
    object_keys : dict of str -> list of (int, Transform)
        Per object name, keyframed transforms.
    """

    frames: int = 1
    camera_keys: tuple = ()
    object_keys: dict = field(default_factory=dict)

    def __post_init__(self):
        if not validate.is_integer(self.frames) or self.frames < 1:
            raise SceneError(f"animation frames must be a positive integer, got {self.frames!r}")
        for what, keys in [("camera", self.camera_keys)] + [(f"object {k!r}", v) for k, v in self.object_keys.items()]:
            frames = [k[0] for k in keys]
            if any(not validate.is_integer(f) for f in frames):
                raise SceneError(f"animation {what}: key frames must be integers")
            if any(f < 0 or f >= self.frames for f in frames):
                raise SceneError(f"animation {what}: key frames must be in [0, {self.frames - 1}], got {frames}")
            if any(b <= a for a, b in zip(frames, frames[1:])):
                raise SceneError(f"animation {what}: key frames must be strictly increasing, got {frames}")


def _interp_keys(keys, frame, lerp):
    """Value at ``frame`` from sorted (frame, value) keys: clamped at the ends, linear between."""
    if frame <= keys[0][0]:
        return keys[0][1]
    if frame >= keys[-1][0]:
        return keys[-1][1]
    for (f0, a), (f1, b) in zip(keys, keys[1:]):
        if f0 <= frame <= f1:
            return lerp(a, b, (frame - f0) / (f1 - f0))
    raise AssertionError("unreachable")  # pragma: no cover


def _lerp(a, b, t):
    return (1.0 - t) * np.asarray(a, dtype=np.float64) + t * np.asarray(b, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Scene:
    """Objects, a camera, and an optional animation.

    Parameters
    ----------
    objects : list of SceneObject
        Object ``i`` has id ``i + 1``.
    camera : Camera
    animation : Animation, optional
    name : str
    """

    objects: tuple
    camera: Camera
    animation: Animation | None = None
    name: str = "scene"

    def __post_init__(self):
        objs = tuple(self.objects)
        if not objs:
            raise SceneError(f"scene {self.name!r} has no objects")
        names = [o.name for o in objs]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise SceneError(f"scene {self.name!r}: duplicate object names {sorted(dup)}")
        if self.animation is not None:
            unknown = set(self.animation.object_keys) - set(names)
            if unknown:
                raise SceneError(f"scene {self.name!r}: animation names unknown objects {sorted(unknown)}")
        object.__setattr__(self, "objects", objs)

    @property
    def n_frames(self) -> int:
        """Frames in the animation (1 for a static scene, which may be rendered any number of times)."""
        return 1 if self.animation is None else self.animation.frames

    @property
    def reflector_ids(self) -> list[int]:
        """1-based ids of the reflectors, in scene order."""
        return [i + 1 for i, o in enumerate(self.objects) if o.reflector]

    def object_by_id(self, object_id: int) -> SceneObject:
        if not 1 <= object_id <= len(self.objects):
            raise SceneError(f"scene {self.name!r} has no object id {object_id} (ids 1..{len(self.objects)})")
        return self.objects[object_id - 1]

    def camera_at(self, frame: int = 0) -> Camera:
        """The camera at ``frame`` (keyframes interpolated linearly, held outside)."""
        if self.animation is None or not self.animation.camera_keys:
            return self.camera
        keys = [(f, {k: np.asarray(v, dtype=np.float64) for k, v in d.items()}) for f, d in self.animation.camera_keys]

        def lerp(a, b, t):
            return {k: _lerp(a[k], b[k], t) for k in a}

        values = _interp_keys(keys, frame, lerp)
        kw = {k: (float(v) if k == "fov_y" else v) for k, v in values.items()}
        return replace(self.camera, **kw)

    def transform_at(self, object_id: int, frame: int = 0) -> Transform:
        """The transform of object ``object_id`` at ``frame``."""
        obj = self.object_by_id(object_id)
        if self.animation is None or obj.name not in self.animation.object_keys:
            return obj.transform
        keys = self.animation.object_keys[obj.name]

        def lerp(a, b, t):
            return Transform(_lerp(a.translate, b.translate, t), _lerp(a.rotate_deg, b.rotate_deg, t),
                             _lerp(a.scale, b.scale, t))

        return _interp_keys(list(keys), frame, lerp)

    def world_mesh(self, object_id: int, frame: int = 0, proxy: bool = False) -> Mesh:
        """Object ``object_id``'s mesh in world space at ``frame``.

        ``proxy=True`` gives the closed proxy of an open reflector (its own mesh if it has none).
        """
        obj = self.object_by_id(object_id)
        mesh = obj.closed_proxy if (proxy and obj.closed_proxy is not None) else obj.mesh
        return mesh.transformed(self.transform_at(object_id, frame).matrix())

    def counts(self) -> dict:
        """Vertex, triangle, reflector and frame counts (for listings)."""
        return {
            "vertices": sum(o.mesh.n_vertices for o in self.objects),
            "triangles": sum(o.mesh.n_faces for o in self.objects),
            "reflectors": len(self.reflector_ids),
            "frames": self.n_frames,
        }


def scene_vertices(scene: Scene, frame: int = 0, meshes=None):
    """World-space vertices of every non-reflector object: the vertices a reflection method
    reflects (spec section 7's ``vertex_object_k`` rows).

    Parameters
    ----------
    scene : Scene
    frame : int
    meshes : list of Mesh, optional
        The world meshes of all objects at ``frame``, already computed.

    Returns
    -------
    vertices : ndarray, shape (N, 3), float64
        Concatenated in scene order, each object's vertices in file order.
    vertex_object : ndarray, shape (N,), int32
        1-based object id of each vertex.
    """
    verts, ids = [], []
    for k, obj in enumerate(scene.objects, start=1):
        if obj.reflector:
            continue
        m = scene.world_mesh(k, frame) if meshes is None else meshes[k - 1]
        verts.append(m.vertices)
        ids.append(np.full(m.n_vertices, k, dtype=np.int32))
    if not verts:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int32)
    return np.concatenate(verts), np.concatenate(ids)

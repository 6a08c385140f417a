"""The environment map as a reflection method (:mod:`refsoft.seam`; docs/envmap.md).

Per reflector and frame: a cube map around the centre of the reflector's world AABB
(:func:`refsoft.envmap.cube.build_cube_map`, stage ``envmap_build``), then at each stencil pixel
the texel the reflected direction points at (stage ``envmap_lookup``). The position of the pixel
on the reflector is not used: the classic assumption of infinitely distant surroundings, whose
error is parallax.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import keys, validate
from ..errors import RefsoftError
from ..raster import PRECISIONS, _setup, interpolate, rasterize
from ..scene.model import Scene
from ..seam import ReflectorResult, stencil_box
from .cube import MAX_RESOLUTION, CubeMap, build_cube_map, lookup

#: (H, W) int8: the face looked up at each reflector pixel (0..5), -1 elsewhere.
ENVMAP_FACE = "envmap_face"
#: (H, W, 2) int16: the texel (row, col) looked up, -1 elsewhere.
ENVMAP_TEXEL = "envmap_texel"
#: (6, R, R, 3) float32 per reflector: the cube map's shaded colours.
ENVMAP_COLOR = keys.PerReflector("envmap_color")
#: (6, R, R) int32 per reflector: the cube map's object ids (0 background).
ENVMAP_ID = keys.PerReflector("envmap_id")
#: (3,) float64 per reflector: the cube map's centre.
ENVMAP_CENTER = keys.PerReflector("envmap_center")


@dataclass(eq=False)
class Rays:
    """The reflected rays of a reflector's stencil pixels (the LDT's rays, docs/ldt.md).

    Attributes
    ----------
    rows, cols : ndarray (P,) int64
        The stencil pixels, row-major order.
    position : ndarray (P, 3), working precision
        ``P - eye``: the perspective-correct interpolated world position, eye-relative.
    normal : ndarray (P, 3), working precision
        The interpolated normal, renormalised.
    direction : ndarray (P, 3), working precision
        ``r = I - 2 (N . I) N`` with ``I = normalize(P - eye)`` (the view direction for an
        orthographic camera).
    triangle : ndarray (P,) int32
        The reflector triangle visible at each pixel (the main view's).
    """

    rows: np.ndarray
    cols: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    direction: np.ndarray
    triangle: np.ndarray


def _normalized(v, dt):
    """``v / |v|`` row by row, ``|v| = sqrt((x x + y y) + z z)`` in ``dt``; zero stays zero."""
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    length = np.sqrt((x * x + y * y) + z * z)
    safe = np.where(length > 0, length, dt(1))
    return np.where(length[:, None] > 0, v / safe[:, None], dt(0)).astype(dt)


def reflected_rays(camera, mesh, stencil, precision="float32") -> Rays:
    """The reflected direction at every stencil pixel: ``mesh`` (the reflector's world mesh, as
    drawn in the main view) rasterized by itself over the stencil's box, its eye-relative
    positions and normals interpolated there (the same arithmetic as :func:`refsoft.raster.gbuffer`),
    then ``I`` and ``r`` in the working precision.

    Parameters
    ----------
    camera : Camera
        The main view's camera.
    mesh : Mesh
    stencil : ndarray (H, W) bool
        Pixels where the reflector is the visible surface (not empty).
    precision : {"float32", "float64"}

    Returns
    -------
    Rays
    """
    dt = PRECISIONS[validate.choice(precision, tuple(PRECISIONS), "precision")]
    stencil = np.asarray(stencil)
    if stencil.dtype != bool or stencil.shape != (camera.height, camera.width):
        raise RefsoftError(f"stencil must be a ({camera.height}, {camera.width}) bool array, got {stencil.dtype} "
                           f"{stencil.shape}")
    if not stencil.any():
        raise RefsoftError("stencil is empty: no reflector pixel to reflect at")
    r0, r1, c0, c1 = stencil_box(stencil)
    eye = np.asarray(camera.eye, dtype=np.float64)
    clip = _setup.transform_points(np.ascontiguousarray(mesh.vertices), camera.view_proj())
    frags = rasterize(clip, mesh.faces, camera.width, camera.height, region=(r0, r1, c0, c1))
    pos = interpolate(frags, mesh.vertices - eye, mesh.faces, dt)
    nrm = interpolate(frags, mesh.normals, mesh.faces, dt, normalize=True)
    sub = stencil[r0:r1, c0:c1]
    rr, cc = np.nonzero(sub)
    p, n = pos[rr, cc], nrm[rr, cc]
    if camera.projection == "perspective":
        i = _normalized(p, dt)
    else:
        i = np.broadcast_to(camera.rays(np.array([0]), np.array([0]))[1][0].astype(dt), p.shape)
    k = dt(2) * ((n[:, 0] * i[:, 0] + n[:, 1] * i[:, 1]) + n[:, 2] * i[:, 2])
    r = (i - k[:, None] * n).astype(dt)
    return Rays(rr + r0, cc + c0, p, n, r, frags.triangle[rr, cc])


@dataclass
class _Last:
    key: tuple  # every object's transform
    cube: CubeMap


@dataclass(eq=False)
class EnvmapState:
    """A reflector's intermediates of one frame (:attr:`ReflectorResult.state`).

    Attributes
    ----------
    cube : CubeMap
    rays : Rays or None
        None when the stencil is empty.
    face : ndarray (P,) int8
    row, col : ndarray (P,) int32
        The texel looked up at each of ``rays``' pixels.
    """

    cube: CubeMap
    rays: Rays | None = None
    face: np.ndarray | None = None
    row: np.ndarray | None = None
    col: np.ndarray | None = None


class EnvironmentMap:
    """The environment-map baseline for every reflector of a scene (the :mod:`refsoft.seam`
    interface; docs/envmap.md).

    Keeps each reflector's last cube map and reuses it while no object moves (the cube map
    depends on the objects' transforms only: the outputs are the same bit for bit).

    Parameters
    ----------
    scene : Scene
    resolution : int
        Face size ``R_e`` in texels.
    precision : {"float32", "float64"}
        Arithmetic of the reflected rays and the lookup (the cube map is float32 either way).
    """

    name = "envmap"
    stages = ("envmap_build", "envmap_lookup")
    pixel_arrays = {ENVMAP_FACE: ((), np.int8, -1), ENVMAP_TEXEL: ((2,), np.int16, -1)}

    def __init__(self, scene, *, resolution: int = 256, precision: str = "float32"):
        if not isinstance(scene, Scene):
            raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
        self.scene = scene
        self.resolution = validate.integer(resolution, "envmap resolution", 1, MAX_RESOLUTION)
        self.precision = validate.choice(precision, tuple(PRECISIONS), "precision")
        self._ids = [k for k in range(1, len(scene.objects) + 1) if not scene.object_by_id(k).reflector]
        self._colors = np.array([scene.object_by_id(k).color for k in self._ids], dtype=np.float64).reshape(-1, 3)
        self._last = {}

    def cube_map(self, view, k: int):
        """Reflector ``k``'s cube map at this frame, and whether the last one was reused."""
        key = tuple(view.transforms[j] for j in range(1, len(self.scene.objects) + 1))
        last = self._last.get(k)
        if last is not None and last.key == key:
            return last.cube, True
        b = self.scene.world_mesh(k, view.frame, proxy=True).bounds()
        cube = build_cube_map([view.meshes[j - 1] for j in self._ids], self._ids, self._colors, 0.5 * (b[0] + b[1]),
                              self.resolution)
        for a in (cube.color, cube.object_id, cube.center):
            a.setflags(write=False)  # shared by every frame that reuses it
        self._last[k] = _Last(key, cube)
        return cube, False

    def reflect(self, view, k: int, stencil) -> ReflectorResult:
        """Reflector ``k``'s cube map and, at its stencil pixels, the texel of the reflected
        direction: its colour and object id (id 0: no reflection)."""
        t = time.perf_counter()
        cube, reused = self.cube_map(view, k)
        times = {"envmap_build": 1000 * (time.perf_counter() - t), "envmap_lookup": 0.0}
        report = {"reflector_pixels": 0, "hits": 0, "cube_reused": reused}
        out = ReflectorResult(k, time_ms=times, report=report, state=EnvmapState(cube))
        out.arrays = {ENVMAP_COLOR(k): cube.color, ENVMAP_ID(k): cube.object_id, ENVMAP_CENTER(k): cube.center}
        if not stencil.any():
            return out
        t = time.perf_counter()
        rays = reflected_rays(view.camera, view.meshes[k - 1], stencil, self.precision)
        face, row, col, _, _ = lookup(rays.direction, cube.resolution)
        ids = cube.object_id[face, row, col]
        r0, r1, c0, c1 = box = stencil_box(stencil)
        h, w = r1 - r0, c1 - c0
        rr, cc = rays.rows - r0, rays.cols - c0
        out.box = box
        out.colour = np.zeros((h, w, 3), np.float32)
        out.reflected_id = np.zeros((h, w), np.int32)
        out.covered = np.zeros((h, w), bool)
        out.colour[rr, cc] = cube.color[face, row, col]
        out.reflected_id[rr, cc] = ids
        out.covered[rr, cc] = ids > 0
        face_map = np.full((h, w), -1, np.int8)
        texel = np.full((h, w, 2), -1, np.int16)
        face_map[rr, cc] = face
        texel[rr, cc, 0], texel[rr, cc, 1] = row, col
        out.pixels = {ENVMAP_FACE: face_map, ENVMAP_TEXEL: texel}
        out.pixel_mask = stencil[r0:r1, c0:c1]  # every reflector pixel has a texel, id 0 or not
        out.state = EnvmapState(cube, rays, face, row, col)
        report.update(reflector_pixels=int(len(rr)), hits=int(np.sum(ids > 0)))
        times["envmap_lookup"] = 1000 * (time.perf_counter() - t)
        return out

    def frame_report(self, results) -> dict:
        """``stats.json``'s per-frame counts: reflector pixels, pixels that show an object, and
        the reflectors whose cube map was reused."""
        return {"reflector_pixels": sum(r.report["reflector_pixels"] for r in results.values()),
                "hits": sum(r.report["hits"] for r in results.values()),
                "cube_maps_reused": [k for k, r in results.items() if r.report["cube_reused"]]}

"""Ray-traced truth (spec section 6): what a perfect mirror would show at every reflector pixel.

The main view is the same rasterized pass as :func:`refsoft.render` (same ``object_id``, same
reflector pixels). At each pixel where a reflector is visible, the eye ray through the pixel
centre meets the reflector's visible triangle (float64, the triangle the rasterizer found there);
the ray is reflected about the normal interpolated at that hit (the normal the G-buffer holds)
and traced against the objects the render reflects (every non-reflector object) with Embree
(``trimesh.ray.ray_pyembree`` through embreex). Embree runs in float32 and only names the hit
triangle: the hit point and its barycentrics are recomputed in float64 on that triangle.

For reflectors that are spheres (every vertex on one sphere: icosphere, uv-sphere) the truth
also holds each searched vertex's exact reflection point (Alhazen's problem, solved by
:func:`refsoft.truth.analytic.sphere_reflection_points`) and its exact virtual vertex, so per-vertex
errors can be measured (:mod:`refsoft.truth.metrics`).

Outputs follow spec section 7: ``image``, ``object_id``, ``reflected_id``, plus
``reflected_hit`` (H, W, 3) float64, the world position hit by each reflected ray (valid where
``reflected_id > 0``, zero elsewhere).
"""

from __future__ import annotations

import time

import numpy as np

from .. import constants, keys, linalg
from ..errors import RefsoftError
from ..frame.driver import FrameDriver, frame_indices, resolve_scene, run_to_folder
from ..options import RenderOptions
from ..raster import shade
from ..raster.rays import primary_rays, ray_triangle
from ..scene.mesh import concatenate
from ..scene.model import Scene
from ..seam import ReflectorResult, stencil_box
from .analytic import fit_sphere, sphere_reflection_points


def _interpolated_normals(normals, faces, tri, bary):
    n = np.einsum("nk,nkj->nj", bary, normals[faces[tri]])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


class _Targets:
    """The objects reflected rays are traced against, as one Embree scene."""

    def __init__(self, scene: Scene, meshes):
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        ids = [k for k in range(1, len(scene.objects) + 1) if not scene.object_by_id(k).reflector]
        self.empty = not ids
        if self.empty:
            return
        c = concatenate([meshes[k - 1] for k in ids], ids)
        self.vertices, self.normals, self.faces, self.face_object = c.vertices, c.normals, c.faces, c.face_object
        mesh = trimesh.Trimesh(self.vertices, self.faces, process=False, validate=False)
        self.intersector = RayMeshIntersector(mesh)

    def _trace(self, origins, directions):
        """Embree's first hit per ray, the rays split over Numba's thread count (embreex releases
        the GIL; each ray's answer is independent of the split, so the result is too)."""
        from concurrent.futures import ThreadPoolExecutor

        from trimesh import util

        from .._parallel import thread_count
        from trimesh.ray.ray_pyembree import _embree_dtype

        # the arrays exactly as trimesh's intersects_first prepares them
        o = np.array(origins, dtype=_embree_dtype)
        d = np.ascontiguousarray(util.unitize(np.array(directions, dtype=_embree_dtype)))
        n = len(o)
        parts = max(1, min(thread_count(), n // constants.TRUTH_RAYS_PER_THREAD))
        if parts == 1:
            return self.intersector._scene.run(o, d)
        bounds = np.linspace(0, n, parts + 1).astype(np.int64)
        with ThreadPoolExecutor(parts) as pool:
            got = pool.map(lambda i: self.intersector._scene.run(o[bounds[i]:bounds[i + 1]], d[bounds[i]:bounds[i + 1]]),
                           range(parts))
            return np.concatenate(list(got))

    def first_hits(self, origins, directions):
        """Index of the first triangle hit by each ray (-1: none), hit points and object ids."""
        n = len(origins)
        tri = np.full(n, -1, dtype=np.int64)
        hit = np.zeros((n, 3))
        obj = np.zeros(n, dtype=np.int32)
        normal = np.zeros((n, 3))
        if self.empty or n == 0:
            return tri, hit, obj, normal
        tri[:] = self._trace(origins, directions)
        ok = np.flatnonzero(tri >= 0)
        f = self.faces[tri[ok]]
        t, bary = ray_triangle(origins[ok], directions[ok], self.vertices[f[:, 0]], self.vertices[f[:, 1]],
                               self.vertices[f[:, 2]])
        bad = ~np.isfinite(t)
        tri[ok[bad]] = -1
        ok, t, bary = ok[~bad], t[~bad], bary[~bad]
        hit[ok] = origins[ok] + t[:, None] * directions[ok]
        obj[ok] = self.face_object[tri[ok]]
        normal[ok] = _interpolated_normals(self.normals, self.faces, tri[ok], bary)
        return tri, hit, obj, normal


def _is_closed(faces, n_vertices: int) -> bool:
    """Every edge is shared by exactly two triangles (a watertight surface): the sorted edge keys
    ``min * n + max`` come in equal pairs and no key appears more than twice."""
    f = np.asarray(faces, dtype=np.int64)
    a, b = np.concatenate([f[:, 0], f[:, 1], f[:, 2]]), np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    key = np.sort(np.minimum(a, b) * np.int64(n_vertices) + np.maximum(a, b))
    return bool(len(key) % 2 == 0 and np.all(key[0::2] == key[1::2]) and np.all(key[1:-1:2] != key[2::2]))


def exact_sphere_vertices(scene: Scene, reflector: int, frame: int, vertices):
    """Exact reflection points and virtual vertices of ``vertices`` in a spherical reflector.

    Returns None unless the reflector (its closed proxy) is a closed mesh whose vertices all lie on
    one sphere, seen from outside.

    Returns
    -------
    points : ndarray, shape (N, 3), float64
        Exact reflection points; NaN where none exists (the vertex inside the sphere).
    virtual : ndarray, shape (N, 3), float64
        Mirror images of the vertices across the exact tangent planes; NaN likewise.
    """
    mesh = scene.world_mesh(reflector, frame, proxy=True)
    fit = fit_sphere(mesh.vertices)
    if fit is not None and not _is_closed(mesh.faces, mesh.n_vertices):  # a whole sphere, not a bowl
        fit = None
    if fit is None:
        return None
    centre, radius = fit
    eye = scene.camera_at(frame).eye
    if np.linalg.norm(eye - centre) <= radius:
        return None
    points = sphere_reflection_points(centre, radius, eye, vertices)
    n = (points - centre) / radius
    d = np.sum((vertices - points) * n, axis=1, keepdims=True)
    return points, vertices - 2.0 * d * n


class RayTracedTruth:
    """The ray-traced truth as a reflection method (:mod:`refsoft.seam`): at each stencil pixel
    the eye ray meets the reflector's visible triangle, is reflected about the interpolated
    normal there and traced against every non-reflector object.

    Keeps the Embree scene while no reflected object moves.

    Parameters
    ----------
    scene : Scene
    exact : bool
        Also solve the exact reflection points of spherical reflectors (per-vertex truth).
    """

    name = "truth"
    stages = ("primary", "trace", "shade", "exact")
    pixel_arrays = {keys.REFLECTED_HIT: ((3,), np.float64)}

    def __init__(self, scene: Scene, exact: bool = True):
        self.scene = scene
        self.exact = exact
        self._targets = None
        self._colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)

    def _targets_at(self, meshes):
        scene = self.scene
        moving = set() if scene.animation is None else set(scene.animation.object_keys)
        static = not any(o.name in moving for o in scene.objects if not o.reflector)
        if self._targets is None or not static:
            self._targets = _Targets(scene, meshes)
        return self._targets

    def reflect(self, view, k: int, stencil) -> ReflectorResult:
        """The reflected colour, object id and hit point at reflector ``k``'s stencil pixels; the
        exact reflection points of the searched vertices when ``k`` is a sphere."""
        out = ReflectorResult(k, time_ms=dict.fromkeys(self.stages, 0.0), report={"reflector_pixels": 0, "hits": 0})
        if stencil.any():
            self._trace(view, k, stencil, out)
        if self.exact:
            t = time.perf_counter()
            exact = exact_sphere_vertices(self.scene, k, view.frame, view.vertices)
            if exact is not None:
                out.arrays = {keys.EXACT_REFLECTION_POINT(k): exact[0], keys.EXACT_VIRTUAL_VERTEX(k): exact[1],
                              keys.VERTEX_OBJECT(k): view.vertex_object.astype(np.int32)}
            out.time_ms["exact"] = 1000 * (time.perf_counter() - t)
        return out

    def _trace(self, view, k, stencil, out):
        times = out.time_ms
        t = time.perf_counter()
        box = stencil_box(stencil)
        r0, r1, c0, c1 = box
        rows, cols = np.nonzero(stencil)
        hit, ray, ok = primary_rays(view.camera, view.meshes[k - 1], rows, cols, view.view.triangle[rows, cols])
        times["primary"] += 1000 * (time.perf_counter() - t)
        t = time.perf_counter()
        hit_tri, hit2, obj, nrm2 = self._targets_at(view.meshes).first_hits(hit[ok], ray[ok])
        times["trace"] += 1000 * (time.perf_counter() - t)
        t = time.perf_counter()
        sel = np.flatnonzero(ok)[hit_tri >= 0]
        got = hit_tri >= 0
        rr, cc = rows[sel] - r0, cols[sel] - c0
        h, w = r1 - r0, c1 - c0
        out.box = box
        out.colour = np.zeros((h, w, 3), np.float32)
        out.reflected_id = np.zeros((h, w), np.int32)
        out.covered = np.zeros((h, w), bool)
        hits = np.zeros((h, w, 3))
        out.colour[rr, cc] = shade(nrm2[got], self._colors[obj[got]])
        out.reflected_id[rr, cc] = obj[got]
        out.covered[rr, cc] = True
        hits[rr, cc] = hit2[got]
        out.pixels = {keys.REFLECTED_HIT: hits}
        out.report = {"reflector_pixels": int(len(rows)), "hits": int(got.sum())}
        times["shade"] += 1000 * (time.perf_counter() - t)

    def frame_report(self, results) -> dict:
        """``stats.json``'s per-frame counts: reflector pixels and reflected rays that hit."""
        return {"reflector_pixels": sum(r.report["reflector_pixels"] for r in results.values()),
                "hits": sum(r.report["hits"] for r in results.values())}


class TruthRenderer(FrameDriver):
    """Ray-traces frames of a scene: the frame driver with :class:`RayTracedTruth` as the
    reflection method (the same main view, composite and outputs as a render)."""

    def __init__(self, scene: Scene, exact: bool = True, memory_limit=None):
        if not isinstance(scene, Scene):
            raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
        # the render's estimate bounds the truth's: the same view, per-pixel rays instead of G-buffers
        super().__init__(scene, RenderOptions(), memory_limit, method=RayTracedTruth(scene, exact))
        self.exact = exact


def render_truth(scene, frames=None, out=None, progress=False, exact=True, memory_limit=None, width=None,
                 height=None, subdivide=None, overwrite=False, on_start=None):
    """Ray-trace frames of a scene (the Python face of ``refsoft truth``).

    Parameters
    ----------
    scene : Scene or str
        A scene or a built-in name / TOML path.
    frames : int or sequence of int, optional
        A number of frames (0 .. n-1) or explicit frame indices; default every frame.
    out : str or PathLike, optional
        Folder for ``frame_NNNN.npz``, ``frame_NNNN.png`` and ``stats.json``.
    progress : bool
        Show a tqdm progress bar.
    exact : bool
        Also solve the exact reflection points of spherical reflectors.
    memory_limit : int or str, optional
        As :func:`refsoft.render`.
    width, height : int, optional
        Image size (replaces the scene camera's).
    subdivide : float, optional
        Loader subdivision override, as :func:`refsoft.render`.
    overwrite : bool
        Replace an earlier run's files in ``out``.
    on_start : callable, optional
        As :func:`refsoft.render`: called just before the first frame.

    Returns
    -------
    frames : list of refsoft.frame.Frame
    stats : dict
    """
    scene = resolve_scene(scene, width, height, subdivide)
    indices = frame_indices(scene, frames)
    return run_to_folder(TruthRenderer(scene, exact=exact, memory_limit=memory_limit), indices, out, "truth", None,
                         progress, overwrite=overwrite, on_start=on_start)

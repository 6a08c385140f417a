"""Ray-traced truth (spec section 6): what a perfect mirror would show at every reflector pixel.

The main view is the same rasterized pass as :func:`refsoft.render` (same ``object_id``, same
reflector pixels). At each pixel where a reflector is visible, the eye ray through the pixel
centre meets the reflector's visible triangle (float64, the triangle the rasterizer found there);
the ray is reflected about the normal interpolated at that hit (the normal the G-buffer holds)
and traced against the objects the render reflects (every non-reflector object) with Embree
(``trimesh.ray.ray_pyembree`` through embreex). Embree runs in float32 and only names the hit
triangle: the hit point and its barycentrics are recomputed in float64 on that triangle.
With ``bounces = N > 1`` the reflected ray may meet other reflectors and reflect again, up to N
reflections in all (the mirror paths of spec section 5.1, :mod:`refsoft.truth.paths`).

For reflectors that are spheres (every vertex on one sphere: icosphere, uv-sphere) the truth
also holds each searched vertex's exact reflection point (Alhazen's problem, solved by
:func:`refsoft.truth.analytic.sphere_reflection_points`) and its exact virtual vertex, so per-vertex
errors can be measured (:mod:`refsoft.truth.metrics`).

Outputs follow spec section 7: ``image``, ``object_id``, ``reflected_id``, plus
``reflected_hit`` (H, W, 3) float64, the world position hit by each reflected ray (with
several bounces, where the path ends; valid where ``reflected_id > 0``, zero elsewhere) and
``bounce_depth`` (H, W) int8, the reflections each reflector pixel's path takes (0 elsewhere).
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
from .paths import _interpolated_normals, trace_paths


class _Targets:
    """Objects rays are traced against, as one Embree scene: by default every non-reflector (the
    first-order contract); ``ids`` names others (the reflectors a mirror path may meet next)."""

    def __init__(self, scene: Scene, meshes, ids=None):
        import trimesh
        from trimesh.ray.ray_pyembree import RayMeshIntersector

        if ids is None:
            ids = [k for k in range(1, len(scene.objects) + 1) if not scene.object_by_id(k).reflector]
        self.ids = list(ids)
        self.empty = not self.ids
        if self.empty:
            return
        c = concatenate([meshes[k - 1] for k in self.ids], self.ids)
        self.vertices, self.normals, self.faces, self.face_object = c.vertices, c.normals, c.faces, c.face_object
        #: object id -> the index of its first triangle among ``faces``
        self.first_face = {k: int(c.face_offsets[i]) for i, k in enumerate(self.ids)}
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

    def named(self, origins, directions, traced_from=None):
        """The triangle Embree names for each ray (-1: none) and the ray's float64 parameter and
        barycentrics on it (NaN and zero where none).

        ``traced_from``: the origins given to Embree when they are not ``origins`` (a ray moved
        off the surface it leaves); ``t`` and the barycentrics are still those of ``origins``.
        """
        n = len(origins)
        tri = np.full(n, -1, dtype=np.int64)
        t = np.full(n, np.nan)
        bary = np.zeros((n, 3))
        if self.empty or n == 0:
            return tri, t, bary
        tri[:] = self._trace(origins if traced_from is None else traced_from, directions)
        ok = np.flatnonzero(tri >= 0)
        f = self.faces[tri[ok]]
        tt, bb = ray_triangle(origins[ok], directions[ok], self.vertices[f[:, 0]], self.vertices[f[:, 1]],
                              self.vertices[f[:, 2]])
        bad = ~np.isfinite(tt)
        tri[ok[bad]] = -1
        t[ok[~bad]], bary[ok[~bad]] = tt[~bad], bb[~bad]
        return tri, t, bary

    def complete(self, origins, directions, tri, t, bary):
        """Hit points, object ids (0: none) and interpolated normals of :meth:`named`'s answer."""
        n = len(origins)
        hit = np.zeros((n, 3))
        obj = np.zeros(n, dtype=np.int32)
        normal = np.zeros((n, 3))
        if self.empty:
            return hit, obj, normal
        ok = np.flatnonzero(tri >= 0)
        hit[ok] = origins[ok] + t[ok][:, None] * directions[ok]
        obj[ok] = self.face_object[tri[ok]]
        normal[ok] = _interpolated_normals(self.normals, self.faces, tri[ok], bary[ok])
        return hit, obj, normal

    def first_hits(self, origins, directions):
        """Index of the first triangle hit by each ray (-1: none), hit points and object ids."""
        tri, t, bary = self.named(origins, directions)
        return (tri,) + self.complete(origins, directions, tri, t, bary)


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


def check_bounces(bounces) -> int:
    """``bounces`` as an int, or a :class:`RefsoftError` unless it is an integer from 1 to
    ``MAX_BOUNCES``."""
    from .. import validate

    if not validate.is_integer(bounces) or not 1 <= bounces <= constants.MAX_BOUNCES:
        raise RefsoftError(f"bounces must be an integer from 1 to {constants.MAX_BOUNCES}, got {bounces!r}")
    return int(bounces)


class RayTracedTruth:
    """The ray-traced truth as a reflection method (:mod:`refsoft.seam`): at each stencil pixel
    the eye ray meets the reflector's visible triangle, is reflected about the interpolated
    normal there and traced against every non-reflector object; with ``bounces > 1`` it follows
    the mirror path through further reflectors (:mod:`refsoft.truth.paths`).

    Keeps the Embree scenes while the objects in them do not move.

    Parameters
    ----------
    scene : Scene
    exact : bool
        Also solve the exact reflection points of spherical reflectors (per-vertex truth).
    bounces : int
        Most reflections per path, 1 .. ``MAX_BOUNCES`` (1: the first-order contract).
    """

    name = "truth"
    stages = ("primary", "trace", "shade", "exact")
    pixel_arrays = {keys.REFLECTED_HIT: ((3,), np.float64), keys.BOUNCE_DEPTH: ((), np.int8)}

    def __init__(self, scene: Scene, exact: bool = True, bounces: int = 1):
        self.scene = scene
        self.exact = exact
        self.bounces = check_bounces(bounces)
        self._targets = None
        self._mirrors = ({}, None)  # reflector id -> (targets, offset), and the frame they hold (None: static)
        self._colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
        self._rho = np.array([0.0] + [o.reflectivity for o in scene.objects], np.float32)

    def _targets_at(self, meshes):
        scene = self.scene
        moving = set() if scene.animation is None else set(scene.animation.object_keys)
        static = not any(o.name in moving for o in scene.objects if not o.reflector)
        if self._targets is None or not static:
            self._targets = _Targets(scene, meshes)
        return self._targets

    def _mirrors_at(self, view):
        """``mirrors(s)`` of :func:`refsoft.truth.paths.trace_paths` at this frame: the
        reflectors a ray leaving reflector ``s`` may meet, built once while no reflector moves."""
        from .paths import sees_itself

        scene = self.scene
        moving = set() if scene.animation is None else set(scene.animation.object_keys)
        when = view.frame if any(o.name in moving for o in scene.objects if o.reflector) else None
        cache, held = self._mirrors
        if held != when:  # a reflector moved: the frame's own meshes
            cache = {}
            self._mirrors = (cache, when)

        def mirrors(s):
            if s not in cache:
                own = sees_itself(scene, s)
                ids = [r for r in scene.reflector_ids if r != s or own]
                offset = 0.0
                if own:
                    v = view.meshes[s - 1].vertices
                    offset = constants.TRUTH_SELF_OFFSET * float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
                cache[s] = (_Targets(scene, view.meshes, ids), offset)
            return cache[s]

        return mirrors

    def reflect(self, view, k: int, stencil) -> ReflectorResult:
        """The reflected colour, object id and hit point at reflector ``k``'s stencil pixels; the
        exact reflection points of the searched vertices when ``k`` is a sphere."""
        out = ReflectorResult(k, time_ms=dict.fromkeys(self.stages, 0.0), report={"reflector_pixels": 0, "hits": 0})
        if self.bounces > 1:
            out.report["bounce_depth"] = {}
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
        tri = view.view.triangle[rows, cols]
        hit, ray, ok = primary_rays(view.camera, view.meshes[k - 1], rows, cols, tri)
        times["primary"] += 1000 * (time.perf_counter() - t)
        t = time.perf_counter()
        if self.bounces == 1:
            hit_tri, hit2, obj, nrm2 = self._targets_at(view.meshes).first_hits(hit[ok], ray[ok])
            depth = np.ones(len(hit2), np.int8)
        else:
            paths = trace_paths(hit[ok], ray[ok], k, tri[ok], self.bounces, self._targets_at(view.meshes),
                                self._mirrors_at(view))
            hit2, obj, nrm2, depth = paths.hit, paths.obj, paths.normal, paths.depth
        times["trace"] += 1000 * (time.perf_counter() - t)
        t = time.perf_counter()
        if self.bounces == 1:
            got = hit_tri >= 0
            colour = shade(nrm2[got], self._colors[obj[got]])
        else:
            colour, got = self._path_colours(paths)
        sel = np.flatnonzero(ok)[got]
        rr, cc = rows[sel] - r0, cols[sel] - c0
        h, w = r1 - r0, c1 - c0
        out.box = box
        out.colour = np.zeros((h, w, 3), np.float32)
        out.reflected_id = np.zeros((h, w), np.int32)
        out.covered = np.zeros((h, w), bool)
        hits = np.zeros((h, w, 3))
        out.colour[rr, cc] = colour
        out.reflected_id[rr, cc] = obj[got]
        out.covered[rr, cc] = True
        hits[rr, cc] = hit2[got]
        bounce = np.zeros((h, w), np.int8)
        bounce[rows[ok] - r0, cols[ok] - c0] = depth
        out.pixels = {keys.REFLECTED_HIT: hits, keys.BOUNCE_DEPTH: bounce}
        out.pixel_mask = stencil[r0:r1, c0:c1]  # every reflector pixel gets its depth
        out.report.update({"reflector_pixels": int(len(rows)), "hits": int((obj > 0).sum())})
        if self.bounces > 1:
            out.report["bounce_depth"] = {str(j): int((depth == j).sum()) for j in range(1, self.bounces + 1)}
        times["shade"] += 1000 * (time.perf_counter() - t)

    def _path_colours(self, paths):
        """The colour each path shows, from its end back to its second reflection (the composite
        of spec section 5 at each reflector it meets: ``rho * what it reflects + (1 - rho) *
        its own shaded colour``, its own colour alone where the rest of the path escapes), and
        whether it shows anything (it ends on a non-reflector or meets a second reflector).

        Returns
        -------
        colour : ndarray (C, 3) float32
            For the paths that show something, in path order.
        shows : ndarray (P,) bool
        """
        colour = np.zeros((len(paths.depth), 3), np.float32)
        shows = paths.obj > 0
        colour[shows] = shade(paths.normal[shows], self._colors[paths.obj[shows]])
        one = np.float32(1)
        for rays, refl, normal in reversed(paths.levels):  # deepest reflection first
            own = shade(normal, self._colors[refl])
            rho, seen = self._rho[refl][:, None], shows[rays]
            mixed = own.copy()
            mixed[seen] = rho[seen] * colour[rays[seen]] + (one - rho[seen]) * own[seen]
            colour[rays] = mixed
            shows[rays] = True
        return colour[shows], shows

    def frame_report(self, results) -> dict:
        """``stats.json``'s per-frame counts: reflector pixels and reflected rays that hit (a
        non-reflector); with ``bounces > 1`` also the reflector pixels per number of reflections."""
        rep = {"reflector_pixels": sum(r.report["reflector_pixels"] for r in results.values()),
               "hits": sum(r.report["hits"] for r in results.values())}
        if self.bounces > 1:
            rep["bounce_depth"] = {str(j): sum(r.report["bounce_depth"].get(str(j), 0) for r in results.values())
                                   for j in range(1, self.bounces + 1)}
        return rep


class TruthRenderer(FrameDriver):
    """Ray-traces frames of a scene: the frame driver with :class:`RayTracedTruth` as the
    reflection method (the same main view, composite and outputs as a render); ``bounces`` as
    :class:`RayTracedTruth`."""

    def __init__(self, scene: Scene, exact: bool = True, memory_limit=None, bounces: int = 1):
        if not isinstance(scene, Scene):
            raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
        bounces = check_bounces(bounces)
        # the render's estimate bounds the truth's: the same view, per-pixel rays instead of G-buffers
        super().__init__(scene, RenderOptions(), memory_limit, method=RayTracedTruth(scene, exact, bounces))
        self.exact = exact
        self.bounces = bounces


def render_truth(scene, frames=None, out=None, progress=False, exact=True, memory_limit=None, width=None,
                 height=None, subdivide=None, overwrite=False, on_start=None, bounces=1):
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
    bounces : int
        Most reflections per mirror path, 1 .. 8 (spec section 5.1): 1, the default, reflects
        each eye ray once and traces it against the non-reflectors; N > 1 follows it through up
        to N reflectors (``bounce_depth`` holds the reflections taken per pixel).

    Returns
    -------
    frames : list of refsoft.frame.Frame
    stats : dict
    """
    bounces = check_bounces(bounces)
    scene = resolve_scene(scene, width, height, subdivide)
    indices = frame_indices(scene, frames)
    driver = TruthRenderer(scene, exact=exact, memory_limit=memory_limit, bounces=bounces)
    return run_to_folder(driver, indices, out, "truth", None, progress, overwrite=overwrite, on_start=on_start)

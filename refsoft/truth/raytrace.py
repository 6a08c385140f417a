"""Ray-traced truth (DESIGN section 6): what a perfect mirror would show at every reflector pixel.

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

Outputs follow DESIGN section 7: ``image``, ``object_id``, ``reflected_id``, plus
``reflected_hit`` (H, W, 3) float64, the world position hit by each reflected ray (valid where
``reflected_id > 0``, zero elsewhere).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from .analytic import fit_sphere, sphere_reflection_points
from ..errors import RefsoftError
from ..raster import color_pass, shade, to_uint8
from ..search.reflect import scene_vertices
from ..scene.model import Scene

TRUTH_STAGES = ("main", "primary", "trace", "shade", "exact", "total")


@dataclass
class TruthFrame:
    """One ray-traced frame: DESIGN section 7 arrays (``arrays``) and timings (ms)."""

    index: int
    arrays: dict
    time_ms: dict
    counts: dict

    @property
    def image(self) -> np.ndarray:
        return self.arrays["image"]


def ray_triangle(origins, directions, a, b, c):
    """Intersect rays with the planes of triangles (Moller-Trumbore, float64).

    Parameters
    ----------
    origins, directions : ndarray, shape (N, 3)
    a, b, c : ndarray, shape (N, 3)
        Triangle corners, one triangle per ray.

    Returns
    -------
    t : ndarray, shape (N,)
        Ray parameter of the hit (``origin + t * direction``); NaN where the ray is parallel.
    bary : ndarray, shape (N, 3)
        Barycentrics of the hit w.r.t. (a, b, c) (they may leave [0, 1] by rounding at edges).
    """
    e1 = b - a
    e2 = c - a
    p = np.cross(directions, e2)
    det = np.sum(e1 * p, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(det != 0.0, 1.0 / det, np.nan)
        s = origins - a
        u = np.sum(s * p, axis=1) * inv
        q = np.cross(s, e1)
        v = np.sum(directions * q, axis=1) * inv
        t = np.sum(e2 * q, axis=1) * inv
    return t, np.stack([1.0 - u - v, u, v], axis=1)


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
        parts = [meshes[k - 1] for k in ids]
        offs = np.cumsum([0] + [m.n_vertices for m in parts])
        self.vertices = np.concatenate([m.vertices for m in parts])
        self.normals = np.concatenate([m.normals for m in parts])
        self.faces = np.concatenate([m.faces.astype(np.int64) + offs[i] for i, m in enumerate(parts)])
        self.face_object = np.repeat(np.array(ids, dtype=np.int32), [m.n_faces for m in parts])
        mesh = trimesh.Trimesh(self.vertices, self.faces, process=False, validate=False)
        self.intersector = RayMeshIntersector(mesh)

    def first_hits(self, origins, directions):
        """Index of the first triangle hit by each ray (-1: none), hit points and object ids."""
        n = len(origins)
        tri = np.full(n, -1, dtype=np.int64)
        hit = np.zeros((n, 3))
        obj = np.zeros(n, dtype=np.int32)
        normal = np.zeros((n, 3))
        if self.empty or n == 0:
            return tri, hit, obj, normal
        tri[:] = self.intersector.intersects_first(origins, directions)
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


def _is_closed(faces) -> bool:
    """Every edge is shared by exactly two triangles (a watertight surface)."""
    f = np.asarray(faces, dtype=np.int64)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


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
    fit = fit_sphere(mesh.vertices) if _is_closed(mesh.faces) else None  # a whole sphere, not a bowl
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


class TruthRenderer:
    """Ray-traces frames of a scene (caches the Embree scene while no reflected object moves)."""

    def __init__(self, scene: Scene, exact: bool = True, memory_limit=None):
        from ..limits import check_frame_memory
        from ..frame.driver import RenderOptions

        if not isinstance(scene, Scene):
            raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
        if not scene.reflector_ids:
            raise RefsoftError(f"scene {scene.name!r} has no reflector: nothing to reflect "
                               "(mark an object with reflector = true)")
        # the render's estimate bounds the truth's: the same view, per-pixel rays instead of G-buffers
        check_frame_memory(scene, RenderOptions(), 1, memory_limit)
        self.scene = scene
        self.exact = exact
        self._targets = None

    def _targets_at(self, frame, meshes):
        scene = self.scene
        moving = set() if scene.animation is None else set(scene.animation.object_keys)
        static = not any(o.name in moving for o in scene.objects if not o.reflector)
        if self._targets is None or not static:
            self._targets = _Targets(scene, meshes)
        return self._targets

    def render_frame(self, frame: int) -> TruthFrame:
        scene = self.scene
        if scene.animation is not None and not 0 <= frame < scene.n_frames:
            raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {frame}")
        times = dict.fromkeys(TRUTH_STAGES, 0.0)
        t0 = time.perf_counter()
        camera = scene.camera_at(frame)
        meshes = [scene.world_mesh(k, frame) for k in range(1, len(scene.objects) + 1)]
        view = color_pass(meshes, [o.color for o in scene.objects], camera)
        times["main"] = 1000 * (time.perf_counter() - t0)
        h, w = view.object_id.shape
        colour = view.color.copy()
        reflected = np.full((h, w), -1, dtype=np.int32)
        reflected_hit = np.zeros((h, w, 3))
        colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
        targets = None
        arrays = {}
        counts = {"reflector_pixels": 0, "hits": 0}
        for k in scene.reflector_ids:
            rows, cols = np.nonzero(view.object_id == k)
            if len(rows) == 0:
                continue
            t = time.perf_counter()
            reflected[rows, cols] = 0
            m = meshes[k - 1]
            f = m.faces.astype(np.int64)[view.triangle[rows, cols]]
            origin, direction = camera.rays(rows, cols)
            tt, bary = ray_triangle(origin, direction, m.vertices[f[:, 0]], m.vertices[f[:, 1]], m.vertices[f[:, 2]])
            ok = np.isfinite(tt)
            hit = origin + np.where(ok, tt, 0.0)[:, None] * direction
            normal = _interpolated_normals(m.normals, m.faces.astype(np.int64), view.triangle[rows, cols],
                                           np.where(ok[:, None], bary, 0.0))
            ray = direction - 2.0 * np.sum(direction * normal, axis=1, keepdims=True) * normal
            times["primary"] += 1000 * (time.perf_counter() - t)
            t = time.perf_counter()
            if targets is None:
                targets = self._targets_at(frame, meshes)
            tri, hit2, obj, nrm2 = targets.first_hits(hit[ok], ray[ok])
            times["trace"] += 1000 * (time.perf_counter() - t)
            t = time.perf_counter()
            sel = np.flatnonzero(ok)[tri >= 0]
            got = tri >= 0
            rho = np.float32(scene.object_by_id(k).reflectivity)
            col = shade(nrm2[got], colors[obj[got]])
            r_, c_ = rows[sel], cols[sel]
            colour[r_, c_] = rho * col + (np.float32(1) - rho) * view.color[r_, c_]
            reflected[r_, c_] = obj[got]
            reflected_hit[r_, c_] = hit2[got]
            counts["reflector_pixels"] += len(rows)
            counts["hits"] += int(got.sum())
            times["shade"] += 1000 * (time.perf_counter() - t)
        if self.exact and scene.reflector_ids:
            t = time.perf_counter()
            verts, owner = scene_vertices(scene, frame, meshes)
            for k in scene.reflector_ids:
                exact = exact_sphere_vertices(scene, k, frame, verts)
                if exact is not None:
                    arrays[f"exact_reflection_point_{k}"] = exact[0]
                    arrays[f"exact_virtual_vertex_{k}"] = exact[1]
                    arrays[f"vertex_object_{k}"] = owner.astype(np.int32)
            times["exact"] = 1000 * (time.perf_counter() - t)
        arrays.update(image=to_uint8(colour), object_id=view.object_id.astype(np.int32), reflected_id=reflected,
                      reflected_hit=reflected_hit)
        times["total"] = 1000 * (time.perf_counter() - t0)
        return TruthFrame(frame, arrays, times, counts)


def truth_stats(frames) -> dict:
    """``stats.json`` of a truth run: per-frame stage milliseconds and ray counts."""
    return {"frames": [{"frame": f.index, "time_ms": {k: round(v, 3) for k, v in f.time_ms.items()},
                        **f.counts} for f in frames],
            "summary": {"frames": len(frames),
                        "median_total_ms": float(np.median([f.time_ms["total"] for f in frames])) if frames else 0.0}}


def render_truth(scene, frames=None, out=None, progress=False, exact=True, memory_limit=None, width=None,
          height=None):
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

    Returns
    -------
    frames : list of TruthFrame
    stats : dict
    """
    from ..io import write_json
    from ..frame.driver import frame_indices, run_frames
    from ..scene.builtin import load_scene

    if not isinstance(scene, Scene):
        scene = load_scene(scene, width=width, height=height)
    elif width is not None or height is not None:
        from dataclasses import replace as _replace

        scene = _replace(scene, camera=_replace(scene.camera, **{k: v for k, v in (("width", width),
                                                                                  ("height", height)) if v is not None}))
    indices = frame_indices(scene, frames)
    done = run_frames(TruthRenderer(scene, exact=exact, memory_limit=memory_limit), indices, out, progress,
                      f"truth {scene.name}")
    stats = truth_stats(done)
    if out is not None:
        write_json(os.path.join(out, "stats.json"), stats)
    return done, stats

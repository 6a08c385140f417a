"""Layered depth textures (Zhang, Hsieh and Shen 2008) as a reflection method (:mod:`refsoft.seam`;
docs/ldt.md).

On the first frame, every reflected object's LDT is built in model space (stage ``ldt_build``)
and kept: it stays valid under any animated affine transform. Per reflector and frame: the cone
test of its visible triangles against every object (``regions``), then the per-pixel search of
its stencil (``ldt_search``), whose nearest hit gives the reflected object and its colour, shaded
(:func:`refsoft.raster.shade`) at the LDT's normal mapped to world by ``M^-T``.

The per-pixel inputs P and N are the main view's: the reflector's own world mesh is rasterized
over the stencil's box with the main view's matrix (:func:`refsoft.raster.rasterize`, the same
visible triangles as the main view, bit for bit) and its positions and normals interpolated
perspective-correctly at the pixel centres (:func:`refsoft.raster.interpolate`, renormalised
normals), in the working precision, as the vertex search's G-buffer does.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import linalg, validate
from ..errors import RefsoftError
from .. import keys
from ..raster import PRECISIONS, _setup, interpolate, rasterize, shade
from ..seam import ReflectorResult, stencil_box
from . import constants as C
from .build import build_ldt, check_resolution
from .regions import bounding_sphere, regions as region_table, visible_triangles
from .search import Stack, check_linear, cube_matrices, hit_normals, search

#: (T_k, K) bool per reflector: the cone test per triangle and object (False: not visible).
LDT_REGION = keys.LDT_REGION
#: (K,) int32: the reflected objects' ids, the order of ``ldt_object_distance``.
LDT_OBJECT_IDS = keys.LDT_OBJECT_IDS

#: Flag bit -> name in ``stats.json``.
FLAG_NAMES = {C.START_INSIDE: "start_inside", C.NO_FACE_WITHIN_TAU: "no_face_within_tau",
              C.LAYER_MISMATCH: "layer_mismatch", C.REGION_CULLED: "region_culled", C.OPEN_OBJECT: "open_object",
              C.ORIGIN_IN_CUBE: "origin_in_cube"}


#: Fill value of each per-pixel array where no object is hit (or off the stencil): -1 for ids,
#: indices and distances, 0 for the rest.
NO_HIT = {"ldt_hit_distance": -1, "ldt_face": -1, "ldt_layer": -1, "ldt_texel": -1, "ldt_object_distance": -1}


def pixel_arrays(n_objects: int) -> dict:
    """The method's per-pixel arrays (:data:`refsoft.keys.LDT_PIXEL_ARRAYS`): name -> (trailing
    shape, dtype, fill value off the reflectors and where nothing is hit)."""
    f32, i8 = np.float32, np.int8
    spec = {"ldt_ray_origin": ((3,), f32), "ldt_ray_dir": ((3,), f32), "ldt_hit_position": ((3,), f32),
            "ldt_hit_distance": ((), f32), "ldt_face": ((), i8), "ldt_layer": ((), i8),
            "ldt_texel": ((2,), np.int16), "ldt_residual": ((), f32), "ldt_linear_samples": ((), np.int32),
            "ldt_binary_steps": ((), np.int32), "ldt_faces_searched": ((), i8), "ldt_objects_tested": ((), i8),
            "ldt_flags": ((), np.uint8), "ldt_object_distance": ((n_objects,), f32), "ldt_margin": ((), f32)}
    return {name: spec[name] + (NO_HIT.get(name, 0),) for name in keys.LDT_PIXEL_ARRAYS}


@dataclass(eq=False)
class LDTState:
    """One reflector's search as :class:`refsoft.seam.ReflectorResult` keeps it (``state``): the
    inputs of :func:`refsoft.ldt.search.search` and its result, enough to replay any pixel.

    Attributes
    ----------
    rows, cols : ndarray (n,) int64
        The stencil pixels, in row-major order.
    P, N : ndarray (n, 3), the working precision
    triangle : ndarray (n,) int
        The main view's reflector triangle at each pixel.
    region : ndarray (T, K) bool
    W : ndarray (K, 4, 4) float64
        World -> cube matrices (rounded to the working precision by the search).
    view_dir : ndarray (3,) or None
        The orthographic view direction, None for a perspective camera.
    result : PixelSearch
    """

    rows: np.ndarray
    cols: np.ndarray
    P: np.ndarray
    N: np.ndarray
    triangle: np.ndarray
    region: np.ndarray
    W: np.ndarray
    view_dir: object
    result: object


class LayeredDepthTextures:
    """The LDT reflection method for every reflector of a scene.

    Parameters
    ----------
    scene : Scene
    resolution : int
        Texels per face edge R (4 .. 4096; a power of two keeps mirrored texels bit-exact).
    layers : {"all", 1}
        Depth-peeling layers built: all (up to 8) or the first only (the convex assumption).
    faces : {"three", "entry"}
        Faces searched per object: up to three, or only the entry face (Fig. 5's failure).
    linear : int or "texel"
        Linear search steps per face, or one step per texel.
    tau : float
        Residual (texels) under which a face's hit is accepted.
    regions : {"cone", "none"}
        The cone test per reflector triangle, or every triangle searched. The cone's apex is the
        eye: an orthographic view has none, and passes every visible triangle.
    precision : {"float32", "float64"}
        Working precision of the search (the LDT depths stay float32).
    """

    name = "ldt"
    stages = ("ldt_build", "regions", "ldt_search")

    def __init__(self, scene, *, resolution=C.RESOLUTION, layers="all", faces="three", linear=C.LINEAR_STEPS,
                 tau=C.TAU, regions="cone", precision="float32"):
        self.scene = scene
        self.resolution = check_resolution(resolution)
        if layers not in ("all", 1, "1"):
            raise RefsoftError(f"layers must be 'all' or 1, got {layers!r}")
        self.layers = "all" if layers == "all" else 1
        if faces not in C.FACE_MODES:
            raise RefsoftError(f"faces must be one of {C.FACE_MODES}, got {faces!r}")
        self.faces = faces
        check_linear(linear)
        self.linear = linear
        if not (validate.is_number(tau) and tau >= 0):
            raise RefsoftError(f"tau must be a number >= 0, got {tau!r}")
        self.tau = float(tau)
        if regions not in C.REGION_MODES:
            raise RefsoftError(f"regions must be one of {C.REGION_MODES}, got {regions!r}")
        self.regions = regions
        if precision not in PRECISIONS:
            raise RefsoftError(f"precision must be 'float32' or 'float64', got {precision!r}")
        self.precision = precision
        self.targets = [k for k in range(1, len(scene.objects) + 1) if not scene.object_by_id(k).reflector]
        self.pixel_arrays = pixel_arrays(len(self.targets))
        self.leading_axis_arrays = ("ldt_object_distance",)
        self.ldts = None      # object id -> LDT, built on the first frame
        self.build_ms = {}    # object id -> milliseconds
        self.stack = None     # the LDTs as one Stack (refsoft.ldt.search), made with them
        self._colors = np.array([o.color for o in scene.objects], np.float32).reshape(-1, 3)

    # --- the build ----------------------------------------------------------------------------
    def build(self) -> float:
        """Build every reflected object's LDT (once); returns the milliseconds spent."""
        if self.ldts is not None:
            return 0.0
        t0 = time.perf_counter()
        max_layers = C.MAX_LAYERS if self.layers == "all" else 1
        ldts = {}
        for k in self.targets:
            t = time.perf_counter()
            ldts[k] = build_ldt(self.scene.object_by_id(k).mesh, self.resolution, max_layers)
            self.build_ms[k] = 1000 * (time.perf_counter() - t)
        self.ldts = ldts
        self.stack = Stack.of(ldts, self.precision)
        return 1000 * (time.perf_counter() - t0)

    # --- the seam -----------------------------------------------------------------------------
    def reflect(self, view, k: int, stencil) -> ReflectorResult:
        """Reflector ``k``'s regions and per-pixel search over its stencil (the :mod:`refsoft.seam`
        interface)."""
        times = dict.fromkeys(self.stages, 0.0)
        times["ldt_build"] = self.build()
        out = ReflectorResult(k, time_ms=times, report={"reflector_pixels": 0, "hits": 0})
        mesh = view.meshes[k - 1]
        K = len(self.targets)
        t = time.perf_counter()
        visible = visible_triangles(view.view.triangle, stencil) if stencil.any() else np.zeros(0, np.int64)
        if self.regions == "cone" and view.camera.projection == "perspective":
            centres, radii = self.spheres(view)
            table = region_table(mesh, visible, view.camera.eye, centres, radii)
        else:  # no test, or an orthographic view: the cone's apex is the eye, which it has not
            table = np.zeros((mesh.n_faces, K), dtype=bool)
            table[visible] = True
        times["regions"] = 1000 * (time.perf_counter() - t)
        out.arrays = {LDT_REGION(k): table, LDT_OBJECT_IDS: np.asarray(self.targets, np.int32)}
        out.report["region_triangles"] = {"visible": int(len(visible)), "passed": int(table[visible].any(axis=1).sum())}
        if not stencil.any():
            return out
        t = time.perf_counter()
        box = stencil_box(stencil)
        r0, r1, c0, c1 = box
        rows, cols = np.nonzero(stencil)
        P, N = self.surface(view, k, box, rows, cols)
        cam = view.camera
        view_dir = None
        if cam.projection == "orthographic":
            d = np.asarray(cam.target, np.float64) - cam.eye
            view_dir = d / linalg.norm3(d)
        W = cube_matrices(self.stack, view.transforms)
        tri = view.view.triangle[rows, cols]
        res = search(P, N, cam.eye, tri, table, W, self.stack, view_dir, self.linear, self.tau, self.faces,
                     self.regions, self.precision)
        got = res.object >= 0
        ids = np.zeros(len(got), np.int32)  # (a scene may have no reflected object: ids is then empty)
        ids[got] = self.stack.ids[res.object[got]]
        colour = self.colours(view, res, ids)
        h, w = r1 - r0, c1 - c0
        rr, cc = rows - r0, cols - c0
        out.box = box
        out.colour = np.zeros((h, w, 3), np.float32)
        out.reflected_id = np.zeros((h, w), np.int32)
        out.covered = np.zeros((h, w), bool)
        out.colour[rr[got], cc[got]] = colour[got]
        out.reflected_id[rr, cc] = ids
        out.covered[rr[got], cc[got]] = True
        values = {"ldt_ray_origin": P, "ldt_ray_dir": res.ray, "ldt_hit_position": res.hit,
                  "ldt_hit_distance": res.distance, "ldt_face": res.face, "ldt_layer": res.layer,
                  "ldt_texel": res.texel, "ldt_residual": res.residual, "ldt_linear_samples": res.linear_samples,
                  "ldt_binary_steps": res.binary_steps, "ldt_faces_searched": res.faces_searched,
                  "ldt_objects_tested": res.objects_tested, "ldt_flags": res.flags,
                  "ldt_object_distance": res.object_distance, "ldt_margin": res.margin}
        pixels = {}
        for name, (shape, dt, fill) in self.pixel_arrays.items():
            a = np.full((h, w) + shape, fill, dtype=dt)
            a[rr, cc] = values[name]
            pixels[name] = a
        out.pixels = pixels
        out.pixel_mask = stencil[r0:r1, c0:c1]
        out.state = LDTState(rows, cols, P, N, tri, table, W, view_dir, res)
        out.report.update(self._pixel_report(res))
        times["ldt_search"] = 1000 * (time.perf_counter() - t)
        return out

    def frame_report(self, results) -> dict:
        """``stats.json``'s ``ldt`` entry: pixels, hits, samples and steps (mean, max), flag counts,
        the cone test's visible and passed triangles per reflector, and per object its layers,
        layer histogram, mismatch texels, open and capped flags and build milliseconds."""
        reps = [r.report for r in results.values()]
        pixels = sum(r["reflector_pixels"] for r in reps)

        def stat(name):
            total = sum(r.get(name + "_sum", 0) for r in reps)
            return {"mean": total / pixels if pixels else 0.0, "max": max([r.get(name + "_max", 0) for r in reps] + [0])}

        flags = {n: sum(r.get("flags", {}).get(n, 0) for r in reps) for n in FLAG_NAMES.values()}
        objects = {}
        for k, ldt in (self.ldts or {}).items():
            objects[str(k)] = {"layers": ldt.n_layers, "layer_histogram": {str(a): b for a, b in ldt.layer_histogram.items()},
                               "mismatch_texels": int(ldt.mismatch.sum()), "open": ldt.open,
                               "layers_capped": ldt.layers_capped, "build_ms": self.build_ms.get(k, 0.0)}
        return {"ldt": {"reflector_pixels": pixels, "hits": sum(r["hits"] for r in reps),
                        "linear_samples": stat("linear_samples"), "binary_steps": stat("binary_steps"),
                        "flags": flags,
                        "region_triangles": {str(k): r.report["region_triangles"] for k, r in results.items()},
                        "resolution": self.resolution, "objects": objects}}

    def run_files(self) -> dict:
        """``{"ldt_J": arrays}`` for every reflected object J (:meth:`refsoft.ldt.LDT.arrays`),
        written once per run beside the frames; empty before the first frame built them."""
        return {keys.ldt_file(j): ldt.arrays() for j, ldt in (self.ldts or {}).items()}

    # --- the pieces ---------------------------------------------------------------------------
    def spheres(self, view):
        """Each reflected object's world bounding sphere this frame: the world image of its cube
        centre, and the farthest world vertex's distance from it (times 1 + 1e-6)."""
        centres = np.zeros((len(self.targets), 3))
        radii = np.zeros(len(self.targets))
        for i, j in enumerate(self.targets):
            M = view.transforms[j].matrix()
            centres[i] = linalg.matvec(M[:3, :3], self.ldts[j].cube_center) + M[:3, 3]
            radii[i] = bounding_sphere(view.meshes[j - 1], centres[i])
        return centres, radii

    def surface(self, view, k, box, rows, cols):
        """P and N (n, 3) in the working precision at the stencil pixels (rows, cols): the
        reflector's world mesh rasterized over ``box`` and interpolated."""
        mesh = view.meshes[k - 1]
        cam = view.camera
        clip = _setup.transform_points(mesh.vertices, cam.view_proj())
        frags = rasterize(clip, mesh.faces, cam.width, cam.height, region=box)
        r0, c0 = box[0], box[2]
        P = interpolate(frags, mesh.vertices, mesh.faces, self.precision)[rows - r0, cols - c0]
        N = interpolate(frags, mesh.normals, mesh.faces, self.precision, normalize=True)[rows - r0, cols - c0]
        return P, N

    def colours(self, view, res, ids):
        """(n, 3) float32: each hit's object colour shaded at its LDT normal in world
        (``normalize(M^-T n)``); zero where nothing is hit."""
        n_model = hit_normals(self.stack, res).astype(np.float64)
        n_world = np.zeros_like(n_model)
        for j in np.unique(ids[ids > 0]):
            sel = ids == j
            minv = linalg.inv3(view.transforms[int(j)].matrix()[:3, :3])
            n_world[sel] = linalg.rows_times(n_model[sel], minv.T)  # rows: (M^-T n)^T = n^T M^-1
        length = linalg.norm3(n_world)[:, None]
        n_world = np.divide(n_world, length, out=np.zeros_like(n_world), where=length > 0)
        colour = shade(n_world, self._colors[np.maximum(ids - 1, 0)])
        colour[ids == 0] = 0.0
        return colour

    def _pixel_report(self, res) -> dict:
        flags = {name: int(np.count_nonzero(res.flags & bit)) for bit, name in FLAG_NAMES.items()}
        return {"reflector_pixels": int(len(res.object)), "hits": int(np.count_nonzero(res.object >= 0)),
                "linear_samples_sum": int(res.linear_samples.sum()),
                "linear_samples_max": int(res.linear_samples.max(initial=0)),
                "binary_steps_sum": int(res.binary_steps.sum()), "binary_steps_max": int(res.binary_steps.max(initial=0)),
                "flags": flags}

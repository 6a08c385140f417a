"""One frame of the main method on llvmpipe (spec sections 1, 4 and 5), stage by stage.

:class:`Pipeline` is the exact variant: every stage is refsoft's arithmetic written out
(float64 setup, integer coverage, the working precision's interpolation and search with
``precise``). :class:`refsoft_glsl.plain.PlainPipeline` overrides the stages a usual port
writes differently. Each stage's buffers stay on the GPU; :meth:`Pipeline.outputs` reads back
what spec section 7 asks for.
"""

from __future__ import annotations

import time

import numpy as np

from .camera import gbuffer_camera
from .raster import Raster, params_array

HIDDEN, BORDER, CAPPED, RESTARTED, CULLED = 1, 2, 4, 8, 16
#: Spec 4.3: a walk that stopped on the border is walked again only below this score.
BORDER_RESTART_SCORE = 0.9
INVERSE_MODES = ("plane", "search", "discard")
NEIGHBOURHOODS = {"cross": 5, "box": 9}


class FrameData:
    """A frame's meshes on the GPU: the whole scene (main view), the reflected objects
    (vertices searched, their faces and normals) and each reflector's G-buffer mesh."""

    def __init__(self, gl, case, frame, cache):
        self.gl = gl
        objs = case.objects
        meshes = [frame.meshes[o["id"]] for o in objs]
        self.scene = cache.get(("scene", tuple(id(m) for m in meshes)), lambda: _concat(gl, meshes,
                                                                                          [o["id"] for o in objs]))
        refl_ids = case.reflected_ids
        refl = [frame.meshes[k] for k in refl_ids]
        self.reflected = cache.get(("reflected", tuple(id(m) for m in refl)), lambda: _concat(gl, refl, refl_ids))
        self.proxies = {}
        for k in case.reflector_ids:
            m = frame.proxies.get(k, frame.meshes[k])
            self.proxies[k] = cache.get(("proxy", id(m)), lambda m=m: _concat(gl, [m], [k]))


class Cache:
    """GPU copies of meshes, kept while the same world meshes come back frame after frame."""

    def __init__(self):
        self.items, self.used = {}, set()

    def get(self, key, make):
        self.used.add(key)
        if key not in self.items:
            self.items[key] = make()
        return self.items[key]

    def end_frame(self):
        for key in set(self.items) - self.used:
            del self.items[key]
        self.used = set()


class MeshData:
    """Concatenated meshes on the GPU and on the host."""

    def __init__(self, gl, vertices, normals, faces, face_object, vertex_object):
        self.n_vertices, self.n_faces = len(vertices), len(faces)
        self.vertices = vertices
        self.vertex_object = vertex_object
        self.points = gl.buffer(vertices.astype(np.float64))
        self.normals = gl.buffer(normals.astype(np.float64))
        self.faces = gl.buffer(faces.astype(np.int32))
        self.face_object = gl.buffer(face_object.astype(np.int32))
        self.host = (vertices, normals, faces, face_object)


def _concat(gl, meshes, ids):
    if not meshes:
        z = np.zeros((0, 3))
        return MeshData(gl, z, z, np.zeros((0, 3), np.int32), np.zeros(0, np.int32), np.zeros(0, np.int32))
    offsets = np.cumsum([0] + [m.n_vertices for m in meshes])
    v = np.concatenate([m.vertices for m in meshes])
    n = np.concatenate([m.normals for m in meshes])
    f = np.concatenate([m.faces.astype(np.int64) + offsets[i] for i, m in enumerate(meshes)])
    fo = np.repeat(np.asarray(ids, np.int32), [m.n_faces for m in meshes])
    vo = np.repeat(np.asarray(ids, np.int32), [m.n_vertices for m in meshes])
    return MeshData(gl, v, n, f, fo, vo)


def shading_buffer(gl, case, background=None):
    """The float32 table ``interp.comp`` shades with: the light (3), ambient, diffuse, the
    background colour (3; the case's unless given), then every object's colour by id (row 0
    unused)."""
    s = case.shading
    table = np.zeros((len(case.objects) + 1, 3))
    table[1:] = [o["color"] for o in case.objects]
    bg = s["background"] if background is None else background
    values = np.concatenate([s["light"], [s["ambient"], s["diffuse"]], bg, table.reshape(-1)])
    return gl.buffer(values.astype(np.float32))


class Pipeline:
    """The main method on llvmpipe, exact: one case, frame after frame (coherence between them).

    Parameters
    ----------
    gl : refsoft_glsl.context.GL
    case : refsoft_glsl.inputs.Case
    """

    exact = True

    def __init__(self, gl, case):
        self.gl, self.case = gl, case
        opt = case.options
        self.options = opt
        for name, allowed in (("method", ("walk", "hierarchy")), ("virtual", ("mirror", "unfold")),
                              ("silhouette", ("texel", "clip")), ("adaptive_widen", (False,)),
                              ("draw", (None, "raster"))):
            if opt.get(name) not in allowed:
                raise NotImplementedError(f"case {case.name}: option {name}={opt.get(name)!r} is not ported")
        self.double = opt.get("precision", "float32") == "float64"
        self.hierarchy = opt["method"] == "hierarchy"
        self.refine = bool(opt.get("refine", False))
        self.tessellate = opt.get("tessellate")
        self.clip = opt.get("silhouette") == "clip"
        self.unfold = opt.get("virtual") == "unfold"
        if self.hierarchy and (self.double or self.tessellate is not None or self.clip):
            raise NotImplementedError(f"case {case.name}: the hierarchy search is ported in float32, without "
                                      "tessellation or the silhouette cut")
        self.real = np.float64 if self.double else np.float32
        self.nb = NEIGHBOURHOODS[opt["neighbourhood"]]
        self.inverse = opt["inverse"]
        self.rasters = {}
        self.cache = Cache()
        self.previous = {}   # reflector -> (pixel buffer, count, G-buffer size)
        self.shading = shading_buffer(gl, case)

    def raster(self, w, h) -> Raster:
        r = self.rasters.get((w, h))
        if r is None:
            r = self.rasters[(w, h)] = Raster(self.gl, w, h)
        return r

    # --- one frame -------------------------------------------------------------------------------
    def render(self, frame):
        """Render one frame; returns ``(arrays, time_ms, iterations)``."""
        gl, case = self.gl, self.case
        times = dict.fromkeys(("gbuffer", "search", "virtual", "main", "composite"), 0.0)
        t0 = time.perf_counter()
        W, H = case.width, case.height
        t = time.perf_counter()
        data = FrameData(gl, case, frame, self.cache)
        view = self.main_view(frame, data)
        gl.finish()
        times["main"] += _ms(t)
        colour = gl.ctx.buffer(view["colour"].read())
        reflected = gl.buffer(np.full(W * H, -1, np.int32))
        arrays, iterations = {}, {}
        for k in case.reflector_ids:
            t = time.perf_counter()
            gb = self.gbuffer(frame, data, k)
            gl.finish()
            times["gbuffer"] += _ms(t)
            t = time.perf_counter()
            res = self.search(frame, data, gb, k)
            surface = self.refine_points(gb, data.reflected.points, data.reflected.n_vertices, res) \
                if self.refine else None
            vv = self.virtual_vertices(frame, data, gb, res, surface)
            gl.finish()
            times["search"] += _ms(t)   # the search, the refinement and the virtual vertices, as refsoft's
            t = time.perf_counter()
            if self.tessellate is not None or self.clip:
                geometry = self.refined_geometry(data, gb, res, surface, vv)
                times["tessellate"] = times.get("tessellate", 0.0) + _ms(t)
                t = time.perf_counter()
                vcol, vid = self.draw_virtual(frame, view, *geometry, k)
            else:
                vcol, vid = self.virtual_pass(frame, data, view, vv, res, k)
            gl.finish()
            times["virtual"] += _ms(t)
            t = time.perf_counter()
            rho = float(case.objects[k - 1]["reflectivity"])
            gl.run(gl.compute("composite"), W * H, [view["id"], view["colour"], vcol, vid, colour, reflected],
                   n=W * H, reflector=k, rho=rho)
            gl.finish()
            times["composite"] += _ms(t)
            arrays.update(self.reflector_outputs(k, gb, res, vv, data))
            it, fl = arrays[f"iterations_{k}"], arrays[f"flags_{k}"]
            live = it[(fl & CULLED) == 0]
            iterations[str(k)] = {"mean": float(live.mean()) if len(live) else 0.0,
                                  "max": int(live.max()) if len(live) else 0}
        t = time.perf_counter()
        image = gl.buffer(nbytes=W * H * 3)
        gl.run(gl.compute("to_uint8"), -(-W * H * 3 // 4), [colour, image], n=W * H * 3)
        arrays["image"] = gl.read(image, np.uint8, (H, W, 3))
        times["composite"] += _ms(t)
        arrays["object_id"] = gl.read(view["id"], np.int32, (H, W))
        arrays["reflected_id"] = gl.read(reflected, np.int32, (H, W))
        times["total"] = _ms(t0)
        self.cache.end_frame()
        return arrays, times, iterations

    # --- stages ----------------------------------------------------------------------------------
    def main_view(self, frame, data) -> dict:
        """Colour (float32) and object id of every pixel of the view (spec section 5)."""
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        scene = data.scene
        params = gl.buffer(params_array(frame.view_proj, W, H))
        r = self.raster(W, H)
        s = r.setup(scene.points, scene.n_vertices, scene.faces, scene.n_faces, params)
        r.draw(s)
        return self._shade(r, s, scene, params, mode=1)

    def _shade(self, r, s, mesh, params, mode, view_id=None, reflector=0, shading=None):
        gl, W, H = self.gl, r.width, r.height
        colour = gl.buffer(nbytes=W * H * 12)
        ids = gl.buffer(nbytes=W * H * 4)
        r.bind_setup(s)
        gl.run(gl.compute("interp", MODE=mode), W * H,
               [None, None, None, None, None, mesh.faces, mesh.points, mesh.normals, params,
                self.shading if shading is None else shading,
                mesh.face_object, view_id, colour, ids], width=W, height=H, reflector=reflector, region=(0, H, 0, W))
        return {"colour": colour, "id": ids}

    def gbuffer(self, frame, data, k) -> dict:
        """Reflector ``k``'s G-buffer (its closed proxy), positions relative to the eye."""
        gl = self.gl
        vp, w, h = gbuffer_camera(frame, self.options)
        mesh = data.proxies[k]
        params = gl.buffer(np.concatenate([params_array(vp, w, h, frame.eye), frame.eye]))
        r = self.raster(w, h)
        s = r.setup(mesh.points, mesh.n_vertices, mesh.faces, mesh.n_faces, params)
        r.draw(s)
        es = 8 if self.double else 4
        P, N, M = gl.buffer(nbytes=w * h * 3 * es), gl.buffer(nbytes=w * h * 3 * es), gl.buffer(nbytes=w * h * 4)
        r.bind_setup(s)
        gl.run(gl.compute("interp", MODE=0, DOUBLE=int(self.double)), w * h,
               [None, None, None, None, None, mesh.faces, mesh.points, mesh.normals, params, None, None, None,
                P, N, M], width=w, height=h, region=(0, h, 0, w))
        start = gl.buffer(nbytes=16)
        gl.run(gl.compute("start"), 0, [P, N, M, start], groups=1, gwidth=w, gheight=h)
        return {"P": P, "N": N, "mask": M, "params": params, "view_proj": vp, "width": w, "height": h,
                "start": start}

    def search(self, frame, data, gb, k) -> dict:
        """Every reflected vertex's search in reflector ``k``'s G-buffer (spec section 4)."""
        gl, opt = self.gl, self.options
        w, h = gb["width"], gb["height"]
        n = data.reflected.n_vertices
        start = gb["start"]
        if self.hierarchy:
            from .hierarchy import hierarchy_search

            return hierarchy_search(self, data, gb, start)
        prev = self.previous.get(k) if opt.get("coherence", True) else None
        has_prev = prev is not None and prev[1] == n
        es = 8 if self.double else 4
        out = {"pixel": gl.buffer(nbytes=8 * n), "score": gl.buffer(nbytes=es * n), "margin": gl.buffer(nbytes=es * n),
               "iterations": gl.buffer(nbytes=4 * n), "flags": gl.buffer(nbytes=4 * n)}
        cap = opt.get("cap") or 2 * (w + h)
        gl.run(gl.compute("search", NB=self.nb, DOUBLE=int(self.double), EXACT=int(self.exact)), n,
               [gb["P"], gb["N"], gb["mask"], start, data.reflected.points, gb["params"],
                prev[0] if has_prev else out["pixel"], out["pixel"], out["score"], out["margin"], out["iterations"],
                out["flags"]], n=n, cap=int(cap), has_previous=has_prev, inverse_search=self.inverse == "search",
               gwidth=w, gheight=h)
        if has_prev and opt.get("border_restart", False):
            out = self._border_restart(data, gb, out, n, cap)
        self.previous[k] = (out["pixel"], n, (w, h))
        return out

    def _border_restart(self, data, gb, out, n, cap):
        """Spec 4.3's restart beyond the papers (``border_restart``): the walks from a previous
        pixel that stopped on the border (BORDER, not RESTARTED or CULLED) with a score below
        :data:`BORDER_RESTART_SCORE` (compared in the score's own precision) walked again from
        the start without history; the higher score kept (a tie keeps the first walk), the
        iterations summed."""
        gl, real = self.gl, self.real
        flags = gl.read(out["flags"], np.uint32, (n,))
        score = gl.read(out["score"], real, (n,))
        again = np.flatnonzero(((flags & BORDER) != 0) & ((flags & (CULLED | RESTARTED)) == 0)
                               & (score < real(BORDER_RESTART_SCORE)))
        if len(again) == 0:
            return out
        m = len(again)
        es = 8 if self.double else 4
        fresh = {"pixel": gl.buffer(nbytes=8 * m), "score": gl.buffer(nbytes=es * m),
                 "margin": gl.buffer(nbytes=es * m), "iterations": gl.buffer(nbytes=4 * m),
                 "flags": gl.buffer(nbytes=4 * m)}
        w, h = gb["width"], gb["height"]
        gl.run(gl.compute("search", NB=self.nb, DOUBLE=int(self.double), EXACT=int(self.exact)), m,
               [gb["P"], gb["N"], gb["mask"], gb["start"],
                gl.buffer(np.asarray(data.reflected.vertices, np.float64)[again]), gb["params"], fresh["pixel"],
                fresh["pixel"], fresh["score"], fresh["margin"], fresh["iterations"], fresh["flags"]],
               n=m, cap=int(cap), has_previous=False, inverse_search=self.inverse == "search", gwidth=w, gheight=h)
        shapes = {"pixel": (np.int32, (2,)), "score": (real, ()), "margin": (real, ()), "iterations": (np.int32, ()),
                  "flags": (np.uint32, ())}
        old = {key: gl.read(out[key], dt, (n,) + tail) for key, (dt, tail) in shapes.items()}
        new = {key: gl.read(fresh[key], dt, (m,) + tail) for key, (dt, tail) in shapes.items()}
        better = new["score"] > old["score"][again]
        take = again[better]
        for key in ("pixel", "score", "margin", "flags"):
            old[key][take] = new[key][better]
        old["iterations"][again] += new["iterations"]
        return {key: gl.buffer(np.ascontiguousarray(v)) for key, v in old.items()}

    def virtual_vertices(self, frame, data, gb, res, surface=None) -> dict:
        return self._virtual(gb, data.reflected.points, data.reflected.n_vertices, res["pixel"], res["flags"],
                             surface)

    def _virtual(self, gb, points, n, pixel, flags, surface=None) -> dict:
        """Virtual vertices (spec section 4.6) of ``n`` world points, from their pixels or their
        sub-texel ``surface`` (buffers ``P``, ``N``): float32 and float64 world buffers."""
        gl = self.gl
        v32, v64 = gl.buffer(nbytes=12 * n), gl.buffer(nbytes=24 * n)
        sp, sn = (surface["P"], surface["N"]) if surface is not None else (None, None)
        gl.run(gl.compute("virtual", DOUBLE=int(self.double), EXACT=int(self.exact), SURFACE=int(surface is not None)),
               n, [gb["P"], gb["N"], sp, sn, points, gb["params"], None, pixel, None, None, None, flags, v32, v64],
               n=n, gwidth=gb["width"], mode=INVERSE_MODES.index(self.inverse), unfold=self.unfold)
        return {"v32": v32, "v64": v64}

    def refine_points(self, gb, points, n, res) -> dict:
        """Sub-texel reflection points of ``n`` world points from their search results (buffers
        ``P``, ``N``, ``offset`` relative to the G-buffer's origin)."""
        gl = self.gl
        es = 8 if self.double else 4
        out = {"P": gl.buffer(nbytes=3 * es * n), "N": gl.buffer(nbytes=3 * es * n), "offset": gl.buffer(nbytes=2 * es * n)}
        gl.run(gl.compute("refine", DOUBLE=int(self.double), EXACT=int(self.exact), MIN_DET=_min_det(self.double)), n,
               [gb["P"], gb["N"], gb["mask"], None, points, gb["params"], None, res["pixel"], None, None, None,
                res["flags"], out["P"], out["N"], out["offset"]], n=n, gwidth=gb["width"], gheight=gb["height"])
        return out

    def virtual_pass(self, frame, data, view, vv, res, k):
        """The virtual scene of reflector ``k`` on its stencil: colour and reflected id."""
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        refl = data.reflected
        params = gl.buffer(params_array(frame.view_proj, W, H))
        r = self.raster(W, H)
        box = gl.buffer(nbytes=32)
        gl.run(gl.compute("box"), 0, [view["id"], box], groups=1, width=W, height=H, reflector=k)
        bad = CULLED | (HIDDEN if self.inverse == "discard" else 0)
        s = r.setup(vv["v64"], refl.n_vertices, refl.faces, refl.n_faces, params, flags=res["flags"], bad=bad)
        r.draw(s)
        out = self._shade(r, s, refl, params, mode=2, view_id=view["id"], reflector=k)
        return out["colour"], out["id"]

    def refined_geometry(self, data, gb, res, surface, vv):
        """The reflected geometry after the tessellation and the silhouette cut
        (:mod:`refsoft_glsl.geometry`), the searched vertices first, then the new ones:
        ``(virtual vertices (V, 3) float64 world, normals, faces, face objects, flags)``."""
        from .geometry import Reflected, clip_at_silhouette, tessellate

        gl, opt = self.gl, self.options
        refl = data.reflected
        n = refl.n_vertices
        real = self.real
        vertices, normals, faces, face_obj = refl.host
        geo = Reflected(vertices, normals, gl.read(res["pixel"], np.int32, (n, 2)),
                        gl.read(res["flags"], np.uint32, (n,)),
                        None if surface is None else tuple(gl.read(surface[key], real, (n, width))
                                                           for key, width in (("P", 3), ("N", 3), ("offset", 2))),
                        faces.astype(np.int64), face_obj.astype(np.int32))
        gpu = _GeometryShaders(self, gb)
        virtual = [gl.read(vv["v64"], np.float64, (n, 3))]
        if self.tessellate is not None:
            tessellate(geo, gpu, gpu.mask, float(self.tessellate), int(opt.get("max_level", 3)),
                       int(opt.get("tessellate_span", 0)), self.inverse == "search")
            sub = None if geo.surface is None else tuple(a[n:] for a in geo.surface[:2])
            virtual.append(gpu.virtual(geo.vertices[n:], geo.pixel[n:], geo.flags[n:], sub))
        if self.clip:
            cut_v, cut_n, pixel, flags, _ = clip_at_silhouette(geo, gpu)
            if len(cut_v):
                sub = gpu.refine(cut_v, pixel, flags)[:2] if self.refine else None
                virtual.append(gpu.virtual(cut_v, pixel, flags, sub))
                geo.vertices = np.concatenate([geo.vertices, cut_v])
                geo.normals = np.concatenate([geo.normals, cut_n])
                geo.flags = np.concatenate([geo.flags, flags])
        return np.concatenate(virtual), geo.normals, geo.faces, geo.face_obj, geo.flags

    def draw_virtual(self, frame, view, v64, normals, faces, face_obj, flags, k):
        """Rasterize virtual triangles given on the host (float64 world ``v64``) on reflector
        ``k``'s stencil: colour and reflected id buffers."""
        gl = self.gl
        mesh = MeshData(gl, v64, normals, faces, face_obj, np.zeros(len(v64), np.int32))
        W, H = self.case.width, self.case.height
        params = gl.buffer(params_array(frame.view_proj, W, H))
        r = self.raster(W, H)
        bad = CULLED | (HIDDEN if self.inverse == "discard" else 0)
        s = r.setup(mesh.points, mesh.n_vertices, mesh.faces, mesh.n_faces, params,
                    flags=gl.buffer(np.asarray(flags, np.uint32)), bad=bad)
        r.draw(s)
        out = self._shade(r, s, mesh, params, mode=2, view_id=view["id"], reflector=k)
        return out["colour"], out["id"]

    # --- outputs ---------------------------------------------------------------------------------
    def reflector_outputs(self, k, gb, res, vv, data) -> dict:
        gl = self.gl
        w, h, n = gb["width"], gb["height"], data.reflected.n_vertices
        P, N = gl.buffer(nbytes=w * h * 12), gl.buffer(nbytes=w * h * 12)
        gl.run(gl.compute("gbuffer_out", DOUBLE=int(self.double)), w * h,
               [gb["P"], gb["N"], gb["mask"], None, None, gb["params"], P, N], n=w * h)
        real = self.real
        return {f"gbuffer_position_{k}": gl.read(P, np.float32, (h, w, 3)),
                f"gbuffer_normal_{k}": gl.read(N, np.float32, (h, w, 3)),
                f"gbuffer_mask_{k}": gl.read(gb["mask"], np.int32, (h, w)).astype(bool),
                f"gbuffer_view_proj_{k}": np.asarray(gb["view_proj"], dtype=np.float64),
                f"reflection_pixel_{k}": gl.read(res["pixel"], np.int32, (n, 2)),
                f"virtual_vertex_{k}": gl.read(vv["v32"], np.float32, (n, 3)),
                f"iterations_{k}": gl.read(res["iterations"], np.int32, (n,)),
                f"flags_{k}": gl.read(res["flags"], np.uint32, (n,)).astype(np.uint8),
                f"vertex_object_{k}": data.reflected.vertex_object.astype(np.int32),
                f"score_{k}": gl.read(res["score"], real, (n,)),
                f"margin_{k}": gl.read(res["margin"], real, (n,))}


class _GeometryShaders:
    """The GPU stages :mod:`refsoft_glsl.geometry` calls, on host arrays, in one G-buffer."""

    def __init__(self, pipe, gb):
        self.pipe, self.gb, self.gl = pipe, gb, pipe.gl
        self.mask = self.gl.read(gb["mask"], np.int32, (gb["height"], gb["width"])) != 0

    def texels(self):
        if not hasattr(self, "_texels"):
            gl, gb = self.gl, self.gb
            shape = (gb["height"], gb["width"], 3)
            params = gl.read(gb["params"], np.float64, (24,))
            self._texels = (gl.read(gb["P"], self.pipe.real, shape), gl.read(gb["N"], self.pipe.real, shape),
                            params[18:21].copy(), params[21:24].copy())
        return self._texels

    def search(self, points, starts, inverse_search):
        gl, pipe, gb = self.gl, self.pipe, self.gb
        m = len(points)
        out = {"pixel": gl.buffer(nbytes=8 * m), "score": gl.buffer(nbytes=8 * m), "margin": gl.buffer(nbytes=8 * m),
               "iterations": gl.buffer(nbytes=4 * m), "flags": gl.buffer(nbytes=4 * m)}
        cap = pipe.options.get("cap") or 2 * (gb["width"] + gb["height"])
        gl.run(gl.compute("search", NB=pipe.nb, DOUBLE=int(pipe.double), EXACT=int(pipe.exact)), m,
               [gb["P"], gb["N"], gb["mask"], gb["start"], gl.buffer(np.asarray(points, np.float64)), gb["params"],
                gl.buffer(np.asarray(starts, np.int32)), out["pixel"], out["score"], out["margin"], out["iterations"],
                out["flags"]], n=m, cap=int(cap), has_previous=True, inverse_search=bool(inverse_search),
               gwidth=gb["width"], gheight=gb["height"])
        return gl.read(out["pixel"], np.int32, (m, 2)), gl.read(out["flags"], np.uint32, (m,))

    def _buffers(self, points, pixel, flags):
        gl = self.gl
        return ({"pixel": gl.buffer(np.asarray(pixel, np.int32)), "flags": gl.buffer(np.asarray(flags, np.uint32))},
                gl.buffer(np.asarray(points, np.float64)))

    def refine(self, points, pixel, flags):
        m = len(points)
        res, pts = self._buffers(points, pixel, flags)
        out = self.pipe.refine_points(self.gb, pts, m, res)
        return tuple(self.gl.read(out[key], self.pipe.real, (m, width)) for key, width in (("P", 3), ("N", 3), ("offset", 2)))

    def virtual(self, points, pixel, flags, surface):
        gl = self.gl
        m = len(points)
        if m == 0:
            return np.zeros((0, 3))
        res, pts = self._buffers(points, pixel, flags)
        sub = None if surface is None else {"P": gl.buffer(surface[0]), "N": gl.buffer(surface[1])}
        vv = self.pipe._virtual(self.gb, pts, m, res["pixel"], res["flags"], sub)
        return gl.read(vv["v64"], np.float64, (m, 3))

    def edge_errors(self, vertices, pixel, offset, e0, e1):
        gl, gb, pipe = self.gl, self.gb, self.pipe
        m = len(e0)
        out = gl.buffer(nbytes=8 * m)
        off = offset if offset is not None else np.zeros((1, 2), pipe.real)
        gl.run(gl.compute("edge_error", DOUBLE=int(pipe.double), EXACT=int(pipe.exact)), m,
               [gb["P"], gb["N"], gb["mask"], None, gl.buffer(np.asarray(vertices, np.float64)), gb["params"], None,
                gl.buffer(np.asarray(pixel, np.int32)), gl.buffer(np.asarray(off, pipe.real)),
                gl.buffer(np.c_[e0, e1].astype(np.int32)), out], n=m, subtexel=offset is not None,
               gwidth=gb["width"], gheight=gb["height"])
        return gl.read(out, np.float64, (m,))


def _min_det(double):
    """The refinement's determinant threshold 1e-6 in the working precision, bit for bit."""
    if double:
        lo, hi = np.array([1e-6]).view(np.uint32)
        return f"packDouble2x32(uvec2({lo}u, {hi}u))"
    return f"uintBitsToFloat({int(np.array([1e-6], np.float32).view(np.uint32)[0])}u)"


def _ms(t):
    return 1000.0 * (time.perf_counter() - t)

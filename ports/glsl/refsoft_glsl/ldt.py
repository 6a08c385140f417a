"""The layered depth textures (``method ldt``; refsoft's ``docs/ldt.md``) on llvmpipe.

On the first frame every reflected object's textures are built from its model-space mesh by
depth peeling (:mod:`refsoft_glsl.ldt_build`) and kept. Per reflector and frame: the cone test
of its visible triangles against every object's bounding sphere (on the host, float64 NumPy,
:func:`cone_test`), the reflector's surface rasterized alone (world positions and normals by
``interp.comp``), then ``ldt_search.comp``, one invocation per stencil pixel. The hits are shaded
on the host at the texture's normal mapped to world by ``M^-T`` and composited as for the vertex
search.
"""

from __future__ import annotations

import time

import numpy as np

from .envmap import _mesh
from .ldt_build import MAX_LAYERS, build_textures, pair_back_depths
from .pipeline import Cache, FrameData, Pipeline, _ms, shading_buffer
from .plain import PlainPipeline
from .raster import params_array

#: Flag bits the host adds (the search's own are in ``ldt_search.comp``).
LAYER_MISMATCH, OPEN_OBJECT = 4, 16
#: The cone test's sphere radius is the farthest vertex times this.
SPHERE_GROWTH = 1.0 + 1e-6
#: Per-pixel arrays: name -> (trailing shape, dtype, fill off the reflectors and where nothing is hit).
PIXEL_ARRAYS = {"ldt_ray_origin": ((3,), np.float32, 0), "ldt_ray_dir": ((3,), np.float32, 0),
                "ldt_hit_position": ((3,), np.float32, 0), "ldt_hit_distance": ((), np.float32, -1),
                "ldt_face": ((), np.int8, -1), "ldt_layer": ((), np.int8, -1), "ldt_texel": ((2,), np.int16, -1),
                "ldt_residual": ((), np.float32, 0), "ldt_linear_samples": ((), np.int32, 0),
                "ldt_binary_steps": ((), np.int32, 0), "ldt_faces_searched": ((), np.int8, 0),
                "ldt_objects_tested": ((), np.int8, 0), "ldt_flags": ((), np.uint8, 0),
                "ldt_object_distance": (("K",), np.float32, -1), "ldt_margin": ((), np.float32, 0)}


def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def cone_test(corners, eye, centres, radii) -> np.ndarray:
    """(T, K) bool: whether triangle t (world ``corners`` (T, 3, 3)) can show object k (bounding
    sphere ``centres`` (K, 3), ``radii`` (K,)) seen from ``eye``: refsoft's cone test
    (``docs/ldt.md``, "Reflection regions"), in float64, the same expressions in the same order
    (a corner inside the cone, an edge meeting its surface, its axis through the triangle; or no
    plane, or the eye inside the virtual sphere)."""
    P = np.asarray(corners, np.float64)[:, None]
    Cv = np.asarray(eye, np.float64)
    O = np.asarray(centres, np.float64)[None]
    rho = np.asarray(radii, np.float64)[None]
    p1, p2, p3 = P[..., 0, :], P[..., 1, :], P[..., 2, :]
    n = np.cross(p1 - p2, p3 - p2)
    length = np.sqrt(_dot(n, n))
    flat = length == 0.0
    n = n / np.where(flat, 1.0, length)[..., None]
    e = -_dot(n, p1)
    Ov = O - 2.0 * (_dot(n, O) + e)[..., None] * n
    w = Ov - Cv
    dist = np.sqrt(_dot(w, w))
    passed = flat | (dist <= rho)
    g = w / np.where(dist > 0, dist, 1.0)[..., None]
    cos2 = 1.0 - rho ** 2 / np.where(dist > 0, dist, 1.0) ** 2
    vs = [np.broadcast_to(p - Cv, Ov.shape) for p in (p1, p2, p3)]
    for v in vs:
        gv = _dot(g, v)
        passed |= (gv > 0) & (gv * gv >= cos2 * _dot(v, v))
    for a, b in ((0, 1), (1, 2), (2, 0)):
        v0, d = vs[a], vs[b] - vs[a]
        gd, g0 = _dot(g, d), _dot(g, v0)
        qa = gd * gd - cos2 * _dot(d, d)
        qb = 2.0 * (g0 * gd - cos2 * _dot(v0, d))
        qc = g0 * g0 - cos2 * _dot(v0, v0)
        disc = qb * qb - 4.0 * qa * qc
        with np.errstate(divide="ignore", invalid="ignore"):
            sq = np.sqrt(np.where(disc >= 0, disc, 0.0))
            quad = qa != 0
            roots = [np.where(quad, (-qb - sq) / (2.0 * qa), np.where(qb != 0, -qc / qb, np.nan)),
                     np.where(quad, (-qb + sq) / (2.0 * qa), np.nan)]
        real = ~quad | (disc >= 0)
        for r in roots:
            ok = real & (r >= 0.0) & (r <= 1.0)
            passed |= ok & (g0 + np.where(ok, r, 0.0) * gd >= 0.0)
    e1, e2 = vs[1] - vs[0], vs[2] - vs[0]
    pv = np.cross(g, e2)
    det = _dot(e1, pv)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s0 = -vs[0]
        u = _dot(s0, pv) * inv
        qv = np.cross(s0, e1)
        vv = _dot(g, qv) * inv
        t = _dot(e2, qv) * inv
    passed |= (det != 0) & (u >= 0) & (vv >= 0) & (u + vv <= 1) & (t >= 0)
    return passed


def _matvec(m, v):
    """``m @ v`` summed left to right (refsoft's ``linalg.matvec``)."""
    out = m[:, 0] * v[0]
    for j in range(1, m.shape[1]):
        out = out + m[:, j] * v[j]
    return out


def _inv3(m):
    """A 3x3 inverse as refsoft's ``linalg.inv3``: the adjugate over the rule-of-Sarrus determinant."""
    d = float((m[0, 0] * (m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]) - m[0, 1] * (m[1, 0] * m[2, 2] - m[1, 2] * m[2, 0]))
              + m[0, 2] * (m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]))
    adj = np.array([
        [m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1], m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2],
         m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]],
        [m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2], m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0],
         m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]],
        [m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0], m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1],
         m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]]])
    return adj / d


class LdtPipeline(Pipeline):
    """The layered depth textures on llvmpipe (exact): one case, frame after frame."""

    exact = True

    def __init__(self, gl, case):
        self.gl, self.case = gl, case
        opt = self.options = case.options
        if opt.get("method") != "ldt":
            raise NotImplementedError(f"case {case.name}: method {opt.get('method')!r} is not the LDT")
        self.double = opt.get("precision", "float32") == "float64"
        self.real = np.float64 if self.double else np.float32
        self.resolution = int(opt.get("ldt_resolution", 256))
        self.max_layers = MAX_LAYERS if opt.get("ldt_layers", "all") == "all" else 1
        self.max_faces = 3 if opt.get("ldt_faces", "three") == "three" else 1
        linear = opt.get("ldt_linear", 32)
        self.n_lin = 0 if linear == "texel" else int(linear)
        self.tau = float(opt.get("ldt_tau", 2.0))
        self.regions = opt.get("ldt_regions", "cone")
        self.targets = case.reflected_ids
        self.rasters = {}
        self.cache = Cache()
        self.shading = shading_buffer(gl, case)
        self.textures = None
        self.gpu = None

    # --- the build, once -------------------------------------------------------------------------
    def build(self) -> float:
        if self.textures is not None:
            return 0.0
        t = time.perf_counter()
        self.textures = {j: build_textures(self.gl, self.case.models[j], self.resolution, self.max_layers)
                         for j in self.targets}
        K, R = len(self.targets), self.resolution
        L = max([1] + [self.textures[j]["depth"].shape[1] for j in self.targets])
        depth = np.ones((max(K, 1), 6, L, R, R), np.float32)
        back = np.ones((max(K, 1), 6, L, R, R), self.real)
        count = np.zeros((max(K, 1), 6, R, R), np.int32)
        self.mismatch = np.zeros((max(K, 1), 6, R, R), bool)
        self.normal = np.zeros((max(K, 1), 6, L, R, R, 3), np.float32)
        self.is_open = np.zeros(max(K, 1), bool)
        for i, j in enumerate(self.targets):
            tx = self.textures[j]
            n = tx["depth"].shape[1]
            depth[i, :, :n] = tx["depth"]
            # the search's back depths in its precision (float64: 1 - d computed in float64)
            back[i, :, :n] = tx["back"] if not self.double else \
                pair_back_depths(tx["depth"], tx["count_raw"], bool(tx["open"]), np.float64)[0]
            count[i] = tx["count"]
            self.mismatch[i] = tx["mismatch"]
            self.normal[i, :, :n] = tx["normal"]
            self.is_open[i] = bool(tx["open"])
        self.L = L
        gl = self.gl
        self.gpu = {"depth": gl.buffer(depth), "back": gl.buffer(back), "count": gl.buffer(count),
                    "open": gl.buffer(self.is_open.astype(np.int32))}
        return _ms(t)

    def run_files(self) -> dict:
        """``{"ldt_J": arrays}`` of every reflected object, written once per case."""
        return {f"ldt_{j}": tx for j, tx in (self.textures or {}).items()}

    # --- one frame -------------------------------------------------------------------------------
    def render(self, frame):
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        times = dict.fromkeys(("main", "ldt_build", "regions", "ldt_search", "composite"), 0.0)
        t0 = time.perf_counter()
        times["ldt_build"] = self.build()
        t = time.perf_counter()
        data = FrameData(gl, case, frame, self.cache)
        view = self.main_view(frame, data)
        gl.finish()
        times["main"] += _ms(t)
        view_id = gl.read(view["id"], np.int32, (H, W))
        colour = gl.ctx.buffer(view["colour"].read())
        reflected = gl.buffer(np.full(W * H, -1, np.int32))
        K = len(self.targets)
        arrays = {}
        pixels = {}
        for name, (shape, dt, fill) in PIXEL_ARRAYS.items():
            shape = tuple(K if s == "K" else s for s in shape)
            pixels[name] = np.full((H, W) + shape, fill, dtype=dt)
        for k in case.reflector_ids:
            stencil = view_id == k
            t = time.perf_counter()
            surf = self.reflector_surface(frame, k)
            tri_map = surf["triangle"]
            mesh = frame.meshes[k]
            visible = np.unique(tri_map[stencil]).astype(np.int64) if stencil.any() else np.zeros(0, np.int64)
            table = np.zeros((mesh.n_faces, K), bool)
            if self.regions == "cone" and frame.camera["projection"] == "perspective":
                if len(visible) and K:
                    table[visible] = cone_test(mesh.vertices[mesh.faces[visible]], frame.eye, *self.spheres(frame))
            else:
                table[visible] = True
            times["regions"] += _ms(t)
            arrays[f"ldt_region_{k}"] = table
            if not stencil.any():
                continue
            t = time.perf_counter()
            rows, cols = np.nonzero(stencil)
            res = self.search(frame, surf, rows, cols, tri_map[rows, cols], table)
            vcol, vid = self.shade_hits(frame, res, rows, cols)
            self.store(pixels, res, rows, cols)
            times["ldt_search"] += _ms(t)
            t = time.perf_counter()
            rho = float(case.objects[k - 1]["reflectivity"])
            gl.run(gl.compute("composite"), W * H, [view["id"], view["colour"], gl.buffer(vcol), gl.buffer(vid),
                                                    colour, reflected], n=W * H, reflector=k, rho=rho)
            gl.finish()
            times["composite"] += _ms(t)
        arrays["ldt_object_ids"] = np.asarray(self.targets, np.int32)
        t = time.perf_counter()
        image = gl.buffer(nbytes=W * H * 3)
        gl.run(gl.compute("to_uint8"), -(-W * H * 3 // 4), [colour, image], n=W * H * 3)
        arrays["image"] = gl.read(image, np.uint8, (H, W, 3))
        times["composite"] += _ms(t)
        arrays["object_id"] = view_id.copy()
        arrays["reflected_id"] = gl.read(reflected, np.int32, (H, W))
        pixels["ldt_object_distance"] = np.ascontiguousarray(np.moveaxis(pixels["ldt_object_distance"], -1, 0))
        arrays.update(pixels)
        times["total"] = _ms(t0)
        self.cache.end_frame()
        return arrays, times, {}

    # --- stages ----------------------------------------------------------------------------------
    def spheres(self, frame):
        """Each reflected object's world bounding sphere: its cube centre mapped to world, and the
        farthest world vertex's distance times ``SPHERE_GROWTH``."""
        centres = np.zeros((len(self.targets), 3))
        radii = np.zeros(len(self.targets))
        for i, j in enumerate(self.targets):
            M = frame.transforms[j]
            centres[i] = _matvec(M[:3, :3], self.textures[j]["cube_center"]) + M[:3, 3]
            radii[i] = float(np.linalg.norm(frame.meshes[j].vertices - centres[i], axis=1).max()) * SPHERE_GROWTH
        return centres, radii

    def reflector_surface(self, frame, k) -> dict:
        """Reflector ``k`` rasterized alone in the view: world P and N buffers (``REAL``) and its
        visible triangle per pixel (host (H, W) int, -1 none)."""
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        mesh = self.cache.get(("reflector", id(frame.meshes[k])), lambda: _mesh(gl, frame.meshes[k], k))
        params = gl.buffer(params_array(frame.view_proj, W, H))
        r = self.raster(W, H)
        s = r.setup(mesh.points, mesh.n_vertices, mesh.faces, mesh.n_faces, params)
        r.draw(s)
        es = 8 if self.double else 4
        P, N, M = gl.buffer(nbytes=W * H * 3 * es), gl.buffer(nbytes=W * H * 3 * es), gl.buffer(nbytes=W * H * 4)
        r.bind_setup(s)
        gl.run(gl.compute("interp", MODE=0, DOUBLE=int(self.double)), W * H,
               [None, None, None, None, None, mesh.faces, mesh.points, mesh.normals, params, None, None, None,
                P, N, M], width=W, height=H, region=(0, H, 0, W))
        index = np.frombuffer(r.index.read(), np.int32).reshape(H, W)[::-1] - 1
        info = gl.read(s["tri_info"], np.int32, (max(s.n, 1), 4))
        triangle = np.where(index >= 0, info[np.maximum(index, 0), 0], -1)
        return {"P": P, "N": N, "triangle": triangle}

    def search(self, frame, surf, rows, cols, tri, table):
        gl, K = self.gl, len(self.targets)
        W_ = self.case.width
        real = self.real
        n = len(rows)
        Wm = np.zeros((max(K, 1), 4, 4))
        for i, j in enumerate(self.targets):
            Wm[i] = frame.world_to_cube[j]
        ortho = frame.camera["projection"] != "perspective"
        if ortho:
            d = np.asarray(frame.camera["target"], np.float64) - frame.eye
            vd = d / np.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])
        else:
            vd = np.zeros(3)
        out_real = gl.buffer(nbytes=n * (10 + K) * np.dtype(real).itemsize)
        out_int = gl.buffer(nbytes=n * 11 * 4)
        regions = self.regions == "cone"
        gl.run(gl.compute("ldt_search", DOUBLE=int(self.double)), n,
               [gl.buffer((rows * W_ + cols).astype(np.int32)), surf["P"], surf["N"], gl.buffer(tri.astype(np.int32)),
                gl.buffer(table.astype(np.int32) if table.size else np.zeros(1, np.int32)), gl.buffer(Wm.astype(real)),
                self.gpu["depth"], self.gpu["back"], self.gpu["count"], self.gpu["open"],
                gl.buffer(np.concatenate([frame.eye, vd]).astype(real)), out_real, out_int],
               n=n, K=K, L=self.L, R=self.resolution, n_lin=self.n_lin, max_faces=self.max_faces, ortho=ortho,
               use_regions=regions, tau=real(self.tau).item())
        fr = gl.read(out_real, real, (n, 10 + K))
        fi = gl.read(out_int, np.int32, (n, 11))
        res = {"ray": fr[:, 0:3], "distance": fr[:, 3], "residual": fr[:, 4], "margin": fr[:, 5], "hit": fr[:, 6:9],
               "object_distance": fr[:, 10:], "object": fi[:, 0], "face": fi[:, 1], "layer": fi[:, 2],
               "row": fi[:, 3], "col": fi[:, 4], "samples": fi[:, 5], "steps": fi[:, 6], "faces": fi[:, 7],
               "objects": fi[:, 8], "flags": fi[:, 9]}
        hit = res["object"] >= 0
        o, f, r, c = (res[x][hit] for x in ("object", "face", "row", "col"))
        res["flags"] = res["flags"].copy()
        res["flags"][hit] |= np.where(self.mismatch[o, f, r, c], LAYER_MISMATCH, 0) | \
            np.where(self.is_open[o], OPEN_OBJECT, 0)
        res["P"] = gl.read(surf["P"], real, (self.case.height, W_, 3))[rows, cols]
        return res

    def shade_hits(self, frame, res, rows, cols):
        """The hits' colours (refsoft's ``LayeredDepthTextures.colours``) and ids, as (W H 3)
        float32 and (W H) int32 arrays for the composite."""
        case = self.case
        W, H = case.width, case.height
        hit = res["object"] >= 0
        ids = np.zeros(len(hit), np.int32)
        ids[hit] = np.asarray(self.targets, np.int32)[res["object"][hit]]
        n_model = np.zeros((len(hit), 3), np.float32)
        n_model[hit] = self.normal[res["object"][hit], res["face"][hit], res["layer"][hit], res["row"][hit],
                                   res["col"][hit]]
        n_model = n_model.astype(np.float64)
        n_world = np.zeros_like(n_model)
        for j in np.unique(ids[ids > 0]):
            sel = ids == j
            minv = _inv3(frame.transforms[int(j)][:3, :3])
            m = minv.T
            v = n_model[sel]
            acc = v[:, 0, None] * m[:, 0]
            for q in range(1, 3):
                acc = acc + v[:, q, None] * m[:, q]
            n_world[sel] = acc
        x, y, z = n_world[:, 0], n_world[:, 1], n_world[:, 2]
        length = np.sqrt((x * x + y * y) + z * z)[:, None]
        n_world = np.divide(n_world, length, out=np.zeros_like(n_world), where=length > 0)
        s = case.shading
        light = np.asarray(s["light"], np.float64).astype(np.float32)
        nn = n_world.astype(np.float32)
        lam = np.abs(nn[:, 0] * light[0] + nn[:, 1] * light[1] + nn[:, 2] * light[2])
        kf = np.float32(s["ambient"]) + np.float32(s["diffuse"]) * lam
        table = np.array([o["color"] for o in case.objects], np.float32).reshape(-1, 3)
        colour = (table[np.maximum(ids - 1, 0)] * kf[:, None]).astype(np.float32)
        colour[ids == 0] = 0.0
        vcol = np.zeros((H, W, 3), np.float32)
        vid = np.zeros((H, W), np.int32)
        vcol[rows[hit], cols[hit]] = colour[hit]
        vid[rows, cols] = ids
        return vcol, vid

    def store(self, pixels, res, rows, cols):
        """The search's results into the frame-wide per-pixel arrays at ``rows``, ``cols``."""
        values = {"ldt_ray_origin": res["P"], "ldt_ray_dir": res["ray"], "ldt_hit_position": res["hit"],
                  "ldt_hit_distance": res["distance"], "ldt_face": res["face"], "ldt_layer": res["layer"],
                  "ldt_texel": np.stack([res["row"], res["col"]], axis=1), "ldt_residual": res["residual"],
                  "ldt_linear_samples": res["samples"], "ldt_binary_steps": res["steps"],
                  "ldt_faces_searched": res["faces"], "ldt_objects_tested": res["objects"], "ldt_flags": res["flags"],
                  "ldt_object_distance": res["object_distance"], "ldt_margin": res["margin"]}
        for name, a in pixels.items():
            a[rows, cols] = values[name]


class PlainLdtPipeline(LdtPipeline):
    """The plain variant of :class:`LdtPipeline` (``--plain``): the main view drawn by GL itself.
    The textures, the reflector's surface and the search are the exact variant's: ``refsoft
    check`` judges the search's discrete decisions (the sample where the ray crosses, the
    bisection's last step) against the oracle's own, so GLSL's ``normalize`` and ``dot`` in the
    reflected ray, a few ULP off, move hits by a bisection step and fail even the ``gpu``
    profile (docs/ports.md section 7)."""

    exact = False

    def __init__(self, gl, case):
        super().__init__(gl, case)
        self.gl_rasters = {}
        self.view_ids = None

    # the plain vertex search's GL main view, as it is
    gl_raster = PlainPipeline.gl_raster
    main_view = PlainPipeline.main_view


"""The environment-map baseline (``method envmap``; refsoft's ``docs/envmap.md``) on llvmpipe.

Per reflector and frame, :meth:`EnvmapPipeline.cube_map` renders the six faces of a cube map
around the centre of the reflector's world bounding box (its closed proxy's when it has one)
with the exact raster of the main method (``raster.py``): the reflected objects, both windings,
their float64 world points made relative to the centre on the host (``X - c``, as refsoft does
before its face table), then per face a matrix that only permutes, negates and scales them
into ``(sc, tc, A ma - B', ma)``; ``interp.comp`` shades each texel (colour 0 and id 0 where
nothing is drawn). Then ``envmap.comp`` reflects the eye ray at every pixel of the reflector's
stencil (the reflector's own world mesh rasterized alone, positions relative to the eye and
normals interpolated by ``interp.comp``) and looks up the nearest texel; ``composite.comp``
blends it in as for the vertex search.

The cube's far plane ``1.01 max |X - c|``, its near plane ``1e-4 far`` and the face matrices
are computed on the host in float64, in refsoft's order.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .camera import view_direction
from .pipeline import Cache, FrameData, MeshData, Pipeline, _ms, shading_buffer
from .raster import params_array

#: ``far = FAR_MARGIN * max |X - c|`` over the reflected vertices; ``near = NEAR_RATIO * far``.
FAR_MARGIN = 1.01
NEAR_RATIO = 1e-4

#: Per face (OpenGL order +X, -X, +Y, -Y, +Z, -Z): ``(sc, tc, ma)`` as (axis, sign) of ``d``,
#: GL's cube-map table (spec section 8.13).
FACE_TABLE = (((2, -1), (1, -1), (0, 1)), ((2, 1), (1, -1), (0, -1)),
              ((0, 1), (2, 1), (1, 1)), ((0, 1), (2, -1), (1, -1)),
              ((0, 1), (1, -1), (2, 1)), ((0, -1), (1, -1), (2, -1)))


def face_matrix(face: int, near: float, far: float) -> np.ndarray:
    """The 4x4 float64 matrix taking ``d = X - c`` to face ``face``'s clip coordinates
    ``(sc, tc, A ma - B', ma)``, ``A = (far + near) / (far - near)``, ``B' = 2 far near /
    (far - near)``. Every row has one non-zero entry (and row 2 a constant), so the raster's
    transform ``((m0 x + m1 y) + m2 z) + m3`` computes ``+-d_i`` and ``(+-A) d_a + (-B')``
    exactly as refsoft's ``A w - B'``: adding zeros and negating are exact."""
    a = (far + near) / (far - near)
    b = 2.0 * far * near / (far - near)
    (ax_s, sg_s), (ax_t, sg_t), (ax_w, sg_w) = FACE_TABLE[face]
    m = np.zeros((4, 4))
    m[0, ax_s] = sg_s
    m[1, ax_t] = sg_t
    m[2, ax_w] = sg_w * a
    m[2, 3] = -b
    m[3, ax_w] = sg_w
    return m


class EnvmapPipeline(Pipeline):
    """The environment map on llvmpipe, exact: one case, frame after frame.

    Parameters
    ----------
    gl : refsoft_glsl.context.GL
    case : refsoft_glsl.inputs.Case
    """

    exact = True

    def __init__(self, gl, case):
        self.gl, self.case = gl, case
        opt = self.options = case.options
        if opt.get("method") != "envmap":
            raise NotImplementedError(f"case {case.name}: method {opt.get('method')!r} is not the environment map")
        self.double = opt.get("precision", "float32") == "float64"
        self.real = np.float64 if self.double else np.float32
        self.resolution = int(opt.get("envmap_resolution", 256))
        self.rasters = {}
        self.cache = Cache()
        self.shading = shading_buffer(gl, case)
        self.cube_shading = shading_buffer(gl, case, background=(0.0, 0.0, 0.0))  # empty texels: colour 0
        self.cubes = {}  # reflector -> (its meshes' identities, its last cube map)

    def render(self, frame):
        """Render one frame; returns ``(arrays, time_ms, iterations)`` (no iterations)."""
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        times = dict.fromkeys(("main", "envmap_build", "envmap_lookup", "composite"), 0.0)
        t0 = t = time.perf_counter()
        data = FrameData(gl, case, frame, self.cache)
        view = self.main_view(frame, data)
        gl.finish()
        times["main"] += _ms(t)
        colour = gl.ctx.buffer(view["colour"].read())
        reflected = gl.buffer(np.full(W * H, -1, np.int32))
        face = gl.buffer(np.full(W * H, -1, np.int32))
        texel = gl.buffer(np.full(W * H * 2, -1, np.int32))
        arrays = {}
        for k in case.reflector_ids:
            t = time.perf_counter()
            # the cube map depends on the world meshes only: kept while they are the same files
            key = (tuple(id(frame.meshes[o["id"]]) for o in case.objects), id(frame.proxies.get(k)))
            last = self.cubes.get(k)
            if last is not None and last[0] == key:
                cube = last[1]
            else:
                if last is not None:
                    for v in last[1].values():
                        if hasattr(v, "release"):
                            v.release()
                cube = self.cube_map(frame, data, k)
            self.cubes[k] = (key, cube)
            gl.finish()
            times["envmap_build"] += _ms(t)
            t = time.perf_counter()
            vcol, vid = self.lookup(frame, view, cube, k, face, texel)
            gl.finish()
            times["envmap_lookup"] += _ms(t)
            t = time.perf_counter()
            rho = float(case.objects[k - 1]["reflectivity"])
            gl.run(gl.compute("composite"), W * H, [view["id"], view["colour"], vcol, vid, colour, reflected],
                   n=W * H, reflector=k, rho=rho)
            gl.finish()
            times["composite"] += _ms(t)
            R = self.resolution
            arrays[f"envmap_color_{k}"] = gl.read(cube["colour"], np.float32, (6, R, R, 3))
            arrays[f"envmap_id_{k}"] = gl.read(cube["id"], np.int32, (6, R, R))
            arrays[f"envmap_center_{k}"] = cube["center"]
        t = time.perf_counter()
        image = gl.buffer(nbytes=W * H * 3)
        gl.run(gl.compute("to_uint8"), -(-W * H * 3 // 4), [colour, image], n=W * H * 3)
        arrays["image"] = gl.read(image, np.uint8, (H, W, 3))
        times["composite"] += _ms(t)
        arrays["object_id"] = gl.read(view["id"], np.int32, (H, W))
        arrays["reflected_id"] = gl.read(reflected, np.int32, (H, W))
        arrays["envmap_face"] = gl.read(face, np.int32, (H, W)).astype(np.int8)
        arrays["envmap_texel"] = gl.read(texel, np.int32, (H, W, 2)).astype(np.int16)
        times["total"] = _ms(t0)
        self.cache.end_frame()
        return arrays, times, {}

    # --- stages ----------------------------------------------------------------------------------
    def cube_centre(self, frame, k) -> np.ndarray:
        """The centre of reflector ``k``'s world bounding box (its closed proxy's if any)."""
        v = frame.proxies.get(k, frame.meshes[k]).vertices
        return 0.5 * (v.min(axis=0) + v.max(axis=0))

    def cube_map(self, frame, data, k) -> dict:
        """Reflector ``k``'s cube map: ``colour`` (6 R R 3 float32) and ``id`` (6 R R int32)
        buffers, rows at the top, and its ``center`` (3,) float64."""
        gl, R = self.gl, self.resolution
        c = self.cube_centre(frame, k)
        colour, ids = gl.buffer(nbytes=6 * R * R * 12), gl.buffer(nbytes=6 * R * R * 4)
        refl = data.reflected
        if refl.n_faces == 0:
            colour.write(np.zeros(6 * R * R * 3, np.float32).tobytes())
            ids.write(np.zeros(6 * R * R, np.int32).tobytes())
            return {"colour": colour, "id": ids, "center": c}
        vertices, normals, faces, face_object = refl.host
        d = vertices - c
        # the largest |d|: sqrt of (x x + y y) + z z, NumPy's order for a row of three
        radius = math.sqrt(float(np.max((d[:, 0] ** 2 + d[:, 1] ** 2) + d[:, 2] ** 2)))
        far = FAR_MARGIN * radius if radius > 0 else 1.0
        near = NEAR_RATIO * far
        mesh = MeshData(gl, d, normals, faces, face_object, refl.vertex_object)
        r = self.raster(R, R)
        for f in range(6):
            params = gl.buffer(params_array(face_matrix(f, near, far), R, R))
            s = r.setup(mesh.points, mesh.n_vertices, mesh.faces, mesh.n_faces, params)
            r.draw(s)
            out = self._shade(r, s, mesh, params, mode=1, shading=self.cube_shading)
            gl.ctx.copy_buffer(colour, out["colour"], R * R * 12, 0, f * R * R * 12)
            gl.ctx.copy_buffer(ids, out["id"], R * R * 4, 0, f * R * R * 4)
            for b in (params, out["colour"], out["id"], *s.buffers.values()):
                b.release()
        return {"colour": colour, "id": ids, "center": c}

    def reflector_surface(self, frame, k) -> dict:
        """Reflector ``k``'s world mesh rasterized alone in the view: per pixel the position
        relative to the eye and the renormalised normal (``REAL``), as refsoft's reflected rays
        interpolate them."""
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        mesh = self.cache.get(("reflector", id(frame.meshes[k])), lambda: _mesh(gl, frame.meshes[k], k))
        params = gl.buffer(params_array(frame.view_proj, W, H, frame.eye))
        r = self.raster(W, H)
        s = r.setup(mesh.points, mesh.n_vertices, mesh.faces, mesh.n_faces, params)
        r.draw(s)
        es = 8 if self.double else 4
        P, N, M = gl.buffer(nbytes=W * H * 3 * es), gl.buffer(nbytes=W * H * 3 * es), gl.buffer(nbytes=W * H * 4)
        r.bind_setup(s)
        gl.run(gl.compute("interp", MODE=0, DOUBLE=int(self.double)), W * H,
               [None, None, None, None, None, mesh.faces, mesh.points, mesh.normals, params, None, None, None,
                P, N, M], width=W, height=H, region=(0, H, 0, W))
        return {"P": P, "N": N}

    def lookup(self, frame, view, cube, k, face, texel):
        """The texel of every reflected direction on reflector ``k``'s stencil: colour and id
        buffers for the composite; ``face`` and ``texel`` written on the stencil."""
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        surf = self.reflector_surface(frame, k)
        ortho = frame.camera["projection"] != "perspective"
        d = view_direction(frame.view_proj, int(frame.camera["width"]), int(frame.camera["height"])) if ortho \
            else np.zeros(3)
        vcol, vid = gl.buffer(nbytes=W * H * 12), gl.buffer(nbytes=W * H * 4)
        gl.run(gl.compute("envmap", DOUBLE=int(self.double), EXACT=int(self.exact)), W * H,
               [view["id"], surf["P"], surf["N"], cube["id"], cube["colour"], gl.buffer(d.astype(np.float64)),
                vcol, vid, face, texel], n=W * H, reflector=k, resolution=self.resolution, orthographic=ortho)
        return vcol, vid


def _mesh(gl, mesh, k) -> MeshData:
    n = mesh.n_vertices
    return MeshData(gl, mesh.vertices, mesh.normals, mesh.faces, np.full(mesh.n_faces, k, np.int32),
                    np.full(n, k, np.int32))


class PlainEnvmapPipeline(EnvmapPipeline):
    """The plain variant of :class:`EnvmapPipeline` (``--plain``), written the way a port usually
    is: the main view and the cube's faces drawn by GL itself (float32 vertices and matrices,
    GL's clipping, coverage and ``smooth`` interpolation; ``plain.vert`` / ``plain.frag``), the
    reflected direction with GLSL's ``normalize`` and ``dot``, and the texel found by GL's own
    cube-map sampling (``textureLod`` of an integer cube texture, nearest), so GL's face
    selection and face coordinates. The reflector's surface (the rays' positions and normals)
    is the exact variant's: ``refsoft check`` judges the texels against the oracle's own rays,
    with ties of a few float32 ULP only (docs/ports.md section 7)."""

    exact = False

    def __init__(self, gl, case):
        super().__init__(gl, case)
        self.gl_rasters = {}
        self.view_ids = None

    def main_view(self, frame, data) -> dict:
        """The main view drawn by GL itself, as the plain variant of the vertex search draws it."""
        from .plain import PlainPipeline

        return PlainPipeline.main_view(self, frame, data)

    def gl_raster(self, w, h, mode):
        from .plain import GLRaster

        r = self.gl_rasters.get((w, h, mode))
        if r is None:
            r = self.gl_rasters[(w, h, mode)] = GLRaster(self.gl, w, h, mode)
        return r

    def cube_map(self, frame, data, k) -> dict:
        gl, R = self.gl, self.resolution
        c = self.cube_centre(frame, k)
        colour = np.zeros((6, R, R, 3), np.float32)
        ids = np.zeros((6, R, R), np.int32)
        vertices, normals, faces, _ = data.reflected.host
        if len(faces):
            d = vertices - c
            far = FAR_MARGIN * float(np.sqrt(np.max(np.sum(d * d, axis=1))))
            far = far if far > 0 else 1.0
            r = self.gl_raster(R, R, 1)
            for f in range(6):
                col, obj = r.draw(face_matrix(f, NEAR_RATIO * far, far), d.astype(np.float32),
                                  normals.astype(np.float32), data.reflected.vertex_object, faces, self.shading)
                colour[f], ids[f] = col[:, :, :3], obj
        index = np.arange(6 * R * R, dtype=np.int32).reshape(6, R, R)
        # GL's cube-map images start at t = 0, the bottom row (row R - 1 here)
        tex = gl.ctx.texture_cube((R, R), 1, np.ascontiguousarray(index[:, ::-1]).tobytes(), dtype="i4")
        tex.filter = (gl.moderngl.NEAREST, gl.moderngl.NEAREST)
        return {"colour": gl.buffer(colour), "id": gl.buffer(ids), "center": c, "index": tex}

    def lookup(self, frame, view, cube, k, face, texel):
        cube["index"].use(location=0)
        prog = self.gl.compute("envmap", DOUBLE=int(self.double), EXACT=0)
        prog["texel_index"].value = 0
        return super().lookup(frame, view, cube, k, face, texel)

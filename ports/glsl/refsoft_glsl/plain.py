"""The plain variant (``--plain``): the main method written the way a port usually is.

It differs from the exact :class:`~refsoft_glsl.pipeline.Pipeline` in what a port author would
not think of writing out:

- the raster: GL draws float32 world vertices transformed by a float32 view-projection matrix in
  the vertex shader, with its own clipping, snapping, coverage and ``smooth`` (perspective-
  correct) interpolation of position and normal (``plain.vert``, ``plain.frag``); no float64
  triangle setup, no eye-relative positions (the G-buffer holds world positions);
- the arithmetic: GLSL's ``normalize``, ``dot``, ``length``, ``atan`` and ``asin`` in the score,
  the refinement and the hierarchy (``EXACT 0`` in ``score.glsl`` and ``hmath.glsl``), and no
  ``precise``, so the compiler may reassociate and contract them.

The stages after the G-buffer (search, refinement, virtual vertices, tessellation, cut,
composite) are the exact variant's, compiled with ``EXACT 0``.
"""

from __future__ import annotations

import ctypes

import numpy as np

from .camera import gbuffer_camera
from .pipeline import CULLED, HIDDEN, Pipeline
from .raster import params_array

_GL_RGBA, _GL_FLOAT = 0x1908, 0x1406


class GLRaster:
    """One viewport drawn by GL itself: two colour textures (MODE 0: position and normal,
    RGBA32F; else colour RGBA32F and object id R32I) and a float32 depth buffer, LESS."""

    def __init__(self, gl, width, height, mode):
        self.gl, self.width, self.height, self.mode = gl, int(width), int(height), mode
        ctx = gl.ctx
        size = (self.width, self.height)
        self.textures = [ctx.texture(size, 4, dtype="f4"),
                         ctx.texture(size, 4, dtype="f4") if mode == 0 else ctx.texture(size, 1, dtype="i4")]
        for t in self.textures:
            t.filter = (gl.moderngl.NEAREST, gl.moderngl.NEAREST)
        self.fbo, self._release = gl.depth_framebuffer(self.textures, size)
        self.program = gl.program("plain", MODE=mode)

    def _clear_float(self, texture, value):
        v = (ctypes.c_float * 4)(*value)
        self.gl._clear_tex_image(texture.glo, 0, _GL_RGBA, _GL_FLOAT, ctypes.cast(v, ctypes.c_void_p))

    def draw(self, view_proj, vertices, normals, objects, faces, shading, clear=(0.0, 0.0, 0.0, 0.0),
             view_ids=None, reflector=0):
        """Draw the triangles ``faces`` (F, 3) of float32 ``vertices``/``normals`` (V, 3) with
        per-vertex ``objects`` (V,); returns the two textures as (H, W, C) arrays, row 0 at the
        top."""
        gl, ctx = self.gl, self.gl.ctx
        self._clear_float(self.textures[0], clear)
        if self.mode == 0:
            self._clear_float(self.textures[1], (0.0, 0.0, 0.0, 0.0))
        else:
            gl.clear_int_texture(self.textures[1], 0)
        self.fbo.use()
        ctx.viewport = (0, 0, self.width, self.height)
        self.fbo.clear_depth()
        ctx.enable(gl.moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        if len(faces):
            rows = np.zeros(len(vertices), dtype=[("p", "<f4", 3), ("n", "<f4", 3), ("o", "<i4")])
            rows["p"], rows["n"], rows["o"] = vertices, normals, objects
            vbo = ctx.buffer(rows.tobytes())
            ibo = ctx.buffer(np.ascontiguousarray(faces, dtype=np.int32).tobytes())
            # the attributes the compiler kept (MODE 0 does not read the object id); the others skipped
            fmt, names = [], []
            for code, skip, name in (("3f", "12x", "in_position"), ("3f", "12x", "in_normal"), ("1i", "4x", "in_object")):
                used = self.program.get(name, None) is not None
                fmt.append(code if used else skip)
                names += [name] if used else []
            vao = ctx.vertex_array(self.program, [(vbo, " ".join(fmt), *names)], index_buffer=ibo,
                                   index_element_size=4)
            self.program["view_proj"].write(np.asarray(view_proj, np.float32).T.copy().tobytes())
            if self.mode == 2:
                view_ids.use(location=0)
                self.program["view_ids"].value = 0
                self.program["reflector"].value = int(reflector)
            shading.bind_to_storage_buffer(0)
            vao.render(mode=gl.moderngl.TRIANGLES)
            ctx.finish()
            vao.release()
            vbo.release()
            ibo.release()
        h, w = self.height, self.width
        a = np.frombuffer(self.textures[0].read(), np.float32).reshape(h, w, 4)[::-1]
        if self.mode == 0:
            b = np.frombuffer(self.textures[1].read(), np.float32).reshape(h, w, 4)[::-1]
        else:
            b = np.frombuffer(self.textures[1].read(), np.int32).reshape(h, w)[::-1]
        return np.ascontiguousarray(a), np.ascontiguousarray(b)


class PlainPipeline(Pipeline):
    """The plain variant of :class:`~refsoft_glsl.pipeline.Pipeline` (see the module's text)."""

    exact = False

    def __init__(self, gl, case):
        super().__init__(gl, case)
        self.gl_rasters = {}
        self.view_ids = None

    def gl_raster(self, w, h, mode) -> GLRaster:
        r = self.gl_rasters.get((w, h, mode))
        if r is None:
            r = self.gl_rasters[(w, h, mode)] = GLRaster(self.gl, w, h, mode)
        return r

    def main_view(self, frame, data) -> dict:
        gl, case = self.gl, self.case
        W, H = case.width, case.height
        v, n, f, _ = data.scene.host
        r = self.gl_raster(W, H, 1)
        bg = tuple(case.shading["background"]) + (1.0,)
        colour, ids = r.draw(frame.view_proj, v.astype(np.float32), n.astype(np.float32), data.scene.vertex_object,
                             f, self.shading, clear=bg)
        self.view_ids = r.textures[1]
        return {"colour": gl.buffer(colour[:, :, :3]), "id": gl.buffer(ids)}

    def gbuffer(self, frame, data, k) -> dict:
        """Reflector ``k``'s G-buffer drawn by GL: world positions and normals (the origin is
        the world's)."""
        gl = self.gl
        vp, w, h = gbuffer_camera(frame, self.options)
        v, n, f, _ = data.proxies[k].host
        r = self.gl_raster(w, h, 0)
        pos, nrm = r.draw(vp, v.astype(np.float32), n.astype(np.float32), np.zeros(len(v), np.int32), f, self.shading)
        mask = pos[:, :, 3] > 0
        P = np.where(mask[:, :, None], pos[:, :, :3], 0).astype(self.real)
        N = np.where(mask[:, :, None], nrm[:, :, :3], 0).astype(self.real)
        M = gl.buffer(mask.astype(np.int32))
        params = gl.buffer(np.concatenate([params_array(vp, w, h, (0.0, 0.0, 0.0)), frame.eye]))
        Pb, Nb = gl.buffer(P), gl.buffer(N)
        start = gl.buffer(nbytes=16)
        gl.run(gl.compute("start"), 0, [Pb, Nb, M, start], groups=1, gwidth=w, gheight=h)
        return {"P": Pb, "N": Nb, "mask": M, "params": params, "view_proj": vp, "width": w, "height": h,
                "start": start}

    def virtual_pass(self, frame, data, view, vv, res, k):
        gl = self.gl
        refl = data.reflected
        v32 = gl.read(vv["v32"], np.float32, (refl.n_vertices, 3))
        flags = gl.read(res["flags"], np.uint32, (refl.n_vertices,))
        _, normals, faces, face_obj = refl.host
        return self.draw_virtual(frame, view, v32, normals, faces, face_obj, flags, k)

    def draw_virtual(self, frame, view, vertices, normals, faces, face_obj, flags, k):
        """The virtual triangles without a bad corner drawn by GL on reflector ``k``'s stencil."""
        gl, case = self.gl, self.case
        faces = np.asarray(faces, np.int64)
        bad = CULLED | (HIDDEN if self.inverse == "discard" else 0)
        keep = ~np.any(np.asarray(flags)[faces] & bad, axis=1)
        objects = np.zeros(len(vertices), np.int32)
        objects[faces] = np.asarray(face_obj, np.int32)[:, None]
        r = self.gl_raster(case.width, case.height, 2)
        colour, ids = r.draw(frame.view_proj, np.asarray(vertices, np.float32), np.asarray(normals, np.float32),
                             objects, faces[keep], self.shading, view_ids=self.view_ids, reflector=k)
        return gl.buffer(colour[:, :, :3]), gl.buffer(ids)

"""The exact raster (spec section 2) on llvmpipe, in four steps.

1. ``transform.comp``: clip coordinates, outcodes and snapped window coordinates (float64);
2. ``count.comp``, ``scan.comp``, ``emit.comp``: triangle setup, homogeneous clipping and the
   clip triangles in input order (float64 and 64-bit integers);
3. ``raster.vert`` / ``raster.frag``: GL draws each clip triangle's pixel box; the fragment
   shader decides coverage by refsoft's integer edge functions and writes refsoft's float32
   window depth; the float32 depth buffer keeps the nearest, the first drawn at equal depth;
4. ``interp.comp``: barycentrics and attributes of the visible triangle (working precision).

:class:`Raster` holds one viewport's framebuffer; :meth:`Raster.draw` runs steps 1-3 for one
mesh and leaves the visible clip triangle of every pixel in its index texture.
"""

from __future__ import annotations

import numpy as np

from .context import GROUP

#: Guard band half-width in pixels (refsoft.constants.GUARD_BAND_PIXELS).
GUARD_BAND_PIXELS = float(1 << 20)
_SCAN_BLOCK = GROUP * 16


def params_array(view_proj, width, height, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """The float64 parameters the setup shaders read: ``view_proj`` row-major (16), the guard
    band's ``gx = 2 g / width``, ``gy = 2 g / height``, then ``origin`` (3)."""
    g = GUARD_BAND_PIXELS
    return np.concatenate([np.asarray(view_proj, dtype=np.float64).reshape(16),
                           [2.0 * g / width, 2.0 * g / height], np.asarray(origin, dtype=np.float64)])


class Setup:
    """The clip triangles of one mesh in one viewport (GPU buffers) and their count ``n``."""

    def __init__(self, n, buffers):
        self.n = n
        self.buffers = buffers  # name -> moderngl.Buffer

    def __getitem__(self, name):
        return self.buffers[name]


class Raster:
    """Rasterizes meshes into one ``width`` x ``height`` viewport."""

    def __init__(self, gl, width, height):
        self.gl = gl
        self.width, self.height = int(width), int(height)
        ctx = gl.ctx
        self.index = ctx.texture((self.width, self.height), 1, dtype="i4")
        self.fbo, self._release = gl.depth_framebuffer([self.index], (self.width, self.height))
        self.vao = ctx.vertex_array(gl.program("raster"), [])

    def release(self):
        self.vao.release()
        self.index.release()
        self._release()

    # --- steps 1 and 2 ---------------------------------------------------------------------------
    def setup(self, points, n_points, faces, n_faces, params, flags=None, bad=0, region=None, cull=0) -> Setup:
        """Transform and set up a mesh: ``points`` a buffer of (V, 3) float64 world points,
        ``faces`` (F, 3) int32, ``params`` (:func:`params_array`) as a buffer; ``flags`` (V,)
        uint32 per vertex and ``bad``: triangles with a vertex flag in ``bad`` are left out;
        ``region`` (row0, row1, col0, col1), half-open: the pixels rasterized (default all);
        ``cull`` 0 both windings, 1 only clockwise triangles (snapped window area < 0, y up), 2
        only counter-clockwise ones."""
        gl, w, h = self.gl, self.width, self.height
        b = {}
        b["clip"] = gl.buffer(nbytes=32 * n_points)
        b["codes"] = gl.buffer(nbytes=4 * n_points)
        b["win_xy"] = gl.buffer(nbytes=8 * n_points)
        b["win_zw"] = gl.buffer(nbytes=16 * n_points)
        gl.run(gl.compute("transform"), n_points, [points, params, b["clip"], b["codes"], b["win_xy"], b["win_zw"]],
               n=n_points, width=w, height=h)
        counts = gl.buffer(nbytes=4 * n_faces)
        clipped = gl.buffer(nbytes=4 * n_faces)
        if flags is None:
            flags, bad = counts, 0  # any buffer: not read
        gl.run(gl.compute("count"), n_faces, [faces, b["clip"], b["codes"], params, flags, counts, clipped],
               n=n_faces, bad=int(bad))
        offsets = self.scan(counts, n_faces)
        clip_offsets = self.scan(clipped, n_faces)
        n_tri, n_clipped = (int(gl.read(o, np.int32, (n_faces + 1,))[-1]) if n_faces else 0
                            for o in (offsets, clip_offsets))
        b["tri_xy"] = gl.buffer(nbytes=24 * n_tri)
        b["tri_zw"] = gl.buffer(nbytes=48 * n_tri)
        b["tri_info"] = gl.buffer(nbytes=16 * n_tri)
        b["tri_box"] = gl.buffer(nbytes=16 * n_tri)
        b["tri_edge"] = gl.buffer(nbytes=32 * n_tri)
        b["bary"] = gl.buffer(nbytes=72 * n_clipped)
        r0, r1, c0, c1 = (0, h, 0, w) if region is None else region
        gl.run(gl.compute("emit"), n_faces,
               [faces, b["clip"], b["win_xy"], b["win_zw"], offsets, clip_offsets, params, b["tri_xy"], b["tri_zw"],
                b["tri_info"], b["tri_box"], b["tri_edge"], b["bary"]],
               n=n_faces, width=w, height=h, region=(int(r0), int(r1) - 1, int(c0), int(c1) - 1), cull=int(cull))
        for buf in (counts, clipped, offsets, clip_offsets):
            buf.release()
        return Setup(n_tri, b)

    def scan(self, values, n):
        """Exclusive prefix sum of ``n`` int32 in a buffer: a buffer of ``n + 1`` (total last)."""
        gl = self.gl
        out = gl.buffer(nbytes=4 * (n + 1))
        blocks = -(-n // _SCAN_BLOCK)
        gx = min(max(blocks, 1), 65535)
        block_sums = gl.buffer(nbytes=4 * gx * -(-max(blocks, 1) // gx))
        gl.run(gl.compute("scan", PHASE=0), 0, [values, block_sums, out], groups=blocks, n=n)
        gl.run(gl.compute("scan", PHASE=1), 1, [values, block_sums, out], groups=1, n=n)
        gl.run(gl.compute("scan", PHASE=2), 0, [values, block_sums, out], groups=blocks, n=n)
        block_sums.release()
        return out

    # --- step 3 ------------------------------------------------------------------------------
    def draw(self, setup: Setup, peel=None):
        """Visibility of ``setup``'s clip triangles: the index texture holds, per pixel, the
        visible clip triangle + 1 (0: none). ``peel``: a buffer of (H, W) float32 depths (rows
        from the top): only fragments strictly behind them are drawn."""
        gl, ctx = self.gl, self.gl.ctx
        self.fbo.use()
        gl.clear_int_texture(self.index, 0)
        self.fbo.clear_depth()
        ctx.enable(gl.moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        for i, name in enumerate(("tri_info", "tri_box", "tri_xy", "tri_zw", "tri_edge")):
            setup[name].bind_to_storage_buffer(i)
        prog = self.vao.program
        prog["width"].value = self.width
        prog["height"].value = self.height
        if peel is not None:
            peel.bind_to_storage_buffer(5)
        prog["use_peel"].value = peel is not None
        if setup.n:
            self.vao.render(mode=gl.moderngl.TRIANGLES, vertices=6 * setup.n)
        ctx.memory_barrier()

    # --- step 4 ------------------------------------------------------------------------------
    def bind_setup(self, setup: Setup):
        """Bind the index texture (image unit 0) and the setup buffers ``bary.glsl`` reads."""
        self.index.bind_to_image(0, read=True, write=False)
        for i, name in ((1, "tri_xy"), (2, "tri_zw"), (3, "tri_info"), (4, "bary")):
            setup[name].bind_to_storage_buffer(i)

"""Real peers measured in the same run as refsoft: Mesa's software OpenGL (llvmpipe) through
moderngl's EGL backend. Needs Debian's libegl1, libegl-mesa0, libgl1-mesa-dri and the ``bench``
extra; :func:`llvmpipe_available` says why not when they are missing."""

from __future__ import annotations

import numpy as np

VERTEX_SHADER = """
#version 330
uniform mat4 view_proj;
in vec3 in_position;
in vec3 in_normal;
out vec3 v_position;
out vec3 v_normal;
void main() {
    v_position = in_position;
    v_normal = in_normal;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
"""

FRAGMENT_SHADER = """
#version 330
in vec3 v_position;
in vec3 v_normal;
layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
void main() {
    out_position = vec4(v_position, 1.0);
    out_normal = vec4(normalize(v_normal), 1.0);
}
"""


def llvmpipe_available() -> str | None:
    """None when llvmpipe can be used, else the reason it cannot."""
    try:
        import moderngl
    except ImportError:
        return "moderngl is not installed (pip install '.[bench]')"
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as exc:  # no EGL / Mesa on this machine
        return f"no EGL context ({exc}); install libegl1 libegl-mesa0 libgl1-mesa-dri"
    renderer = ctx.info.get("GL_RENDERER", "")
    ctx.release()
    if "llvmpipe" not in renderer:
        return f"the EGL renderer is {renderer!r}, not llvmpipe"
    return None


class LlvmpipeGBuffer:
    """Draws a mesh's G-buffer (two RGBA32F targets + a 32-bit float depth buffer) in llvmpipe."""

    def __init__(self, mesh, camera):
        import moderngl

        self.ctx = moderngl.create_context(standalone=True, backend="egl")
        w, h = camera.width, camera.height
        self.targets = [self.ctx.texture((w, h), 4, dtype="f4") for _ in range(2)]
        self.depth = self.ctx.depth_texture((w, h))
        self.fbo = self.ctx.framebuffer(color_attachments=self.targets, depth_attachment=self.depth)
        prog = self.ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=FRAGMENT_SHADER)
        prog["view_proj"].write(camera.view_proj().astype("f4").T.tobytes())  # column-major
        data = np.c_[mesh.vertices, mesh.normals].astype("f4")
        vbo = self.ctx.buffer(data.tobytes())
        ibo = self.ctx.buffer(mesh.faces.astype("i4").tobytes())
        self.vao = self.ctx.vertex_array(prog, [(vbo, "3f 3f", "in_position", "in_normal")], index_buffer=ibo)
        self.ctx.enable(moderngl.DEPTH_TEST)

    def draw(self):
        """Clear, draw, and wait for the rasterizer to finish (no read-back)."""
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        self.vao.render()
        self.ctx.finish()

    def draw_and_read(self):
        """As :meth:`draw`, then read both targets back into NumPy arrays."""
        self.draw()
        return [np.frombuffer(t.read(), dtype="f4") for t in self.targets]

    def mask(self) -> np.ndarray:
        """Coverage as an (H, W) bool array, rows top to bottom."""
        self.draw()
        w, h = self.targets[0].size
        a = np.frombuffer(self.targets[1].read(), dtype="f4").reshape(h, w, 4)
        return a[::-1, :, 3] > 0

    def release(self):
        self.ctx.release()


SHADED_VERTEX_SHADER = """
#version 330
uniform mat4 view_proj;
in vec3 in_position;
in vec3 in_normal;
in int in_object;
out vec3 v_normal;
flat out int v_object;
void main() {
    v_normal = in_normal;
    v_object = in_object;
    gl_Position = view_proj * vec4(in_position, 1.0);
}
"""

# refsoft.raster.shade: colour * (AMBIENT + DIFFUSE * |dot(n, L)|) on the renormalised normal
SHADED_FRAGMENT_SHADER = """
#version 330
uniform vec3 colors[{n}];
uniform vec3 light;
uniform float ambient;
uniform float diffuse;
in vec3 v_normal;
flat in int v_object;
layout(location = 0) out vec4 out_color;
layout(location = 1) out int out_id;
void main() {{
    vec3 n = normalize(v_normal);
    out_color = vec4(colors[v_object] * (ambient + diffuse * abs(dot(n, light))), 1.0);
    out_id = v_object;
}}
"""


class LlvmpipeShaded:
    """Draws triangles shaded as :func:`refsoft.raster.shade` does, with their object ids and
    depth, in llvmpipe: an RGBA32F colour target, an R32I object-id target and a depth texture,
    one draw call (the object id is a per-vertex attribute indexing a colour table uniform).

    Parameters
    ----------
    vertices, normals : ndarray, shape (V, 3)
        World-space positions and normals.
    faces : ndarray, shape (F, 3), integer
    vertex_object : ndarray, shape (V,), integer
        1-based object id of each vertex.
    colors : ndarray, shape (M + 1, 3)
        Row ``k``: object ``k``'s colour (row 0 unused).
    camera : refsoft.Camera
    box : (r0, r1, c0, c1), optional
        Draw (and clear) only these rows and columns of the viewport: the scissor box.
    """

    def __init__(self, vertices, normals, faces, vertex_object, colors, camera, box=None):
        import moderngl

        from refsoft import constants

        self.ctx = moderngl.create_context(standalone=True, backend="egl")
        w, h = camera.width, camera.height
        self.size = (w, h)
        self.color = self.ctx.texture((w, h), 4, dtype="f4")
        self.ids = self.ctx.texture((w, h), 1, dtype="i4")
        self.depth = self.ctx.depth_texture((w, h))
        self.fbo = self.ctx.framebuffer(color_attachments=[self.color, self.ids], depth_attachment=self.depth)
        # a clear writes its float values' bits into an integer target: the ids are cleared apart
        self.fbo_ids = self.ctx.framebuffer(color_attachments=[self.ids])
        colors = np.asarray(colors, dtype="f4")
        prog = self.ctx.program(vertex_shader=SHADED_VERTEX_SHADER,
                                fragment_shader=SHADED_FRAGMENT_SHADER.format(n=len(colors)))
        prog["view_proj"].write(camera.view_proj().astype("f4").T.tobytes())  # column-major
        prog["colors"].write(colors.tobytes())
        prog["light"].write(constants.LIGHT_DIRECTION.astype("f4").tobytes())
        prog["ambient"].value = constants.AMBIENT
        prog["diffuse"].value = constants.DIFFUSE
        data = np.empty(len(vertices), dtype=[("p", "f4", 3), ("n", "f4", 3), ("o", "i4")])
        data["p"], data["n"], data["o"] = vertices, normals, vertex_object
        self.vbo = self.ctx.buffer(data.tobytes())
        self.ibo = self.ctx.buffer(np.ascontiguousarray(faces, dtype="i4").tobytes())
        self.vao = self.ctx.vertex_array(prog, [(self.vbo, "3f 3f 1i", "in_position", "in_normal", "in_object")],
                                         index_buffer=self.ibo)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.box = box
        if box is not None:
            r0, r1, c0, c1 = box
            for fbo in (self.fbo, self.fbo_ids):
                fbo.scissor = (c0, h - r1, c1 - c0, r1 - r0)  # GL's origin is the bottom-left corner
        self.background = constants.BACKGROUND_COLOR

    def draw(self):
        """Clear, draw, and wait for the rasterizer to finish (no read-back)."""
        bg = self.background if self.box is None else (0.0, 0.0, 0.0)
        self.fbo.clear(float(bg[0]), float(bg[1]), float(bg[2]), 0.0, depth=1.0)  # colour, depth
        self.fbo_ids.clear(0.0, 0.0, 0.0, 0.0)  # ids 0
        self.fbo.use()
        self.vao.render()
        self.ctx.finish()

    def read(self):
        """Draw, then read back colour (H, W, 3) float32, object id (H, W) int32 and depth
        (H, W) float32, rows top to bottom."""
        self.draw()
        w, h = self.size
        color = np.frombuffer(self.color.read(), dtype="f4").reshape(h, w, 4)[::-1, :, :3]
        ids = np.frombuffer(self.ids.read(), dtype="i4").reshape(h, w)[::-1]
        depth = np.frombuffer(self.depth.read(), dtype="f4").reshape(h, w)[::-1]
        return color, ids, depth

    def release(self):
        self.ctx.release()


def llvmpipe_main_view(meshes, colors, camera):
    """An :class:`LlvmpipeShaded` of the frame's main pass (:func:`refsoft.raster.color_pass`
    of the same meshes and colours): every object, the whole viewport."""
    from refsoft.scene.mesh import concatenate

    scene = concatenate(meshes)
    vertex_object = np.repeat(np.arange(1, len(meshes) + 1), [m.n_vertices for m in meshes])
    table = np.vstack([np.zeros(3), np.asarray(colors, dtype=np.float64)])
    return LlvmpipeShaded(scene.vertices, scene.normals, scene.faces, vertex_object, table, camera)


def llvmpipe_virtual_pass(scene, parts, camera, box, inverse):
    """An :class:`LlvmpipeShaded` of one reflector's virtual pass
    (:func:`refsoft.search.virtual.virtual_pass` of the same parts): the virtual triangles
    whose vertices all have a virtual vertex (as ``inverse`` says), scissored to ``box``.
    refsoft's exact box culls are not applied (llvmpipe clips and scissors on its own)."""
    from refsoft.search import CULLED, HIDDEN

    bad = CULLED | (HIDDEN if inverse == "discard" else 0)
    verts, normals, faces, vobj, offset = [], [], [], [], 0
    for virtual, nrm, f, fobj, flags in parts:
        keep = ~np.any(flags[f] & bad, axis=1)
        obj = np.zeros(len(virtual), dtype=np.int32)
        obj[f[keep].ravel()] = np.repeat(fobj[keep], 3)  # a vertex's object, from its faces
        verts.append(virtual)
        normals.append(nrm)
        faces.append(f[keep] + offset)
        vobj.append(obj)
        offset += len(virtual)
    table = np.vstack([np.zeros(3), [o.color for o in scene.objects]])
    return LlvmpipeShaded(np.concatenate(verts), np.concatenate(normals), np.concatenate(faces),
                          np.concatenate(vobj), table, camera, box)

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

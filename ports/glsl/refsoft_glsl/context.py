"""The one OpenGL context of a run: Mesa llvmpipe through moderngl's EGL backend.

Everything the port draws or computes goes through :class:`GL`. One context per process:
moderngl objects made in several standalone contexts silently run against the last one created.

moderngl's own depth textures are 24-bit fixed point; the exact raster needs the float32 depth
of the spec (window depth rounded to float32, LESS), so the depth attachment is a
``GL_DEPTH_COMPONENT32F`` texture made with three raw GL calls (:meth:`GL.depth_framebuffer`).
"""

from __future__ import annotations

import ctypes
import os
from importlib import resources

import numpy as np

_GL_TEXTURE_2D = 0x0DE1
_GL_DEPTH_COMPONENT32F = 0x8CAC
_GL_FRAMEBUFFER = 0x8D40
_GL_COLOR_ATTACHMENT0 = 0x8CE0
_GL_DEPTH_ATTACHMENT = 0x8D00
_GL_FRAMEBUFFER_COMPLETE = 0x8CD5

#: Invocations per work group of every compute shader (``local_size_x``).
GROUP = 64


class GLUnavailable(RuntimeError):
    """No EGL context on Mesa llvmpipe can be made on this machine."""


def unavailable_reason() -> str | None:
    """None when an llvmpipe EGL context can be made, else why not (for skips and messages).
    Makes the process's context as a side effect when it can."""
    try:
        context()
    except GLUnavailable as exc:
        return str(exc)
    return None


_CONTEXT = None


def context() -> "GL":
    """The process's context, made on first use."""
    global _CONTEXT
    if _CONTEXT is None:
        _CONTEXT = GL()
    return _CONTEXT


class GL:
    """moderngl context, raw GL entry points and the compiled programs, cached by source."""

    def __init__(self):
        try:
            import moderngl
        except ImportError as exc:
            raise GLUnavailable(f"moderngl is not installed ({exc}); pip install '.[glsl]'") from None
        try:
            self.ctx = moderngl.create_context(standalone=True, backend="egl", require=450)
        except Exception as exc:  # no libEGL, no Mesa driver, no GL 4.5
            raise GLUnavailable(f"no EGL OpenGL 4.5 context ({exc}); install libegl1 libegl-mesa0 "
                                "libgl1-mesa-dri") from None
        info = self.ctx.info
        self.renderer = info.get("GL_RENDERER", "")
        self.version = info.get("GL_VERSION", "")
        self.vendor = info.get("GL_VENDOR", "")
        if "llvmpipe" not in self.renderer:
            raise GLUnavailable(f"the EGL renderer is {self.renderer!r}, not Mesa llvmpipe")
        missing = [e for e in ("GL_ARB_gpu_shader_int64", "GL_ARB_gpu_shader_fp64") if e not in self.ctx.extensions]
        if missing:
            raise GLUnavailable(f"llvmpipe lacks {', '.join(missing)}")
        self._programs = {}
        self._load_entry_points()
        self.moderngl = moderngl

    # --- raw GL -------------------------------------------------------------------------------
    def _load_entry_points(self):
        egl = ctypes.CDLL("libEGL.so.1")
        egl.eglGetProcAddress.restype = ctypes.c_void_p
        egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        U, I = ctypes.c_uint, ctypes.c_int

        def fn(name, *args, restype=None):
            address = egl.eglGetProcAddress(name.encode())
            if not address:
                raise GLUnavailable(f"no GL entry point {name}")
            return ctypes.CFUNCTYPE(restype, *args)(address)

        self._gen_textures = fn("glGenTextures", I, ctypes.POINTER(U))
        self._delete_textures = fn("glDeleteTextures", I, ctypes.POINTER(U))
        self._bind_texture = fn("glBindTexture", U, U)
        self._tex_storage_2d = fn("glTexStorage2D", U, I, U, I, I)
        self._gen_framebuffers = fn("glGenFramebuffers", I, ctypes.POINTER(U))
        self._delete_framebuffers = fn("glDeleteFramebuffers", I, ctypes.POINTER(U))
        self._bind_framebuffer = fn("glBindFramebuffer", U, U)
        self._framebuffer_texture_2d = fn("glFramebufferTexture2D", U, U, U, U, I)
        self._draw_buffers = fn("glDrawBuffers", I, ctypes.POINTER(U))
        self._check_framebuffer_status = fn("glCheckFramebufferStatus", U, restype=U)
        self._clear_tex_image = fn("glClearTexImage", U, I, U, U, ctypes.c_void_p)

    def depth_framebuffer(self, colour_textures, size):
        """A framebuffer of moderngl colour textures and a float32 depth texture of ``size``.

        Returns ``(moderngl.Framebuffer, release)``; ``release()`` deletes the raw GL objects."""
        w, h = size
        depth = ctypes.c_uint()
        self._gen_textures(1, ctypes.byref(depth))
        self._bind_texture(_GL_TEXTURE_2D, depth.value)
        self._tex_storage_2d(_GL_TEXTURE_2D, 1, _GL_DEPTH_COMPONENT32F, w, h)
        fbo = ctypes.c_uint()
        self._gen_framebuffers(1, ctypes.byref(fbo))
        self._bind_framebuffer(_GL_FRAMEBUFFER, fbo.value)
        for i, tex in enumerate(colour_textures):
            self._framebuffer_texture_2d(_GL_FRAMEBUFFER, _GL_COLOR_ATTACHMENT0 + i, _GL_TEXTURE_2D, tex.glo, 0)
        self._framebuffer_texture_2d(_GL_FRAMEBUFFER, _GL_DEPTH_ATTACHMENT, _GL_TEXTURE_2D, depth.value, 0)
        bufs = (ctypes.c_uint * len(colour_textures))(*[_GL_COLOR_ATTACHMENT0 + i
                                                       for i in range(len(colour_textures))])
        self._draw_buffers(len(colour_textures), bufs)
        status = self._check_framebuffer_status(_GL_FRAMEBUFFER)
        if status != _GL_FRAMEBUFFER_COMPLETE:
            raise GLUnavailable(f"float32 depth framebuffer incomplete (status {status:#x})")
        framebuffer = self.ctx.detect_framebuffer(fbo.value)
        one = (ctypes.c_float * 1)(1.0)

        def clear_depth():
            self._clear_tex_image(depth.value, 0, 0x1902, 0x1406, ctypes.cast(one, ctypes.c_void_p))  # DEPTH_COMPONENT, FLOAT

        framebuffer.clear_depth = clear_depth

        def release():
            self._delete_framebuffers(1, ctypes.byref(fbo))
            self._delete_textures(1, ctypes.byref(depth))

        return framebuffer, release

    def clear_int_texture(self, texture, value=0):
        """Every texel of a one-channel int32 texture set to ``value`` (``glClearTexImage``)."""
        v = (ctypes.c_int * 4)(value, value, value, value)
        self._clear_tex_image(texture.glo, 0, 0x8D94, 0x1404, ctypes.cast(v, ctypes.c_void_p))  # RED_INTEGER, INT

    # --- programs -----------------------------------------------------------------------------
    def compute(self, name: str, **defines):
        """The compute shader ``shaders/NAME.comp`` compiled with ``#define KEY VALUE`` lines."""
        key = ("comp", name, tuple(sorted(defines.items())))
        prog = self._programs.get(key)
        if prog is None:
            prog = self.ctx.compute_shader(shader_source(name + ".comp", defines))
            self._programs[key] = prog
        return prog

    def program(self, name: str, **defines):
        """The vertex and fragment shaders ``shaders/NAME.vert`` and ``NAME.frag``."""
        key = ("draw", name, tuple(sorted(defines.items())))
        prog = self._programs.get(key)
        if prog is None:
            prog = self.ctx.program(vertex_shader=shader_source(name + ".vert", defines),
                                    fragment_shader=shader_source(name + ".frag", defines))
            self._programs[key] = prog
        return prog

    # --- buffers ------------------------------------------------------------------------------
    def buffer(self, array=None, nbytes=None):
        """A storage buffer holding ``array`` (C order), or ``nbytes`` uninitialised bytes (at
        least 16: GL refuses empty buffers)."""
        if array is not None:
            data = np.ascontiguousarray(array).tobytes()
            return self.ctx.buffer(data if data else bytes(16))
        return self.ctx.buffer(reserve=max(int(nbytes), 16))

    def read(self, buffer, dtype, shape):
        """A buffer's first ``prod(shape)`` elements as a NumPy array."""
        dtype = np.dtype(dtype)
        n = int(np.prod(shape))
        if n == 0:
            return np.zeros(shape, dtype)
        return np.frombuffer(buffer.read(size=n * dtype.itemsize), dtype=dtype).reshape(shape).copy()

    def run(self, prog, count: int, buffers, groups=None, **uniforms):
        """Dispatch ``prog`` over ``count`` invocations (groups of :data:`GROUP`; or ``groups`` work
        groups) with ``buffers`` bound to storage bindings 0, 1, ... (None: left as bound) and
        the uniforms set (those the compiler removed are skipped); a barrier after."""
        for i, b in enumerate(buffers):
            if b is not None:
                b.bind_to_storage_buffer(i)
        for name, value in uniforms.items():
            try:
                u = prog[name]
            except KeyError:
                continue
            u.value = value
        if groups is None:
            groups = -(-int(count) // GROUP) if count > 0 else 0
        if groups > 0:
            gx = min(groups, 65535)
            gy = -(-groups // gx)
            prog.run(gx, gy, 1)
            self.ctx.memory_barrier()

    def finish(self):
        self.ctx.finish()


_HEADER = """#version 450
#extension GL_ARB_gpu_shader_int64 : require
#extension GL_ARB_gpu_shader_fp64 : require
"""


def shader_source(filename: str, defines: dict) -> str:
    """``#version`` and extensions, the defines, then the file (``#include "x.glsl"`` lines are
    replaced by that file, once)."""
    lines = [_HEADER]
    lines += [f"#define {k} {_glsl_value(v)}\n" for k, v in defines.items()]
    lines.append(f"#define GROUP {GROUP}\n")
    seen = set()
    lines.append(_expand(filename, seen))
    return "".join(lines)


def _glsl_value(v):
    if isinstance(v, bool):
        return "1" if v else "0"
    return str(v)


def _expand(filename, seen):
    text = resources.files(__package__).joinpath("shaders").joinpath(filename).read_text()
    out = []
    for line in text.splitlines(keepends=True):
        s = line.strip()
        if s.startswith("#include"):
            inc = s.split('"')[1]
            if inc not in seen:
                seen.add(inc)
                out.append(_expand(inc, seen))
            continue
        out.append(line)
    return "".join(out)

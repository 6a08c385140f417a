"""refsoft: the CPU reference implementation of curved-mirror reflections by per-vertex
reflection-point search in screen space (Estalella et al., EGSR 2006).

The packages follow the pipeline: :mod:`refsoft.scene` (input), :mod:`refsoft.raster` (the exact
rasterizer), :mod:`refsoft.search` (the vertex-search reflection method), :mod:`refsoft.frame`
(the frame driver and its outputs), :mod:`refsoft.truth` (ray-traced truth and metrics),
:mod:`refsoft.conformance` (golden set and checks for ports), :mod:`refsoft.bench` and
:mod:`refsoft.cli`.

The names below are loaded on first use, so ``import refsoft`` (and the command line's start) does
not pay for NumPy, Numba and trimesh until something needs them.
"""

import os as _os
import sys as _sys
from importlib import import_module

if _sys.argv[:1] == ["-m"] or _os.path.basename(_sys.argv[0] if _sys.argv else "") == "refsoft":
    # run as the command (``python -m refsoft``, the ``refsoft`` script): record Ctrl-C from here
    # on, before NumPy and Numba load (refsoft.interrupt; the handler raises KeyboardInterrupt, as
    # Python's own does)
    import atexit as _atexit
    import gc as _gc

    from . import interrupt as _interrupt

    _interrupt.install(hold=True)  # released by the entry point, refsoft._start.main
    # At exit, the interpreter's last garbage collections traverse every object Numba and LLVM
    # made (0.3-0.5 s of a one-frame render's process): frozen, they are skipped. Registered
    # first, this runs after every other exit handler; objects still go away by reference count.
    _atexit.register(_gc.freeze)

__version__ = "0.1.0"

#: Public name -> the module that defines it.
_LAZY = {
    "RefsoftError": "errors", "SceneError": "errors", "MeshError": "errors", "CameraError": "errors",
    "LimitError": "errors", "InputFileError": "errors",
    "Animation": "scene", "Camera": "scene", "Mesh": "scene", "Scene": "scene", "SceneObject": "scene",
    "Transform": "scene", "builtin_names": "scene", "load_mesh": "scene", "load_scene": "scene",
    "primitives": "scene",
    "FrameDriver": "frame", "render": "frame",
    "RenderOptions": "options",
    "TruthRenderer": "truth", "render_truth": "truth",
}
#: Subpackages reachable as attributes (``refsoft.raster``, ...).
_SUBMODULES = ("raster", "search", "scene", "frame", "truth", "conformance", "bench", "cli", "constants", "keys",
               "options", "seam", "validate", "errors", "io", "limits", "visualize")

__all__ = sorted(_LAZY) + ["raster", "search", "__version__"]


def __getattr__(name):
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
    elif name in _SUBMODULES:
        value = import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module 'refsoft' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | set(_SUBMODULES))

"""The fixed parameters of the layered depth textures (docs/ldt.md): defaults where the paper gives
no number, the caps, the face table and the per-pixel flag bits, in one place."""

import numpy as np

from .. import constants as _options

# --- build ------------------------------------------------------------------------------------
#: Texels per face edge (the option's default, refsoft.constants.LDT_RESOLUTION).
RESOLUTION = _options.LDT_RESOLUTION
#: Smallest and largest face resolutions accepted (refsoft.constants).
MIN_RESOLUTION = _options.LDT_MIN_RESOLUTION
MAX_RESOLUTION = _options.LDT_MAX_RESOLUTION
#: Depth-peeling layers at most (the paper's models use 1-5).
MAX_LAYERS = 8

#: Faces in OpenGL order: 0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z; axis ``f // 2``, sign +1 for even f.
#: Row f is ``(s axis, s sign, t axis, t sign)``: the GL cube-map selection table (GL 4.6 section
#: 8.13, table 8.19) with ``|ma| = 1``, ``sc = s sign * q[s axis]``, ``tc = t sign * q[t axis]``.
FACE_TABLE = np.array([[2, -1, 1, -1],   # +X: (-qz, -qy)
                       [2, 1, 1, -1],    # -X: ( qz, -qy)
                       [0, 1, 2, 1],     # +Y: ( qx,  qz)
                       [0, 1, 2, -1],    # -Y: ( qx, -qz)
                       [0, 1, 1, -1],    # +Z: ( qx, -qy)
                       [0, -1, 1, -1]],  # -Z: (-qx, -qy)
                      dtype=np.int64)

# --- search -----------------------------------------------------------------------------------
#: Linear search steps per face (N + 1 samples, both ends included; the option's default).
LINEAR_STEPS = _options.LDT_LINEAR_STEPS
#: Residual, in texels, under which a face's hit is accepted (the option's default).
TAU = _options.LDT_TAU
#: The bisection halves the step until it is at most this many texels long...
BISECTION_TEXELS = 0.125
#: ...or this many times.
BISECTION_MAX = 16
#: ``linear="texel"``: at most this many steps per face, times R.
TEXEL_STEPS_PER_R = 4

#: Faces searched per object, layers built, reflection regions: the options' vocabularies.
FACE_MODES = _options.LDT_FACE_MODES
LAYER_MODES = _options.LDT_LAYER_MODES
REGION_MODES = _options.LDT_REGION_MODES
#: The cone test's sphere radius is the farthest vertex times this.
SPHERE_GROWTH = 1.0 + 1e-6

# --- per-pixel flags (ldt_flags, uint8) ---------------------------------------------------------
#: The accepted hit was inside at the face's first sample (no bisection).
START_INSIDE = 1
#: No face of the hit object came within TAU; the smallest residual was taken.
NO_FACE_WITHIN_TAU = 2
#: The hit texel's layer counts differ between the face and its opposite face.
LAYER_MISMATCH = 4
#: An object whose cube the ray meets was skipped by the cone test.
REGION_CULLED = 8
#: The hit object is an open mesh (single layer, searched by the crossing rule).
OPEN_OBJECT = 16
#: The ray starts inside the cube of an object it searched.
ORIGIN_IN_CUBE = 32

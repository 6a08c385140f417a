"""The fixed parameters of the layered depth textures (docs/ldt.md): defaults where the paper gives
no number, the caps, the face table and the per-pixel flag bits, in one place."""

import numpy as np

# --- build ------------------------------------------------------------------------------------
#: Texels per face edge (the paper's only figure, "256 x 256 x 6").
RESOLUTION = 256
#: Smallest face resolution accepted (the cube keeps one empty texel on each side: R - 2 > 0).
MIN_RESOLUTION = 4
#: Largest face resolution accepted (R = 4096 with 8 layers is 3 GB per object).
MAX_RESOLUTION = 4096
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
#: Linear search steps per face (N + 1 samples, both ends included).
LINEAR_STEPS = 32
#: Residual, in texels, under which a face's hit is accepted.
TAU = 2.0
#: The bisection halves the step until it is at most this many texels long...
BISECTION_TEXELS = 0.125
#: ...or this many times.
BISECTION_MAX = 16
#: ``linear="texel"``: at most this many steps per face, times R.
TEXEL_STEPS_PER_R = 4

#: Faces searched per object: "three" (the paper, Fig. 5) or "entry" (one face).
FACE_MODES = ("three", "entry")
#: Layers built: every layer up to MAX_LAYERS, or the first only (the convex assumption).
LAYER_MODES = ("all", 1)
#: Reflection regions: the paper's cone test per reflector triangle, or none.
REGION_MODES = ("cone", "none")
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
#: The hit object is an open mesh (single layer, height-field semantics).
OPEN_OBJECT = 16
#: The ray starts inside the cube of an object it searched.
ORIGIN_IN_CUBE = 32

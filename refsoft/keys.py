"""The names of the output arrays of a frame (``frame_NNNN.npz``, spec section 7), in one place.

Frame-wide arrays have fixed names (:data:`IMAGE`, ...). Per-reflector arrays are named
``NAME_K`` with ``K`` the reflector's object id: each per-reflector name below is a string that,
called with ``K``, gives the key (``GBUFFER_MASK(3) == "gbuffer_mask_3"``); :func:`parse` splits
a key back.
"""

from __future__ import annotations


class PerReflector(str):
    """A per-reflector array name; ``name(k)`` is its key for reflector ``k``."""

    def __call__(self, k) -> str:
        return f"{self}_{int(k)}"


# --- frame-wide ------------------------------------------------------------------------------
#: (H, W, 3) uint8: the composited picture.
IMAGE = "image"
#: (H, W) int32: the directly visible object, 0 background.
OBJECT_ID = "object_id"
#: (H, W) int32: at reflector pixels the object seen in the reflection (0 none), -1 elsewhere.
REFLECTED_ID = "reflected_id"
#: (H, W, 3) float64, truth only: the world point each reflected ray hits (0 where none).
REFLECTED_HIT = "reflected_hit"
#: (H, W) int8: the reflections the mirror path through each reflector pixel takes (1 ..
#: bounces; spec section 5.1), 0 elsewhere; the truth's always, a render's with bounces > 1.
BOUNCE_DEPTH = "bounce_depth"

# --- per reflector: the G-buffer ---------------------------------------------------------------
GBUFFER_POSITION = PerReflector("gbuffer_position")
GBUFFER_NORMAL = PerReflector("gbuffer_normal")
GBUFFER_MASK = PerReflector("gbuffer_mask")
GBUFFER_VIEW_PROJ = PerReflector("gbuffer_view_proj")

# --- per reflector: one row per searched vertex ------------------------------------------------
REFLECTION_PIXEL = PerReflector("reflection_pixel")
VIRTUAL_VERTEX = PerReflector("virtual_vertex")
ITERATIONS = PerReflector("iterations")
FLAGS = PerReflector("flags")
VERTEX_OBJECT = PerReflector("vertex_object")
SCORE = PerReflector("score")
MARGIN = PerReflector("margin")

# --- per reflector, truth only: exact solutions on spherical reflectors -------------------------
EXACT_REFLECTION_POINT = PerReflector("exact_reflection_point")
EXACT_VIRTUAL_VERTEX = PerReflector("exact_virtual_vertex")

# --- the layered depth textures (method "ldt"; refsoft.ldt) ----------------------------------
#: (T_k, K) bool per reflector: the cone test per reflector triangle and reflected object.
LDT_REGION = PerReflector("ldt_region")
#: (K,) int32: the reflected objects' ids, the order of ``ldt_object_distance``.
LDT_OBJECT_IDS = "ldt_object_ids"
#: Frame-wide per-pixel arrays (zero, or -1 for ids, indices and distances, off the reflectors
#: and where nothing is hit).
LDT_PIXEL_ARRAYS = ("ldt_ray_origin", "ldt_ray_dir", "ldt_hit_position", "ldt_hit_distance", "ldt_face", "ldt_layer",
                    "ldt_texel", "ldt_residual", "ldt_linear_samples", "ldt_binary_steps", "ldt_faces_searched",
                    "ldt_objects_tested", "ldt_flags", "ldt_object_distance", "ldt_margin")


#: The per-pixel arrays one at a time (``refsoft check``'s rules name them).
LDT_RAY_ORIGIN, LDT_RAY_DIR, LDT_HIT_POSITION, LDT_HIT_DISTANCE = LDT_PIXEL_ARRAYS[:4]
LDT_FACE, LDT_LAYER, LDT_TEXEL, LDT_RESIDUAL = LDT_PIXEL_ARRAYS[4:8]
LDT_LINEAR_SAMPLES, LDT_BINARY_STEPS, LDT_FACES_SEARCHED, LDT_OBJECTS_TESTED = LDT_PIXEL_ARRAYS[8:12]
LDT_FLAGS, LDT_OBJECT_DISTANCE, LDT_MARGIN = LDT_PIXEL_ARRAYS[12:]
#: The arrays of one object's ``ldt_J.npz`` (refsoft.ldt.LDT.arrays).
LDT_TEXTURE_ARRAYS = ("depth", "back", "normal", "triangle", "count_raw", "count", "mismatch", "cube_center",
                      "cube_half", "open", "layers_capped")

# --- the environment map (method "envmap"; refsoft.envmap) ------------------------------------
#: (H, W) int8: the face looked up at each reflector pixel (0..5), -1 elsewhere.
ENVMAP_FACE = "envmap_face"
#: (H, W, 2) int16: the texel (row, col) looked up, -1 elsewhere.
ENVMAP_TEXEL = "envmap_texel"
#: (6, R, R, 3) float32 per reflector: the cube map's shaded colours.
ENVMAP_COLOR = PerReflector("envmap_color")
#: (6, R, R) int32 per reflector: the cube map's object ids (0 background).
ENVMAP_ID = PerReflector("envmap_id")
#: (3,) float64 per reflector: the cube map's centre.
ENVMAP_CENTER = PerReflector("envmap_center")


def ldt_file(j: int) -> str:
    """The name (without ``.npz``) of object ``j``'s layered depth texture, written once per run."""
    return f"ldt_{int(j)}"


# --- per reflector: every image of every vertex (spec section 4.8; only where the enumeration ran)
#: (N,) int32: the number of images of each vertex.
IMAGE_COUNT = PerReflector("image_count")
#: (M,) int32: the vertex of each image (vertex i's images are consecutive, its walk's first).
IMAGE_VERTEX = PerReflector("image_vertex")
#: (M, 2) int32: the reflection pixel (row, col) of each image in the G-buffer.
IMAGE_PIXEL = PerReflector("image_pixel")
#: (M, 3) float32: the virtual vertex of each image (spec section 4.6's mirror), world space.
IMAGE_VIRTUAL = PerReflector("image_virtual")
#: (M,) int32: the sheet of each image (-1: no sheets made).
IMAGE_SHEET = PerReflector("image_sheet")
#: The per-image arrays, judged together by ``refsoft check``.
IMAGE_ARRAYS = (IMAGE_COUNT, IMAGE_VERTEX, IMAGE_PIXEL, IMAGE_VIRTUAL, IMAGE_SHEET)

#: Every per-reflector name, longest first (so that :func:`parse` matches ``gbuffer_view_proj``
#: before a shorter name could).
PER_REFLECTOR = tuple(sorted((GBUFFER_POSITION, GBUFFER_NORMAL, GBUFFER_MASK, GBUFFER_VIEW_PROJ, REFLECTION_PIXEL,
                              VIRTUAL_VERTEX, ITERATIONS, FLAGS, VERTEX_OBJECT, SCORE, MARGIN,
                              EXACT_REFLECTION_POINT, EXACT_VIRTUAL_VERTEX, LDT_REGION, ENVMAP_COLOR, ENVMAP_ID,
                              ENVMAP_CENTER) + IMAGE_ARRAYS, key=len, reverse=True))
#: The per-vertex arrays of the vertex search, judged together by ``refsoft check``.
VERTEX_ARRAYS = (REFLECTION_PIXEL, VIRTUAL_VERTEX, FLAGS, ITERATIONS, SCORE, VERTEX_OBJECT, MARGIN)


def parse(key: str):
    """``(name, k)`` of a per-reflector key (``"flags_2"`` -> ``(FLAGS, 2)``); ``None`` for any
    other key."""
    for name in PER_REFLECTOR:
        prefix = name + "_"
        if key.startswith(prefix) and key[len(prefix):].isdigit():
            return name, int(key[len(prefix):])
    return None


def reflectors(arrays, name: str = REFLECTION_PIXEL) -> list[int]:
    """The reflector ids ``k`` for which ``arrays`` holds ``name(k)``, sorted."""
    out = []
    for key in arrays:
        p = parse(key)
        if p is not None and p[0] == name:
            out.append(p[1])
    return sorted(out)

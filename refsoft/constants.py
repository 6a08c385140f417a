"""Every tolerance, limit and fixed parameter of refsoft, in one place.

Modules import their numbers from here so that a port author (and a reviewer) can see at a
glance which constants shape the outputs.
"""

import numpy as np

# --- Rasterizer (DESIGN section 2) -------------------------------------------------------
#: Fractional bits of snapped window coordinates (1/256 pixel, as llvmpipe).
SUBPIXEL_BITS = 8
#: One pixel in snapped units.
SUBPIXEL_ONE = 1 << SUBPIXEL_BITS
#: Half the guard band, in pixels: triangles reaching further than this from the viewport
#: centre are clipped against x/y planes so that 64-bit edge functions cannot overflow
#: (coordinates stay below 2**29 snapped units; products below 2**60).
GUARD_BAND_PIXELS = float(1 << 20)
#: Tile edge in pixels for the binned, tile-parallel rasterizer.
TILE_SIZE = 16
#: Depth buffer clear value (window depth; LESS test).
DEPTH_CLEAR = 1.0

# --- Limits (DESIGN section 10) -----------------------------------------------------------
#: Largest image edge accepted, in pixels.
MAX_IMAGE_EDGE = 16384
#: Largest image accepted, in pixels (width * height); about 1 GiB of G-buffer at float32.
MAX_IMAGE_PIXELS = 1 << 26
#: Default memory limit of a run (refsoft.limits): estimated bytes above this are refused.
#: Override with ``--memory-limit`` or the environment variable ``REFSOFT_MEMORY_LIMIT``.
MEMORY_LIMIT_BYTES = 4 << 30
#: Largest mesh accepted.
MAX_VERTICES = 1 << 26
MAX_TRIANGLES = 1 << 26

# --- Shading (DESIGN section 5) -----------------------------------------------------------
#: Fixed world-space direction *towards* the light (normalised at import).
LIGHT_DIRECTION = np.array([0.3, 0.8, 0.5]) / np.linalg.norm([0.3, 0.8, 0.5])
#: colour * (AMBIENT + DIFFUSE * |dot(n, L)|): two-sided, so a surface's colour does not
#: depend on the side it is seen from (a reflection and the truth see the same colour).
AMBIENT = 0.3
DIFFUSE = 0.7
#: Colour of pixels no object covers (linear RGB in [0, 1]).
BACKGROUND_COLOR = np.array([0.08, 0.09, 0.12])

# --- Option vocabularies (the choices the API and the CLI accept) ---------------------------
#: Presets of :class:`refsoft.RenderOptions` (refsoft.options.PRESETS lists what each sets).
PRESET_NAMES = ("paper", "accurate")
#: Reflection methods: the vertex search's linear walk from a start pixel (Estalella, the
#: papers' method) and Szabo's ray-cone hierarchy.
METHODS = ("walk", "hierarchy")
#: The walk's neighbourhoods -> candidates per iteration (current pixel included).
NEIGHBOURHOODS = {"cross": 5, "box": 9}
#: Hidden-vertex modes (DESIGN 4.6).
INVERSE_MODES = ("plane", "search", "discard")
#: Working precisions of the G-buffer and the search.
PRECISIONS = ("float32", "float64")
#: Virtual vertices of visible reflections: mirrored across the reflection point's tangent
#: plane (the papers) or unfolded onto the eye's ray through it.
VIRTUAL_RULES = ("mirror", "unfold")
#: Triangles across the reflector's silhouette: left to the hidden-vertex rule (the papers) or
#: cut at the silhouette.
SILHOUETTE_RULES = ("texel", "clip")
#: The exact skips of a render: outputs are bit-identical with them on or off.
SKIPS = ("cull_reflectors", "reuse", "cull_virtual", "crop_virtual")
#: Adaptive tessellation levels accepted.
MAX_TESSELLATION_LEVEL = 8

# --- Camera validation ---------------------------------------------------------------------
#: |cross(forward, up)| below this means up is parallel to the view direction.
CAMERA_PARALLEL_TOL = 1e-9

# --- Conformance (DESIGN section 8) --------------------------------------------------------
#: Two reflection pixels are a tie when the oracle's scores differ by at most this many float32
#: ULP of the better one (``refsoft check``, ``refsoft.conformance.precision``).
TIE_ULPS = 8

# --- Kernel sentinels ---
#: The score of "no candidate" (a missing second-best) and of an uncovered or outside pixel:
#: below every score (scores are cosines, in [-1, 1]).
NO_SCORE = -3.0
#: The margin of a search that ends on a pixel with no other covered candidate, and of the
#: hierarchy search (which compares no neighbours): above every margin of two scores.
LONE_MARGIN = 2.0
#: A search record's status of a candidate slot the neighbourhood does not have (the box's
#: corners in a crosshair walk), after EVALUATED, UNCOVERED and OUTSIDE (0, 1, 2).
NOT_A_CANDIDATE = 3
#: Half a pixel in snapped units: pixel centres lie at ``SUBPIXEL_ONE * k + SUBPIXEL_HALF``.
SUBPIXEL_HALF = SUBPIXEL_ONE >> 1

"""Every tolerance, limit and fixed parameter of refsoft, in one place.

Modules import their numbers from here so that a port author (and a reviewer) can see at a
glance which constants shape the outputs.
"""

import numpy as np

# --- Rasterizer (spec section 2) -------------------------------------------------------
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

# --- Limits (spec section 10) -----------------------------------------------------------
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

# --- Frame files (spec section 7; refsoft.io.write_npz_level) ---------------------------
#: Bytes of an array a frame's ``.npz`` writer looks at as one unit: a run of units that repeat
#: the same :data:`NPZ_PERIOD_BYTES` (zeros: most of a G-buffer, the pixels outside the
#: reflector; one id or colour: the background of an id map or image) is not compressed again but
#: written as zlib's output for such bytes, computed once (a page: the G-buffers' rows that
#: cross the reflector are mostly zero pages).
NPZ_UNIT_BYTES = 1 << 12
#: The period of a repeating run: 24 bytes, a whole number of pixels of every dtype a frame holds
#: (uint8, int32, float32, float64; one value or three).
NPZ_PERIOD_BYTES = 24
#: Units of the shortest run written from the cache: a shorter one is deflated with the bytes
#: around it (a full flush ends zlib's block, and a block's Huffman tables cost more CPU and
#: bytes than zlib's run-length matches over a few pages).
NPZ_SHORTEST_RUN = 4
#: Bytes of other bytes CRC-32'd and deflated at a time (while in cache), and of deflate output
#: held before it is written to the file.
NPZ_PIECE_BYTES = 1 << 18
#: Largest piece of a repeating run written as one cached deflate output: a run is written as
#: pieces of a multiple of ``NPZ_UNIT_BYTES`` and ``NPZ_PERIOD_BYTES`` times a power of two, at
#: most this long (refsoft.io.npz._repeat_sizes: a 9.4 MB G-buffer's zeros in 12 pieces, of 2 sizes).
NPZ_REPEAT_BYTES = 1 << 20
#: Bytes of an array sampled (in 4 places) to decide whether deflating it pays; arrays smaller
#: than 4 samples are always deflated. Deflating samples of high-entropy floats costs ~0.1 ms
#: per 8 KiB; 2 KiB tell them from the frame's compressible arrays as well as 8 do.
NPZ_SAMPLE_BYTES = 1 << 9
#: An array whose samples deflate to more than this share of their size is stored as it is
#: (zip's "stored"): high-entropy floats (virtual vertices, scores, margins) deflate to 0.6-0.9
#: of their size at ~60 MB/s, where storing them costs nothing.
NPZ_STORE_RATIO = 0.5
#: A picture's bytes (a frame's image, its id maps, its G-buffer masks, its PNG's rows) outside
#: their repeating runs are written by :func:`refsoft.io.neighbour.neighbour_deflate` (each byte
#: a copy of the pixel to its left or above, or a literal: 3-5 times zlib level 1's speed on a flat
#: frame) unless more than this share of them must be literals (a textured picture: zlib's output
#: is then much smaller, and as fast).
NPZ_LITERAL_SHARE = 1 / 32
#: A picture's other bytes shorter than this (a G-buffer mask's reflector rows) go to zlib: the
#: encoder's fixed cost (its NumPy passes, ~40 us) is more than zlib takes over them.
NPZ_PICTURE_BYTES = 1 << 16

# --- Shading (spec section 5) -----------------------------------------------------------
#: Fixed world-space direction *towards* the light (normalised at import).
LIGHT_DIRECTION = np.array([0.3, 0.8, 0.5]) / np.sqrt((0.3 * 0.3 + 0.8 * 0.8) + 0.5 * 0.5)  # no BLAS (refsoft.linalg)
#: colour * (AMBIENT + DIFFUSE * |dot(n, L)|): two-sided, so a surface's colour does not
#: depend on the side it is seen from (a reflection and the truth see the same colour).
AMBIENT = 0.3
DIFFUSE = 0.7
#: Colour of pixels no object covers (linear RGB in [0, 1]).
BACKGROUND_COLOR = np.array([0.08, 0.09, 0.12])

# --- Option vocabularies (the choices the API and the CLI accept) ---------------------------
#: Presets of :class:`refsoft.RenderOptions` (refsoft.options.PRESETS lists what each sets).
PRESET_NAMES = ("paper", "accurate")
#: The vertex search's methods: the linear walk from a start pixel (Estalella, the papers'
#: method) and Szabo's ray-cone hierarchy.
SEARCH_METHODS = ("walk", "hierarchy")
#: Reflection methods: the vertex search's two, and the per-pixel comparison methods: Zhang,
#: Hsieh and Shen's layered depth textures (:mod:`refsoft.ldt`) and the environment map
#: (:mod:`refsoft.envmap`).
METHODS = SEARCH_METHODS + ("ldt", "envmap")
#: The environment map's texels per cube face edge.
ENVMAP_RESOLUTION = 256

# --- The layered depth textures' options (defaults where the paper gives no number) ----------
#: Texels per cube face edge (the paper's only figure, "256 x 256 x 6").
LDT_RESOLUTION = 256
#: Smallest face resolution accepted (the cube keeps one empty texel on each side: R - 2 > 0).
LDT_MIN_RESOLUTION = 4
#: Largest face resolution accepted (R = 4096 with 8 layers is 3 GB per object).
LDT_MAX_RESOLUTION = 4096
#: Layers built: every layer up to refsoft.ldt.constants.MAX_LAYERS, or the first only (the
#: convex assumption).
LDT_LAYER_MODES = ("all", 1)
#: Faces searched per object: up to three (the paper, its Fig. 5) or the entry face only.
LDT_FACE_MODES = ("three", "entry")
#: Linear search steps per face (N + 1 samples, both ends included), or "texel".
LDT_LINEAR_STEPS = 32
#: Residual, in texels, under which a face's hit is accepted.
LDT_TAU = 2.0
#: Reflection regions: the paper's cone test per reflector triangle, or none.
LDT_REGION_MODES = ("cone", "none")
#: The walk's neighbourhoods -> candidates per iteration (current pixel included).
NEIGHBOURHOODS = {"cross": 5, "box": 9}
#: Hidden-vertex modes (spec section 4.6).
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
#: The kinds of output ``refsoft check --kinds`` selects (refsoft.conformance.check.output_kind).
CHECK_KINDS = ("coverage", "gbuffer", "pixel", "virtual", "flags", "vertex_object", "iterations", "score", "margin",
               "images", "bounces", "image", "ids", "trace", "ldt_texture", "ldt_region", "ldt_ray", "ldt_pixel", "ldt_counts", "envmap_cube",
               "envmap_pixel")

# --- Camera validation ---------------------------------------------------------------------
#: |cross(forward, up)| below this means up is parallel to the view direction.
CAMERA_PARALLEL_TOL = 1e-9

# --- Conformance (spec section 8) --------------------------------------------------------
#: Two reflection pixels are a tie when the oracle's scores of both differ by at most
#: ``TIE_K * TIE_EPS * (1 + 1 / |U + B|)``, with U and B the two unit directions the score adds
#: at the oracle's pixel (``refsoft check``, ``refsoft.conformance.precision``): normalising
#: ``U + B`` amplifies the rounding of U and B by ``1 / |U + B|``, large near grazing angles.
TIE_K = 8
#: The unit of that bound: one float32 ULP of a number in [0.5, 1), where scores near the
#: optimum lie.
TIE_EPS = 2.0 ** -24
#: A G-buffer pixel is a depth tie when the next fragment's window depth exceeds the winner's by
#: at most ``DEPTH_TIE_K * TIE_EPS`` (a few float32 ULP of a depth in [0.5, 1), where window
#: depths lie): a GPU that evaluates depth planes its own way may keep either fragment there, and
#: ``refsoft check`` accepts a position or normal matching either.
DEPTH_TIE_K = 8
#: Float outputs (G-buffer positions and normals, virtual vertices, scores) pass within this many
#: float32 ULP of the oracle's...
F32_ULP_TOL = 4
#: ...or within this share of the scene's extent.
EXTENT_TOL = 1e-6
#: Normals also pass within this angle (radians).
NORMAL_ANGLE_TOL = 1e-4
#: A coverage difference is ambiguous (accepted) where the pixel centre lies this close (pixels)
#: to an edge of the oracle's unsnapped triangles.
EDGE_AMBIGUITY_PX = 1e-4
#: ``refsoft check --profile gpu`` (refsoft.conformance.profiles; derived in docs/precision.md).
#: A GPU interpolates from its own float32 window coordinates, refsoft from vertices snapped to
#: 1/256 px: the sample moves relative to the triangle by at most half a step (1/512 px) along
#: each axis, plus the float32 transform's error (below another 1/512 px up to 8192-px
#: viewports). G-buffer values may therefore differ by this many pixels times their rate of
#: change across the screen, and depth ties widen by it times the fragments' depth slopes.
GPU_SUBPIXEL_PX = 1.0 / 256.0
#: An edge moves by at most sqrt(2) * GPU_SUBPIXEL_PX: coverage differences, and fragments of
#: another triangle, are ambiguous within this distance (pixels) of an edge.
GPU_EDGE_AMBIGUITY_PX = 2.0 / 256.0
#: ``K`` of the tie bound ``K * TIE_EPS * (1 + 1/|U + B|)`` with built-in normalize (inversesqrt
#: within 2 ULP) and dot (any order): the worst case of both scores' rounding, the port's and
#: the oracle's, at both pixels.
GPU_TIE_K = 52
#: The profiles of ``refsoft check``.
CHECK_PROFILES = ("default", "gpu")
#: At most this share of a reflector's vertices may differ by a tie...
TIE_SHARE_MAX = 0.01
#: ...and this share differ in iterations where the pixels agree.
ITERATION_SHARE_MAX = 0.01
#: 8-bit images pass within this per channel (the loose rule: this, with a 1-pixel window, and at
#: most this share of pixels failing).
IMAGE_TOL = 1
IMAGE_TOL_LOOSE = 4
IMAGE_LOOSE_SHARE = 0.001

# --- Conformance of the comparison methods (DESIGN-ldt 2.9 and 5; docs/ports.md) ---------------
#: A reflector pixel whose LDT result (reflected object, face, layer, texel) differs from the
#: oracle's is a tie when the oracle's ``ldt_margin`` (its smallest decisive comparison: depth
#: differences, and texel coordinates' distance from an integer) is at most 8 float32 ULP of 1.0
#: (``2^-23`` each); more than TIE_SHARE_MAX of a frame's reflector pixels tied fail.
LDT_TIE_MARGIN = 8 * 2.0 ** -23
#: LDT hit positions and distances pass, where the texels agree, within this share of the hit
#: object's cube side in world units, plus F32_ULP_TOL float32 ULP of the value.
LDT_HIT_TOL = 1e-6
#: An environment-map texel differing from the oracle's is a tie when the oracle's ``s R`` (or
#: ``t R``) lies within ``ENVMAP_TIE_ULP * TIE_EPS * R`` of an integer: that many float32 ULP of
#: a face coordinate in [0.5, 1), scaled to texels (llvmpipe's ``sc * (0.5 / |ma|) + 0.5`` can
#: differ from ``(sc / |ma| + 1) * 0.5`` in the last bit).
ENVMAP_TIE_ULP = 8

# --- Truth and metrics (spec section 6) ---------------------------------------------------
#: The rim of a reflector's stencil, in 8-neighbour steps: "interior" and "rim" agreement split
#: there.
RIM_PIXELS = 2
#: A speck: a mirror pixel more than SPECK_LEVELS (8-bit levels, the largest channel difference)
#: off the truth whose two neighbours along a row or along a column are within
#: SPECK_NEIGHBOUR_LEVELS of it.
SPECK_LEVELS = 30
SPECK_NEIGHBOUR_LEVELS = 8

# --- Search and its options beyond the papers ---------------------------------------------
#: Edge, in pixels, of the cells vertices are grouped by before searching (cache locality).
LOCALITY_CELL = 16
#: The thesis's enlargement factors for cone angles and sphere radii after a failed traversal.
CONE_FACTOR = 1.5
SPHERE_FACTOR = 2.0
#: Bisection steps per cut edge: the cut lies within ``2**-iterations`` of the edge's length of
#: where the vertex search's classification changes.
CLIP_ITERATIONS = 10
#: Regula falsi steps of the predicted silhouette cut where two neighbouring texels' scores tie.
CLIP_TIE_STEPS = 8
#: Extra pixels around a stencil box before an object's virtual triangles count as outside it:
#: more than the 1/512 px a snapped window coordinate can move (spec section 2).
BOX_MARGIN_PIXELS = 2.0
#: Largest offset, in texels along each axis, one refinement step may move the point.
MAX_OFFSET = 1.0
# --- Exact reflection points on spheres (the truth) ------------------------------------------
#: Samples along the arc used to bracket the roots.
ARC_SAMPLES = 64
#: Brent's stopping rule: half the bracket below ``(XTOL + RTOL |t|) / 2`` radians, or MAXITER steps.
XTOL = 1e-15
RTOL = 4 * np.finfo(np.float64).eps
MAXITER = 200
#: Samples around the whole great circle that bracket the reflection points seen from inside a
#: sphere (roots closer than ``2 pi / INSIDE_ARC_SAMPLES`` radians may share a sample interval).
INSIDE_ARC_SAMPLES = 1024
#: Most reflection points of one point seen from inside a sphere (Alhazen's quartic).
MAX_SPHERE_IMAGES = 4
#: Relative length below which the arc's plane is degenerate (eye, point and centre collinear).
COLLINEAR_TOL = 1e-12

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

# --- The ray-traced truth ----------------------------------------------------------------------
#: Embree traces the reflected rays split over the threads in parts of at least this many rays
#: (fewer rays: one call; the split does not change any ray's answer).
TRUTH_RAYS_PER_THREAD = 20000
#: Mirror paths (spec section 5.1), the truth's and the render's: at most this many reflections
#: per eye ray (``bounces``; 1, the default, is the papers' first-order contract).
MAX_BOUNCES = 8
#: A ray leaving a reflector that can see itself (not convex) starts this far along its direction,
#: times the reflector's bounding-box diagonal, when traced against that reflector: Embree's
#: float32 hit on the triangle it leaves lies within about 1e-7 of the extent of it.
TRUTH_SELF_OFFSET = 1e-5

# --- Every reflection point of a vertex (spec section 4.8) ------------------------------------
#: ``images`` option: every reflection point (``all``) or the walk's one (``one``, the papers).
IMAGE_MODES = ("all", "one")
#: How the virtual triangles are drawn (RenderOptions.draw): rasterized with a z-buffer (the papers),
#: by exact per-pixel acceptance of the candidates they give (refsoft.search.exact), or rasterized
#: and then drawn exactly along the outlines.
DRAW_MODES = ("raster", "exact", "edges")
#: draw="edges": the pixels drawn exactly lie within this many 8-neighbour steps of a change of
#: the rasterized reflected object or coverage, or of the mirror's outline.
EDGE_BAND_PIXELS = 2
#: A texel that is a local maximum of the score is an image when Newton's iteration solving
#: "normal = bisector" from it, texel to texel, converges at most this many texels (Euclidean, in
#: the texel grid) from it.
IMAGE_REACH = 4.0
#: Newton's iteration has converged when its step from the texel it stands on, or the move of
#: the step's point from the last step's, is at most this many texels long (a solution on a
#: texel's edge or corner is 0.5 to 0.71 texels from the texels beside it; a peak narrower than
#: a texel sends the iteration back and forth between texels that point at one place); its image
#: is the covered texel nearest the converged point.
IMAGE_CONVERGED = 0.75
#: Newton steps an iteration may take before it has converged.
IMAGE_STEPS = 8
#: Accepted maxima whose converged points lie closer than this many texels are one solution (a
#: plateau, a tie, or two maxima of one solution): the best score is kept.
IMAGE_MERGE = 1.0
#: Beside a fold two solutions can share one peak of the score: at an accepted image whose 2x2
#: Jacobian has ``|det|`` below this share of the sum of its squared entries (nearly singular),
#: Newton's iteration also starts from texels 2 to IMAGE_SEED_STEPS texels along its null
#: direction, both ways (``refsoft.search._images.seed_folds``).
IMAGE_FOLD_RATIO = 0.1
IMAGE_SEED_STEPS = 6
#: The enumeration's per-texel bounds cover this many times the largest step (position and
#: reflected direction) to a 3x3 neighbour: more than the 1.5 texels (up to sqrt(2) 1.5 along a
#: diagonal) a solution may lie from a texel beside it.
IMAGE_BOUND_FACTOR = 2.5
#: Images kept per vertex and reflector (a concave sphere gives at most 4); accepted maxima
#: examined per vertex before merging.
MAX_IMAGES = 16
IMAGE_CANDIDATES = 64
#: The convex skip (refsoft.search.convex): a one-ring vertex counts as on a triangle's plane
#: within this fraction of the mesh's extent (the weld's 1e-9: rounding of coplanar points).
CONVEX_TOLERANCE = 1e-9
# --- The trace viewer (trace.html) -------------------------------------------------------------
#: A heat map embedded in trace.html holds at most this many pixels (about 10 bytes each in the
#: page); a larger reflector is traced at a smaller --width/--height.
VIEWER_MAX_GRID_PIXELS = 400_000

# --- every image drawn on mirrors that are not convex (refsoft/search/several.py) ---
#: Candidate virtual triangles per scene triangle: image triples of its vertices beyond this are
#: left out (a vertex has at most a few images; the cap bounds a pathological G-buffer).
SEVERAL_MAX_TRIPLES = 64
#: Midpoint subdivisions of a scene triangle with a vertex without an image or no linked triple.
SEVERAL_MAX_LEVEL = 3
#: A candidate virtual triangle is rasterized dilated by this many pixels plus
#: SEVERAL_DILATE_FRACTION of its longest edge: its vertices' images are exact, its edges are
#: straight where the real image curves; the per-pixel ray test accepts only exact hits.
SEVERAL_DILATE_PIXELS = 1.0
SEVERAL_DILATE_FRACTION = 0.25
#: On a flat mirror (every vertex normal the same, every vertex in the plane they give, within
#: EXACT_FLAT_TOLERANCE times the mirror's size) a straight edge's image is straight: a candidate
#: is dilated by SEVERAL_DILATE_PIXELS alone, unless a corner lies within EXACT_FLAT_NEAR times the
#: mirror's size of its plane, where the search cannot tell the reflection point well (the score
#: hardly changes along a line of texels): those keep the whole dilation.
EXACT_FLAT_TOLERANCE = 1e-9
EXACT_FLAT_NEAR = 0.01
#: The exact drawing (``draw="exact"``) draws a triangle a second time, with its vertices' images
#: by the ``mirror`` rule, when one of them lies more than this many view pixels from its image
#: by the preset's rule (:func:`refsoft.search.virtual.with_mirror_copies`): where the search's
#: reflection point is not exact (a vertex reflected beyond the outline, or within a texel of the
#: mirror) the two part, and the mirror rule's stays near the true image.
EXACT_TWIN_PIXELS = 1.0
#: ... for the vertices on the outline (BORDER) or seen from their reflection point within this
#: sine of its tangent plane (grazing: there the score hardly changes along a line of texels);
#: the others' reflection points are exact enough that the two images meet.
EXACT_TWIN_GRAZING = 0.05
#: ... and a triangle with a vertex HIDDEN by less than this sine where its walk stopped on the
#: outline (a grazing reflection near the silhouette, which the texel's normal may put behind),
#: and every triangle the silhouette cut replaced (whole), are drawn a second time with their
#: hidden vertices' images on the eye's rays through their walks' last texels.
EXACT_TWIN_HIDDEN = 0.1
#: The exact acceptance walks each pixel's ray through a hierarchy of the candidates' real
#: triangles (``_traced.accept_traced``) when the candidates' dilated bounds cover more than this
#: many of them per valid pixel on average: where the reflection compresses the scene (a small
#: mirror, a mirror's outline) thousands of candidates cover a pixel and few of their triangles lie
#: near its ray, where a walk costs about as much as a few hundred covered pixels. Both give the
#: same bits; this only picks the cheaper.
EXACT_TRACE_COVER = 250.0
#: The hierarchy's boxes are widened by this fraction of the largest coordinate (plus one), and a
#: box is entered while its entry is within this fraction of the best hit: far above the rounding
#: of Moller-Trumbore and of the box test, so no hit it would accept is ever skipped.
EXACT_TRACE_MARGIN = 1e-9
#: Two images are linked when the walk started at one ends within this many texels (Chebyshev)
#: of the other, both ways.
SEVERAL_LINK_TEXELS = 1
#: A triangle is left out of the candidates (with its parts) when no reflected ray of the
#: reflector's pixels comes within this margin of it: barycentrics below -margin or a sum above
#: 1 + margin, or ``t`` below -margin times its two edges' lengths. Its parts' corners are its
#: own up to rounding (1e-16 relative), which the margin covers many times over.
SEVERAL_PRUNE_MARGIN = 1e-4
#: Every scene triangle with a candidate is also met with each reflected ray that may hit it, found
#: through square tiles of SEVERAL_RAY_TILE pixels a side (each bounded by a ball of its rays'
#: origins and a cone of their directions), grouped SEVERAL_RAY_BLOCK tiles a side: where a
#: candidate's virtual triangle misses its image by more than the dilation, or an image was not
#: found, the triangle is still drawn where it reflects.
SEVERAL_RAY_TILE = 8
SEVERAL_RAY_BLOCK = 8
#: A ray whose |det| (Moller-Trumbore) is at most this fraction of |d| |e1| |e2| (within 1e-6
#: rad of the triangle's plane) is kept without a test: its barycentrics are ill-conditioned.
SEVERAL_PRUNE_PARALLEL = 1e-6

# --- Several bounces (spec section 5.1) ---------------------------------------------------------
#: (The most reflections an eye ray follows: MAX_BOUNCES, with the truth's.)
#: A later bounce's search starts each vertex at the covered pixel of highest score among this
#: many covered pixels taken evenly over the level's stencil (no coherence there).
BOUNCE_START_SAMPLES = 64
#: A reflector is searched on another's G-buffer (a later bounce) only where a reflected ray can
#: reach its bounding sphere: its radius widened by this many times the spread of the rays of a
#: texel's covered neighbours (``refsoft.search.bounces.may_see``).
BOUNCE_BOUND_FACTOR = 2.5
#: Drawn by exact acceptance with at most this many rays, a level's candidates are first
#: narrowed to the triangles one of the rays can meet (``refsoft.search.levels``): a cost
#: choice, the picture is the same.
BOUNCE_FEW_RAYS = 256

#: Pixels per side of a fine tile of a level's rays bounded together by the rays' pruning
#: (:func:`refsoft.search.meet.near_rays`); a coarse tile is four fine ones a side.
RAY_TILE = 4
#: Slack of the pruning's bounds: radians added to a tile's cone and to a triangle's parallel
#: angle, and the relative widening of the tiles' and triangles' radii (the bounds only choose
#: which rays the exact test sees: wider costs time, never a ray).
TILE_ANGLE_SLACK = 1e-6
TILE_RADIUS_SLACK = 1e-6

#: The restart at the border (``border_restart``) walks again only the walks that stopped on the
#: border with a score below this: a walk trapped at a local maximum on a mirror's far rim scores
#: low (the ``ufo``'s near -0.5), one whose vertex reflects at the outline close to 1 (of the
#: ``kitchen``'s 630-800 border walks a frame at 1024x768, walked again at twice the iterations
#: of the frame's 11,800 other walks, 2-8 scored higher, their first walks scoring 0.79-0.9998).
BORDER_RESTART_SCORE = 0.9

"""Several bounces (spec section 5.1), the G-buffer of a later level: a reflector seen in an
earlier bounce's image, where each pixel has its own eye (the previous bounce point).

A :class:`Bounce` holds it over the bounding box of the pixels where the reflector is seen. The
walk of spec section 4.2 runs on it with the eye direction of each pixel taken from that pixel's
eye (:func:`search_bounce`, kernels in :mod:`refsoft.search._bounces`); a virtual vertex lies on
the camera's ray through its reflection pixel at the whole path's length, ``|O - R1| + ... +
|R_j - V|`` (:func:`unfolded`). :mod:`refsoft.search.levels` draws the levels; the paper preset
finds the reflectors seen in a level by rasterizing their virtual triangles
(:func:`seen_reflectors`, :func:`first_bounces`, :func:`later_bounces`).

Each vertex starts from its reflection pixel at the previous frame's bounce of the same path
where that pixel is still in the stencil (coherence), else from the covered pixel, among
:data:`~refsoft.constants.BOUNCE_START_SAMPLES` spread over the stencil, where its score is
highest. A hidden vertex is searched again with spec section 4.6's inverse score where the
options ask for it (``inverse = "search"``); otherwise its walk's end is kept, and the virtual
pass leaves its triangles out (``discard``) or draws them with the vertex unfolded from that end
(``plane``, the paper preset's rule: equation 1 keeps ``|V - R|``), or, drawn by exact
acceptance, they are tried everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import constants
from .._numba import readonly
from ..errors import RefsoftError
from .._parallel import parallel_range
from ..raster import CULL_MODES, GBuffer, _setup, rasterize_trusted
from ..raster._threads import SERIAL_MAX_VERTICES
from ..raster.rays import primary_rays, ray_triangle
from . import CULLED, HIDDEN, RESTARTED, SearchResult, _bounces


@dataclass(frozen=True, eq=False)
class Bounce:
    """A reflector seen in an earlier bounce's image: a later level's stencil and G-buffer, over
    ``box`` (the stencil's bounding box in the view).

    Attributes
    ----------
    level : int
        The bounce this reflector gives (2 for a reflector seen in a first bounce's image).
    reflector : int
        Its object id.
    box : (r0, r1, c0, c1)
        The view pixels the arrays below cover (h = r1 - r0 rows, w = c1 - c0 columns).
    shape : (H, W)
        The view's size.
    mask : ndarray (h, w) bool
        Where it is seen (the level's stencil).
    position, normal : ndarray (h, w, 3) float64
        Its world position and unit normal there (zero elsewhere).
    eye : ndarray (h, w, 3) float64
        Each pixel's eye: the previous bounce point.
    path : ndarray (h, w) float64
        The path's length from the camera's eye to this bounce point.
    direction : ndarray (h, w, 3) float64
        The camera's unit ray direction through each pixel.
    origin : ndarray (3,) float64
        The camera's eye.
    """

    level: int
    reflector: int
    box: tuple
    shape: tuple
    mask: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    eye: np.ndarray
    path: np.ndarray
    direction: np.ndarray
    origin: np.ndarray

    def stencil(self) -> np.ndarray:
        """The stencil over the whole view, (H, W) bool."""
        r0, r1, c0, c1 = self.box
        out = np.zeros(self.shape, bool)
        out[r0:r1, c0:c1] = self.mask
        return out


def make_bounce(level, reflector, mask, position, normal, eye, path, direction, origin, offset=(0, 0),
                shape=None) -> Bounce | None:
    """A :class:`Bounce` cropped to the bounding box of ``mask`` (h, w) (the arrays over the same
    pixels, ``offset`` the view pixel of their first; ``shape`` the view's size, default the
    mask's); None when the mask is empty."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return None
    a0, a1, b0, b1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    m = np.ascontiguousarray(mask[a0:a1, b0:b1])
    crop = (lambda x: np.ascontiguousarray(np.where(m[..., None] if x.ndim == 3 else m, x[a0:a1, b0:b1], 0.0)))
    box = (a0 + offset[0], a1 + offset[0], b0 + offset[1], b1 + offset[1])
    return Bounce(level, reflector, box, tuple(shape or mask.shape), m, crop(position), crop(normal), crop(eye),
                  crop(path), crop(direction), np.asarray(origin, np.float64))


def gbuffer_of(bounce: Bounce, camera, precision="float32") -> GBuffer:
    """The bounce's G-buffer over its box, positions relative to the camera's eye in
    ``precision`` (pixel (r, c) of it is view pixel (r0 + r, c0 + c))."""
    dt = np.dtype(precision)
    origin = np.asarray(camera.eye, np.float64)
    m = bounce.mask
    pos = np.where(m[..., None], bounce.position - origin, 0.0).astype(dt)
    nrm = np.where(m[..., None], bounce.normal, 0.0).astype(dt)
    depth = np.where(m, np.float32(0.5), np.float32(1.0)).astype(np.float32)
    tri = np.where(m, 0, -1).astype(np.int32)
    return GBuffer(pos, nrm, m.copy(), depth, tri, camera.view_proj(), origin)


def search_bounce(bounce: Bounce, gb: GBuffer, vertices, neighbourhood="cross", cap=None,
                  previous=None, inverse="discard", start=None, G=None) -> SearchResult:
    """The walk of spec section 4.2 for every vertex on a bounce's G-buffer, each pixel's eye
    its own (:class:`Bounce`).

    Parameters
    ----------
    bounce : Bounce
    gb : GBuffer
        :func:`gbuffer_of` the bounce.
    vertices : ndarray (N, 3) float64
        World space.
    neighbourhood : {"cross", "box"}
    cap : int, optional
        Iteration cap (default ``2 * (width + height)``).
    previous : ndarray (N, 2) int, optional
        Each vertex's reflection pixel in the view (row, column) at the previous frame's bounce of
        the same path, or -1: coherence. A vertex starts there when the pixel is in this
        bounce's stencil and its score there is higher than at the best sample (:func:`_starts`),
        else from the best sample (flag RESTARTED when the pixel is off the stencil).
    inverse : {"discard", "search"}
        A hidden vertex (behind the end pixel's tangent plane): its walk's end kept
        (``discard``; its triangles are left out or tried everywhere by the drawing), or spec
        section 4.6's inverse search from there (``search``), its score with each pixel's own
        eye; ``iterations`` counts both walks. The unfolded rule (:func:`unfolded`) then places
        the vertex's virtual vertex on the camera's ray through the pixel found.
    start : ndarray (N, 2) int, optional
        Pixels of the bounce's G-buffer the vertices start from (a vertex added between two
        searched ones: the pixel its parents' lead to, as the first level's tessellation starts
        them), -1 where none: those start as without it (``previous`` is then not read). A pixel
        given that is not covered starts as without it too, flag RESTARTED.
    G : ndarray (h, w, 9), optional
        :func:`packed` of the bounce, when the caller has it.

    Returns
    -------
    SearchResult
        Pixels in the G-buffer (the bounce's box); flags: HIDDEN where the vertex lies behind the
        end pixel's tangent plane, CAPPED, BORDER, RESTARTED.
    """
    from . import default_cap

    if inverse not in ("discard", "search"):
        raise RefsoftError(f"inverse at a later bounce must be 'discard' or 'search', got {inverse!r}")
    dt = gb.position.dtype.type
    fp = dt(0)
    verts = np.asarray(vertices, np.float64).reshape(-1, 3)
    n = len(verts)
    h, w = gb.mask.shape
    cap = default_cap((h, w)) if cap is None else int(cap)
    pixel = np.full((n, 2), -1, np.int32)
    score, margin = np.zeros(n, dt), np.zeros(n, dt)
    iterations, flags = np.zeros(n, np.int32), np.full(n, CULLED, np.uint8)
    if not n or not gb.mask.any():
        return SearchResult(pixel, score, margin, iterations, flags, neighbourhood, inverse, cap)
    G = packed(bounce, gb) if G is None else G
    rel = np.ascontiguousarray((verts - gb.origin).astype(dt))
    if start is None:
        own, restarted = own_starts(bounce, previous, n)
        starts = _starts(G, gb.mask, rel, own)
    else:
        starts, restarted = _given_starts(G, gb.mask, rel, start)
    flags[:] = 0
    parallel_range(_bounces.search_each, n, G, gb.mask, rel, starts, constants.NEIGHBOURHOODS[neighbourhood], cap,
                   inverse == "search", fp, pixel, score, margin, iterations, flags)
    flags[restarted] |= np.uint8(RESTARTED)
    return SearchResult(pixel, score, margin, iterations, flags, neighbourhood, inverse, cap)


class LevelSearch:
    """A later level's own search, for the vertices the tessellation and the silhouette cut add
    (the ``level`` of :func:`refsoft.search.tessellate.tessellate` and
    :func:`refsoft.search.silhouette.clip_at_silhouette`): :func:`search_bounce` on the bounce's
    G-buffer with each pixel's own eye, and the thesis's edge error with the eye of the texel it
    is taken at (kernel :func:`refsoft.search._bounces.edge_errors`). With every eye the camera's,
    both are the first level's bit for bit.

    Parameters
    ----------
    bounce : Bounce
    gb : GBuffer
        :func:`gbuffer_of` the bounce.
    neighbourhood : {"cross", "box"}
    cap : int, optional
    inverse : {"discard", "search"}
        As :func:`search_bounce`'s.
    """

    def __init__(self, bounce: Bounce, gb: GBuffer, neighbourhood="cross", cap=None, inverse="discard"):
        self.bounce, self.gb = bounce, gb
        self.neighbourhood, self.cap, self.inverse = neighbourhood, cap, inverse
        self.G = packed(bounce, gb)  # once: every tessellation level's and the cut's walks read it
        self.eyes = np.ascontiguousarray(bounce.eye, np.float64)

    def search(self, vertices, start) -> SearchResult:
        """The walks of vertices (M, 3) float64 world from pixels ``start`` (M, 2) int of the
        G-buffer (-1: the best sample), :func:`search_bounce`'s results."""
        return search_bounce(self.bounce, self.gb, vertices, self.neighbourhood, self.cap, None, self.inverse,
                             start=start, G=self.G)

    def edge_errors(self, verts, pixel, e0, e1) -> np.ndarray:
        """The thesis's error (E,) float64 of edges (verts[e0], verts[e1]) (``verts`` (n, 3)
        float64 world, ``pixel`` (n, 2) their pixels, -1 none), each with the eye of the texel
        it is taken at."""
        gb = self.gb
        out = np.empty(len(e0))
        parallel_range(_bounces.edge_errors, len(e0), gb.position, gb.normal, gb.mask,
                       np.asarray(gb.origin, np.float64), self.eyes, np.ascontiguousarray(verts, np.float64),
                       np.ascontiguousarray(pixel, np.int64), np.ascontiguousarray(e0, np.int64),
                       np.ascontiguousarray(e1, np.int64), out, serial=len(e0) <= SERIAL_MAX_VERTICES)
        return out

    def walked(self):
        """The packed G-buffer as :func:`refsoft.search._packed` gives it for the one-walk
        kernels: ``(G, mask, fp, (0, 0))`` (the bounce's box holds every covered pixel, and a
        neighbour outside it is outside the buffer)."""
        return self.G, np.ascontiguousarray(self.gb.mask), self.gb.position.dtype.type(0), (0, 0)


def packed(bounce: Bounce, gb: GBuffer) -> np.ndarray:
    """The bounce's G-buffer packed for the walk, (h, w, 9) in its precision: P, N and the unit
    direction to each pixel's own eye (kernel :func:`refsoft.search._bounces.pack_eyes`)."""
    dt = gb.position.dtype.type
    h, w = gb.mask.shape
    G = np.zeros((h, w, 9), dtype=dt)
    eye_rel = np.ascontiguousarray((bounce.eye - gb.origin).astype(dt))
    parallel_range(_bounces.pack_eyes, h, gb.position, gb.normal, gb.mask, eye_rel, dt(0), G)
    return G


def _given_starts(G, mask, rel, start):
    """:func:`search_bounce`'s starts from ``start`` (N, 2) int G-buffer pixels: each covered one
    as it is, the best sample (:func:`_starts`) for the others; and (N,) bool the given pixels
    that were not covered (they restart)."""
    start = np.asarray(start, np.int64).reshape(-1, 2)
    h, w = mask.shape
    r, c = start[:, 0], start[:, 1]
    given = (r >= 0) & (c >= 0)
    ok = given & (r < h) & (c < w)
    ok[ok] = mask[r[ok], c[ok]]
    out = start.copy()
    if not ok.all():
        out[~ok] = _starts(G, mask, rel[~ok])
    return out, given & ~ok


def own_starts(bounce: Bounce, previous, n):
    """Coherence at a later level: ``previous`` (n, 2) int view pixels (-1 none) or None as the
    bounce's pixels where they are in its stencil, (n, 2) int64 (-1 elsewhere), and (n,) bool
    the vertices whose previous pixel is off it (they restart)."""
    own = np.full((n, 2), -1, np.int64)
    if previous is None:
        return own, np.zeros(n, bool)
    prev = np.asarray(previous, np.int64).reshape(n, 2)
    h, w = bounce.mask.shape
    r, c = prev[:, 0] - bounce.box[0], prev[:, 1] - bounce.box[2]
    given = prev[:, 0] >= 0
    kept = given & (r >= 0) & (r < h) & (c >= 0) & (c < w)
    kept[kept] = bounce.mask[r[kept], c[kept]]
    own[kept] = np.stack([r[kept], c[kept]], axis=1)
    return own, given & ~kept


def _starts(G, mask, rel, previous=None):
    """Per vertex the covered pixel of highest score among up to BOUNCE_START_SAMPLES covered
    pixels taken evenly in row-major order (ties: the first; kernel
    :func:`refsoft.search._bounces.best_starts`, in float64): a stencil seen in a curved mirror
    can be small and split, and no projection of the vertex points into it. With ``previous``
    (N, 2) int (covered pixels, or -1 none) a vertex's previous pixel where its score is higher
    still. (N, 2) int64."""
    rows, cols = np.nonzero(mask)
    step = max(1, -(-len(rows) // constants.BOUNCE_START_SAMPLES))
    rows, cols = rows[::step], cols[::step]
    g = np.ascontiguousarray(G[rows, cols], np.float64)  # (S, 9): P, N, U
    n = len(rel)
    has = np.zeros(n, bool) if previous is None else np.asarray(previous)[:, 0] >= 0
    own = np.zeros((n, 9))
    if has.any():
        own[has] = G[previous[has, 0], previous[has, 1]]
    best = np.empty(n, np.int64)
    parallel_range(_bounces.best_starts, n, g, np.ascontiguousarray(rel, np.float64), own, has, best,
                   serial=n * len(g) <= SERIAL_MAX_VERTICES)
    out = np.empty((n, 2), np.int64)
    sampled = best < len(g)
    out[sampled] = np.stack([rows[best[sampled]], cols[best[sampled]]], axis=1)
    if not sampled.all():
        out[~sampled] = previous[~sampled]
    return out


def unfolded(bounce: Bounce, result: SearchResult, vertices) -> np.ndarray:
    """Virtual vertices (N, 3) float64 world: on the camera's ray through each vertex's reflection
    pixel, at the path's length to the bounce point plus ``|V - R|`` (spec section 5.1); NaN
    where the search found no pixel."""
    return unfolded_at(bounce, result.pixel, vertices)


def unfolded_at(bounce: Bounce, pixel, vertices) -> np.ndarray:
    """:func:`unfolded` of vertices (N, 3) whose reflection pixels in the bounce's G-buffer are
    ``pixel`` (N, 2) int (-1: none, NaN there)."""
    verts = np.asarray(vertices, np.float64).reshape(-1, 3)
    pixel = np.asarray(pixel).reshape(-1, 2)
    out = np.full(verts.shape, np.nan)
    ok = pixel[:, 0] >= 0
    r, c = pixel[ok, 0], pixel[ok, 1]
    length = bounce.path[r, c] + np.linalg.norm(verts[ok] - bounce.position[r, c], axis=1)
    out[ok] = bounce.origin + length[:, None] * bounce.direction[r, c]
    return out


def level_rays(bounce: Bounce):
    """Each pixel's reflected ray at a bounce over its box: ``(valid (h, w) bool, origin (h, w,
    3), direction (h, w, 3))`` float64, the bounce point and the direction from the pixel's eye
    reflected about the normal there (:func:`refsoft.search.acceptance.draw`'s ``rays``)."""
    valid = bounce.mask.copy()
    origin = np.where(valid[..., None], bounce.position, 0.0)
    n = bounce.normal
    i = origin - bounce.eye
    i /= np.maximum(np.linalg.norm(i, axis=-1, keepdims=True), 1e-300)
    d = i - 2.0 * np.sum(i * n, axis=-1, keepdims=True) * n
    return valid, np.ascontiguousarray(origin), np.ascontiguousarray(np.where(valid[..., None], d, 0.0))


def may_see(position, normal, eye, mask, centre, radius) -> bool:
    """Whether a reflected ray of a G-buffer can reach a sphere (a reflector's bounds): False
    only when, at every covered texel, the ray reflected about its normal from its eye passes the
    sphere farther than ``radius`` plus BOUNCE_BOUND_FACTOR times the spread to its covered
    4-neighbours (the arc their rays' angle sweeps at the sphere's distance, and the distance
    between their points), so that a ray from anywhere between texels misses it too
    (:func:`texel_reach` once per G-buffer, then :func:`reaches` per sphere).

    Parameters
    ----------
    position, normal : ndarray (H, W, 3)
        World positions and unit normals (zero where not covered).
    eye : ndarray (3,) or (H, W, 3)
        The eye, or each texel's.
    mask : ndarray (H, W) bool
    centre : array_like (3,)
    radius : float
    """
    return reaches(texel_reach(position, normal, eye, mask), centre, radius)


def texel_reach(position, normal, eye, mask, origin=None):
    """What :func:`may_see` tests of a G-buffer, for any number of spheres: per covered texel
    (row-major order) its point (M, 3), its reflected ray's unit direction (M, 3), the largest
    angle to its covered 4-neighbours' rays (M,) and distance to their points (M,), float64;
    None when no texel is covered. Arguments as :func:`may_see`; with ``origin`` (3,) the
    positions are relative to it (float32 or float64)."""
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return None
    a0, a1, b0, b1 = int(rows[0]), int(rows[-1]) + 1, int(cols.min()), int(cols.max()) + 1
    mask = mask[a0:a1, b0:b1]  # the covered texels' box: a neighbour outside it is not covered
    rows, cols = rows - a0, cols - b0
    P = np.asarray(position[a0:a1, b0:b1]).astype(np.float64)
    if origin is not None:
        P = np.where(mask[..., None], P + origin, 0.0)
    N = np.asarray(normal[a0:a1, b0:b1], np.float64)
    E = np.asarray(eye, np.float64)
    p = P[rows, cols]
    e = E if E.ndim == 1 else E[a0:a1, b0:b1][rows, cols]
    i = p - e
    i /= np.maximum(np.linalg.norm(i, axis=1, keepdims=True), 1e-300)
    n = N[rows, cols]
    r = i - 2.0 * np.sum(i * n, axis=1, keepdims=True) * n
    R = np.zeros(P.shape)
    R[rows, cols] = r
    h, w = mask.shape
    angle, step = np.zeros(len(rows)), np.zeros(len(rows))
    for dr, dc in ((0, 1), (1, 0), (0, -1), (-1, 0)):
        rr, cc = rows + dr, cols + dc
        ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
        ok[ok] &= mask[rr[ok], cc[ok]]
        q = np.zeros((len(rows), 3))
        q[ok] = R[rr[ok], cc[ok]]
        cos = np.clip(np.sum(q * r, axis=1), -1.0, 1.0)
        angle = np.maximum(angle, np.where(ok, np.arccos(cos), 0.0))
        d = np.zeros(len(rows))
        d[ok] = np.linalg.norm(P[rr[ok], cc[ok]] - p[ok], axis=1)
        step = np.maximum(step, d)
    return p, r, np.minimum(angle, np.pi), step


def reaches(texels, centre, radius) -> bool:
    """:func:`may_see`'s answer for a sphere from :func:`texel_reach`'s ``texels`` (False for
    None)."""
    if texels is None:
        return False
    p, r, angle, step = texels
    cp = np.asarray(centre, np.float64) - p
    t = np.maximum(np.sum(cp * r, axis=1), 0.0)
    miss = np.linalg.norm(cp - t[:, None] * r, axis=1)
    spread = np.linalg.norm(cp, axis=1) * angle + step
    return bool(np.any(miss <= radius + constants.BOUNCE_BOUND_FACTOR * spread))


def bounding_sphere(mesh):
    """(centre (3,), radius) of a mesh's vertices: the centre of their box (the last answers kept
    by mesh: a static object's world mesh is the same frame after frame)."""
    hit = _SPHERES.get(id(mesh))
    if hit is not None and hit[0] is mesh:
        return hit[1]
    v = np.asarray(mesh.vertices, np.float64)
    c = 0.5 * (v.min(axis=0) + v.max(axis=0))
    out = c, float(np.sqrt(np.max(np.sum((v - c) ** 2, axis=1))))
    if len(_SPHERES) >= 64:
        _SPHERES.pop(next(iter(_SPHERES)))
    _SPHERES[id(mesh)] = (mesh, out)
    return out


_SPHERES = {}


# --- the paper preset: the reflectors seen, by rasterizing their virtual triangles ---------------
def object_parts(meshes, ids, virtual, flags):
    """The virtual geometry of objects ``ids`` (their vertices consecutive in ``virtual`` and
    ``flags``, in that order), one part per object: (virtual (n, 3) float64, normals, faces (m, 3)
    int64, face object (m,) int32, flags (n,) uint8)."""
    parts, start = [], 0
    for k in ids:
        mesh = meshes[k - 1]
        n = mesh.n_vertices
        parts.append((virtual[start:start + n], mesh.normals, mesh.faces.astype(np.int64),
                      np.full(mesh.n_faces, k, dtype=np.int32), flags[start:start + n]))
        start += n
    return parts


def seen_reflectors(parts, reflector_parts, camera, stencil, box):
    """The reflectors whose virtual triangles are nearest at pixels of ``stencil``, drawn with the
    virtual triangles of ``parts`` in one z-buffer over ``box`` (spec section 5.1; triangles with
    a CULLED or HIDDEN corner left out).

    Parameters
    ----------
    parts : list
        The non-reflectors' virtual parts (:func:`object_parts`, or the virtual pass's own).
    reflector_parts : list
        :func:`object_parts` of the reflectors, one part each.
    camera : Camera
    stencil : ndarray (H, W) bool
    box : (r0, r1, c0, c1)

    Returns
    -------
    dict
        Reflector id -> (mask (h, w) bool over ``box``, face (h, w) int64: the reflector's
        triangle (a row of its mesh's faces) nearest at each pixel of the mask, -1 elsewhere).
    """
    if not reflector_parts:
        return {}
    r0, r1, c0, c1 = (int(x) for x in box)
    # the reflectors' triangles alone first: only a pixel one of them covers can show one
    alone = _nearest(list(reflector_parts), camera, (r0, r1, c0, c1))
    if alone is None:
        return {}
    sten = stencil[r0:r1, c0:c1] & (alone[0] >= 0)
    rows, cols = np.flatnonzero(sten.any(axis=1)), np.flatnonzero(sten.any(axis=0))
    if not len(rows):
        return {}
    sub = (r0 + int(rows[0]), r0 + int(rows[-1]) + 1, c0 + int(cols[0]), c0 + int(cols[-1]) + 1)
    tri, face_obj, local = _nearest(list(parts) + list(reflector_parts), camera, sub)
    obj = np.where(tri >= 0, face_obj[np.maximum(tri, 0)], 0)
    sten = stencil[sub[0]:sub[1], sub[2]:sub[3]] & (tri >= 0)
    reflectors = {int(p[3][0]) for p in reflector_parts if len(p[3])}
    out = {}
    sl = (slice(sub[0] - r0, sub[1] - r0), slice(sub[2] - c0, sub[3] - c0))
    for b in (int(x) for x in np.unique(obj[sten])):
        if b in reflectors:
            m = np.zeros((r1 - r0, c1 - c0), bool)
            face = np.full((r1 - r0, c1 - c0), -1, np.int64)
            m[sl] = sten & (obj == b)
            face[sl] = np.where(m[sl], local[np.maximum(tri, 0)], -1)
            out[b] = (m, face)
    return out


def _nearest(parts, camera, box):
    """The virtual triangles of ``parts`` (:func:`seen_reflectors`) in one z-buffer over ``box``,
    those with a CULLED or HIDDEN corner left out: ``(triangle (h, w) int64 into the kept ones, -1
    none; each kept one's object (T,) int32 and row in its part (T,) int64)``, or None when none
    is kept."""
    vp = camera.view_proj()
    faces, face_obj, clips, flags, local = [], [], [], [], []
    offset = 0
    for part in parts:
        virtual, _, f, fobj, fl = part[:5]
        bad = ~np.all(np.isfinite(virtual), axis=1)
        clip = _setup.transform_points(np.where(bad[:, None], 0.0, virtual), vp)
        faces.append(f + offset)
        face_obj.append(fobj)
        clips.append(clip)
        flags.append(np.where(bad, np.uint8(CULLED), fl).astype(np.uint8))
        local.append(np.arange(len(f), dtype=np.int64))
        offset += len(clip)
    faces, face_obj, clip = np.concatenate(faces), np.concatenate(face_obj), np.ascontiguousarray(np.concatenate(clips))
    flags, local = np.concatenate(flags), np.concatenate(local)
    out = (flags & np.uint8(CULLED | HIDDEN)) != 0
    keep = ~(out[faces[:, 0]] | out[faces[:, 1]] | out[faces[:, 2]])
    keep[keep] = _over(clip, faces[keep], camera, box)
    faces, face_obj, local = faces[keep], face_obj[keep], local[keep]
    if not len(faces):
        return None
    faces32 = readonly(np.ascontiguousarray(faces, np.int32))
    frags = rasterize_trusted(clip, faces32, camera.width, camera.height, tuple(int(x) for x in box), None,
                              CULL_MODES[None])
    return frags.triangle, face_obj, local


def _over(clip, faces, camera, box):
    """(T,) bool: the triangles ``faces`` (T, 3) of points ``clip`` (V, 4) that may cover a pixel of
    ``box``: all but those whose corners all lie ahead of the eye plane (``w > 0``; a corner at
    or behind it is clipped) and beyond one side of the box widened by a pixel (the snapping
    moves a corner by less): each corner's side codes, the triangle's their common bits. A part
    of a triangle that clipping keeps projects inside its projected bounds."""
    w = clip[:, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (clip[:, 0] / w + 1.0) * 0.5 * camera.width
        y = (1.0 - clip[:, 1] / w) * 0.5 * camera.height
    r0, r1, c0, c1 = box
    code = ((x < c0 - 1).astype(np.uint8) | ((x > c1 + 1).astype(np.uint8) << 1) | ((y < r0 - 1).astype(np.uint8) << 2)
            | ((y > r1 + 1).astype(np.uint8) << 3))
    code[~(w > 0)] = 0  # clipped: kept
    return (code[faces[:, 0]] & code[faces[:, 1]] & code[faces[:, 2]]) == 0


def _arrive(mesh, face, origin, direction):
    """Where rays (P, 3) meet the planes of ``mesh``'s triangles ``face`` (P,), and the normals
    interpolated there (renormalised): ``(point (P, 3), normal (P, 3), ok (P,))``, ``ok`` False
    where a ray is parallel to its plane or meets it behind its origin."""
    f = mesh.faces[face]
    v = np.asarray(mesh.vertices, np.float64)
    t, bary = ray_triangle(origin, direction, v[f[:, 0]], v[f[:, 1]], v[f[:, 2]])
    ok = np.isfinite(t) & (t > 0)
    point = origin + np.where(ok, t, 0.0)[:, None] * direction
    n = np.einsum("pk,pkj->pj", np.where(ok[:, None], bary, 0.0), np.asarray(mesh.normals, np.float64)[f])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    ok &= length[:, 0] > 0
    return point, n / np.where(length > 0, length, 1.0), ok


def _arrived(level, b, mask, face, mesh, origin, direction, path, camera_ray, camera_eye, offset, shape):
    """The :class:`Bounce` of reflector ``b`` where the rays ``origin``, ``direction`` (h, w, 3)
    of the previous level's pixels of ``mask`` (h, w) meet its triangles ``face`` (h, w), with
    the path's length ``path`` (h, w) to their origins and the camera's ray directions."""
    rows, cols = np.nonzero(mask)
    point, normal, ok = _arrive(mesh, face[rows, cols], origin[rows, cols], direction[rows, cols])
    m = np.zeros(mask.shape, bool)
    r, c = rows[ok], cols[ok]
    m[r, c] = True
    pos, nrm = np.zeros(mask.shape + (3,)), np.zeros(mask.shape + (3,))
    length = np.zeros(mask.shape)
    pos[r, c], nrm[r, c] = point[ok], normal[ok]
    length[r, c] = path[r, c] + np.linalg.norm(point[ok] - origin[r, c], axis=1)
    return make_bounce(level, b, m, pos, nrm, origin, length, camera_ray, camera_eye, offset, shape)


def first_bounces(camera, meshes, k, triangle, seen, box):
    """The reflectors seen in reflector ``k``'s first-bounce image as level-2 :class:`Bounce` s:
    each pixel's eye ray meets ``k``'s visible triangle (``triangle``, the main view's;
    :func:`refsoft.raster.rays.primary_rays`), reflects, and meets the triangle of the reflector
    the virtual pass shows there (``seen``: :func:`seen_reflectors` over ``box``); the bounce
    point is that hit (float64, on the triangle's plane) and its normal the one interpolated
    there."""
    r0, r1, c0, c1 = box
    eye = np.asarray(camera.eye, np.float64)
    out = []
    for b, (mask, face) in sorted(seen.items()):
        rows, cols = np.nonzero(mask)
        hit, ray, _ = primary_rays(camera, meshes[k - 1], rows + r0, cols + c0, triangle[rows + r0, cols + c0])
        origin, direction, to = (np.zeros(mask.shape + (3,)) for _ in range(3))
        origin[rows, cols], direction[rows, cols] = hit, ray
        dist = np.zeros(mask.shape)
        dist[rows, cols] = np.linalg.norm(hit - eye, axis=1)
        to[rows, cols] = (hit - eye) / np.maximum(dist[rows, cols], 1e-300)[:, None]
        bounce = _arrived(2, b, mask, face, meshes[b - 1], origin, direction, dist, to, eye, (r0, c0),
                          triangle.shape)
        if bounce is not None:
            out.append(bounce)
    return out


def later_bounces(bounce: Bounce, seen, meshes):
    """The reflectors seen in ``bounce``'s image (``seen`` over its box) as the next level's
    :class:`Bounce` s (the bounce's reflected rays, :func:`level_rays`, meeting their
    triangles)."""
    _, origin, direction = level_rays(bounce)
    out = []
    for c, (mask, face) in sorted(seen.items()):
        nxt = _arrived(bounce.level + 1, c, mask, face, meshes[c - 1], origin, direction, bounce.path,
                       bounce.direction, bounce.origin, bounce.box[::2], bounce.shape)
        if nxt is not None:
            out.append(nxt)
    return out

"""Every reflection point of every vertex on one reflector (spec section 4.8).

The papers' walk stops at one optimum; on a mirror that is not convex a vertex can have several
reflection points (a concave sphere: up to four) or none. :class:`Images` holds all of them per
vertex, in compressed rows: vertex ``i``'s images are ``offset[i]:offset[i + 1]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import validate
from .._parallel import parallel_range
from ..constants import IMAGE_MERGE, IMAGE_REACH, IMAGE_SEED_STEPS, MAX_IMAGES
from ..errors import RefsoftError
from ..raster import GBuffer

#: Flag bit (spec section 4.7): the vertex has more than one reflection point on this reflector.
from ._kernels import SEVERAL  # noqa: E402  (defined beside the other flags)


@dataclass(frozen=True, eq=False)
class Images:
    """Every image of every vertex on one reflector.

    Attributes
    ----------
    offset : ndarray, shape (N + 1,), int64
        Vertex ``i``'s images are rows ``offset[i]:offset[i + 1]`` of the per-image arrays.
    pixel : ndarray, shape (M, 2), int32
        Reflection pixel (row, col) of each image in the G-buffer.
    virtual : ndarray, shape (M, 3), float64
        Virtual vertex of each image, world space (mirror of the vertex across the tangent plane
        at its reflection point, spec section 4.6).
    sheet : ndarray, shape (M,), int32
        Sheet of each image (spec section 4.8: a continuous piece of the mapping); -1 until the
        sheets are made.
    """

    offset: np.ndarray
    pixel: np.ndarray
    virtual: np.ndarray
    sheet: np.ndarray

    @property
    def count(self) -> np.ndarray:
        """Number of images per vertex, shape (N,), int32."""
        return np.diff(self.offset).astype(np.int32)

    @property
    def vertex(self) -> np.ndarray:
        """Vertex index of each image, shape (M,), int32."""
        return np.repeat(np.arange(len(self.offset) - 1, dtype=np.int32), self.count)

    def __len__(self) -> int:
        return len(self.offset) - 1


def _check_result(result, n):
    from . import SearchResult

    if not isinstance(result, SearchResult):
        raise RefsoftError(f"result must be a refsoft.search.SearchResult, got {type(result).__name__}")
    if len(result) != n:
        raise RefsoftError(f"result has {len(result)} vertices, vertices has {n}")


def _prepared(gbuffer, eye):
    """The packed, cropped G-buffer and its dilated pyramid: ``(G, mask, fp, (r0, c0), pyramid)``."""
    from . import _images, _packed, hierarchy

    G, mask, fp, crop = _packed(gbuffer, eye)
    return G, mask, fp, crop, hierarchy.build(G, mask, fp, base=_images.dilated_base)


def find_images(gbuffer, eye, vertices, result, reach: float = IMAGE_REACH, merge: float = IMAGE_MERGE) -> Images:
    """Every reflection point of every vertex on one reflector's G-buffer (spec section 4.8).

    A texel is an image of vertex ``V`` when its score (spec section 4.1) is a maximum of its
    covered 3x3 neighbourhood, ``V`` lies in front of its tangent plane (``dot(V - P, N) > 0``),
    its reflected eye ray can reach ``V`` (``V`` within the texel's dilated bounds,
    :mod:`refsoft.search._images`) and Newton's iteration solving "normal = bisector" from it,
    texel to texel, converges at most ``reach`` texels away (a maximum of a score that no
    solution is near, at the rim or on a part that does not reflect ``V``, is not an image). The
    image is the covered texel nearest the converged point (it too must have ``V`` in front and
    within its bounds). Maxima whose converged points lie closer than ``merge`` texels, or that
    give the same texel, are one image: the one of highest score is kept (ties to the smaller
    row, then col). The cells of a
    ray-cone pyramid whose bounds cannot hold a solution are pruned
    (:mod:`refsoft.search._images`), so a vertex costs a few descents, at most every cell once.

    The walk's image comes first: when the walk's pixel (``result.pixel``) is covered, has ``V``
    in front and within its bounds, and Newton's iteration from it converges within ``reach``
    (its own walk made it a maximum), the image is the texel where that iteration converged, as
    for every other maximum (a maximum of the discrete score can lie a pixel or more from the
    exact point; the converged texel lies within one). The single-image arrays of spec section 7
    keep the walk's pixel itself; the other images follow in row-major order.

    Parameters
    ----------
    gbuffer : GBuffer
        The reflector's G-buffer (float32 or float64; scores in its precision, Newton's iteration
        in float64).
    eye : array_like, shape (3,)
        The eye, world space.
    vertices : array_like, shape (N, 3)
        Vertices, world space.
    result : SearchResult
        The walk's result for these vertices (its pixel is the first image).
    reach, merge : float
        Texels (defaults :data:`~refsoft.constants.IMAGE_REACH`,
        :data:`~refsoft.constants.IMAGE_MERGE`).

    Returns
    -------
    Images
        Sheets -1 (made by the drawing of every image).
    """
    from . import _check_gbuffer, _images

    dt = _check_gbuffer(gbuffer)
    e = validate.point(eye, "eye")
    verts = validate.points(vertices, "vertices")
    _check_result(result, len(verts))
    validate.number(reach, "reach", minimum=0.0)
    validate.number(merge, "merge", minimum=0.0)
    n = len(verts)
    count = np.zeros(n, dtype=np.int32)
    pixel = np.full((n, MAX_IMAGES, 2), -1, dtype=np.int32)
    if n and gbuffer.mask.any():
        G, mask, fp, (r0, c0), (sph, cone, offsets, sizes) = _prepared(gbuffer, e)
        first = np.ascontiguousarray(np.asarray(result.pixel, dtype=np.int64) - [r0, c0])
        first[np.asarray(result.pixel)[:, 0] < 0] = -1
        stats = np.zeros((n, 4), dtype=np.int64)
        parallel_range(_images.enumerate_all, n, G, mask, sph, cone, offsets, sizes, len(sizes),
                       np.ascontiguousarray(verts), np.asarray(gbuffer.origin, dtype=np.float64), first, float(reach),
                       float(merge), fp, count, pixel, stats)
        pixel[:, :, 0] += r0
        pixel[:, :, 1] += c0
    return _record(gbuffer, verts, count, pixel)


def _record(gbuffer, verts, count, pixel) -> Images:
    """The :class:`Images` of per-vertex ``count`` (N,) and ``pixel`` (N, MAX_IMAGES, 2) (G-buffer
    coordinates): rows compressed, virtual vertices mirrored in float64 (spec section 4.6)."""
    offset = np.zeros(len(count) + 1, dtype=np.int64)
    np.cumsum(count, out=offset[1:])
    take = np.arange(MAX_IMAGES)[None, :] < count[:, None]
    pix = np.ascontiguousarray(pixel[take], dtype=np.int32)
    vert = np.repeat(np.arange(len(count)), count)
    return Images(offset, pix, mirrored(gbuffer, verts[vert], pix), np.full(len(pix), -1, dtype=np.int32))


def mirrored(gbuffer, vertices, pixels) -> np.ndarray:
    """``V - 2 dot(V - P, N) N`` (spec section 4.6) per row, float64 world space, with P and N the
    G-buffer's at ``pixels`` (M, 2); shape (M, 3)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if not len(v):
        return np.zeros((0, 3), dtype=np.float64)
    r, c = pixels[:, 0], pixels[:, 1]
    p = gbuffer.position[r, c].astype(np.float64) + np.asarray(gbuffer.origin, dtype=np.float64)
    nrm = gbuffer.normal[r, c].astype(np.float64)
    d = v - p
    k = 2.0 * ((d[:, 0] * nrm[:, 0] + d[:, 1] * nrm[:, 1]) + d[:, 2] * nrm[:, 2])
    return v - k[:, None] * nrm


#: The verdict names of :class:`ImagesTrace` rows (``refsoft.search._images`` codes).
VERDICTS = ("accepted", "not a 3x3 maximum", "behind the tangent plane", "Newton left the mirror or the reach",
            "Newton step singular", "merged", "too many candidates", "Newton did not converge",
            "converged texel cannot reflect the vertex")


@dataclass
class ImagesTrace:
    """How the enumeration found one vertex's images (:func:`trace_images`).

    Attributes
    ----------
    images : list of [row, col]
        The images, in output order (the walk's first when it has one).
    walk_pixel : [row, col] or None
        The walk's pixel, and ``walk_is_image`` whether it has an image (the first).
    visited, pruned, judged : int
        Pyramid cells visited (popped), cells pruned (bounds cannot meet the vertex), texels judged.
    maxima : list of dict
        Every judged texel that is a 3x3 maximum (or failed before that test could matter): its
        ``texel``, ``score``, ``newton`` point (row, col: where Newton's iteration from it
        converged, or stopped), ``image`` texel (the covered texel nearest that point) and
        ``verdict`` (:data:`VERDICTS`; accepted maxima later dropped as one solution with a kept
        image are ``merged``).
    """

    images: list
    walk_pixel: list | None
    walk_is_image: bool
    visited: int
    pruned: int
    judged: int
    maxima: list

    def to_dict(self) -> dict:
        return {"images": self.images, "walk_pixel": self.walk_pixel, "walk_is_image": self.walk_is_image,
                "visited": self.visited, "pruned": self.pruned, "judged": self.judged, "maxima": self.maxima}

    def table(self) -> str:
        """The trace as text: the counts, the maxima and their verdicts, the images."""
        lines = [f"every image: {len(self.images)} found; pyramid cells visited {self.visited}, pruned {self.pruned}; "
                 f"texels judged {self.judged}; maxima {len(self.maxima)}"]
        lines.append(f"{'texel':>12} {'score':>12} {'Newton point':>18} {'image':>12}  verdict")
        for m in self.maxima:
            nr, nc = m["newton"]
            lines.append(f"{str(tuple(m['texel'])):>12} {m['score']:>12.8f} {f'({nr:.2f}, {nc:.2f})':>18} "
                         f"{str(tuple(m['image'])):>12}  {m['verdict']}")
        walk = "none" if self.walk_pixel is None else (f"{tuple(self.walk_pixel)}, " +
                                                      ("its image kept first" if self.walk_is_image else "no image"))
        lines.append(f"walk's pixel: {walk}")
        lines.append("images: " + (", ".join(str(tuple(p)) for p in self.images) or "none"))
        return "\n".join(lines)


def trace_images(gbuffer, eye, vertex, walk_pixel=None, reach: float = IMAGE_REACH,
                 merge: float = IMAGE_MERGE) -> ImagesTrace:
    """Replay :func:`find_images` for one vertex (the kernels' own, with a record).

    Parameters
    ----------
    gbuffer : GBuffer
    eye, vertex : array_like, shape (3,)
        World space.
    walk_pixel : (row, col), optional
        The walk's pixel (its image kept first when it has one).

    Returns
    -------
    ImagesTrace
    """
    from . import _check_gbuffer, _images

    dt = _check_gbuffer(gbuffer)
    e = validate.point(eye, "eye")
    v = validate.point(vertex, "vertex")
    if not gbuffer.mask.any():
        raise RefsoftError("the reflector covers no pixel of its G-buffer: there is nothing to enumerate")
    G, mask, fp, (r0, c0), (sph, cone, offsets, sizes) = _prepared(gbuffer, e)
    v_rel = (v - np.asarray(gbuffer.origin, dtype=np.float64)).astype(dt)  # as find_images' kernel rounds it
    cand = np.empty((MAX_IMAGES * 4, _images.CAND_WIDTH))
    record = np.zeros((int(mask.size) + 1 + 2 * IMAGE_SEED_STEPS * MAX_IMAGES * 4, _images.RECORD_WIDTH))
    stack = np.empty((3 * len(sizes) + 4, 3), dtype=np.int64)
    t, work = np.empty((2, 3)), np.empty((5, 2))
    n_cand, visited, pruned, judged, n_rec = _images.enumerate_one(G, mask, sph, cone, offsets, sizes, len(sizes),
                                                                   v_rel, float(reach), float(merge), fp, stack, cand,
                                                                   t, work, record, 0)
    fr = fc = -1
    if walk_pixel is not None and walk_pixel[0] >= 0:
        fr, fc = int(walk_pixel[0]) - r0, int(walk_pixel[1]) - c0
    fr, fc, flr, flc = _images.first_walk(G, mask, sph, cone, sizes[0], fr, fc, v_rel, float(reach), fp, t, work)
    keep = np.empty(MAX_IMAGES, dtype=np.int64)
    n_keep = _images.merge(cand, n_cand, fr, fc, flr, flc, float(merge), keep, np.empty(len(cand), dtype=bool))
    kept = {int(k) for k in keep[:n_keep] if k >= 0}
    images = [[int(fr) + r0, int(fc) + c0] if k < 0 else [int(cand[k, 0]) + r0, int(cand[k, 1]) + c0]
              for k in keep[:n_keep]]
    maxima = []
    n_accepted = 0  # the accepted records are the rows of cand, in order
    for i, j, verdict, s, lr, lc, ir, ic in record[:n_rec]:
        code = int(verdict)
        if code == _images.ACCEPTED:
            if n_accepted not in kept:
                code = _images.MERGED
            n_accepted += 1
        maxima.append({"texel": [int(i) + r0, int(j) + c0], "score": float(s), "newton": [float(lr) + r0, float(lc) + c0],
                       "image": [int(ir) + r0, int(ic) + c0], "verdict": VERDICTS[code]})
    walk = None if walk_pixel is None or walk_pixel[0] < 0 else [int(walk_pixel[0]), int(walk_pixel[1])]
    return ImagesTrace(images, walk, fr >= 0, int(visited), int(pruned), int(judged), maxima)


def facing_gbuffer(gb, eye):
    """``gb`` with every normal turned to face the eye (an open mirror seen from behind reflects
    on that side: the truth's reflection about the normal does not depend on its sign, but an image
    needs the vertex in front of the tangent plane, spec section 4.8); ``gb`` itself where every
    covered normal faces the eye already."""
    P = np.asarray(gb.position)
    N = np.asarray(gb.normal)
    rel = (np.asarray(eye, np.float64) - gb.origin).astype(P.dtype)
    back = gb.mask & (np.sum((rel - P) * N, axis=2) < 0)
    if not back.any():
        return gb
    normal = np.where(back[..., None], -N, N).astype(N.dtype)
    return GBuffer(gb.position, normal, gb.mask, gb.depth, gb.triangle, gb.view_proj, gb.origin)

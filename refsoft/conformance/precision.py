"""float32 against float64: the same search run in both precisions, and where they part.

The G-buffer's coverage does not depend on the precision (it comes from snapped integer edge
functions), so both searches walk the same pixel grid. For every vertex searched in both:

- ``identical``: the same reflection pixel;
- ``tie``: different pixels whose float64 scores differ by at most the tie bound of
  :func:`tie_bound` at the float32 search's pixel (the rule ``refsoft check`` accepts, spec
  section 8): a near-tie that float32 rounding decides either way;
- ``diverged``: different pixels further apart in score: float32 rounding decided a near-tie
  earlier on the walk (or at a coherence restart), and the two walks then reached different
  local optima (only where the score has several: concave, saddle-shaped or occluded mirrors).

The float64 scores are computed here in NumPy with the formula of spec section 4.1, from the float64
G-buffer.
"""

from __future__ import annotations

import numpy as np

from .. import constants
from ..search.reflect import reflect
from ..search import CULLED


def _unit(x):
    length = np.linalg.norm(x, axis=1, keepdims=True)
    return np.divide(x, length, out=np.zeros_like(x), where=length > 0)


def _directions(gbuffer, eye, vertices, pixels, inverse=None, lengths=False):
    """``(U, B, N)`` in float64 at each vertex's pixel (row, col): the unit directions to the
    eye and to the vertex (to its mirror image ``W = V - 2 dot(V - P, N) N`` where ``inverse``,
    spec section 4.6) and the normal, from the G-buffer's values (relative to its origin); with
    ``lengths``, also the distances to the eye and to the vertex (or its image), (N,) each."""
    pixels = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    r, c = pixels[:, 0], pixels[:, 1]
    p = gbuffer.position[r, c].astype(np.float64)
    n = gbuffer.normal[r, c].astype(np.float64)
    o = gbuffer.origin
    u = (np.asarray(eye, dtype=np.float64) - o) - p
    v = np.asarray(vertices, dtype=np.float64) - o
    if inverse is not None and np.any(inverse):
        w = v - 2.0 * np.einsum("ij,ij->i", v - p, n)[:, None] * n
        v = np.where(np.asarray(inverse, dtype=bool)[:, None], w, v)
    if lengths:
        return _unit(u), _unit(v - p), n, np.linalg.norm(u, axis=1), np.linalg.norm(v - p, axis=1)
    return _unit(u), _unit(v - p), n


def scores64(gbuffer, eye, vertices, pixels) -> np.ndarray:
    """``s`` of spec section 4.1 in float64 for each vertex at its pixel (row, col) of a float64
    G-buffer (positions relative to its origin), shape (N,)."""
    u, b, n = _directions(gbuffer, eye, vertices, pixels)
    return np.einsum("ij,ij->i", n, _unit(u + b))


def score_condition(gbuffer, eye, vertices, pixels, inverse=None) -> np.ndarray:
    """``|U + B|`` at each vertex's pixel, float64 (N,): the length of the sum the score
    normalises (spec section 4.1), U the unit direction to the eye and B to the vertex (to its
    mirror image for the inverse score, ``inverse`` (N,) bool). Rounding errors of U and B are
    amplified ``1 / |U + B|`` times in the normalised bisector: near grazing angles (U and B
    nearly opposite) the score is badly conditioned."""
    u, b, _ = _directions(gbuffer, eye, vertices, pixels, inverse)
    return np.linalg.norm(u + b, axis=1)


def tie_bound(condition, k=constants.TIE_K) -> np.ndarray:
    """The largest difference of two scores accepted as a tie, for ``|U + B|`` = ``condition``
    at the oracle's pixel: ``k * TIE_EPS * (1 + 1 / |U + B|)``, ``k = TIE_K`` by default
    (infinite where ``U + B`` is zero: the score is then no evidence either way)."""
    cond = np.asarray(condition, dtype=np.float64)
    inv = np.divide(1.0, cond, out=np.full(cond.shape, np.inf), where=cond > 0)
    return k * constants.TIE_EPS * (1.0 + inv)


def position_sensitivity(gbuffer, eye, vertices, pixels, inverse=None) -> np.ndarray:
    """How much the score at each vertex's pixel may change per unit of error in the
    G-buffer's position there, to first order, float64 (N,): ``(1/|O - P| + 1/|V - P|) /
    |U + B|`` (a position error ``e`` turns U by at most ``e / |O - P|`` and B by ``e / |V - P|``,
    and normalising ``U + B`` amplifies that ``1 / |U + B|`` times; the normal is unchanged).
    Infinite where ``U + B`` is zero."""
    u, b, _, du, db = _directions(gbuffer, eye, vertices, pixels, inverse, lengths=True)
    cond = np.linalg.norm(u + b, axis=1)
    num = np.divide(1.0, du, out=np.full(du.shape, np.inf), where=du > 0) + np.divide(
        1.0, db, out=np.full(db.shape, np.inf), where=db > 0)
    return np.divide(num, cond, out=np.full(cond.shape, np.inf), where=cond > 0)


def compare_precisions(scene, frame: int = 0, preset: str = "paper", **options) -> dict:
    """Search every reflector of ``scene`` at ``frame`` in float32 and in float64 (cold; the
    papers' search unless ``preset`` or ``options`` say otherwise, as
    :func:`refsoft.search.reflect.reflect` takes them) and classify the differences.

    Returns
    -------
    dict
        Per reflector id: ``n`` (vertices searched in both), ``identical``, ``tie``, ``diverged``
        (counts), ``identical_share``, ``max_distance`` (pixels, among differing vertices) and
        ``median_margin_differing`` / ``median_margin_all`` (the float32 search's margins).
    """
    verts, _, r32 = reflect(scene, frame, precision="float32", preset=preset, **options)
    _, _, r64 = reflect(scene, frame, precision="float64", preset=preset, **options)
    eye = scene.camera_at(frame).eye
    out = {}
    for k in r32:
        a, b = r32[k].result, r64[k].result
        ok = ((a.flags | b.flags) & CULLED) == 0
        if not np.array_equal(r32[k].gbuffer.mask, r64[k].gbuffer.mask):  # pragma: no cover - a rasterizer bug
            raise RuntimeError("float32 and float64 G-buffers cover different pixels (an internal error)")
        same = ok & np.all(a.pixel == b.pixel, axis=1)
        diff = ok & ~same
        gb = r64[k].gbuffer
        s_a = scores64(gb, eye, verts[diff], a.pixel[diff])
        s_b = scores64(gb, eye, verts[diff], b.pixel[diff])
        tie = np.abs(s_a - s_b) <= tie_bound(score_condition(gb, eye, verts[diff], a.pixel[diff]))
        dist = np.linalg.norm((a.pixel[diff] - b.pixel[diff]).astype(np.float64), axis=1)
        margins = a.margin.astype(np.float64)
        out[k] = {
            "n": int(ok.sum()), "identical": int(same.sum()), "tie": int(tie.sum()), "diverged": int((~tie).sum()),
            "identical_share": float(same.sum() / max(ok.sum(), 1)),
            "max_distance": float(dist.max()) if len(dist) else 0.0,
            "median_margin_differing": float(np.median(margins[diff])) if diff.any() else 0.0,
            "median_margin_all": float(np.median(margins[ok])) if ok.any() else 0.0,
        }
    return out

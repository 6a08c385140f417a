"""The oracle's cube faces as ``refsoft check`` measures them (the comparison methods' rules,
:mod:`refsoft.conformance.comparison`): how far a texel centre lies from the projected edges of
the triangles drawn into a face, and how fast a rasterized value changes across it.

Two kinds of face: a layered depth texture's orthographic face ``f`` of an object's model-space
cube (docs/ldt.md: clip coordinates ``(sc, tc, -sigma_f q_a, 1)`` with ``q = (p - centre) /
half``), and an environment map's 90-degree perspective face (docs/envmap.md: ``(sc, tc, ., ma)``
of ``d = X - centre``, clipped at ``ma = near``). Both are float64, unsnapped: the rules accept a
coverage difference at a texel whose centre lies within a small distance of an edge, where the
snapping of any exact port may decide either way.
"""

from __future__ import annotations

import numpy as np

#: Pairs of (segment, texel) measured per batch in :func:`segment_distance` (bounds its memory).
_BATCH_PAIRS = 1 << 22


def mesh_edges(faces) -> np.ndarray:
    """The distinct edges (E, 2) int64 of a triangle list (F, 3), each as (smaller, larger)
    vertex index."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0) if len(e) else np.zeros((0, 2), np.int64)


def segment_distance(a, b, width: int, height: int, pixels, reach: float) -> np.ndarray:
    """Distance (pixels) from the centre of each pixel to the nearest segment ``a_i b_i``, up to
    ``reach``: +inf where no segment comes that close.

    Only the segments whose bounding box, grown by ``reach``, holds a pixel's centre are
    measured (through a grid of the boxes' pixels, so the cost follows the segments' sizes).

    Parameters
    ----------
    a, b : array_like, shape (E, 2), float64
        Segment ends in window coordinates (x right, y up, pixel (row, col) centred at
        ``(col + 0.5, height - row - 0.5)``).
    width, height : int
    pixels : array_like, shape (n, 2), int
        (row, col).
    reach : float

    Returns
    -------
    ndarray, shape (n,), float64
    """
    pixels = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 2)
    out = np.full(len(pixels), np.inf)
    if not len(pixels) or not len(a):
        return out
    unique, back = np.unique(pixels, axis=0, return_inverse=True)
    back = back.reshape(-1)
    slot = np.full((height, width), -1, dtype=np.int64)
    slot[unique[:, 0], unique[:, 1]] = np.arange(len(unique))
    best = np.full(len(unique), np.inf)
    lo, hi = np.minimum(a, b) - reach, np.maximum(a, b) + reach
    with np.errstate(invalid="ignore"):
        c0 = np.clip(np.ceil(lo[:, 0] - 0.5), 0, width)
        c1 = np.clip(np.floor(hi[:, 0] - 0.5), -1, width - 1)
        r0 = np.clip(np.ceil(height - 0.5 - hi[:, 1]), 0, height)
        r1 = np.clip(np.floor(height - 0.5 - lo[:, 1]), -1, height - 1)
    ok = np.isfinite(lo).all(axis=1) & np.isfinite(hi).all(axis=1)
    nc = np.where(ok, np.maximum(c1 - c0 + 1, 0), 0).astype(np.int64)
    nr = np.where(ok, np.maximum(r1 - r0 + 1, 0), 0).astype(np.int64)
    count = nc * nr
    live = np.flatnonzero(count)
    start = 0
    while start < len(live):  # batches of segments with at most _BATCH_PAIRS texels between them
        total = np.cumsum(count[live[start:]])
        stop = start + max(1, int(np.searchsorted(total, _BATCH_PAIRS, side="right")))
        seg = live[start:stop]
        n = count[seg]
        owner = np.repeat(seg, n)
        local = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        rows = r0[owner].astype(np.int64) + local // nc[owner]
        cols = c0[owner].astype(np.int64) + local % nc[owner]
        s = slot[rows, cols]
        keep = s >= 0
        owner, s = owner[keep], s[keep]
        p = np.stack([cols[keep] + 0.5, height - rows[keep] - 0.5], axis=1)
        e = b[owner] - a[owner]
        ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
        t = np.clip(np.einsum("ij,ij->i", p - a[owner], e) / ee, 0.0, 1.0)
        np.minimum.at(best, s, np.linalg.norm(a[owner] + t[:, None] * e - p, axis=1))
        start = stop
    best[best > reach] = np.inf
    out[:] = best[back]
    return out


# --- the layered depth textures' faces ------------------------------------------------------------

def ldt_face_matrix(center, half: float, f: int) -> np.ndarray:
    """(4, 4) float64: model-space point -> face ``f``'s clip coordinates ``(sc, tc, -sigma_f
    q_a, 1)`` with ``q = (p - center) / half`` (docs/ldt.md, "The build")."""
    from ..ldt.constants import FACE_TABLE

    sa, ss, ta, ts = (int(x) for x in FACE_TABLE[f])
    a, sigma = f // 2, (1.0 if f % 2 == 0 else -1.0)
    c = np.asarray(center, dtype=np.float64)
    m = np.zeros((4, 4))
    for row, (axis, sign) in enumerate(((sa, ss), (ta, ts), (a, -sigma))):
        m[row, axis] = sign / half
        m[row, 3] = -sign * c[axis] / half
    m[3, 3] = 1.0
    return m


def ldt_edge_distance(mesh, center, half: float, resolution: int, f: int, texels, reach: float) -> np.ndarray:
    """Distance (texels) from each texel centre (n, 2: row, col) of face ``f`` to the nearest
    projected edge of the model-space ``mesh``'s triangles (+inf beyond ``reach``;
    :func:`segment_distance`)."""
    clip = np.c_[mesh.vertices, np.ones(mesh.n_vertices)] @ ldt_face_matrix(center, half, f).T
    win = (clip[:, :2] + 1.0) * (0.5 * resolution)
    e = mesh_edges(mesh.faces)
    return segment_distance(win[e[:, 0]], win[e[:, 1]], resolution, resolution, texels, reach)


def ldt_fragments(mesh, center, half: float, resolution: int, f: int, texels, triangles):
    """:func:`refsoft.conformance.profiles.fragments` of the model-space ``mesh``'s
    ``triangles`` at the texel centres of face ``f``: their window depth (``delta_f``), normal
    and rates of change per texel."""
    from .profiles import fragments

    return fragments(mesh, ldt_face_matrix(center, half, f), resolution, resolution, texels, triangles)


# --- the environment map's faces -------------------------------------------------------------------

def envmap_edge_distance(vertices, faces, center, resolution: int, f: int, near: float, texels,
                         reach: float) -> np.ndarray:
    """Distance (texels) from each texel centre (n, 2) of cube-map face ``f`` around ``center``
    to the nearest projected edge of the world triangles ``(vertices, faces)``, each edge
    clipped at ``ma = near`` (+inf beyond ``reach``)."""
    from ..envmap.cube import face_coordinates

    d = np.asarray(vertices, dtype=np.float64) - np.asarray(center, dtype=np.float64)
    sc, tc, ma = face_coordinates(d, f)
    p = np.stack([sc, tc, ma], axis=1)
    e = mesh_edges(faces)
    u, v = p[e[:, 0]], p[e[:, 1]]
    front_u, front_v = u[:, 2] >= near, v[:, 2] >= near
    keep = front_u | front_v
    u, v, front_u, front_v = u[keep], v[keep], front_u[keep], front_v[keep]
    # the end behind the plane moves onto it (clip coordinates are linear in d)
    t = np.divide(near - u[:, 2], v[:, 2] - u[:, 2], out=np.zeros(len(u)), where=v[:, 2] != u[:, 2])
    cut = u + t[:, None] * (v - u)
    u = np.where(front_u[:, None], u, cut)
    v = np.where(front_v[:, None], v, cut)

    def window(q):
        return (q[:, :2] / q[:, 2:3] + 1.0) * (0.5 * resolution)

    return segment_distance(window(u), window(v), resolution, resolution, texels, reach)

"""Geometry the accurate preset adds to a reflector's virtual scene: the crack-free adaptive
tessellation of the reflected triangles (Szabo 2013, chapter 5) and the cut of mixed triangles
at the reflector's silhouette (spec section 5; refsoft's ``tessellate`` and ``silhouette="clip"``).

The arithmetic runs on the GPU (edge errors, the searches of new vertices, their refinement and
virtual vertices: :class:`Shaders`, provided by the pipeline); the topology (which edges are
split, the red-green split's faces in the order the oracle draws them, the visible parts of cut
triangles) is bookkeeping on index arrays, done here with NumPy. Every float64 formula on the
host is written in the oracle's order: a midpoint is ``0.5 * (a + b)``, a unit normal
``x / sqrt((x.x^2 + x.y^2) + x.z^2)`` (zero for a zero vector).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HIDDEN, CULLED = 1, 16
#: Bisection steps per cut edge (refsoft.constants.CLIP_ITERATIONS): the cut's bracket is closed
#: to ``2**-CLIP_ITERATIONS`` of the edge.
CLIP_ITERATIONS = 10
#: Regula falsi steps of a predicted cut's score tie (refsoft.constants.CLIP_TIE_STEPS).
CLIP_TIE_STEPS = 8
#: Undirected edge keys ``min * KEY_BASE + max``.
KEY_BASE = np.int64(1) << 31


class Shaders:
    """What the geometry needs of the GPU, for one reflector's G-buffer (the pipeline's)."""

    def search(self, points, starts, inverse_search):
        """``(pixel (M, 2) int32, flags (M,) uint32)`` of world ``points`` (M, 3) float64 searched
        from ``starts`` (M, 2) ((-1, -1): the default start)."""
        raise NotImplementedError

    def refine(self, points, pixel, flags):
        """Sub-texel ``(P, N, offset)`` of the points (relative to the G-buffer's origin)."""
        raise NotImplementedError

    def edge_errors(self, vertices, pixel, offset, e0, e1):
        """The edge errors (E,) float64 of edges ``(vertices[e0], vertices[e1])``."""
        raise NotImplementedError

    def texels(self):
        """``(P, N, origin, eye)``: the G-buffer's positions and normals (h, w, 3), read back
        (relative to ``origin``), its origin and the eye (3,) float64."""
        raise NotImplementedError


def unit_rows(a) -> np.ndarray:
    """Rows of a (M, 3) float64 array divided by their length; zero rows stay zero."""
    n = np.sqrt((a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1]) + a[:, 2] * a[:, 2])[:, None]
    return np.divide(a, n, out=np.zeros_like(a), where=n > 0)


@dataclass
class Reflected:
    """The reflected geometry of one reflector: vertices (world float64), normals, search pixels
    and flags, sub-texel points ``(P, N, offset)`` (relative to the G-buffer's origin, or None
    without refinement), faces (int64) and their object ids."""

    vertices: np.ndarray
    normals: np.ndarray
    pixel: np.ndarray
    flags: np.ndarray
    surface: tuple | None
    faces: np.ndarray
    face_obj: np.ndarray

    @property
    def offset(self):
        return None if self.surface is None else self.surface[2]

    def add(self, vertices, normals, pixel, flags, surface):
        self.vertices = np.concatenate([self.vertices, vertices])
        self.normals = np.concatenate([self.normals, normals])
        self.pixel = np.concatenate([self.pixel, pixel.astype(np.int32)])
        self.flags = np.concatenate([self.flags, flags.astype(np.uint32)])
        if self.surface is not None:
            self.surface = tuple(np.concatenate([a, b]) for a, b in zip(self.surface, surface))


def _dot_texel(x, p, n, origin):
    """``dot(x - (P + origin), N)`` per row, its three terms added to 0.0 in order (the
    oracle's loop)."""
    d = np.zeros(len(x))
    for k in range(3):
        d = d + (x[:, k] - (p[:, k] + origin[k])) * n[:, k]
    return d


def _unit3(x, y, z):
    n = np.sqrt((x * x + y * y) + z * z)
    ok = n > 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok, x / n, x), np.where(ok, y / n, y), np.where(ok, z / n, z)


def _score(P, N, origin, eye, x, r, c):
    """The search's score of points ``x`` (M, 3) at texels (r, c), in float64 (the oracle's
    ``_silhouette._score``)."""
    p = P[r, c].astype(np.float64)
    n = N[r, c].astype(np.float64)
    px, py, pz = p[:, 0] + origin[0], p[:, 1] + origin[1], p[:, 2] + origin[2]
    ux, uy, uz = _unit3(eye[0] - px, eye[1] - py, eye[2] - pz)
    vx, vy, vz = _unit3(x[:, 0] - px, x[:, 1] - py, x[:, 2] - pz)
    hx, hy, hz = _unit3(ux + vx, uy + vy, uz + vz)
    return (n[:, 0] * hx + n[:, 1] * hy) + n[:, 2] * hz


def _predict(gpu, p_vis, p_hid, a, b, lo_px, hi_px):
    """The oracle's predicted cut (``refsoft.search._silhouette._predict``) of each edge's
    bracket [a, b] whose ends reflect at texels ``lo_px`` and ``hi_px`` (M, 2); -1 for none."""
    P, N, origin, eye = gpu.texels()
    mask = gpu.mask
    h, w = mask.shape
    r1, c1, r2, c2 = lo_px[:, 0], lo_px[:, 1], hi_px[:, 0], hi_px[:, 1]
    ok = (np.abs(r1 - r2) <= 1) & (np.abs(c1 - c2) <= 1)
    ok &= (r1 >= 0) & (r1 < h) & (c1 >= 0) & (c1 < w) & (r2 >= 0) & (r2 < h) & (c2 >= 0) & (c2 < w)
    r1, c1, r2, c2 = (np.where(ok, x, 0) for x in (r1, c1, r2, c2))
    ok &= mask[r1, c1] & mask[r2, c2]

    def point(t):
        return p_vis + t[:, None] * (p_hid - p_vis)

    p1, n1 = P[r1, c1].astype(np.float64), N[r1, c1].astype(np.float64)
    d0, d1 = _dot_texel(point(a), p1, n1, origin), _dot_texel(point(b), p1, n1, origin)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where((d0 > 0.0) & (d1 < 0.0), a + (b - a) * (d0 / (d0 - d1)), -1.0)
    t = np.where((d0 <= 0.0) & (d1 < 0.0), a, t)
    other = ok & ((r1 != r2) | (c1 != c2))

    def g(x):
        return _score(P, N, origin, eye, x, r1, c1) - _score(P, N, origin, eye, x, r2, c2)

    ta, tb = a.copy(), b.copy()
    g0, g1 = g(point(ta)), g(point(tb))
    tie_ok = other & (g0 >= 0.0) & (g1 < 0.0)
    side = np.zeros(len(a), dtype=np.int8)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        for _ in range(CLIP_TIE_STEPS):
            tt = ta + (tb - ta) * (g0 / (g0 - g1))
            gt = g(point(np.where(tie_ok, tt, ta)))
            up = gt >= 0.0
            g1n = np.where(up, np.where(side == 1, g1 * 0.5, g1), gt)
            g0n = np.where(up, gt, np.where(side == -1, g0 * 0.5, g0))
            ta, tb = np.where(up, tt, ta), np.where(up, tb, tt)
            g0, g1 = g0n, g1n
            side = np.where(up, 1, -1).astype(np.int8)
    tie = np.where(tie_ok, ta, -1.0)
    t = np.where(tie_ok & ((t < 0.0) | (tie < t)), tie, t)
    return np.where(ok, t, -1.0)


def _cut(gpu, p_vis, p_hid, lo_px, hi_px, flags, tolerance):
    """The oracle's cut (``refsoft.search._silhouette.cut_edges`` with ``predict``): per edge a
    bracket [a, b] of t, seen at a, hidden at b, shrunk to ``tolerance``; each step searches, from
    the last seen point's pixel, the points tolerance / 2 either side of the predicted cut
    (:func:`_predict`), the second only when the first is seen, or the midpoint where there is no
    prediction or the last step did not halve the bracket. Returns (a, pixel, flags)."""
    m = len(p_vis)
    a, b = np.zeros(m), np.ones(m)
    lo_px, hi_px = lo_px.astype(np.int64).copy(), hi_px.astype(np.int64).copy()
    got_flags = flags.copy()
    halved = np.ones(m, dtype=bool)
    while True:
        todo = np.flatnonzero(b - a > tolerance)
        if len(todo) == 0:
            break
        ta, tb = a[todo], b[todo]
        width = tb - ta
        t1, t2 = 0.5 * (ta + tb), np.full(len(todo), -1.0)
        tp = np.full(len(todo), -1.0)
        pred = np.flatnonzero(halved[todo])
        if len(pred):
            e = todo[pred]
            tp[pred] = _predict(gpu, p_vis[e], p_hid[e], a[e], b[e], lo_px[e], hi_px[e])
        use = tp >= 0.0
        t1 = np.where(use, np.maximum(tp - 0.5 * tolerance, ta), t1)
        t2 = np.where(use, np.minimum(tp + 0.5 * tolerance, tb), t2)
        stop = np.zeros(len(todo), dtype=bool)  # a probe found the hidden side: no second probe
        for t in (t1, t2):
            cur_a, cur_b = a[todo], b[todo]
            go = np.flatnonzero(~stop & (t >= 0.0) & (t > cur_a) & (t < cur_b))
            if len(go) == 0:
                continue
            e, te = todo[go], t[go]
            pixel, fl = gpu.search(p_vis[e] + te[:, None] * (p_hid[e] - p_vis[e]), lo_px[e], False)
            seen = (fl & (HIDDEN | CULLED)) == 0
            a[e] = np.where(seen, te, a[e])
            b[e] = np.where(seen, b[e], te)
            lo_px[e] = np.where(seen[:, None], pixel, lo_px[e])
            hi_px[e] = np.where(seen[:, None], hi_px[e], pixel)
            got_flags[e] = np.where(seen, fl, got_flags[e])
            stop[go] = ~seen
        halved[todo] = (b[todo] - a[todo]) <= 0.5 * width
    return a, lo_px.astype(np.int32), got_flags


def edge_keys(u, v) -> np.ndarray:
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    return lo.astype(np.int64) * KEY_BASE + hi


def split(faces, keys, mids):
    """Red-green split of ``faces`` (T, 3) int64 by the split edges ``keys`` (sorted) with
    midpoints ``mids``: a face with 3, 2, 1, 0 split edges gives 4, 3, 2, 1 children, in the
    faces' order. Returns ``(children (T', 3), parent (T',))``."""
    t = len(faces)
    if t == 0:
        return faces.copy(), np.zeros(0, np.int64)
    has = np.zeros((t, 3), bool)
    mid = np.full((t, 3), -1, np.int64)
    for e in range(3):  # edges (v0 v1), (v1 v2), (v2 v0)
        key = edge_keys(faces[:, e], faces[:, (e + 1) % 3])
        at = np.clip(np.searchsorted(keys, key), 0, max(len(keys) - 1, 0))
        hit = keys[at] == key if len(keys) else np.zeros(t, bool)
        has[:, e] = hit
        mid[:, e] = np.where(hit, mids[at] if len(mids) else -1, -1)
    count = has.sum(axis=1)
    kids = np.full((t, 4, 3), -1, np.int64)
    rows = np.arange(t)
    v = faces
    s = count == 0
    kids[s, 0] = v[s]
    s = count == 3
    a, b, c, ab, bc, ca = v[s, 0], v[s, 1], v[s, 2], mid[s, 0], mid[s, 1], mid[s, 2]
    kids[s, 0] = np.c_[a, ab, ca]
    kids[s, 1] = np.c_[ab, b, bc]
    kids[s, 2] = np.c_[ca, bc, c]
    kids[s, 3] = np.c_[ab, bc, ca]
    s = count == 1  # the split edge k from v_k to v_k+1
    r, k = rows[s], np.argmax(has[s], axis=1)
    v0, v1, opp, m = v[r, k], v[r, (k + 1) % 3], v[r, (k + 2) % 3], mid[r, k]
    kids[s, 0] = np.c_[v0, m, opp]
    kids[s, 1] = np.c_[m, v1, opp]
    s = count == 2  # the unsplit edge k keeps a triangle of its own
    r, k = rows[s], np.argmin(has[s], axis=1)
    v0, v1, opp = v[r, k], v[r, (k + 1) % 3], v[r, (k + 2) % 3]
    m1, m2 = mid[r, (k + 1) % 3], mid[r, (k + 2) % 3]
    kids[s, 0] = np.c_[v0, v1, m1]
    kids[s, 1] = np.c_[v0, m1, m2]
    kids[s, 2] = np.c_[m2, m1, opp]
    keep = np.arange(4)[None, :] <= count[:, None]
    return kids[keep], np.repeat(rows, count + 1)


def tessellate(geo: Reflected, gpu: Shaders, mask, threshold, max_level, min_span, inverse_search):
    """Split triangles whose largest edge error exceeds ``threshold`` (0: all), crack-free, up to
    ``max_level`` levels, each level only among the faces the last one made; new vertices are
    searched from their parents' pixels and refined. ``geo`` grows in place; returns
    ``(vertices searched, levels)``."""
    active = np.ones(len(geo.faces), bool)
    searched = levels = 0
    h, w = mask.shape
    for _ in range(max_level):
        cand = np.flatnonzero(active)
        if len(cand) == 0:
            break
        f = geo.faces[cand]
        e0, e1 = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
        err = np.zeros(len(e0))
        need = np.ones(len(e0), bool)
        if min_span > 0:  # an edge reflected within min_span pixels is not a reason to split
            need = np.abs(geo.pixel[e0].astype(np.int64) - geo.pixel[e1]).max(axis=1) > min_span
        if need.any():
            err[need] = gpu.edge_errors(geo.vertices, geo.pixel, geo.offset, e0[need], e1[need])
        fl = geo.flags[f]
        bad = ((fl & CULLED) != 0).any(axis=1)
        if threshold > 0:
            bad |= ((fl & HIDDEN) != 0).all(axis=1)
        worst = np.where(bad, -np.inf, err.reshape(-1, 3).max(axis=1))
        chosen = cand[worst > threshold]
        if len(chosen) == 0:
            break
        t = geo.faces[chosen]
        keys = np.unique(np.concatenate([edge_keys(t[:, e], t[:, (e + 1) % 3]) for e in range(3)]))
        ea, eb = keys // KEY_BASE, keys % KEY_BASE
        mids = len(geo.vertices) + np.arange(len(keys), dtype=np.int64)
        new_v = 0.5 * (geo.vertices[ea] + geo.vertices[eb])
        new_n = unit_rows(geo.normals[ea] + geo.normals[eb])
        pa, pb = geo.pixel[ea].astype(np.int64), geo.pixel[eb].astype(np.int64)
        start = (pa + pb) // 2  # halfway between the parents' pixels, where covered; else the first's
        ok = np.all(pa >= 0, axis=1) & np.all(pb >= 0, axis=1)
        ok &= mask[np.clip(start[:, 0], 0, h - 1), np.clip(start[:, 1], 0, w - 1)]
        start = np.where(ok[:, None], start, pa)
        start = np.where(np.all(start >= 0, axis=1)[:, None], start, -1)
        pixel, flags = gpu.search(new_v, start, inverse_search)
        surface = None if geo.surface is None else gpu.refine(new_v, pixel, flags)
        geo.add(new_v, new_n, pixel, flags, surface)
        searched += len(new_v)
        faces, parent = split(geo.faces, keys, mids)
        many = np.bincount(parent, minlength=len(geo.faces)) > 1
        geo.faces, geo.face_obj, active = faces, geo.face_obj[parent], many[parent]
        levels += 1
    return searched, levels


def clip_at_silhouette(geo: Reflected, gpu: Shaders, iterations=CLIP_ITERATIONS):
    """Cut each edge from a visible to a hidden vertex of the mixed faces (a hidden and a visible
    corner, none CULLED) where its reflection reaches the silhouette (:func:`_cut`, each step a
    search from the last visible point's pixel), and replace each mixed face by its
    visible part, in place: one hidden corner ``z`` (after ``x, y``): ``(x, y, X_yz)``,
    ``(x, X_yz, X_xz)``; two (``x`` visible): ``(x, X_xy, X_xz)``. Returns
    ``(new vertices (M, 3), their pixels, flags, edges cut)``; ``geo`` gets the new vertices'
    positions, normals and faces, the caller their pixels, flags and offsets."""
    faces, flags = geo.faces, geo.flags
    n = len(geo.vertices)
    hidden = (flags & HIDDEN) != 0
    fh = hidden[faces]
    mixed = np.flatnonzero(fh.any(axis=1) & ~fh.all(axis=1) & ~((flags[faces] & CULLED) != 0).any(axis=1))
    if len(mixed) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2), np.int32), np.zeros(0, np.uint32), 0
    f = faces[mixed]
    a, b = f.reshape(-1, order="F"), f[:, [1, 2, 0]].reshape(-1, order="F")
    cross = hidden[a] != hidden[b]
    vis, hid = np.where(hidden[a], b, a)[cross], np.where(hidden[a], a, b)[cross]
    key = np.unique(vis * np.int64(n) + hid)
    vis, hid = key // n, key % n
    p_vis, p_hid = geo.vertices[vis], geo.vertices[hid]
    lo, got_pixel, got_flags = _cut(gpu, p_vis, p_hid, geo.pixel[vis], geo.pixel[hid], geo.flags[vis],
                                    2.0 ** -iterations)
    cut_v = p_vis + lo[:, None] * (p_hid - p_vis)
    cut_n = unit_rows(geo.normals[vis] + lo[:, None] * (geo.normals[hid] - geo.normals[vis]))

    def cut(u, v):
        return n + np.searchsorted(key, u * n + v)

    one = fh[mixed].sum(axis=1) == 1
    rows = np.arange(len(f))
    k = np.where(one, np.argmax(fh[mixed], axis=1), np.argmax(~fh[mixed], axis=1))
    x = np.where(one, f[rows, (k + 1) % 3], f[rows, k])
    y = np.where(one, f[rows, (k + 2) % 3], f[rows, (k + 1) % 3])
    z = np.where(one, f[rows, k], f[rows, (k + 2) % 3])
    first = np.where(one[:, None], np.c_[x, y, cut(y, z)], np.c_[x, cut(x, y), cut(x, z)])
    second = np.c_[x, cut(y, z), cut(x, z)]
    count = np.ones(len(faces), np.int64)
    count[mixed] = np.where(one, 2, 1)
    out = np.repeat(faces, count, axis=0)
    at = (np.cumsum(count) - count)[mixed]
    out[at] = first
    out[at[one] + 1] = second[one]
    geo.faces, geo.face_obj = out, np.repeat(geo.face_obj, count)
    return cut_v, cut_n, got_pixel.astype(np.int32), got_flags.astype(np.uint32), len(key)

"""The silhouette cut's kernel (:mod:`refsoft.search.silhouette`): every step of every cut edge in
one pass, each step's search the one-walk search (:func:`refsoft.search._kernels.search_one`,
which gives :func:`refsoft.search.search`'s results bit for bit) from the last visible point's
pixel; optionally each step placed where the cut is predicted (float64 arithmetic)."""

import numpy as np

from .._numba import kernel, like
from ._kernels import CULLED, HIDDEN, RESTARTED, search_one


@kernel(inline=True)
def _point(p_vis, p_hid, i, t, k):
    """Coordinate ``k`` of ``p_vis[i] + t (p_hid[i] - p_vis[i])`` (NumPy's order of operations)."""
    return p_vis[i, k] + t * (p_hid[i, k] - p_vis[i, k])


@kernel(inline=True)
def _plane(P, N, origin, p_vis, p_hid, i, t, r, c):
    """``dot(X - P, N)`` at texel (r, c) for the point at ``t`` of edge ``i`` (float64)."""
    d = 0.0
    for k in range(3):
        d += (_point(p_vis, p_hid, i, t, k) - (np.float64(P[r, c, k]) + origin[k])) * np.float64(N[r, c, k])
    return d


@kernel
def _score(P, N, origin, eye, p_vis, p_hid, i, t, r, c):
    """The search's score (spec section 4.1) of the point at ``t`` of edge ``i`` at texel (r, c),
    in float64."""
    px = np.float64(P[r, c, 0]) + origin[0]
    py = np.float64(P[r, c, 1]) + origin[1]
    pz = np.float64(P[r, c, 2]) + origin[2]
    ux, uy, uz = eye[0] - px, eye[1] - py, eye[2] - pz
    n = np.sqrt((ux * ux + uy * uy) + uz * uz)
    if n > 0.0:
        ux, uy, uz = ux / n, uy / n, uz / n
    vx = _point(p_vis, p_hid, i, t, 0) - px
    vy = _point(p_vis, p_hid, i, t, 1) - py
    vz = _point(p_vis, p_hid, i, t, 2) - pz
    n = np.sqrt((vx * vx + vy * vy) + vz * vz)
    if n > 0.0:
        vx, vy, vz = vx / n, vy / n, vz / n
    hx, hy, hz = ux + vx, uy + vy, uz + vz
    n = np.sqrt((hx * hx + hy * hy) + hz * hz)
    if n > 0.0:
        hx, hy, hz = hx / n, hy / n, hz / n
    return (np.float64(N[r, c, 0]) * hx + np.float64(N[r, c, 1]) * hy) + np.float64(N[r, c, 2]) * hz


@kernel
def _tie(P, N, origin, eye, p_vis, p_hid, i, a, b, r1, c1, r2, c2, steps):
    """Where in [a, b] texel (r2, c2) starts to outscore texel (r1, c1) for the points of edge
    ``i``: ``steps`` regula falsi (Illinois) steps on the difference of the scores; -1 unless
    (r1, c1) scores at least as high at ``a`` and lower at ``b``."""
    g0 = _score(P, N, origin, eye, p_vis, p_hid, i, a, r1, c1) - _score(P, N, origin, eye, p_vis, p_hid, i, a, r2, c2)
    g1 = _score(P, N, origin, eye, p_vis, p_hid, i, b, r1, c1) - _score(P, N, origin, eye, p_vis, p_hid, i, b, r2, c2)
    if not (g0 >= 0.0 and g1 < 0.0):
        return -1.0
    side = 0
    for _ in range(steps):
        t = a + (b - a) * (g0 / (g0 - g1))
        g = _score(P, N, origin, eye, p_vis, p_hid, i, t, r1, c1) - _score(P, N, origin, eye, p_vis, p_hid, i, t, r2,
                                                                             c2)
        if g >= 0.0:  # the tie lies beyond t; an end kept a second time has its value halved
            a = t
            g0 = g
            if side == 1:
                g1 *= 0.5
            side = 1
        else:
            b = t
            g1 = g
            if side == -1:
                g0 *= 0.5
            side = -1
    return a


@kernel
def _predict(P, N, mask, origin, eye, p_vis, p_hid, i, a, b, r1, c1, r2, c2, tie_steps):
    """Where in [a, b] the point of edge ``i`` is predicted to turn hidden when the bracket's ends
    reflect at the same or neighbouring texels (r1, c1) (seen) and (r2, c2) (hidden): where it
    crosses the tangent plane of (r1, c1) (linear in t: exact while the search stays there) or
    where (r2, c2) outscores (r1, c1), whichever comes first; -1 for none."""
    h, w = mask.shape
    if abs(r1 - r2) > 1 or abs(c1 - c2) > 1:
        return -1.0
    if not (0 <= r1 < h and 0 <= c1 < w and 0 <= r2 < h and 0 <= c2 < w and mask[r1, c1] and mask[r2, c2]):
        return -1.0
    t = -1.0
    d0 = _plane(P, N, origin, p_vis, p_hid, i, a, r1, c1)
    d1 = _plane(P, N, origin, p_vis, p_hid, i, b, r1, c1)
    if d0 > 0.0 and d1 < 0.0:
        t = a + (b - a) * (d0 / (d0 - d1))
    elif d0 <= 0.0 and d1 < 0.0:  # on the mark at a, its sign lost to rounding
        t = a
    if r1 != r2 or c1 != c2:
        tie = _tie(P, N, origin, eye, p_vis, p_hid, i, a, b, r1, c1, r2, c2, tie_steps)
        if tie >= 0.0 and (t < 0.0 or tie < t):
            t = tie
    return t


@kernel
def cut_edges(lo, hi, G, mask, r0, c0, P, N, full_mask, origin, eye, p_vis, p_hid, start, end, default_r, default_c,
              n_candidates, cap, tolerance, predict, tie_steps, fp, cut_t, pixel, flags, searched, v, scratch, seen,
              record):
    """For each edge ``i`` in ``lo .. hi - 1`` (run over every edge by
    :func:`refsoft._parallel.parallel_range`) from visible ``p_vis[i]`` to hidden ``p_hid[i]``
    (world, float64, searched at pixels ``start[i]`` and ``end[i]``): a bracket [a, b] of ``t``,
    ``p_vis + t (p_hid - p_vis)`` seen (neither HIDDEN nor CULLED) at ``a`` and not at ``b``,
    shrunk until at most ``tolerance`` wide. Each step searches (``discard``: no inverse search)
    from the last seen point's pixel; without ``predict``, at the bracket's midpoint (bisection);
    with it, where the bracket's ends reflect at the same or neighbouring texels, at the points
    ``tolerance / 2`` either side of the predicted cut (:func:`_predict`), which close the bracket
    when the prediction is on the mark, and at the midpoint otherwise and after a step that did
    not halve the bracket. Writes ``cut_t[i]`` (a), that point's ``pixel[i]`` and ``flags[i]``
    (at ``a = 0``: ``start[i]`` and ``flags[i]`` as given) and ``searched[i]``. ``G``, ``mask``:
    the packed G-buffer, cropped at (r0, c0) of the ``full_mask``; ``P``, ``N``: the G-buffer
    (relative to ``origin``). A start not covered restarts at (default_r, default_c), flag
    RESTARTED, (-1, -1) starts there without it (as :func:`refsoft.search.search`). ``v`` (3,),
    ``scratch`` (2, 9), ``seen`` (2, 9) bool and ``record`` (0, RECORD_WIDTH): work arrays."""
    fh, fw = full_mask.shape
    for i in range(lo, hi):
        a = 0.0
        b = 1.0
        sr = start[i, 0]
        sc = start[i, 1]
        er = end[i, 0]
        ec = end[i, 1]
        fl = flags[i]
        n = 0
        halved = True
        while b - a > tolerance:
            t1 = 0.5 * (a + b)
            t2 = -1.0
            if predict and halved:
                tp = _predict(P, N, full_mask, origin, eye, p_vis, p_hid, i, a, b, sr, sc, er, ec, tie_steps)
                if tp >= 0.0:
                    t1 = max(tp - 0.5 * tolerance, a)
                    t2 = min(tp + 0.5 * tolerance, b)
            width = b - a
            for j in range(2):
                t = t1 if j == 0 else t2
                if t < 0.0 or t <= a or t >= b:
                    continue
                for k in range(3):
                    v[k] = like(_point(p_vis, p_hid, i, t, k) - origin[k], fp)
                extra = 0
                wr = default_r
                wc = default_c
                if 0 <= sr < fh and 0 <= sc < fw and full_mask[sr, sc]:
                    wr = sr
                    wc = sc
                elif sr != -1 or sc != -1:  # a start no longer covered: restart ((-1, -1) is none)
                    extra = RESTARTED
                r, c, best, margin, total, f, n_rec = search_one(G, mask, v, wr - r0, wc - c0, n_candidates, cap,
                                                                 False, fp, record, scratch, seen)
                f |= extra
                n += 1
                if (f & (HIDDEN | CULLED)) == 0:
                    a = t
                    sr = r + r0
                    sc = c + c0
                    fl = f
                else:
                    b = t
                    er = r + r0
                    ec = c + c0
                    break
            halved = b - a <= 0.5 * width
        cut_t[i] = a
        pixel[i, 0] = sr
        pixel[i, 1] = sc
        flags[i] = fl
        searched[i] = n


@kernel
def mixed_faces(faces, flags, out):
    """``out[i]``: face ``i`` has a HIDDEN and a visible corner and no CULLED corner
    (:func:`refsoft.search.silhouette.mixed_faces`)."""
    for i in range(faces.shape[0]):
        a = flags[faces[i, 0]]
        b = flags[faces[i, 1]]
        c = flags[faces[i, 2]]
        ha = (a & HIDDEN) != 0
        hb = (b & HIDDEN) != 0
        hc = (c & HIDDEN) != 0
        out[i] = (ha != hb or ha != hc) and ((a | b | c) & CULLED) == 0

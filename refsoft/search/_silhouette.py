"""The silhouette cut's bisection kernel (:mod:`refsoft.search.silhouette`): every step of every
cut edge in one pass, each step's search the one-walk search
(:func:`refsoft.search._kernels.search_one`, which gives :func:`refsoft.search.search`'s results
bit for bit) from the last visible point's pixel."""

import numpy as np

from .._numba import kernel, like
from ._kernels import CULLED, HIDDEN, RESTARTED, search_one


@kernel
def bisect_cuts(lo, hi, G, mask, r0, c0, full_mask, origin, p_vis, p_hid, start, default_r, default_c, n_candidates,
                cap, iterations, fp, cut_t, pixel, flags, v, scratch, seen, record):
    """For each edge ``i`` in ``lo .. hi - 1`` (run over every edge by
    :func:`refsoft._parallel.parallel_range`) from visible ``p_vis[i]`` to hidden ``p_hid[i]``
    (world, float64): ``iterations`` bisection steps of ``t`` on whether ``p_vis + t (p_hid -
    p_vis)`` is seen (neither HIDDEN nor CULLED), each a search (``discard``: no inverse search)
    from the last seen point's pixel, at first ``start[i]``. Writes ``cut_t[i]``, the last seen
    ``t`` (0: none), and that point's ``pixel[i]`` and ``flags[i]`` (at ``t = 0``: ``start[i]``
    and ``flags[i]`` as given). ``G``, ``mask``: the packed G-buffer, cropped at (r0, c0) of the
    ``full_mask``; a start that is not covered restarts at (default_r, default_c), flag RESTARTED,
    and (-1, -1) starts there without the flag (as :func:`refsoft.search.search`). ``v`` (3,), ``scratch`` (2, 9), ``seen`` (2, 9) bool and
    ``record`` (0, RECORD_WIDTH): the part's work arrays."""
    fh, fw = full_mask.shape
    for i in range(lo, hi):
        a = 0.0
        b = 1.0
        sr = start[i, 0]
        sc = start[i, 1]
        fl = flags[i]
        for _ in range(iterations):
            t = 0.5 * (a + b)
            for k in range(3):
                v[k] = like((p_vis[i, k] + t * (p_hid[i, k] - p_vis[i, k])) - origin[k], fp)
            extra = 0
            wr = default_r
            wc = default_c
            if 0 <= sr < fh and 0 <= sc < fw and full_mask[sr, sc]:
                wr = sr
                wc = sc
            elif sr != -1 or sc != -1:  # a start no longer covered: restart ((-1, -1) is none)
                extra = RESTARTED
            r, c, best, margin, total, f, n_rec = search_one(G, mask, v, wr - r0, wc - c0, n_candidates, cap, False,
                                                             fp, record, scratch, seen)
            f |= extra
            if (f & (HIDDEN | CULLED)) == 0:
                a = t
                sr = r + r0
                sc = c + c0
                fl = f
            else:
                b = t
        cut_t[i] = a
        pixel[i, 0] = sr
        pixel[i, 1] = sc
        flags[i] = fl

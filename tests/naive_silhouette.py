"""A plain reference of the silhouette cut's bisection (refsoft.search.silhouette): edge by edge,
step by step, one call of the public search for one point, from the last visible point's pixel."""

import numpy as np

from refsoft import search


def naive_bisect(gbuffer, eye, p_vis, p_hid, pixel, flags, neighbourhood, iterations, cap=None):
    """(t (M,), pixel (M, 2) int32, flags (M,) uint8) of each edge p_vis[i] -> p_hid[i]: the last
    point seen (neither HIDDEN nor CULLED) after ``iterations`` halvings of [0, 1]."""
    m = len(p_vis)
    out_t, out_pixel, out_flags = np.zeros(m), np.array(pixel, dtype=np.int32), np.array(flags, dtype=np.uint8)
    for i in range(m):
        lo, hi = 0.0, 1.0
        start = np.array([pixel[i]], dtype=np.int64)
        for _ in range(iterations):
            t = 0.5 * (lo + hi)
            point = p_vis[i] + t * (p_hid[i] - p_vis[i])
            res = search.search(gbuffer, eye, point[None, :], neighbourhood, "discard", start, cap)
            if res.flags[0] & (search.HIDDEN | search.CULLED):
                hi = t
            else:
                lo = t
                start = res.pixel.astype(np.int64)
                out_pixel[i], out_flags[i] = res.pixel[0], res.flags[0]
        out_t[i] = lo
    return out_t, out_pixel, out_flags

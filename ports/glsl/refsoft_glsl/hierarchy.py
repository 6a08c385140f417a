"""Szabo's ray-cone hierarchy search on the GPU (``method = "hierarchy"``; refsoft's
``refsoft/search/_hierarchy.py``): level 0 from the G-buffer (``hbase.comp``), each level above
from the one below (``hlevel.comp``), one stack traversal per vertex (``hsearch.comp``), float32
only. The pyramid covers the covered pixels' box plus a one-pixel margin, padded to a square
power of two, as the oracle's does: the order children are visited in depends on it.
"""

from __future__ import annotations

import numpy as np

#: The enlargements after a failed traversal (refsoft.constants CONE_FACTOR, SPHERE_FACTOR).
CONE_FACTOR, SPHERE_FACTOR = 1.5, 2.0


def hierarchy_search(pipe, data, gb, start) -> dict:
    """Szabo's ray-cone hierarchy (``method = "hierarchy"``) over the covered pixels' box
    plus a one-pixel margin, padded to a square power of two; no coherence."""
    gl, opt = pipe.gl, pipe.options
    w, h = gb["width"], gb["height"]
    n = data.reflected.n_vertices
    mask = gl.read(gb["mask"], np.int32, (h, w)) != 0
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if len(rows):
        r0, r1 = max(int(rows[0]) - 1, 0), min(int(rows[-1]) + 2, h)
        c0, c1 = max(int(cols[0]) - 1, 0), min(int(cols[-1]) + 2, w)
    else:
        r0 = r1 = c0 = c1 = 0
    crop = (r0, c0, r1 - r0, c1 - c0)
    size = 1
    while size < max(crop[2], crop[3]):
        size *= 2
    sizes = [size]
    while sizes[-1] > 1:
        sizes.append(sizes[-1] // 2)
    offsets = np.concatenate([[0], np.cumsum([s * s for s in sizes[:-1]])]).astype(np.int32)
    total = int(sum(s * s for s in sizes))
    sph, cone = gl.buffer(nbytes=16 * total), gl.buffer(nbytes=16 * total)
    levels = np.zeros(32, np.int32)
    levels[:len(sizes)] = offsets
    levels[16:16 + len(sizes)] = sizes
    gl.run(gl.compute("hbase", EXACT=int(pipe.exact)), size * size, [gb["P"], gb["N"], gb["mask"], None, None, gb["params"], sph, cone],
           size=size, gwidth=w, crop=crop)
    for lvl in range(1, len(sizes)):
        gl.run(gl.compute("hlevel", EXACT=int(pipe.exact)), sizes[lvl] ** 2, [None] * 6 + [sph, cone], size=sizes[lvl],
               src=int(offsets[lvl - 1]), dst=int(offsets[lvl]))
    out = {"pixel": gl.buffer(nbytes=8 * n), "score": gl.buffer(nbytes=4 * n), "margin": gl.buffer(nbytes=4 * n),
           "iterations": gl.buffer(nbytes=4 * n), "flags": gl.buffer(nbytes=4 * n)}
    cap = opt.get("cap") or 2 * (w + h)
    gl.run(gl.compute("hsearch", NLEV=len(sizes), DOUBLE=0, EXACT=int(pipe.exact)), n,
           [gb["P"], gb["N"], gb["mask"], start, data.reflected.points, gb["params"], sph, cone,
            out["pixel"], out["score"], out["margin"], out["iterations"], out["flags"], gl.buffer(levels)],
           n=n, cap=int(cap), inverse_search=pipe.inverse == "search", crop=crop, gwidth=w, gheight=h,
           cone_factor=CONE_FACTOR, sphere_factor=SPHERE_FACTOR)
    return out

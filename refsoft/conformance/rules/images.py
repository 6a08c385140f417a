"""``refsoft check``'s rule of every image of every vertex (kind ``images``; spec sections 4.8
and 8), the per-image arrays a reflector has where the enumeration ran:

- ``image_count_K``: identical (the number of images of each vertex is a decision: a differing
  count fails);
- ``image_vertex_K``, ``image_pixel_K``, ``image_sheet_K``: identical, over the vertices whose
  counts agree;
- ``image_virtual_K``: the float rule (4 float32 ULP or 1e-6 of the scene's extent) where the
  image's pixel agrees.

A candidate whose count differs from the oracle's has per-image arrays of another length: the
driver reports their shapes, and this rule judges the counts.
"""

from __future__ import annotations

import numpy as np

from ... import keys
from .common import compare_float_field, where

KINDS = ("images",)


def kind_of(key: str):
    p = keys.parse(key)
    return "images" if p is not None and p[0] in keys.IMAGE_ARRAYS else None


def _exact(ctx, key, g, c, rows, what):
    """Identical over ``rows`` (bool over the first axis): a finding."""
    gg, cc = g[rows], c[rows]
    same = np.all(gg.reshape(len(gg), -1) == cc.reshape(len(cc), -1), axis=1)
    n = len(same)
    if same.all():
        return ctx.finding(key, "identical", "pass", "identical", 0, n)
    i = int(np.argmin(same))
    at = np.flatnonzero(rows)[i]
    return ctx.finding(key, "identical", "fail", f"{what} differ", int((~same).sum()), n,
                       f"at {where([at])}: expected {np.asarray(gg[i]).tolist()} / observed {np.asarray(cc[i]).tolist()}")


def judge(ctx, G, C, usable) -> None:
    """Every reflector's per-image arrays."""
    for k in keys.reflectors(G, keys.IMAGE_COUNT):
        ck = keys.IMAGE_COUNT(k)
        if not usable(ck):
            continue
        gc, cc = G[ck], C[ck]
        _exact(ctx, ck, gc, cc, np.ones(len(gc), dtype=bool), "image counts")
        agree_v = gc == cc
        # the images of the vertices whose counts agree (both sides list them in the same rows then)
        g_off = np.concatenate([[0], np.cumsum(gc, dtype=np.int64)])
        rows = np.repeat(agree_v, gc)
        c_rows = np.repeat(agree_v, cc) if len(cc) == len(gc) else rows
        if not np.array_equal(np.flatnonzero(rows), np.flatnonzero(c_rows)):
            continue  # earlier rows differ in length: the shapes were reported by the driver
        for name, what in ((keys.IMAGE_VERTEX, "vertices"), (keys.IMAGE_PIXEL, "pixels"), (keys.IMAGE_SHEET, "sheets")):
            key = name(k)
            if usable(key):
                _exact(ctx, key, G[key], C[key], rows, what)
        vk, pk = keys.IMAGE_VIRTUAL(k), keys.IMAGE_PIXEL(k)
        if usable(vk) and len(g_off) > 1:
            sel = rows.copy()
            if usable(pk):
                sel &= np.all(G[pk] == C[pk], axis=1)
            gv, cv = G[vk].astype(np.float64), C[vk].astype(np.float64)
            extent = ctx.oracle().extent if not np.array_equal(gv[sel], cv[sel]) else 1.0
            compare_float_field(ctx, vk, gv, cv, sel, extent)

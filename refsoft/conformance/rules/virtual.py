"""``refsoft check``'s rule of the virtual vertices (kind ``virtual``; spec section 8):
``virtual_vertex_K`` by the float rule where the reflection pixels agree; at a tie, against the
oracle's virtual vertex recomputed from the candidate's pixel (the case's ``refine`` and
``virtual`` rule). On the candidate's own G-buffer (a profile with ``own_gbuffer``), also within
what saving its positions as world-space float32 changes (:func:`virtual_slack`).

The pixels' verdict is :mod:`.search`'s (``ctx.agreement``), which the registry runs first.
"""

from __future__ import annotations

import numpy as np

from ... import keys
from .common import compare_float_field, f32_ulp, mark
from .search import agreement, vertex_reference

KINDS = ("virtual",)


def kind_of(key: str):
    p = keys.parse(key)
    return "virtual" if p is not None and p[0] == keys.VIRTUAL_VERTEX else None


def judge(ctx, G, C, usable) -> None:
    """Every reflector's virtual vertices."""
    for k in keys.reflectors(G):
        if usable(keys.VIRTUAL_VERTEX(k)):
            Gk, _ = vertex_reference(ctx, k, G)
            _, agree, tie = agreement(ctx, k, Gk)
            judge_virtual(ctx, k, Gk, C, agree, tie)


def judge_virtual(ctx, k, G, C, agree, tie) -> list:
    """Virtual vertices: the float rule where the pixels agree; at a tie, against the oracle's
    virtual vertex recomputed from the candidate's pixel (the case's refine and virtual rule)."""
    from ...search import SearchResult
    from ...search.method import virtual_relative

    vk = keys.VIRTUAL_VERTEX(k)
    gv, cv = G[vk].astype(np.float64), C[vk].astype(np.float64)
    if tie.any():
        o = ctx.oracle()
        gb, opts = ctx.stage_gbuffer(k), o.case.options
        sub = np.flatnonzero(tie)
        m = len(sub)
        res = SearchResult(C[keys.REFLECTION_PIXEL(k)][sub].astype(np.int32), np.zeros(m), np.zeros(m),
                           np.ones(m, np.int32), G[keys.FLAGS(k)][sub], opts.get("neighbourhood", "cross"),
                           opts.get("inverse", "plane"), 1, opts.get("method", "walk"))
        rel, _ = virtual_relative(gb, res, o.verts[sub], o.scene.camera_at(ctx.frame).eye, opts.get("refine", False),
                                  opts.get("virtual", "mirror"))
        gv[sub] = (rel.astype(np.float64) + gb.origin).astype(rel.dtype).astype(np.float64)
    sel = agree | tie
    extent = ctx.oracle().extent if not np.array_equal(gv[sel], cv[sel]) else 1.0
    return compare_float_field(ctx, vk, gv, cv, sel, extent, extra=virtual_slack(ctx, k, G, C, sel, gv, cv))


def virtual_slack(ctx, k, G, C, sel, gv, cv):
    """``extra`` of :func:`compare_float_field` for virtual vertices judged on the candidate's
    own G-buffer (None otherwise): within ``6 q (1 + |V - P| / |O - P|)`` of the reference, ``q``
    the rounding of the saved positions (:func:`refsoft.conformance.stages.saved_rounding`'s): a position error ``e`` moves
    a mirrored vertex by at most ``2 e``, one by the plane rule ``4 e``, an unfolded one
    ``(2 + |V - P| / |O - P|) e``, and a sub-texel point, from three texels, by ``3 e``."""
    if ctx.stages.get(k) is None:
        return None

    def run(todo):
        i = np.flatnonzero(sel)[todo]
        o = ctx.oracle()
        gb, eye = ctx.stage_gbuffer(k), o.scene.camera_at(ctx.frame).eye
        pix = C[keys.REFLECTION_PIXEL(k)][i] if keys.REFLECTION_PIXEL(k) in C else G[keys.REFLECTION_PIXEL(k)][i]
        pix = np.clip(pix, 0, np.array(gb.mask.shape) - 1)
        rel = gb.position[pix[:, 0], pix[:, 1]].astype(np.float64)
        q = 0.5 * np.sqrt(3.0) * (f32_ulp(np.abs(rel + gb.origin).max(axis=1)) + f32_ulp(np.abs(rel).max(axis=1)))
        far = np.linalg.norm(o.verts[i] - gb.origin - rel, axis=1) / np.maximum(
            np.linalg.norm(eye - gb.origin - rel, axis=1), 1e-300)
        ref = gv[i]
        ok = np.linalg.norm(cv[i] - ref, axis=1) <= 6 * q * (1 + far)
        return {"within the saved positions' rounding": mark(int(sel.sum()), np.flatnonzero(todo)[ok])}

    return run

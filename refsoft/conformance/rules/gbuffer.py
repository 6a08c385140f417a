"""``refsoft check``'s G-buffer rules (kinds ``coverage`` and ``gbuffer``; spec section 8).

- ``gbuffer_mask_K``: identical, except pixels whose centre lies within the profile's edge
  distance (1e-4 px by default) of an edge of the oracle's projected (unsnapped) triangles
  (ambiguous, accepted);
- ``gbuffer_position_K``, ``gbuffer_normal_K``: the float rule (4 float32 ULP or 1e-6 of the
  scene's extent; normals also within 1e-4 rad) where both masks cover the pixel; at a depth tie
  (the golden ``gbuffer_depth_margin_K`` at most 8 x 2^-24) matching either the winning fragment
  or the next one (rebuilt with :func:`refsoft.raster.gbuffer_layers`); the ``gpu`` profile also
  accepts GPU interpolation (its sub-pixel slack times the value's screen-space rate) and a
  fragment of another triangle whose edge passes within its edge distance;
- ``gbuffer_view_proj_K``: every entry by the float rule.

``gbuffer_depth_margin_K`` is the oracle's own (:data:`ORACLE_ONLY`): a candidate does not write
it and it is not judged.
"""

from __future__ import annotations

import numpy as np

from ... import keys
from ...constants import EXTENT_TOL, F32_ULP_TOL, NORMAL_ANGLE_TOL
from ..golden import DEPTH_MARGIN
from .common import compare_float_field, f32_ulp, float_rule, mark, where

KINDS = ("coverage", "gbuffer")
#: Per-reflector names -> kind.
NAMES = {keys.GBUFFER_MASK: "coverage", keys.GBUFFER_POSITION: "gbuffer", keys.GBUFFER_NORMAL: "gbuffer",
         keys.GBUFFER_VIEW_PROJ: "gbuffer", DEPTH_MARGIN: "gbuffer"}
#: Arrays of the golden frames that only the oracle writes (what the rules read about the oracle
#: itself): a candidate need not have them, and they are not judged.
ORACLE_ONLY = (DEPTH_MARGIN,)


def parse(key: str):
    """:func:`refsoft.keys.parse`, knowing the oracle-only names too."""
    for name in ORACLE_ONLY:
        prefix = name + "_"
        if key.startswith(prefix) and key[len(prefix):].isdigit():
            return name, int(key[len(prefix):])
    return keys.parse(key)


def kind_of(key: str):
    p = parse(key)
    return NAMES.get(p[0]) if p is not None else None


def judge(ctx, G, C, usable) -> None:
    """Every G-buffer map of the frame: masks, positions and normals, view-projection matrices."""
    for key in sorted(G):
        p = parse(key)
        if p is None or p[0] not in NAMES or p[0] in ORACLE_ONLY or not usable(key):
            continue
        name, k = p
        g, c = G[key], C[key]
        if name == keys.GBUFFER_MASK:
            judge_mask(ctx, key, g, c, k)
        elif name in (keys.GBUFFER_POSITION, keys.GBUFFER_NORMAL):
            mk = keys.GBUFFER_MASK(k)
            cover = G[mk] & C[mk] if mk in C and C[mk].shape == G[mk].shape else G[mk]
            extent = ctx.oracle().extent if not np.array_equal(g[cover], c[cover]) else 1.0
            compare_float_field(ctx, key, g, c, cover, extent, normals=name == keys.GBUFFER_NORMAL,
                                extra=gbuffer_alternatives(ctx, name, k, G, cover, c[cover], extent))
        else:
            compare_float_field(ctx, key, g.reshape(1, -1), c.reshape(1, -1), np.ones(1, bool), 1.0)


def judge_mask(ctx, key, g, c, k):
    """The coverage rule of reflector ``k``'s mask."""
    diff = np.argwhere(g != c)
    if len(diff) == 0:
        return [ctx.finding(key, "coverage", "pass", "identical")]
    edge_px = ctx.profile.edge_px
    dist = ctx.oracle().edge_distance(k, diff)
    amb = dist <= edge_px
    fails = diff[~amb]
    ctx.paint(key, g.shape, diff[amb], diff[~amb])
    worst = ""
    if len(fails):
        r, cc = fails[0]
        worst = f"at {where(fails[0])}: expected {bool(g[r, cc])} / observed {bool(c[r, cc])} ({dist[~amb][0]:.3g} px from an edge)"
        return [ctx.finding(key, "coverage", "fail", f"{len(fails)} pixels differ away from edges "
                            f"({int(amb.sum())} ambiguous within {edge_px:.3g} px)", len(fails), g.size, worst)]
    return [ctx.finding(key, "coverage", "accepted", f"only ambiguous edge pixels differ (centre within "
                        f"{edge_px:.3g} px of an edge)", int(amb.sum()), g.size)]


def near(c, ref, rate, extent, normals, subpixel):
    """Rows of ``c`` within the float rule of ``ref`` widened by ``subpixel`` pixels times
    ``rate`` (world units or radians per pixel): (n,) bool."""
    ok, _ = float_rule(ref, c, extent, normals)
    c64, r64 = np.asarray(c, np.float64), np.asarray(ref, np.float64)
    if normals:
        ang = np.arctan2(np.linalg.norm(np.cross(c64, r64), axis=1), np.einsum("ij,ij->i", c64, r64))
        return ok | (ang <= NORMAL_ANGLE_TOL + subpixel * rate)
    slack = EXTENT_TOL * extent + F32_ULP_TOL * f32_ulp(np.abs(r64).max(axis=1))
    return ok | (np.linalg.norm(c64 - r64, axis=1) <= slack + subpixel * rate)


def gbuffer_alternatives(ctx, name, k, G, cover, cc, extent):
    """``extra`` of :func:`compare_float_field` for reflector ``k``'s position or normal map
    ``cc`` (the candidate's values at ``cover``): for the elements ``todo`` failing the float
    rule, those the profile accepts otherwise:

    - ``within GPU interpolation`` (a profile with ``subpixel_px``): within that many pixels
      times the winning fragment's rate of change;
    - ``match the next fragment at a depth tie``: where the golden frame's depth margin is a tie
      (:meth:`Profile.depth_tie`, with both fragments' depth slopes), matching the next fragment;
    - ``match another triangle at an edge`` (a profile with ``subpixel_px``): matching a fragment
      of a triangle whose edge passes within ``edge_px`` of the pixel centre and which is in
      front of the winner, or at a depth tie with it.
    """
    prof = ctx.profile
    normals = name == keys.GBUFFER_NORMAL
    pix = np.argwhere(cover)
    margin = G.get(DEPTH_MARGIN(k))
    margin = margin[cover] if margin is not None and margin.shape == cover.shape else None

    def value(fr):
        return fr.normal if normals else fr.position

    def rate(fr):
        return fr.normal_rate if normals else fr.position_rate

    def run(todo):
        out = {}
        o = ctx.oracle()
        todo = todo.copy()
        if prof.subpixel_px and todo.any():
            i = np.flatnonzero(todo)
            win = o.fragments(k, pix[i])
            ok = near(cc[i], value(win), rate(win), extent, normals, prof.subpixel_px)
            out["within GPU interpolation"] = mark(len(cc), i[ok])
            todo[i[ok]] = False
        maybe = None
        if margin is not None:
            # without a subpixel tolerance the margin alone decides the ties: the next fragment
            # is rebuilt only if there are some
            maybe = todo & (np.isfinite(margin) if prof.subpixel_px else prof.depth_tie(margin))
        if maybe is not None and maybe.any():
            i = np.flatnonzero(maybe)
            pos2, nrm2, tri2 = o.second_fragment(k)
            tied = np.ones(len(i), dtype=bool)
            if prof.subpixel_px:
                sec = o.fragments(k, pix[i], tri2[pix[i, 0], pix[i, 1]])
                tied = prof.depth_tie(margin[i], o.fragments(k, pix[i]).depth_rate + sec.depth_rate)
            ref = (nrm2 if normals else pos2)[pix[i, 0], pix[i, 1]]
            ok = tied & float_rule(ref, cc[i], extent, normals)[0]
            if prof.subpixel_px:
                ok |= tied & near(cc[i], value(sec), rate(sec), extent, normals, prof.subpixel_px)
            out["match the next fragment at a depth tie"] = mark(len(cc), i[ok])
            todo[i[ok]] = False
        if prof.subpixel_px and todo.any():
            i = np.flatnonzero(todo)
            at, tri = o.edge_triangles(k, pix[i], prof.edge_px)
            if len(at):
                fr = o.fragments(k, pix[i][at], tri)
                w = o.fragments(k, pix[i][at])
                front = prof.depth_tie(fr.depth - w.depth, fr.depth_rate + w.depth_rate)
                ok = front & near(cc[i][at], value(fr), rate(fr), extent, normals, prof.subpixel_px)
                out["match another triangle at an edge"] = mark(len(cc), i[at[ok]])
        return out

    return run

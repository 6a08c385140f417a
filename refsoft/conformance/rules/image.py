"""``refsoft check``'s rules of the picture (kinds ``image`` and ``ids``; spec section 8).

- ``image``: every channel within 1 (``loose``, and the ``gpu`` profile: within 4, with a
  1-pixel window and at most 0.1% of the pixels failing); under a profile that judges the
  stages on the candidate's own G-buffer, against the oracle's composite from it;
- ``object_id``, ``reflected_id``: reported, not judged (a comparison method's ``reflected_id``
  is part of its per-pixel decision: :mod:`.ldt`, :mod:`.envmap`).
"""

from __future__ import annotations

import numpy as np

from ... import keys
from ...constants import IMAGE_LOOSE_SHARE, IMAGE_TOL, IMAGE_TOL_LOOSE

KINDS = ("image", "ids")
_KEYS = {keys.IMAGE: "image", keys.OBJECT_ID: "ids", keys.REFLECTED_ID: "ids"}


def kind_of(key: str):
    return _KEYS.get(key)


def drawn_from_every_image(G) -> bool:
    """Whether the golden frame's picture was drawn from every image of every vertex (spec
    section 4.8): the frame holds per-image arrays (``image_count_K``), so its ``image`` and
    ``reflected_id`` depend on outputs of kind ``images``."""
    return any(k.startswith(f"{keys.IMAGE_COUNT}_") for k in G)


def judge(ctx, G, C, usable) -> None:
    """The image (against ``ctx.reference`` when the oracle was run on the candidate's inputs)
    and the ids. A port that declares kind ``images`` not ported draws one image per vertex, one
    that declares ``bounces`` one bounce: on a frame the oracle drew from every image, or with
    several bounces, its picture and reflected ids are ``not_ported``."""
    lacking = [(kind, why) for kind, why, drawn in (
        ("images", "drawn from every image of every vertex", drawn_from_every_image(G)),
        ("bounces", "drawn with several bounces", keys.BOUNCE_DEPTH in G)) if drawn and kind in ctx.not_ported_kinds]
    if lacking:
        kind, why = lacking[0]
        for key in (keys.IMAGE, keys.REFLECTED_ID):
            if usable(key):
                ctx.finding(key, "image", "not_ported", f"{why}: kind {kind!r} declared not ported", kind=kind)
        if usable(keys.OBJECT_ID):
            d = int((G[keys.OBJECT_ID] != C[keys.OBJECT_ID]).sum())
            ctx.finding(keys.OBJECT_ID, "ids (reported)", "pass" if d == 0 else "accepted",
                        "identical" if d == 0 else "differ (reported, not judged)", d, G[keys.OBJECT_ID].size)
        return
    if usable(keys.IMAGE):
        judge_image(ctx, G[keys.IMAGE] if ctx.reference is None else ctx.reference[keys.IMAGE], C[keys.IMAGE],
                    ctx.loose)
    for key in (keys.OBJECT_ID, keys.REFLECTED_ID):
        if usable(key):
            d = int((G[key] != C[key]).sum())
            ctx.finding(key, "ids (reported)", "pass" if d == 0 else "accepted",
                        "identical" if d == 0 else "differ (reported, not judged)", d, G[key].size)


def judge_image(ctx, g, c, loose):
    """The image rule of ``c`` against ``g``, with the error mask and the difference picture."""
    d = np.abs(g.astype(np.int16) - c.astype(np.int16)).max(axis=2)
    tol = IMAGE_TOL_LOOSE if loose else IMAGE_TOL
    bad = d > tol
    if loose and bad.any():  # a 1-pixel window: the candidate may match a neighbour of the reference
        h, w = d.shape
        best = d.copy()
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                sh = np.full_like(g, 0)
                rs, re_ = max(dr, 0), h + min(dr, 0)
                cs, ce = max(dc, 0), w + min(dc, 0)
                sh[rs:re_, cs:ce] = g[rs - dr:re_ - dr, cs - dc:ce - dc]
                best = np.minimum(best, np.abs(sh.astype(np.int16) - c.astype(np.int16)).max(axis=2))
        bad = best > tol
    n = d.size
    if not d.any():
        return [ctx.finding("image", "image", "pass", "identical", 0, n)]
    r, cc = np.unravel_index(int(np.argmax(d)), d.shape)
    worst = f"at ({r}, {cc}): expected {g[r, cc].tolist()} / observed {c[r, cc].tolist()}"
    # the error mask and the difference (16x brighter), for an image that did not pass
    ctx.paint("image", d.shape, np.argwhere((d > 0) & ~bad), np.argwhere(bad), d == 0)
    ctx.picture("image_diff", np.clip(np.abs(g.astype(np.int16) - c.astype(np.int16)) * 16, 0, 255))
    nbad = int(bad.sum())
    if nbad and (not loose or nbad > IMAGE_LOOSE_SHARE * n):
        return [ctx.finding("image", "image", "fail", f"channels differ by more than {tol}", nbad, n, worst)]
    return [ctx.finding("image", "image", "accepted", f"within {tol} per channel" + (" (loose)" if loose else ""),
                        int((d > 0).sum()), n, worst)]

"""``refsoft check``'s rule of several bounces (kind ``bounces``; spec sections 5 and 8).

- ``bounce_depth`` (written with ``bounces > 1``): identical, except pixels beside a change of
  the oracle's depth (an 8-neighbour of a pixel of another depth), where which level draws the
  pixel turns on a ray meeting a triangle's edge: accepted there.

A port that declares kind ``bounces`` not ported draws one bounce: on a frame the oracle drew
with several, its ``bounce_depth``, ``image`` and ``reflected_id`` are ``not_ported``
(:mod:`.image`); the first level's arrays are judged as in any frame (they do not depend on the
later levels).
"""

from __future__ import annotations

import numpy as np

from ... import keys

KINDS = ("bounces",)


def kind_of(key: str):
    return "bounces" if key == keys.BOUNCE_DEPTH else None


def several_bounces(G) -> bool:
    """Whether the golden frame ``G`` was drawn with several bounces (it holds ``bounce_depth``)."""
    return keys.BOUNCE_DEPTH in G


def beside_a_change(depth) -> np.ndarray:
    """(H, W) bool: pixels with an 8-neighbour of another value in ``depth``."""
    h, w = depth.shape
    pad = np.pad(depth, 1, mode="edge")
    out = np.zeros((h, w), bool)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            out |= pad[1 + dr:h + 1 + dr, 1 + dc:w + 1 + dc] != depth
    return out


def judge(ctx, G, C, usable) -> None:
    if not usable(keys.BOUNCE_DEPTH):
        return
    g, c = G[keys.BOUNCE_DEPTH], C[keys.BOUNCE_DEPTH]
    differ = g != c
    n = int(differ.sum())
    if not n:
        ctx.finding(keys.BOUNCE_DEPTH, "bounces", "pass", "identical", 0, g.size)
        return
    edge = beside_a_change(g)
    bad = differ & ~edge
    ctx.paint(keys.BOUNCE_DEPTH, g.shape, np.argwhere(differ & edge), np.argwhere(bad), ~differ)
    r, cc = np.argwhere(differ)[0]
    where = f"first at ({r}, {cc}): expected {int(g[r, cc])} / observed {int(c[r, cc])}"
    if bad.any():
        ctx.finding(keys.BOUNCE_DEPTH, "bounces", "fail",
                    f"{int(bad.sum())} pixel(s) away from a change of depth differ; {where}", int(bad.sum()), g.size)
    else:
        ctx.finding(keys.BOUNCE_DEPTH, "bounces", "accepted",
                    f"{n} pixel(s) differ, each beside a change of the oracle's depth; {where}", n, g.size)

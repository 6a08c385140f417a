"""Vertices worth tracing (``refsoft trace SCENE`` without ``--vertex``): one frame's search of
every vertex in one reflector, and from it the longest search, a hidden vertex, a capped one, one
on the border, one with several images, and a typical one."""

from __future__ import annotations

import numpy as np

from ..errors import RefsoftError
from . import BORDER, CAPPED, CULLED, HIDDEN
from .images import SEVERAL

#: What each suggestion is, in the order listed.
KINDS = (("longest search", 0), ("hidden (behind the tangent plane)", HIDDEN), ("capped", CAPPED),
         ("several images", SEVERAL), ("on the reflector's border", BORDER), ("typical (median length)", None))


def interesting_vertices(scene, reflector=None, frame: int = 0, **options) -> list:
    """Suggest vertices to trace in one reflector at one frame (searched without coherence).

    Parameters
    ----------
    scene : Scene
    reflector : int, optional
        Object id (default: the first reflector).
    frame : int
    **options
        :class:`refsoft.RenderOptions` fields of the vertex search (``neighbourhood``, ``inverse``, ...).

    Returns
    -------
    list of dict
        ``{"kind", "vertex", "iterations", "flags", "pixel"}``, one per kind found (a kind no
        vertex has is left out), in the order of :data:`KINDS`; the same vertex may appear twice.
    """
    from .reflect import check_reflector, reflect

    if not scene.reflector_ids:
        raise RefsoftError(f"scene {scene.name!r} has no reflector")
    k = scene.reflector_ids[0] if reflector is None else check_reflector(scene, reflector)
    _, _, out = reflect(scene, frame, reflectors=[k], **options)
    res = out[k].result
    it = np.asarray(res.iterations, dtype=np.int64)
    fl = np.asarray(res.flags, dtype=np.int64)
    if out[k].images is not None:  # every image enumerated (images="all"): SEVERAL as the frame's flags have it
        fl = fl | np.where(out[k].images.count > 1, SEVERAL, 0)
    live = (fl & CULLED) == 0
    found = []
    for kind, bit in KINDS:
        if bit is None:
            idx = np.flatnonzero(live)
            if len(idx) == 0:
                continue
            order = idx[np.argsort(it[idx], kind="stable")]
            v = int(order[len(order) // 2])
        else:
            sel = live if bit == 0 else live & ((fl & bit) != 0)
            if not sel.any():
                continue
            v = int(np.flatnonzero(sel)[np.argmax(it[sel])])  # the longest of them, the first on a tie
        found.append({"kind": kind, "vertex": v, "iterations": int(it[v]), "flags": int(fl[v]),
                      "pixel": [int(x) for x in res.pixel[v]]})
    return found

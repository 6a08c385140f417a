"""The ray-cone hierarchy search (Szabo 2013, chapter 4): ``search(..., neighbourhood="hierarchy")``.

Built per G-buffer: the covered pixels' box (plus a one-pixel margin) padded to a square power
of two is level 0; each level above bounds 2x2 texels with the thesis's boundSphere and
boundCone, with two fixes: a sphere that contains the other is kept as it is (the thesis's
formula would cut it), and the angle between two cone axes is ``atan2(|a x b|, a . b)`` (the
thesis's ``acos(a . b)`` loses up to 4e-4 rad in float32 for nearly parallel axes, and the cones
then miss their children).
A vertex's search walks the pyramid top-down with a stack (children tested and visited in the
order top-left, top-right, bottom-left, bottom-right), following every branch whose cone contains
the vertex, and ends at the best base pixel, by the linear search's score ``s``, under all the
level-1 texels it reached. (The thesis takes the first path down and the ray passing closest to
the vertex; following every containing branch and using ``s`` make the result the exhaustive
argmax wherever the optimum's ancestors all contain the vertex, which the tests check, at the
price of more tests where cones overlap.) The thesis's two error
corrections: when no path reaches the bottom, the traversal restarts with cone angles and sphere
radii enlarged by ``cone_factor`` (1.5) and ``sphere_factor`` (2), compounding, up to
:data:`~refsoft.search._hierarchy.MAX_ENLARGEMENTS` times; and ``break_level`` > 0 stops the
descent that many levels above the base (the pixel whose ray passes closest among the texel's
base pixels). A search that still fails ends at the start pixel of spec section 4.3 with ``CAPPED``.

There is no frame-to-frame coherence (the thesis: not possible with the pyramid); ``iterations``
counts the texels tested. HIDDEN and BORDER are set as by the linear search (crosshair
neighbours); with ``inverse="search"`` a hidden vertex's inverse search is the crosshair walk.
"""

from __future__ import annotations

import numpy as np

from .. import validate
from .._parallel import parallel_range
from ..errors import RefsoftError
from . import _hierarchy
from ..constants import CONE_FACTOR, SPHERE_FACTOR


def build(G, mask, fp, base=None):
    """The pyramid of a packed, cropped G-buffer: ``(spheres, cones, offsets, sizes)`` with the
    levels concatenated (level l's texel (i, j) at row ``offsets[l] + i * sizes[l] + j``).
    ``base`` is the kernel that fills level 0 (default :func:`_hierarchy.base_level`; the
    enumeration of every image uses :func:`refsoft.search._images.dilated_base`)."""
    h, w = mask.shape
    size = 1
    while size < max(h, w):
        size *= 2
    sph, cone = np.full((size, size, 4), -1, dtype=G.dtype), np.full((size, size, 4), -1, dtype=G.dtype)
    parallel_range(_hierarchy.base_level if base is None else base, h, G, mask, fp, sph, cone)
    s_levels, c_levels = [sph.reshape(-1, 4)], [cone.reshape(-1, 4)]
    sizes = [size]
    while sph.shape[0] > 1:
        half = sph.shape[0] // 2
        s_out, c_out = np.full((half, half, 4), -1, dtype=G.dtype), np.full((half, half, 4), -1, dtype=G.dtype)
        parallel_range(_hierarchy.next_level, half, sph, cone, fp, s_out, c_out)
        sph, cone = s_out, c_out
        s_levels.append(sph.reshape(-1, 4))
        c_levels.append(cone.reshape(-1, 4))
        sizes.append(sph.shape[0])
    offsets = np.zeros(len(sizes), dtype=np.int64)
    offsets[1:] = np.cumsum([s * s for s in sizes[:-1]])
    return (np.ascontiguousarray(np.concatenate(s_levels)), np.ascontiguousarray(np.concatenate(c_levels)), offsets,
            np.asarray(sizes, dtype=np.int64))


def check_factors(cone_factor, sphere_factor, break_level):
    for name, f in (("cone_factor", cone_factor), ("sphere_factor", sphere_factor)):
        if not validate.is_number(f) or f < 1.0:
            raise RefsoftError(f"{name} must be a number >= 1, got {f!r}")
    if not validate.is_integer(break_level) or break_level < 0:
        raise RefsoftError(f"break_level must be a non-negative integer, got {break_level!r}")

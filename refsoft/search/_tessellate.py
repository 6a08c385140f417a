"""Edge-error kernel of :mod:`refsoft.search.tessellate` (float64 arithmetic, as the thesis's error is
a small difference of cosines)."""

import numpy as np

from .._numba import kernel, like
from ..constants import MAX_OFFSET
from ._refine import gauss_newton_step, surface_values


@kernel(inline=True)
def _unit(x, y, z):
    n = np.sqrt((x * x + y * y) + z * z)
    if n > 0.0:
        return x / n, y / n, z / n
    return 0.0, 0.0, 0.0


@kernel(inline=True)
def thesis_error(px, py, pz, nx, ny, nz, ex, ey, ez, verts, a, b):
    """The thesis's error ``1 - (dot(N, b) + 1) / 2`` at the surface point (px, py, pz) with normal
    (nx, ny, nz), ``b`` the normalised bisector of the directions from it to the eye (ex, ey, ez)
    and to the midpoint of vertices ``verts[a]`` and ``verts[b]`` (float64)."""
    mx = 0.5 * (verts[a, 0] + verts[b, 0])
    my = 0.5 * (verts[a, 1] + verts[b, 1])
    mz = 0.5 * (verts[a, 2] + verts[b, 2])
    vx, vy, vz = _unit(ex - px, ey - py, ez - pz)
    wx, wy, wz = _unit(mx - px, my - py, mz - pz)
    bx, by, bz = _unit(vx + wx, vy + wy, vz + wz)
    return 1.0 - ((nx * bx + ny * by + nz * bz) + 1.0) / 2.0


@kernel
def edge_errors(lo, hi, P, N, mask, origin, eye, verts, pixel, offset, e0, e1, subtexel, fp, out):
    """``out[i]`` for ``i`` in ``lo .. hi - 1`` (run over every edge by
    :func:`refsoft._parallel.parallel_range`): the thesis's error of edge (e0[i], e1[i]) (see
    :func:`refsoft.search.tessellate.edge_errors`), 1 where an end has no pixel or the point the error
    is taken at is not covered."""
    h, w = mask.shape
    for i in range(lo, hi):
        a = e0[i]
        b = e1[i]
        out[i] = 1.0
        if pixel[a, 0] < 0 or pixel[a, 1] < 0 or pixel[b, 0] < 0 or pixel[b, 1] < 0:
            continue
        hr = (pixel[a, 0] + pixel[b, 0]) // 2
        hc = (pixel[a, 1] + pixel[b, 1]) // 2
        if subtexel:
            mr = 0.5 * ((pixel[a, 0] + np.float64(offset[a, 0])) + (pixel[b, 0] + np.float64(offset[b, 0])))
            mc = 0.5 * ((pixel[a, 1] + np.float64(offset[a, 1])) + (pixel[b, 1] + np.float64(offset[b, 1])))
            r = int(np.floor(mr + 0.5))
            c = int(np.floor(mc + 0.5))
            if not (0 <= r < h and 0 <= c < w and mask[r, c]):
                r = hr  # beside the mirror's outline: the thesis's texel halfway
                c = hc
                if not mask[r, c]:
                    continue
            px, py, pz, nx, ny, nz = surface_values(P, N, mask, r, c, like(mr - r, fp), like(mc - c, fp), fp)
            px = np.float64(px) + origin[0]
            py = np.float64(py) + origin[1]
            pz = np.float64(pz) + origin[2]
            nx, ny, nz = np.float64(nx), np.float64(ny), np.float64(nz)
        else:
            if not mask[hr, hc]:
                continue
            px = np.float64(P[hr, hc, 0]) + origin[0]
            py = np.float64(P[hr, hc, 1]) + origin[1]
            pz = np.float64(P[hr, hc, 2]) + origin[2]
            nx, ny, nz = np.float64(N[hr, hc, 0]), np.float64(N[hr, hc, 1]), np.float64(N[hr, hc, 2])
        out[i] = thesis_error(px, py, pz, nx, ny, nz, eye[0], eye[1], eye[2], verts, a, b)


@kernel
def edge_pixel_errors(lo, hi, P, N, mask, origin, eye, verts, pixel, offset, e0, e1, fp, out):
    """``out[i]`` for ``i`` in ``lo .. hi - 1``: how far, in texels, the reflection of the midpoint
    of edge (e0[i], e1[i]) lies from the midpoint of its ends' refined reflection points (the
    straight edge's midpoint), by one Gauss-Newton step of the refinement from the texel nearest
    to the latter (the step is at most ``MAX_OFFSET`` per axis, so a larger error reads as about
    that); 2 where an end has no pixel or that texel is not covered."""
    h, w = mask.shape
    zero = like(0.0, fp)
    lim = like(MAX_OFFSET, fp)
    ex = like(eye[0] - origin[0], fp)
    ey = like(eye[1] - origin[1], fp)
    ez = like(eye[2] - origin[2], fp)
    for i in range(lo, hi):
        a = e0[i]
        b = e1[i]
        out[i] = 2.0
        if pixel[a, 0] < 0 or pixel[a, 1] < 0 or pixel[b, 0] < 0 or pixel[b, 1] < 0:
            continue
        mr = 0.5 * ((pixel[a, 0] + np.float64(offset[a, 0])) + (pixel[b, 0] + np.float64(offset[b, 0])))
        mc = 0.5 * ((pixel[a, 1] + np.float64(offset[a, 1])) + (pixel[b, 1] + np.float64(offset[b, 1])))
        r = int(np.floor(mr + 0.5))
        c = int(np.floor(mc + 0.5))
        if not (0 <= r < h and 0 <= c < w and mask[r, c]):
            continue
        vx = like(0.5 * (verts[a, 0] + verts[b, 0]) - origin[0], fp)
        vy = like(0.5 * (verts[a, 1] + verts[b, 1]) - origin[1], fp)
        vz = like(0.5 * (verts[a, 2] + verts[b, 2]) - origin[2], fp)
        t0, t1 = gauss_newton_step(P, N, mask, r, c, vx, vy, vz, ex, ey, ez, fp)
        t0 = min(max(t0, -lim), lim)
        t1 = min(max(t1, -lim), lim)
        out[i] = np.hypot((r + np.float64(t0)) - mr, (c + np.float64(t1)) - mc)


@kernel
def measured_edges(faces, pixel, flags, min_span, adaptive, culled_bit, hidden_bit, need, bad):
    """For every triangle ``i`` of ``faces`` (C, 3): ``bad[i]`` when a corner is CULLED or (when
    ``adaptive``) all three are HIDDEN; ``need[3 i + k]`` when edge k (corner k to k + 1) is to be
    measured: its ends' pixels more than ``min_span`` apart along an axis (every edge when
    ``min_span`` is 0). What :func:`refsoft.search.tessellate._triangle_errors` gathers with NumPy,
    in one pass."""
    for i in range(faces.shape[0]):
        f0 = faces[i, 0]
        f1 = faces[i, 1]
        f2 = faces[i, 2]
        b = ((flags[f0] | flags[f1] | flags[f2]) & culled_bit) != 0
        if adaptive and (flags[f0] & flags[f1] & flags[f2] & hidden_bit) != 0:
            b = True
        bad[i] = b
        for k in range(3):
            a = faces[i, k]
            c = faces[i, (k + 1) % 3]
            if min_span > 0:
                need[3 * i + k] = (abs(np.int64(pixel[a, 0]) - pixel[c, 0]) > min_span
                                   or abs(np.int64(pixel[a, 1]) - pixel[c, 1]) > min_span)
            else:
                need[3 * i + k] = True


@kernel
def split_pattern(faces, ea, eb, first, marked, mask, use_mask, pattern, slot):
    """Which edges of each face of ``faces`` (T, 3) are split: ``pattern[i]`` bit k when edge k is
    one of the split edges (``ea[j] < eb[j]``, sorted by ``ea`` then ``eb``), ``slot[i, k]`` that
    ``j``. Only faces with two corners in ``marked`` (the split edges' ends) are looked up;
    ``use_mask``: and only faces with ``mask[i]`` (the thesis's rule). ``first`` (N,) int64
    scratch: each vertex's first split edge, looked up along that vertex's run of split edges.
    :func:`refsoft.search.tessellate._split_some`'s lookup."""
    n = ea.shape[0]
    first[:] = -1
    for j in range(n - 1, -1, -1):
        first[ea[j]] = j
    for i in range(faces.shape[0]):
        pattern[i] = 0
        m0 = marked[faces[i, 0]]
        m1 = marked[faces[i, 1]]
        m2 = marked[faces[i, 2]]
        if not ((m0 and m1) or (m2 and (m0 or m1))):
            continue
        if use_mask and not mask[i]:
            continue
        p = 0
        for k in range(3):
            a = faces[i, k]
            b = faces[i, (k + 1) % 3]
            lo = min(a, b)
            hi = max(a, b)
            j = first[lo]
            if j < 0:
                continue
            while j < n and ea[j] == lo:
                if eb[j] == hi:
                    p |= 1 << k
                    slot[i, k] = j
                    break
                j += 1
        pattern[i] = p


@kernel
def write_children(faces, face_obj, pattern, slot, mids, children, n_children, start, out_faces, out_obj, out_active):
    """The children of every face (red-green, :data:`refsoft.search.tessellate._CHILDREN`), in the
    faces' order from row ``start[i]``: a face not split is copied (inactive), a split face's
    children are active (the next level's candidates)."""
    for i in range(faces.shape[0]):
        p = pattern[i]
        at = start[i]
        if p == 0:
            out_faces[at, 0] = faces[i, 0]
            out_faces[at, 1] = faces[i, 1]
            out_faces[at, 2] = faces[i, 2]
            out_obj[at] = face_obj[i]
            out_active[at] = False
            continue
        for j in range(n_children[p]):
            for k in range(3):
                s = children[p, j, k]
                out_faces[at + j, k] = faces[i, s] if s < 3 else mids[slot[i, s - 3]]
            out_obj[at + j] = face_obj[i]
            out_active[at + j] = True


@kernel
def working_faces(faces, pixel, min_span, rings, marked, keep):
    """``keep[i]`` for the faces a tessellation of ``rings`` levels can change: those with an edge
    whose ends' pixels are more than ``min_span`` apart along an axis (the only ones a level can
    split by their own error), then ``rings`` times every face sharing a vertex with a kept one
    (each level splits, besides its candidates, the faces that share an edge with them).
    ``marked``: (N,) bool scratch."""
    t = faces.shape[0]
    for i in range(t):
        keep[i] = False
        for k in range(3):
            a = faces[i, k]
            c = faces[i, (k + 1) % 3]
            if abs(np.int64(pixel[a, 0]) - pixel[c, 0]) > min_span or abs(np.int64(pixel[a, 1]) - pixel[c, 1]) > min_span:
                keep[i] = True
    for _ in range(rings):
        marked[:] = False
        for i in range(t):
            if keep[i]:
                marked[faces[i, 0]] = True
                marked[faces[i, 1]] = True
                marked[faces[i, 2]] = True
        for i in range(t):
            if marked[faces[i, 0]] or marked[faces[i, 1]] or marked[faces[i, 2]]:
                keep[i] = True


@kernel
def merge_faces(all_faces, all_obj, work, faces, face_obj, counts, out, out_obj):
    """Every face in order: face ``i`` as it was where not ``work[i]``, else the next ``counts[w]``
    rows of ``faces`` (its tessellated faces, ``w`` counting the work faces)."""
    at = 0
    j = 0
    w = 0
    for i in range(all_faces.shape[0]):
        if work[i]:
            for r in range(counts[w]):
                out[at, 0] = faces[j, 0]
                out[at, 1] = faces[j, 1]
                out[at, 2] = faces[j, 2]
                out_obj[at] = face_obj[j]
                at += 1
                j += 1
            w += 1
        else:
            out[at, 0] = all_faces[i, 0]
            out[at, 1] = all_faces[i, 1]
            out[at, 2] = all_faces[i, 2]
            out_obj[at] = all_obj[i]
            at += 1

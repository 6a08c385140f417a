"""Kernels of the exact drawing (float64): which virtual triangles can be candidates of a box's
exact acceptance, their corners, real triangles and dilated screen bounds, and the winners'
shading (:mod:`refsoft.search.exact`); the second candidates' vertices and faces
(:func:`refsoft.search.virtual.mirror_images`, :func:`~refsoft.search.virtual.with_mirror_copies`).
Their references: ``tests/search/test_exact.py`` and ``tests/search/test_copies_kernels.py`` (the
same rules in NumPy)."""

import numpy as np

from .._numba import kernel
from ..raster._rays import unit_normal
from ._several import dilated_box, dilation

#: Candidates of :func:`gather` whose bounds are computed together.
GATHER_BLOCK = 512


@kernel
def project(lo, hi, clip, width, height, xy):
    """Vertices ``lo .. hi - 1``: ``xy[i]`` the view-pixel position of clip coordinates
    ``clip[i]`` (the expression ``_several.screen_bounds`` computes per corner, once per vertex;
    meaningless where ``clip[i, 3] <= 0``, which the kernels here never read).

    Parameters
    ----------
    clip : (n, 4) float64
    width, height : float
        The view's size.
    xy : (n, 2) float64
    """
    for i in range(lo, hi):
        wv = clip[i, 3]
        xy[i, 0] = (clip[i, 0] / wv + 1.0) * 0.5 * width
        xy[i, 1] = (1.0 - clip[i, 1] / wv) * 0.5 * height


@kernel
def reaching(lo, hi, clip, xy, faces, flags, lost, r0, r1, c0, c1, pixels, fraction, band, sat, keep):
    """Triangles ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes
    only its own entry): ``keep[t]`` is False where a vertex has a flag in ``lost`` or where the
    triangle's screen bounds, widened by the acceptance's dilation (``pixels + fraction *`` its
    longest screen edge) and one pixel more, stay off the box ``r0 .. r1, c0 .. c1`` (view rows
    and columns), or, with ``band``, whose widened bounds hold no pixel of the band; True
    otherwise, and always for a triangle with a vertex at or behind the eye plane or a screen
    position that is not finite.

    Parameters
    ----------
    clip : (n, 4) float64
        The vertices' clip coordinates (column 3, ``w``, is read).
    xy : (n, 2) float64
        Their view-pixel positions (:func:`project`).
    faces : (m, 3) int64
    flags : (n,) uint8
    lost : uint8
    r0, r1, c0, c1 : float
        The box.
    pixels, fraction : float
        ``SEVERAL_DILATE_PIXELS``, ``SEVERAL_DILATE_FRACTION``.
    band : bool
        Whether ``sat`` holds the pixels drawn.
    sat : (r1 - r0 + 1, c1 - c0 + 1) int64
        The summed-area table of the pixels drawn over the box (``sat[i, j]``: those in box rows
        ``< i`` and columns ``< j``).
    keep : (m,) bool
    """
    for t in range(lo, hi):
        a, b, c = faces[t, 0], faces[t, 1], faces[t, 2]
        if (flags[a] & lost) or (flags[b] & lost) or (flags[c] & lost):
            keep[t] = False
            continue
        if not (clip[a, 3] > 0.0 and clip[b, 3] > 0.0 and clip[c, 3] > 0.0):
            keep[t] = True
            continue
        xa, ya, xb, yb, xc, yc = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[c, 0], xy[c, 1]
        edge = max(np.sqrt((xa - xb) ** 2 + (ya - yb) ** 2), np.sqrt((xb - xc) ** 2 + (yb - yc) ** 2),
                   np.sqrt((xc - xa) ** 2 + (yc - ya) ** 2))
        if not np.isfinite(edge):
            keep[t] = True
            continue
        reach = pixels + fraction * edge + 1.0
        off = (max(xa, xb, xc) + reach < c0 or min(xa, xb, xc) - reach > c1
               or max(ya, yb, yc) + reach < r0 or min(ya, yb, yc) - reach > r1)
        if band and not off:  # pixel centres at .5: rows y0 .. y1 - 1 of the box may be covered
            y0 = max(int(np.floor(min(ya, yb, yc) - reach - 0.5)), int(r0)) - int(r0)
            y1 = min(int(np.ceil(max(ya, yb, yc) + reach - 0.5)) + 1, int(r1)) - int(r0)
            x0 = max(int(np.floor(min(xa, xb, xc) - reach - 0.5)), int(c0)) - int(c0)
            x1 = min(int(np.ceil(max(xa, xb, xc) + reach - 0.5)) + 1, int(c1)) - int(c0)
            off = y0 >= y1 or x0 >= x1 or sat[y1, x1] - sat[y0, x1] - sat[y1, x0] + sat[y0, x0] == 0
        keep[t] = not off


@kernel
def gather(lo, hi, keep, faces, face_obj, points, clip, xy, r0, r1, c0, c1, pixels, fraction, corner, obj, real,
           screen, bbox, dilate, odd, W, B):
    """Candidates ``lo .. hi - 1`` (each writes only its own rows): candidate ``c`` is triangle
    ``t = keep[c]``; its corners ``corner[c] = faces[t]``, object ``obj[c] = face_obj[t]``, real
    corners ``real[c] = points[faces[t]]``, and its view-pixel positions, dilated bounds and
    dilation as ``_several.screen_bounds`` makes them from ``clip`` (the same operations in the
    same order, the positions from :func:`project`'s ``xy``): a candidate with a vertex at or
    behind the eye plane has zeros, the whole box and -1; ``odd[c]`` is set where a value is not
    finite (the caller recomputes those rows with NumPy: their bounds and dilation are left as
    they came out).

    The candidates go in blocks of ``GATHER_BLOCK``: their corners and screen positions are
    copied, the positions also into the rows of ``W`` (x0, y0, x1, y1, x2, y2, and 1 where the
    triangle reaches behind the eye), then the block's bounds are computed from them in one
    branch-free loop that vectorizes (:func:`_block_bounds`, the bounds into ``B``) and copied
    out.

    Parameters
    ----------
    keep : (C,) int64
        The rows of ``faces`` kept, ascending.
    faces : (m, 3) int64
    face_obj : (m,) int32
    points : (n, 3) float64
        The vertices' real positions.
    clip : (n, 4) float64
    xy : (n, 2) float64
    r0, r1, c0, c1 : int
        The box.
    pixels, fraction : float
        ``SEVERAL_DILATE_PIXELS``, ``SEVERAL_DILATE_FRACTION``.
    corner : (C, 3) int64
    obj : (C,) int32
    real : (C, 3, 3) float64
    screen : (C, 3, 2) float64
    bbox : (C, 4) int64
    dilate : (C,) float64
    odd : (C,) bool
    W, B : (7, GATHER_BLOCK) float64, (4, GATHER_BLOCK) int64
        Work memory (:func:`gather_work`).
    """
    for b0 in range(lo, hi, GATHER_BLOCK):
        b1 = min(b0 + GATHER_BLOCK, hi)
        for c in range(b0, b1):
            t = keep[c]
            obj[c] = face_obj[t]
            a, b, e = faces[t, 0], faces[t, 1], faces[t, 2]
            corner[c, 0], corner[c, 1], corner[c, 2] = a, b, e
            real[c, 0, 0], real[c, 0, 1], real[c, 0, 2] = points[a, 0], points[a, 1], points[a, 2]
            real[c, 1, 0], real[c, 1, 1], real[c, 1, 2] = points[b, 0], points[b, 1], points[b, 2]
            real[c, 2, 0], real[c, 2, 1], real[c, 2, 2] = points[e, 0], points[e, 1], points[e, 2]
            q = c - b0
            if not (clip[a, 3] > 0.0 and clip[b, 3] > 0.0 and clip[e, 3] > 0.0):
                x0 = y0 = x1 = y1 = x2 = y2 = 0.0
                W[6, q] = 1.0
            else:
                x0, y0, x1, y1, x2, y2 = xy[a, 0], xy[a, 1], xy[b, 0], xy[b, 1], xy[e, 0], xy[e, 1]
                W[6, q] = 0.0
            screen[c, 0, 0], screen[c, 0, 1] = x0, y0
            screen[c, 1, 0], screen[c, 1, 1] = x1, y1
            screen[c, 2, 0], screen[c, 2, 1] = x2, y2
            W[0, q], W[1, q], W[2, q], W[3, q], W[4, q], W[5, q] = x0, y0, x1, y1, x2, y2
        _block_bounds(b1 - b0, W, B, r0, r1, c0, c1, pixels, fraction, dilate[b0:b1], odd[b0:b1])
        for c in range(b0, b1):
            q = c - b0
            bbox[c, 0], bbox[c, 1], bbox[c, 2], bbox[c, 3] = B[0, q], B[1, q], B[2, q], B[3, q]


@kernel
def _block_bounds(n, W, B, r0, r1, c0, c1, pixels, fraction, dilate, odd):
    """Columns ``0 .. n - 1`` of ``W`` (:func:`gather`'s): the bounds (into ``B``), dilation and
    ``odd`` of ``_several.dilated_bounds`` (the same operations in the same order), or those of
    a candidate behind the eye, chosen by selects (no branch): a loop that vectorizes, the same
    values. (A row whose positions or dilation are not finite gets bounds from zeros: the
    caller replaces them.)"""
    for q in range(n):
        x0, y0, x1, y1, x2, y2 = W[0, q], W[1, q], W[2, q], W[3, q], W[4, q], W[5, q]
        back = W[6, q] != 0.0
        d = dilation(x0, y0, x1, y1, x2, y2, pixels, fraction)
        finite = (np.isfinite(x0) & np.isfinite(y0) & np.isfinite(x1) & np.isfinite(y1) & np.isfinite(x2)
                  & np.isfinite(y2) & np.isfinite(d))
        # no conversion of a value that is not finite to an integer: such a row's bounds from zeros
        b_0, b_1, b_2, b_3 = dilated_box(x0 if finite else 0.0, y0 if finite else 0.0, x1 if finite else 0.0,
                                         y1 if finite else 0.0, x2 if finite else 0.0, y2 if finite else 0.0,
                                         d if finite else 0.0, r0)
        B[0, q] = 0 if back else b_0
        B[1, q] = r1 - r0 if back else b_1
        B[2, q] = c0 if back else b_2
        B[3, q] = c1 if back else b_3
        dilate[q] = -1.0 if back else d
        odd[q] = not (finite or back)


def gather_work():
    """The work memory of one part of :func:`gather` (made by the caller, so that the kernel
    allocates nothing)."""
    return np.empty((7, GATHER_BLOCK)), np.empty((4, GATHER_BLOCK), np.int64)


@kernel
def shade_accepted(lo, hi, best_c, best_uv, corner, normals, cand_object, table, light, ambient, diffuse, colour, rid):
    """Box rows ``lo .. hi - 1`` (run by :func:`refsoft._parallel.parallel_range`; each writes only
    its own rows): at each pixel with a winning candidate ``c = best_c[r, j] >= 0`` the normal
    interpolated at its barycentrics ``best_uv[r, j]`` from its corners' normals, renormalised
    (zero stays zero), shaded as :func:`refsoft.raster.shade` does (float32), and its object.
    The same operations in the same order as :func:`refsoft.search.acceptance.shade_winners`
    (its reference), without its temporaries.

    Parameters
    ----------
    best_c : (h, w) int64
    best_uv : (h, w, 2) float64
    corner : (C, 3) int64
        Each candidate's rows of ``normals``.
    normals : (n, 3) float64
    cand_object : (C,) int32
    table : (K + 1, 3) float32
        Object colours by id.
    light : (3,) float32
    ambient, diffuse : float32
    colour : (h, w, 3) float32
        Zeros on entry; written where covered.
    rid : (h, w) int32
        Zeros on entry; written where covered.
    """
    for r in range(lo, hi):
        for j in range(best_c.shape[1]):
            c = best_c[r, j]
            if c < 0:
                continue
            u, v = best_uv[r, j, 0], best_uv[r, j, 1]
            nx, ny, nz = unit_normal(normals, corner[c, 0], corner[c, 1], corner[c, 2], (1.0 - u) - v, u, v)
            lam = abs((np.float32(nx) * light[0] + np.float32(ny) * light[1]) + np.float32(nz) * light[2])
            k = ambient + diffuse * lam
            obj = cand_object[c]
            colour[r, j, 0] = table[obj, 0] * k
            colour[r, j, 1] = table[obj, 1] * k
            colour[r, j, 2] = table[obj, 2] * k
            rid[r, j] = obj


@kernel
def touching(lo, hi, faces, twin, n, edge, copied, near):
    """Faces ``lo .. hi - 1`` (each writes only its own entries): ``copied[t]`` whether a corner
    of face ``t`` has a second image (``twin[i] >= n``), ``near[t]`` whether a corner is marked in
    ``edge``.

    Parameters
    ----------
    faces : (m, 3) int64
    twin : (n,) int64
        Each vertex's row in the copies' vertices: itself, or ``n`` and more for a second image.
    n : int
    edge : (n,) bool
    copied, near : (m,) bool
    """
    for t in range(lo, hi):
        a, b, c = faces[t, 0], faces[t, 1], faces[t, 2]
        copied[t] = twin[a] >= n or twin[b] >= n or twin[c] >= n
        near[t] = edge[a] or edge[b] or edge[c]


@kernel
def interleave(faces, face_obj, copied, twin, out_faces, out_obj):
    """Every face and its object, each one ``copied`` followed by its copy (its corners' ``twin``
    rows, the same object), into the first ``m + copied.sum()`` rows of ``out_faces`` and
    ``out_obj`` (one pass on one thread: a row's place depends on the faces before it).

    Parameters
    ----------
    faces : (m, 3) int64
    face_obj : (m,) int
    copied : (m,) bool
    twin : (n,) int64
    out_faces : (M, 3) int64
    out_obj : (M,) int, ``face_obj``'s type
    """
    j = 0
    for t in range(faces.shape[0]):
        a, b, c = faces[t, 0], faces[t, 1], faces[t, 2]
        out_faces[j, 0], out_faces[j, 1], out_faces[j, 2] = a, b, c
        out_obj[j] = face_obj[t]
        j += 1
        if copied[t]:
            out_faces[j, 0], out_faces[j, 1], out_faces[j, 2] = twin[a], twin[b], twin[c]
            out_obj[j] = face_obj[t]
            j += 1


@kernel
def mirror_marks(lo, hi, vertices, origin, point, normal, flags, grazing, margin, border, hidden, culled, twin, edge):
    """Vertices ``lo .. hi - 1`` (each writes only its own entries), with ``d = (vertex - origin)
    - point``, ``dn = d . normal`` and ``size = |d|`` (sums left to right, float64): ``twin[i]``
    whether the vertex is visible (neither ``hidden`` nor ``culled``) and ``border`` or seen at a
    grazing angle (``dn < grazing * size``); ``edge[i]`` whether it is not ``culled``, ``hidden``
    and ``border``, by less than the margin (``-dn < margin * size``). As
    :func:`refsoft.search.virtual.mirror_images` states them.

    Parameters
    ----------
    vertices : (n, 3) float64
    origin : (3,) float64
        The G-buffer's origin.
    point, normal : (n, 3) float32 or float64
        Each vertex's reflection point (relative to ``origin``) and normal there.
    flags : (n,) uint8
    grazing, margin : float
        ``EXACT_TWIN_GRAZING``, ``EXACT_TWIN_HIDDEN``.
    border, hidden, culled : uint8
        The flags.
    twin, edge : (n,) bool
    """
    for i in range(lo, hi):
        d0 = (vertices[i, 0] - origin[0]) - np.float64(point[i, 0])
        d1 = (vertices[i, 1] - origin[1]) - np.float64(point[i, 1])
        d2 = (vertices[i, 2] - origin[2]) - np.float64(point[i, 2])
        dn = (d0 * np.float64(normal[i, 0]) + d1 * np.float64(normal[i, 1])) + d2 * np.float64(normal[i, 2])
        size = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
        f = flags[i]
        twin[i] = (f & (hidden | culled)) == 0 and ((f & border) != 0 or dn < grazing * size)
        edge[i] = (f & culled) == 0 and (f & hidden) != 0 and (f & border) != 0 and -dn < margin * size


@kernel
def far_apart(lo, hi, a, b, half_width, half_height, pixels, far):
    """Rows ``lo .. hi - 1`` (each writes only its own entry): ``far[i]`` whether the points of clip
    coordinates ``a[i]`` and ``b[i]`` are both in front of the eye (``w > 0``) and more than
    ``pixels`` view pixels apart in x or in y.

    Parameters
    ----------
    a, b : (k, 4) float64
    half_width, half_height : float
        Half the view's size.
    pixels : float
    far : (k,) bool
    """
    for i in range(lo, hi):
        gx = abs(a[i, 0] / a[i, 3] - b[i, 0] / b[i, 3]) * half_width
        gy = abs(a[i, 1] / a[i, 3] - b[i, 1] / b[i, 3]) * half_height
        far[i] = a[i, 3] > 0.0 and b[i, 3] > 0.0 and (gx > pixels or gy > pixels)

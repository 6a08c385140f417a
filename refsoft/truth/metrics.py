"""Error metrics of a render against the ray-traced truth (spec section 6), all in one place.

Per vertex (where an analytic truth exists): ``1 - score``, the pixel distance between the
found reflection pixel and the projection of the exact reflection point, and the distance
between the virtual vertex and the exact one. Per image: the share of reflector pixels whose
``reflected_id`` differs from the truth, colour error (mean and 99th percentile), isolated
one-pixel defects (specks of wrong colour, holes showing the wrong object), and FLIP (information
only, when the ``flip-evaluator`` package is installed).
"""

from __future__ import annotations

import numpy as np

from .. import keys, linalg
from ..constants import RIM_PIXELS, SPECK_LEVELS, SPECK_NEIGHBOUR_LEVELS
from ..errors import RefsoftError


def score_error(score) -> np.ndarray:
    """``1 - s(R)`` per vertex (float64; 0 at an exact reflection point)."""
    return 1.0 - np.asarray(score, dtype=np.float64)


def window_to_pixel(points, view_proj, shape) -> np.ndarray:
    """Continuous (row, col) pixel coordinates of world points (pixel centres at integers).

    Parameters
    ----------
    points : array_like, shape (N, 3)
    view_proj : array_like, shape (4, 4)
        World-to-clip matrix of the buffer.
    shape : (int, int)
        Buffer (height, width).

    Returns
    -------
    ndarray, shape (N, 2), float64
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    clip = linalg.homogeneous(p, view_proj)
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = clip[:, :2] / clip[:, 3:]
    h, w = shape
    col = (ndc[:, 0] + 1.0) * 0.5 * w - 0.5
    row = h - (ndc[:, 1] + 1.0) * 0.5 * h - 0.5
    return np.c_[row, col]


def pixel_distance(pixel, exact_points, view_proj, shape) -> np.ndarray:
    """Distance in pixels between each found reflection pixel's centre and the projection of
    the exact reflection point (NaN where there is no exact point). Shape (N,), float64."""
    pix = np.asarray(pixel, dtype=np.float64).reshape(-1, 2)
    ref = window_to_pixel(exact_points, view_proj, shape)
    if len(pix) != len(ref):
        raise RefsoftError(f"{len(pix)} reflection pixels but {len(ref)} exact points")
    return np.hypot(pix[:, 0] - ref[:, 0], pix[:, 1] - ref[:, 1])


def virtual_distance(virtual, exact_virtual) -> np.ndarray:
    """Euclidean distance between virtual vertices and the exact ones. Shape (N,), float64."""
    a = np.asarray(virtual, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(exact_virtual, dtype=np.float64).reshape(-1, 3)
    if a.shape != b.shape:
        raise RefsoftError(f"virtual vertices {a.shape} and exact ones {b.shape} differ in shape")
    return np.linalg.norm(a - b, axis=1)


def _check_ids(render_id, truth_id):
    a = np.asarray(render_id)
    b = np.asarray(truth_id)
    if a.shape != b.shape:
        raise RefsoftError(f"reflected_id shapes differ: render {a.shape}, truth {b.shape}")
    return a, b


def reflector_pixels(truth_id) -> np.ndarray:
    """Pixels where a reflector is visible (``reflected_id >= 0``). (H, W) bool."""
    return np.asarray(truth_id) >= 0


def disagreement(render_id, truth_id, where=None) -> float:
    """Share of reflector pixels (or of ``where & reflector pixels``) whose ``reflected_id``
    differs from the truth; 0.0 when there are none."""
    a, b = _check_ids(render_id, truth_id)
    m = reflector_pixels(b)
    if where is not None:
        m &= where
    n = int(m.sum())
    return float(np.count_nonzero(a[m] != b[m]) / n) if n else 0.0


def rim(mask, width: int = RIM_PIXELS) -> np.ndarray:
    """Pixels of ``mask`` within ``width`` 8-neighbour steps of a pixel outside it (or of the
    image border). (H, W) bool."""
    mask = np.asarray(mask, dtype=bool)
    inner = mask.copy()
    for _ in range(width):
        p = np.pad(inner, 1, constant_values=False)
        shrunk = inner.copy()
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                shrunk &= p[1 + dr:1 + dr + mask.shape[0], 1 + dc:1 + dc + mask.shape[1]]
        inner = shrunk
    return mask & ~inner


def interior_disagreement(render_id, truth_id, object_id, width: int = RIM_PIXELS) -> float:
    """:func:`disagreement` leaving out each reflector's rim (``width`` pixels of its stencil's edge)."""
    a, b = _check_ids(render_id, truth_id)
    object_id = np.asarray(object_id)
    edge = np.zeros(b.shape, dtype=bool)
    for k in np.unique(object_id[b >= 0]):
        edge |= rim(object_id == k, width)
    return disagreement(a, b, where=~edge)


def color_error(render_image, truth_image, where=None) -> dict:
    """Per-pixel colour error: mean absolute channel difference in [0, 1] units.

    Returns ``{"mean": ..., "p99": ..., "max": ...}`` over the pixels of ``where`` (default all).
    """
    a = np.asarray(render_image, dtype=np.float64)
    b = np.asarray(truth_image, dtype=np.float64)
    if a.shape != b.shape:
        raise RefsoftError(f"image shapes differ: render {a.shape}, truth {b.shape}")
    scale = 255.0 if np.asarray(render_image).dtype == np.uint8 else 1.0
    err = np.abs(a - b).mean(axis=-1) / scale
    e = err[where] if where is not None else err.ravel()
    if e.size == 0:
        return {"mean": 0.0, "p99": 0.0, "max": 0.0}
    return {"mean": float(e.mean()), "p99": float(np.percentile(e, 99)), "max": float(e.max())}


def isolated(bad, good) -> np.ndarray:
    """Pixels of ``bad`` whose two neighbours along their row (left and right) or along their
    column (above and below) are both ``good``; a pixel on the image's border has no such pair in
    that direction. (H, W) bool."""
    bad = np.asarray(bad, dtype=bool)
    good = np.asarray(good, dtype=bool)
    row = np.zeros_like(bad)
    col = np.zeros_like(bad)
    row[:, 1:-1] = good[:, :-2] & good[:, 2:]
    col[1:-1, :] = good[:-2, :] & good[2:, :]
    return bad & (row | col)


def level_difference(render_image, truth_image) -> np.ndarray:
    """The largest channel difference of two 8-bit images, in levels. (H, W) int16."""
    a = np.asarray(render_image)
    b = np.asarray(truth_image)
    if a.shape != b.shape:
        raise RefsoftError(f"image shapes differ: render {a.shape}, truth {b.shape}")
    if a.dtype != np.uint8 or b.dtype != np.uint8 or a.ndim != 3:
        raise RefsoftError(f"specks need two (H, W, C) uint8 images, got {a.dtype}{list(a.shape)} and "
                           f"{b.dtype}{list(b.shape)}")
    return np.abs(a.astype(np.int16) - b.astype(np.int16)).max(axis=-1)


def specks(render_image, truth_image, truth_id) -> np.ndarray:
    """Mirror pixels (``truth_id >= 0``) more than ``SPECK_LEVELS`` off the truth in some channel
    whose two neighbours along a row or along a column are mirror pixels within
    ``SPECK_NEIGHBOUR_LEVELS`` of it: one-pixel defects in an otherwise right reflection.

    Parameters
    ----------
    render_image, truth_image : ndarray, shape (H, W, 3), uint8
    truth_id : ndarray, shape (H, W), int32
        The truth's ``reflected_id`` (-1 off the mirrors).

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    mirror = reflector_pixels(truth_id)
    d = level_difference(render_image, truth_image)
    if d.shape != mirror.shape:
        raise RefsoftError(f"image {d.shape} and reflected_id {mirror.shape} differ in size")
    return isolated(mirror & (d > SPECK_LEVELS), mirror & (d <= SPECK_NEIGHBOUR_LEVELS))


def holes(render_id, truth_id) -> np.ndarray:
    """Mirror pixels showing the wrong object (``reflected_id`` not the truth's) whose two
    neighbours along a row or along a column are mirror pixels showing the right one.

    Parameters
    ----------
    render_id, truth_id : ndarray, shape (H, W), int32
        ``reflected_id`` of the render and of the truth (-1 off the mirrors).

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    a, b = _check_ids(render_id, truth_id)
    mirror = reflector_pixels(b)
    return isolated(mirror & (a != b), mirror & (a == b))


def defect_counts(render_arrays, truth_arrays) -> dict:
    """Specks and holes of one frame: ``{"specks", "speck_fraction", "holes", "hole_fraction"}``,
    fractions of the mirror pixels (0.0 where there are none)."""
    tid = truth_arrays["reflected_id"]
    n = int(reflector_pixels(tid).sum())
    s = int(specks(render_arrays["image"], truth_arrays["image"], tid).sum())
    h = int(holes(render_arrays["reflected_id"], tid).sum())
    return {"specks": s, "speck_fraction": s / n if n else 0.0, "holes": h, "hole_fraction": h / n if n else 0.0}


def flip_mean(render_image, truth_image):
    """Mean FLIP error (information only) when ``flip-evaluator`` is installed, else None."""
    try:
        import flip_evaluator as flip
    except ImportError:
        return None
    a = np.asarray(render_image, dtype=np.float32) / 255.0
    b = np.asarray(truth_image, dtype=np.float32) / 255.0
    _, mean, _ = flip.evaluate(b, a, "LDR")
    return float(mean)


def hit_distance(hit, truth_hit, render_id, truth_id) -> dict:
    """World distance between a per-pixel method's hit and the truth's where both show the
    same object: ``{"pixels", "mean", "median", "max"}`` (zeros where there is none)."""
    same = (np.asarray(render_id) == np.asarray(truth_id)) & (np.asarray(truth_id) > 0)
    d = np.linalg.norm(np.asarray(hit, np.float64)[same] - np.asarray(truth_hit, np.float64)[same], axis=1)
    if not len(d):
        return {"pixels": 0, "mean": 0.0, "median": 0.0, "max": 0.0}
    return {"pixels": int(len(d)), "mean": float(d.mean()), "median": float(np.median(d)), "max": float(d.max())}


def bounce_levels(render_arrays, truth_arrays):
    """Per number of reflections the truth's mirror paths take (its ``bounce_depth``), the
    reflector pixels and the share of them whose ``reflected_id`` differs, and, when the render
    has a ``bounce_depth`` too, the share where the two depths differ: ``{"pixels": {j: n},
    "disagreement": {j: share}, "depth_mismatch": share or None}`` (keys as strings); None when
    the truth takes one reflection everywhere and the render records no depth."""
    tid = np.asarray(truth_arrays["reflected_id"])
    refl = reflector_pixels(tid)
    tdepth = truth_arrays.get(keys.BOUNCE_DEPTH)
    rdepth = render_arrays.get(keys.BOUNCE_DEPTH)
    if tdepth is None or not refl.any():
        return None
    tdepth = np.asarray(tdepth)
    if rdepth is None and tdepth[refl].max() <= 1:
        return None
    rid = np.asarray(render_arrays["reflected_id"])
    out = {"pixels": {}, "disagreement": {}, "depth_mismatch": None}
    for j in np.unique(tdepth[refl]):
        m = refl & (tdepth == j)
        out["pixels"][str(int(j))] = int(m.sum())
        out["disagreement"][str(int(j))] = float(np.count_nonzero(rid[m] != tid[m]) / m.sum())
    if rdepth is not None:
        out["depth_mismatch"] = float(np.count_nonzero(np.asarray(rdepth)[refl] != tdepth[refl]) / refl.sum())
    return out


def frame_metrics(render_arrays, truth_arrays) -> dict:
    """Every metric of one frame from the spec section 7 arrays of a render and its truth.

    Per-vertex metrics are given per reflector ``k`` when the truth holds that reflector's exact
    reflection points (spherical reflectors) and the render its search outputs.
    """
    for name, arr in (("render", render_arrays), ("truth", truth_arrays)):
        missing = [k for k in ("image", "object_id", "reflected_id") if k not in arr]
        if missing:
            raise RefsoftError(f"{name} frame lacks {', '.join(missing)}")
    rid, tid = render_arrays["reflected_id"], truth_arrays["reflected_id"]
    refl = reflector_pixels(tid)
    out = {
        "reflector_pixels": int(refl.sum()),
        "reflected_id_disagreement": disagreement(rid, tid),
        "interior_disagreement": interior_disagreement(rid, tid, truth_arrays["object_id"]),
        "color_error": color_error(render_arrays["image"], truth_arrays["image"], refl),
        "object_id_mismatch": int(np.count_nonzero(np.asarray(render_arrays["object_id"])
                                                   != np.asarray(truth_arrays["object_id"]))),
    }
    out.update(defect_counts(render_arrays, truth_arrays))
    levels = bounce_levels(render_arrays, truth_arrays)
    if levels is not None:
        out["levels"] = levels
    flip = flip_mean(render_arrays["image"], truth_arrays["image"])
    if flip is not None:
        out["flip_mean"] = flip
    if "ldt_hit_position" in render_arrays and keys.REFLECTED_HIT in truth_arrays:
        out["hit_distance"] = hit_distance(render_arrays["ldt_hit_position"], truth_arrays[keys.REFLECTED_HIT], rid, tid)
    vertices = {}
    for k in keys.reflectors(truth_arrays, keys.EXACT_REFLECTION_POINT):
        key = keys.EXACT_REFLECTION_POINT(k)
        if keys.REFLECTION_PIXEL(k) not in render_arrays:
            continue
        exact = np.asarray(truth_arrays[key])
        flags = np.asarray(render_arrays[keys.FLAGS(k)])
        ok = np.all(np.isfinite(exact), axis=1) & ((flags & 1) == 0)  # visible (not HIDDEN) vertices
        shape = np.asarray(render_arrays[keys.GBUFFER_MASK(k)]).shape
        dist = pixel_distance(render_arrays[keys.REFLECTION_PIXEL(k)], exact, render_arrays[keys.GBUFFER_VIEW_PROJ(k)],
                              shape)[ok]
        vdist = virtual_distance(render_arrays[keys.VIRTUAL_VERTEX(k)], truth_arrays[keys.EXACT_VIRTUAL_VERTEX(k)])[ok]
        entry = {"vertices": int(ok.sum())}
        if len(dist):
            entry.update(pixel_distance_mean=float(dist.mean()), pixel_distance_max=float(dist.max()),
                         virtual_distance_mean=float(vdist.mean()), virtual_distance_max=float(vdist.max()))
        if keys.SCORE(k) in render_arrays and len(dist):
            se = score_error(render_arrays[keys.SCORE(k)])[ok]
            entry.update(score_error_mean=float(se.mean()), score_error_max=float(se.max()))
        vertices[str(k)] = entry
    if vertices:
        out["vertices"] = vertices
    return out

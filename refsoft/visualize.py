"""Arrays to pictures: G-buffer maps as colours (used by the CLI and the docs' figures)."""

from __future__ import annotations

import numpy as np

from .raster import to_uint8


def position_colors(position, mask) -> np.ndarray:
    """Positions as colours: each axis scaled to [0, 1] over the covered pixels. (H, W, 3) uint8."""
    out = np.zeros(position.shape, dtype=np.float64)
    if mask.any():
        p = position[mask].astype(np.float64)
        lo, hi = p.min(axis=0), p.max(axis=0)
        out[mask] = (p - lo) / np.where(hi > lo, hi - lo, 1.0)
    return to_uint8(out)


def normal_colors(normal, mask) -> np.ndarray:
    """Normals as colours ``0.5 n + 0.5``; black where not covered. (H, W, 3) uint8."""
    out = np.where(mask[..., None], 0.5 * normal.astype(np.float64) + 0.5, 0.0)
    return to_uint8(out)


def side_by_side(*images, gap: int = 4) -> np.ndarray:
    """Images of equal height joined left to right with a white gap. (H, sum W, 3) uint8."""
    h = max(im.shape[0] for im in images)
    parts = []
    for i, im in enumerate(images):
        im = im if im.ndim == 3 else np.repeat(im[..., None], 3, axis=2)
        pad = np.zeros((h, im.shape[1], 3), dtype=np.uint8)
        pad[: im.shape[0]] = im
        parts.append(pad)
        if i < len(images) - 1:
            parts.append(np.full((h, gap, 3), 255, dtype=np.uint8))
    return np.concatenate(parts, axis=1)


def agreement_map(render_id, truth_id, image) -> np.ndarray:
    """Reflector pixels green where ``reflected_id`` agrees with the truth, red where not; the
    rest of ``image`` dimmed to grey. (H, W, 3) uint8."""
    grey = np.asarray(image, dtype=np.float64).mean(axis=-1, keepdims=True) / 255.0
    out = np.repeat(0.35 * grey, 3, axis=-1)
    refl = np.asarray(truth_id) >= 0
    agree = refl & (np.asarray(render_id) == np.asarray(truth_id))
    out[agree] = (0.1, 0.75, 0.2)
    out[refl & ~agree] = (0.9, 0.1, 0.1)
    return to_uint8(out)


def difference_image(a, b, gain: float = 4.0) -> np.ndarray:
    """``gain * |a - b|`` per channel, clipped: a magnified difference of two uint8 images."""
    d = np.abs(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) * gain / 255.0
    return to_uint8(d)

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

"""Every reflection point of every vertex on one reflector (spec section 4.8).

The papers' walk stops at one optimum; on a mirror that is not convex a vertex can have several
reflection points (a concave sphere: up to four) or none. :class:`Images` holds all of them per
vertex, in compressed rows: vertex ``i``'s images are ``offset[i]:offset[i + 1]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Flag bit (spec section 4.7): the vertex has more than one reflection point on this reflector.
SEVERAL = 32


@dataclass(frozen=True, eq=False)
class Images:
    """Every image of every vertex on one reflector.

    Attributes
    ----------
    offset : ndarray, shape (N + 1,), int64
        Vertex ``i``'s images are rows ``offset[i]:offset[i + 1]`` of the per-image arrays.
    pixel : ndarray, shape (M, 2), int32
        Reflection pixel (row, col) of each image in the G-buffer.
    virtual : ndarray, shape (M, 3), float64
        Virtual vertex of each image, world space (mirror of the vertex across the tangent plane
        at its reflection point, spec section 4.6).
    sheet : ndarray, shape (M,), int32
        Sheet of each image (spec section 4.8: a continuous piece of the mapping); -1 until the
        sheets are made.
    """

    offset: np.ndarray
    pixel: np.ndarray
    virtual: np.ndarray
    sheet: np.ndarray

    @property
    def count(self) -> np.ndarray:
        """Number of images per vertex, shape (N,), int32."""
        return np.diff(self.offset).astype(np.int32)

    @property
    def vertex(self) -> np.ndarray:
        """Vertex index of each image, shape (M,), int32."""
        return np.repeat(np.arange(len(self.offset) - 1, dtype=np.int32), self.count)

    def __len__(self) -> int:
        return len(self.offset) - 1

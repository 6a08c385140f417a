"""The profiles of ``refsoft check`` (spec section 8; the derivations in ``docs/precision.md``).

- ``default``: the exact rules, which a port writing refsoft's arithmetic out meets.
- ``gpu``: for a port that uses its GPU's own attribute interpolation, depth evaluation and
  built-in ``normalize`` / ``dot``. Each stage is judged on its own inputs, with tolerances
  derived from what that stage's GPU arithmetic may do differently:

  * G-buffer (coverage, positions, normals, depth ties): a GPU interpolates from its own
    float32 vertex positions, not refsoft's snapped ones; that moves the sample relative to the
    triangle by up to :data:`~refsoft.constants.GPU_SUBPIXEL_PX` along each axis, so a value
    may differ by that times the rate at which it changes across the screen
    (:func:`fragments`), and an edge may pass up to ``GPU_EDGE_AMBIGUITY_PX`` away;
  * search (reflection pixels, scores, iterations, flags), virtual vertices and image: against
    the oracle run on the candidate's own G-buffer as saved, its previous frame's pixels as the
    coherent starts (:mod:`refsoft.conformance.stages`), the rounding of built-in ``normalize``
    and ``dot`` bounded by ``GPU_TIE_K * TIE_EPS * (1 + 1/|U + B|)`` per pair of scores (half
    that per score), plus what saving positions as world-space float32 may change;
  * images: the loose rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import constants


@dataclass(frozen=True)
class Profile:
    """One profile's tolerances.

    Attributes
    ----------
    name : str
    edge_px : float
        Coverage differences whose pixel centre lies within this distance (pixels) of an edge
        are ambiguous; the same distance finds the triangles a fragment may come from instead.
    subpixel_px : float
        G-buffer values may also differ by this many pixels times their screen-space rate (0:
        only the float rule).
    tie_k : float
        ``K`` of the reflection pixels' tie bound ``K * TIE_EPS * (1 + 1/|U + B|)``.
    score_k : float
        Scores may also differ by ``score_k * TIE_EPS * (1 + 1/|U + B|)`` (0: only the float
        rule): one score's share of the tie bound.
    own_gbuffer : bool
        Judge the search and the virtual vertices against the oracle run on the candidate's
        own G-buffer (when it wrote one that differs from the golden one).
    loose_images : bool
        Images by the loose rule.
    """

    name: str
    edge_px: float
    subpixel_px: float
    tie_k: float
    score_k: float
    own_gbuffer: bool
    loose_images: bool

    def depth_tie(self, margin, slopes=0.0):
        """Where a G-buffer pixel's depth margin is a tie: ``DEPTH_TIE_K * TIE_EPS``, plus
        ``subpixel_px`` times the two fragments' depth slopes (window depth per pixel, summed)."""
        return margin <= constants.DEPTH_TIE_K * constants.TIE_EPS + self.subpixel_px * slopes


PROFILES = {
    "default": Profile("default", constants.EDGE_AMBIGUITY_PX, 0.0, constants.TIE_K, 0.0, False, False),
    "gpu": Profile("gpu", constants.GPU_EDGE_AMBIGUITY_PX, constants.GPU_SUBPIXEL_PX, constants.GPU_TIE_K,
                   constants.GPU_TIE_K / 2, True, True),
}


def profile(name) -> Profile:
    """The profile named ``name`` (a :class:`Profile` is returned as it is)."""
    from ..errors import RefsoftError

    if isinstance(name, Profile):
        return name
    if name not in PROFILES:
        raise RefsoftError(f"unknown profile {name!r} (profiles: {', '.join(PROFILES)})")
    return PROFILES[name]


@dataclass(frozen=True, eq=False)
class Fragment:
    """Triangles' attributes at pixel centres, float64, exact (unsnapped) perspective-correct
    interpolation, and how fast they change across the screen (see :func:`fragments`).

    Attributes
    ----------
    position : ndarray, shape (n, 3)
        World-space position.
    normal : ndarray, shape (n, 3)
        Interpolated normal, unit length (zero where it interpolates to zero).
    depth : ndarray, shape (n,)
        Window depth ``0.5 * z_ndc + 0.5``.
    position_rate : ndarray, shape (n,)
        ``|dP/dx| + |dP/dy|``, world units per pixel.
    normal_rate : ndarray, shape (n,)
        The same of the unit normal's direction, radians per pixel.
    depth_rate : ndarray, shape (n,)
        ``|dz/dx| + |dz/dy|`` of the window depth, per pixel.
    """

    position: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    position_rate: np.ndarray
    normal_rate: np.ndarray
    depth_rate: np.ndarray


def fragments(mesh, view_proj, width: int, height: int, pixels, triangles, offset=(0.0, 0.0)) -> Fragment:
    """Triangle ``triangles[i]`` of ``mesh`` at the centre of pixel ``pixels[i]`` (row, col),
    moved by ``offset`` (x, y window pixels), as a GPU interpolates it from unsnapped vertices.

    Homogeneous barycentrics: with the clip vertices' ``c_i = (x_i, y_i, w_i)`` and the pixel's
    NDC point ``q = (X, Y, 1)``, ``a_i = (c_j x c_k) . q`` (``j, k`` the other two vertices) and
    ``b_i = a_i / (a_0 + a_1 + a_2)``: the perspective-correct weights, valid for any ``w``. Their
    derivatives along window x and y (``dX/dx = 2 / width``, ``dY/dy = 2 / height``) give the
    rates. The point lies outside the triangle when a weight is negative (a fragment extrapolated
    past its edge).

    Parameters
    ----------
    mesh : Mesh
        World-space mesh.
    view_proj : array_like, shape (4, 4), float64
    width, height : int
    pixels : array_like, shape (n, 2), int
    triangles : array_like, shape (n,), int
    offset : (float, float)

    Returns
    -------
    Fragment
    """
    pixels = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1)
    f = mesh.faces[tri]
    clip = np.c_[mesh.vertices, np.ones(len(mesh.vertices))] @ np.asarray(view_proj, dtype=np.float64).T
    c = clip[f]  # (n, 3, 4)
    cxyw = c[..., [0, 1, 3]]
    X = (pixels[:, 1] + 0.5 + offset[0]) * (2.0 / width) - 1.0
    Y = (height - pixels[:, 0] - 0.5 + offset[1]) * (2.0 / height) - 1.0
    kk = np.stack([np.cross(cxyw[:, (i + 1) % 3], cxyw[:, (i + 2) % 3]) for i in range(3)], axis=1)  # (n, 3, 3)
    a = kk[..., 0] * X[:, None] + kk[..., 1] * Y[:, None] + kk[..., 2]
    s = a.sum(axis=1)
    b = a / s[:, None]
    db = [(kk[..., axis] * s[:, None] - a * kk[..., axis].sum(axis=1)[:, None]) / (s * s)[:, None] * scale
          for axis, scale in ((0, 2.0 / width), (1, 2.0 / height))]
    P = mesh.vertices[f]
    N = mesh.normals[f]
    pos = np.einsum("ni,nij->nj", b, P)
    pos_rate = sum(np.linalg.norm(np.einsum("ni,nij->nj", d, P), axis=1) for d in db)
    n = np.einsum("ni,nij->nj", b, N)
    length = np.linalg.norm(n, axis=1)
    unit = np.divide(n, length[:, None], out=np.zeros_like(n), where=length[:, None] > 0)
    n_rate = np.zeros(len(n))
    for d in db:
        jn = np.einsum("ni,nij->nj", d, N)
        tangential = jn - unit * np.einsum("ij,ij->i", jn, unit)[:, None]
        n_rate += np.divide(np.linalg.norm(tangential, axis=1), length, out=np.zeros(len(n)), where=length > 0)
    zc, wc = np.einsum("ni,ni->n", b, c[..., 2]), np.einsum("ni,ni->n", b, c[..., 3])
    depth = 0.5 * zc / wc + 0.5
    z_rate = sum(np.abs(0.5 * (np.einsum("ni,ni->n", d, c[..., 2]) * wc - zc * np.einsum("ni,ni->n", d, c[..., 3]))
                        / (wc * wc)) for d in db)
    return Fragment(pos, unit, depth, pos_rate, n_rate, z_rate)


def edge_triangles(mesh, view_proj, width: int, height: int, pixels, distance: float, max_pairs: int = 20_000_000):
    """The triangles with an edge within ``distance`` pixels of each pixel's centre (unsnapped
    float64 window coordinates, triangles with every vertex in front of the eye).

    Returns ``(index, triangle)``: pairs of an index into ``pixels`` and a triangle. At most
    ``max_pairs`` pixel-edge distances are computed: beyond that only the first pixels are
    searched (those are the ones a report names)."""
    pixels = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    clip = np.c_[mesh.vertices, np.ones(len(mesh.vertices))] @ np.asarray(view_proj, dtype=np.float64).T
    front = clip[:, 3] > 0
    faces = np.flatnonzero(np.all(front[mesh.faces], axis=1))
    win = np.zeros((len(clip), 2))
    win[front] = np.c_[(clip[front, 0] / clip[front, 3] + 1) * 0.5 * width,
                       (clip[front, 1] / clip[front, 3] + 1) * 0.5 * height]
    f = mesh.faces[faces]
    a = np.concatenate([win[f[:, 0]], win[f[:, 1]], win[f[:, 2]]])
    e = np.concatenate([win[f[:, 1]], win[f[:, 2]], win[f[:, 0]]]) - a
    owner = np.tile(faces, 3)
    ee = np.maximum(np.einsum("ij,ij->i", e, e), 1e-300)
    n_pix = min(len(pixels), max(1, max_pairs // max(len(a), 1)))
    out_i, out_t = [], []
    for i in range(n_pix):
        r, c = pixels[i]
        p = np.array([c + 0.5, height - r - 0.5])
        t = np.clip(np.einsum("ij,ij->i", p - a, e) / ee, 0.0, 1.0)
        near = np.linalg.norm(a + t[:, None] * e - p, axis=1) <= distance
        tris = np.unique(owner[near])
        out_i.append(np.full(len(tris), i))
        out_t.append(tris)
    if not out_i:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(out_i), np.concatenate(out_t)

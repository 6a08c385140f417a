"""The convex skip (spec section 4.8): whether a reflector can give a vertex two reflection points.

:func:`several_possible` is False for a mesh that bounds a convex body; the vertex search then
keeps the papers' one point per vertex and enumerates nothing.

Theorem. Let ``K`` be a convex body, ``O`` (the eye) a point outside it, and ``R`` a point of
its boundary with an outward normal ``N`` of a supporting plane at ``R`` (the body lies in
``dot(x - R, N) <= 0``). If ``R`` is a reflection point of ``V`` (``N`` parallel to ``u + v``,
``u = normalize(O - R)``, ``v = normalize(V - R)``, ``u + v != 0``) with ``O`` and ``V`` in front
of the plane, then ``R`` is the unique minimiser over ``K`` of ``f(x) = |x - O| + |x - V|``.
Hence ``V`` has at most one reflection point on ``K``.

Proof. The level set ``f = f(R)`` is an ellipsoid with foci ``O`` and ``V``; its outward normal
at ``R`` is ``-grad f(R) / |grad f(R)| = (u + v) / |u + v| = N`` up to the sign that puts its
inside, which holds ``O`` and ``V``, in front of the plane. So the tangent plane at ``R`` is the
ellipsoid's, and it separates the open ellipsoid ``{f < f(R)}`` (in front, strictly convex) from
``K`` (behind): no point of ``K`` has ``f < f(R)``, and ``R`` minimises ``f`` over ``K``. ``f``
is convex, so its minimisers over ``K`` form a convex set; ``f`` is constant on a segment
between two of them only when both distances are affine along it, that is when the segment lies
on the line through ``O`` and ``V`` between them, where ``u + v = 0`` (no reflection). So a
reflection point is the one minimiser. (A ``V`` inside ``K`` is behind every supporting plane:
no image.) []

Which bodies :func:`several_possible` recognises, exactly: the mesh, with its vertices welded
(:meth:`refsoft.scene.mesh.Mesh.weld`) and its degenerate triangles left out, is closed (every
edge in exactly two triangles; the winding does not matter, the G-buffer draws both), the
one-ring of each triangle's three corners lies on one side of the triangle's plane (within
``CONVEX_TOLERANCE`` of the mesh's extent), so the surface is locally convex at every point,
and its Euler characteristic ``V - E + F`` is 2: one connected component (each locally convex
closed component is a sphere, of characteristic 2). A
compact, connected, locally convex surface is the boundary of a convex body (Van Heijenoort
1952), and an affine map (the object's transform, a non-uniform scale included) keeps it so, at
every frame.

A plane mirror whose vertex normals are all its plane's normal (open or not) is recognised too
(:func:`_flat`: the mirror image across the plane is unique, and so is the point where the eye's
segment to it crosses the plane).

What the theorem covers: the surface with the normals of its supporting planes, that is the
flat-shaded polyhedron, and a smooth convex surface. The G-buffer shows the closed proxy
(``Scene.world_mesh(k, frame, proxy=True)``) with interpolated vertex normals, which inside a
triangle are not a supporting plane's normal; there the skip is the theorem applied to the
surface the normals approximate. That no convex built-in gives a second image with its
interpolated normals is checked by the plain reference that judges every texel
(``tests/search/test_convex.py``).
"""

from __future__ import annotations

import weakref

import numpy as np

from ..constants import CONVEX_TOLERANCE
from ..errors import RefsoftError
from ..scene.mesh import Mesh


_BLOCK = 2048  # triangles per block of the local convexity test


def several_possible(mesh: Mesh) -> bool:
    """Whether a reflector's (closed proxy) mesh may give a vertex more than one reflection point:
    False when it bounds a convex body (module docstring: the proof and what it covers), True
    otherwise (open, not closed, concave somewhere, or several components).

    Parameters
    ----------
    mesh : Mesh
        The surface the G-buffer shows (model or world space: an affine map keeps convexity).

    Returns
    -------
    bool
    """
    if not isinstance(mesh, Mesh):
        raise RefsoftError(f"mesh must be a refsoft Mesh, got {type(mesh).__name__}")
    if mesh not in _DECIDED:  # a mesh does not change: decided once per process
        _DECIDED[mesh] = not (_flat(mesh) or _convex(mesh))
    return _DECIDED[mesh]


#: Mesh -> its decision, while the mesh lives.
_DECIDED = weakref.WeakKeyDictionary()


def _flat(mesh: Mesh) -> bool:
    """A plane mirror: every vertex on one plane (within ``CONVEX_TOLERANCE`` of the extent) and
    every vertex normal the plane's normal (to 1e-12 in the cosine, one side). Then the normals
    are the plane's everywhere, interpolated or not, and a vertex in front of it reflects only
    where the segment from the eye to its mirror image crosses the plane: at most one point."""
    v, nrm = mesh.vertices, mesh.normals
    n0 = nrm[0]
    if np.any(nrm @ n0 < 1.0 - 1e-12):
        return False
    extent = float(np.max(v.max(axis=0) - v.min(axis=0))) or 1.0
    return bool(np.all(np.abs((v - v[0]) @ n0) <= CONVEX_TOLERANCE * extent))


def _convex(mesh: Mesh) -> bool:
    weld, n_labels = mesh.weld()
    f = weld[mesh.faces.astype(np.int64)]
    p = np.zeros((n_labels, 3))
    p[weld] = mesh.vertices  # one position per label (welded copies agree within the weld's tolerance)
    a, b, c = p[f[:, 0]], p[f[:, 1]], p[f[:, 2]]
    n = np.cross(b - a, c - a)
    area2 = np.sqrt(np.einsum("ij,ij->i", n, n))
    extent = float(np.max(mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0))) or 1.0
    live = area2 > (extent * 1e-9) ** 2
    f, n, area2 = f[live], n[live], area2[live]
    if not len(f):
        return False
    # closed: each undirected edge in exactly two triangles (the G-buffer draws both windings,
    # so the orientation does not matter)
    src = f.reshape(-1)
    dst = f[:, [1, 2, 0]].reshape(-1)
    _, uses = np.unique(np.minimum(src, dst) * n_labels + np.maximum(src, dst), return_counts=True)
    if np.any(uses != 2):
        return False
    # one component: a locally convex closed component is a sphere, of characteristic 2
    if len(np.unique(f)) - len(uses) + len(f) != 2:
        return False
    # locally convex: the one-ring of every corner on or behind the triangle's plane
    both_src, both_dst = np.concatenate([src, dst]), np.concatenate([dst, src])  # either winding
    ring_order = np.argsort(both_src, kind="stable")
    ring = both_dst[ring_order]  # neighbours of each label, grouped by label
    start = np.searchsorted(both_src[ring_order], np.arange(n_labels + 1))
    unit = n / area2[:, None]
    tol = CONVEX_TOLERANCE * extent
    # in blocks of triangles: the one-rings' temporaries stay small beside a frame's arrays
    for lo in range(0, len(f), _BLOCK):
        fb, ub = f[lo:lo + _BLOCK], unit[lo:lo + _BLOCK]
        above = np.zeros(len(fb), dtype=bool)
        below = np.zeros(len(fb), dtype=bool)
        for corner in range(3):
            lab = fb[:, corner]
            deg = start[lab + 1] - start[lab]
            tri = np.repeat(np.arange(len(fb)), deg)
            idx = np.repeat(start[lab], deg) + (np.arange(int(deg.sum())) - np.repeat(np.cumsum(deg) - deg, deg))
            d = np.einsum("ij,ij->i", p[ring[idx]] - p[lab[tri]], ub[tri])
            above |= np.bincount(tri, d > tol, len(fb)) > 0
            below |= np.bincount(tri, d < -tol, len(fb)) > 0
        if np.any(above & below):
            return False
    return True

"""Mirror paths (spec section 5.1): the truth's rays followed through several reflections.

A ray leaving its first reflection (off reflector ``a1``, at the pixel's eye-ray hit) is traced
against the non-reflectors and, while fewer than ``bounces`` reflections were taken, against the
reflectors it may meet next: every reflector but the one it leaves, unless that one can see
itself. Where a reflector is nearer than every non-reflector, the ray reflects again about that
reflector's normal interpolated at the hit (the hit recomputed in float64 on the triangle Embree
names, as the first bounce's) and goes on. The ray leaving the last reflection allowed meets
non-reflectors only, so with ``bounces = 1`` the path is the first-order truth.

Each step traces the non-reflectors as one Embree scene and the reflectors as another, and keeps
the nearer float64 hit: a ray that meets no reflector ends exactly where the first-order truth's
ray from the same point would (the same scene, origin and arithmetic).

Which reflectors can see themselves: those :func:`refsoft.search.convex.several_possible` keeps
(open, not closed, concave somewhere, several pieces). A convex closed mirror and a plane mirror
cannot: a ray leaving the surface of a convex body outwards never meets it again, so an Embree
hit on such a reflector's own triangles is an artefact of the interpolated normals or of float32
and is not traced at all. A reflector that can see itself is traced from a point moved
``TRUTH_SELF_OFFSET`` times its bounding-box diagonal along the ray, and a hit on the very
triangle the ray leaves (impossible for a flat triangle) is dropped.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene.model import Scene


@dataclass(eq=False)
class MirrorPaths:
    """Where the rays leaving their first reflection end.

    Attributes
    ----------
    depth : ndarray (P,) int8
        Reflections taken by each path (1 .. bounces).
    hit : ndarray (P, 3) float64
        The non-reflector point each path ends on (zero where it escapes).
    obj : ndarray (P,) int32
        The non-reflector object id it ends on, 0 where it escapes.
    normal : ndarray (P, 3) float64
        The interpolated normal there (zero where it escapes).
    levels : list of (rays, reflector, normal)
        Reflections 2, 3, ...: the paths that take that reflection ((M,) int64 indices into P),
        the reflector ((M,) int32) and its interpolated normal at the hit ((M, 3) float64).
    """

    depth: np.ndarray
    hit: np.ndarray
    obj: np.ndarray
    normal: np.ndarray
    levels: list = field(default_factory=list)


def _interpolated_normals(normals, faces, tri, bary):
    """The vertex normals of triangles ``tri`` interpolated at ``bary`` and renormalised (zero
    where they cancel), float64 (P, 3)."""
    n = np.einsum("nk,nkj->nj", bary, normals[faces[tri]])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def sees_itself(scene: Scene, k: int) -> bool:
    """Whether reflector ``k`` can reflect a ray onto itself: not a convex closed body nor a plane
    (:func:`refsoft.search.convex.several_possible` of its drawn mesh, decided once per mesh; an
    object's transform is affine and keeps convexity)."""
    from ..search.convex import several_possible

    return several_possible(scene.object_by_id(k).mesh)


def reflect_about(directions, normals):
    """``d - 2 (d . n) n`` per row (float64), the first bounce's rule
    (:mod:`refsoft.raster._rays`)."""
    dn = (directions[:, 0] * normals[:, 0] + directions[:, 1] * normals[:, 1]) + directions[:, 2] * normals[:, 2]
    return directions - (2.0 * dn)[:, None] * normals


def trace_paths(origins, directions, first, first_tri, bounces, plain, mirrors) -> MirrorPaths:
    """Follow the rays leaving their first reflection until they meet a non-reflector, escape, or
    have taken ``bounces`` reflections.

    Parameters
    ----------
    origins, directions : ndarray (P, 3) float64
        The first reflection's points and reflected directions.
    first : int
        The first reflector's object id.
    first_tri : ndarray (P,) int64
        The triangle of ``first`` each ray leaves (its own mesh's index).
    bounces : int
        Most reflections per path (1 .. ``MAX_BOUNCES``).
    plain : refsoft.truth.raytrace._Targets
        The non-reflectors (anything with its ``named``, ``complete``, ``face_object``,
        ``first_face``, ``normals``, ``faces`` and ``empty``).
    mirrors : callable
        ``mirrors(s) -> (targets, offset)``: the reflectors a ray leaving reflector ``s`` may
        meet (a ``_Targets``, empty when none) and the distance its origin moves along the ray
        before Embree traces it (0 unless ``s`` can see itself).

    Returns
    -------
    MirrorPaths
    """
    n = len(origins)
    out = MirrorPaths(np.ones(n, np.int8), np.zeros((n, 3)), np.zeros(n, np.int32), np.zeros((n, 3)))
    rays = np.arange(n, dtype=np.int64)
    o, d = origins, directions
    src, src_tri = np.full(n, first, np.int32), np.asarray(first_tri, np.int64)
    for j in range(1, bounces + 1):
        if not len(rays):
            break
        tri, t, bary = plain.named(o, d)
        m_tri, m_t, m_bary, m_obj = _mirror_hits(o, d, src, src_tri, mirrors) if j < bounces else (None,) * 4
        onward = np.zeros(len(rays), bool)
        if m_tri is not None:
            onward = (m_tri >= 0) & ~(t <= m_t)  # a reflector nearer than every non-reflector (NaN: none)
        stop = np.flatnonzero(~onward)
        hit, obj, nrm = plain.complete(o[stop], d[stop], tri[stop], t[stop], bary[stop])
        out.hit[rays[stop]], out.obj[rays[stop]], out.normal[rays[stop]] = hit, obj, nrm
        go = np.flatnonzero(onward)
        if not len(go):
            break
        new_o, new_n, new_tri = _mirror_points(o[go], d[go], src[go], m_tri[go], m_t[go], m_bary[go], m_obj[go],
                                               mirrors)
        rays, o, d = rays[go], new_o, reflect_about(d[go], new_n)
        src, src_tri = m_obj[go], new_tri
        out.depth[rays] += 1
        out.levels.append((rays, src, new_n))
    return out


def _mirror_hits(o, d, src, src_tri, mirrors):
    """Per ray the triangle of its reflector targets (``mirrors(src)``) Embree names next (-1
    none), its float64 parameter from the ray's true origin (NaN none), barycentrics and object."""
    n = len(o)
    tri = np.full(n, -1, np.int64)
    t = np.full(n, np.nan)
    bary = np.zeros((n, 3))
    obj = np.zeros(n, np.int32)
    for s in np.unique(src):
        sel = np.flatnonzero(src == s)
        targets, offset = mirrors(int(s))
        if targets.empty:
            continue
        moved = None if offset == 0 else o[sel] + offset * d[sel] / np.linalg.norm(d[sel], axis=1, keepdims=True)
        tr, tt, bb = targets.named(o[sel], d[sel], traced_from=moved)
        ob = np.where(tr >= 0, targets.face_object[np.maximum(tr, 0)], 0).astype(np.int32)
        if offset != 0 and int(s) in targets.first_face:  # the triangle a ray leaves cannot be hit again
            tr[(ob == s) & (tr - targets.first_face[int(s)] == src_tri[sel])] = -1
        keep = (tr >= 0) & (tt > 0.0)
        tri[sel], t[sel], bary[sel] = np.where(keep, tr, -1), np.where(keep, tt, np.nan), bb
        obj[sel] = np.where(keep, ob, 0)
    return tri, t, bary, obj


def _mirror_points(o, d, src, tri, t, bary, obj, mirrors):
    """The reflector hits (float64), the interpolated normals there and each hit triangle's index
    in its own reflector's mesh (``tri`` indexes the targets ``mirrors(src)``)."""
    hit = o + t[:, None] * d
    normal = np.zeros_like(hit)
    local = np.zeros(len(o), np.int64)
    for s in np.unique(src):
        sel = np.flatnonzero(src == s)
        targets, _ = mirrors(int(s))
        normal[sel] = _interpolated_normals(targets.normals, targets.faces, tri[sel], bary[sel])
        first = np.array([targets.first_face[int(k)] for k in obj[sel]], np.int64)
        local[sel] = tri[sel] - first
    return hit, normal, local

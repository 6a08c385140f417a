"""Several bounces (spec section 5.1): reflections of reflections, by the vertex search at every
level.

Level 1 is the method of one bounce. With ``bounces = N > 1`` the virtual pass of level ``j``
also rasterizes the other reflectors' virtual triangles (their vertices searched like every other
vertex); where one of them, ``b``, is nearest, those pixels are a :class:`Bounce`: level ``j +
1``'s stencil and G-buffer, ``b``'s world position and normal interpolated over its virtual
triangles, and each pixel's own eye, the previous bounce point. The walk of spec section 4.2
runs on it with the eye direction of each pixel taken from that pixel's eye
(:mod:`refsoft.search._bounces`); a virtual vertex lies on the camera's ray through its
reflection pixel at the whole path's length, ``|O - R1| + ... + |R_j - V|`` (the unfolded rule).
Level ``j + 1``'s virtual triangles are drawn in its stencil only, and composited into level
``j``'s picture as the frame composites a reflector: ``rho * reflection + (1 - rho) * the
reflector's own shade``.

What a later level does not do: coherence (each vertex starts from the covered pixel, among
:data:`~refsoft.constants.BOUNCE_START_SAMPLES` spread over the stencil, where its score is
highest), the inverse search (a hidden vertex's triangles are left out, as ``inverse =
"discard"`` does), tessellation and the silhouette cut, and a reflector seeing itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import constants, keys
from .._numba import readonly
from .._parallel import parallel_range
from ..raster import CULL_MODES, GBuffer, _setup, rasterize_trusted, shade
from ..raster.rays import primary_rays, ray_triangle
from . import CULLED, HIDDEN, SearchResult, _bounces, search
from .virtual import virtual_pass

#: The per-pixel array of the reflections taken (0 off reflectors).
BOUNCE_DEPTH = keys.BOUNCE_DEPTH


@dataclass(frozen=True, eq=False)
class Bounce:
    """A reflector seen in an earlier bounce's image: a later level's stencil and G-buffer.

    Attributes
    ----------
    level : int
        The bounce this reflector gives (2 for a reflector seen in a first bounce's image).
    reflector : int
        Its object id.
    mask : ndarray (H, W) bool
        Where it is seen (the level's stencil), over the view.
    position, normal : ndarray (H, W, 3) float64
        Its world position and unit normal there (zero elsewhere).
    eye : ndarray (H, W, 3) float64
        Each pixel's eye: the previous bounce point.
    path : ndarray (H, W) float64
        The path's length from the camera's eye to this bounce point.
    direction : ndarray (H, W, 3) float64
        The camera's unit ray direction through each pixel.
    origin : ndarray (3,) float64
        The camera's eye.
    """

    level: int
    reflector: int
    mask: np.ndarray
    position: np.ndarray
    normal: np.ndarray
    eye: np.ndarray
    path: np.ndarray
    direction: np.ndarray
    origin: np.ndarray

    def box(self):
        """(r0, r1, c0, c1): the bounding box of ``mask``."""
        rows, cols = np.flatnonzero(self.mask.any(axis=1)), np.flatnonzero(self.mask.any(axis=0))
        return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def gbuffer_of(bounce: Bounce, camera, precision="float32") -> GBuffer:
    """The bounce's G-buffer, positions relative to the camera's eye in ``precision``."""
    dt = np.dtype(precision)
    origin = np.asarray(camera.eye, np.float64)
    m = bounce.mask
    pos = np.where(m[..., None], bounce.position - origin, 0.0).astype(dt)
    nrm = np.where(m[..., None], bounce.normal, 0.0).astype(dt)
    depth = np.where(m, np.float32(0.5), np.float32(1.0)).astype(np.float32)
    tri = np.where(m, 0, -1).astype(np.int32)
    return GBuffer(pos, nrm, m.copy(), depth, tri, camera.view_proj(), origin)


def search_bounce(bounce: Bounce, gb: GBuffer, vertices, neighbourhood="cross", cap=None) -> SearchResult:
    """The walk of spec section 4.2 for every vertex on a bounce's G-buffer, each pixel's eye
    its own (:class:`Bounce`).

    Parameters
    ----------
    bounce : Bounce
    gb : GBuffer
        :func:`gbuffer_of` the bounce.
    vertices : ndarray (N, 3) float64
        World space.
    neighbourhood : {"cross", "box"}
    cap : int, optional
        Iteration cap (default ``2 * (width + height)``).

    Returns
    -------
    SearchResult
        Flags: HIDDEN where the vertex lies behind the end pixel's tangent plane, CAPPED, BORDER.
    """
    from . import default_cap

    dt = gb.position.dtype.type
    fp = dt(0)
    verts = np.asarray(vertices, np.float64).reshape(-1, 3)
    n = len(verts)
    h, w = gb.mask.shape
    cap = default_cap((h, w)) if cap is None else int(cap)
    pixel = np.full((n, 2), -1, np.int32)
    score, margin = np.zeros(n, dt), np.zeros(n, dt)
    iterations, flags = np.zeros(n, np.int32), np.full(n, CULLED, np.uint8)
    if not n or not gb.mask.any():
        return SearchResult(pixel, score, margin, iterations, flags, neighbourhood, "discard", cap)
    G = np.zeros((h, w, 9), dtype=dt)
    eye_rel = np.ascontiguousarray((bounce.eye - gb.origin).astype(dt))
    parallel_range(_bounces.pack_eyes, h, gb.position, gb.normal, gb.mask, eye_rel, fp, G)
    rel = np.ascontiguousarray((verts - gb.origin).astype(dt))
    starts = _starts(G, gb.mask, rel)
    flags[:] = 0
    parallel_range(_bounces.search_each, n, G, gb.mask, rel, starts, constants.NEIGHBOURHOODS[neighbourhood], cap, fp,
                   pixel, score, margin, iterations, flags)
    return SearchResult(pixel, score, margin, iterations, flags, neighbourhood, "discard", cap)


def _starts(G, mask, rel):
    """Per vertex the covered pixel of highest score among up to BOUNCE_START_SAMPLES covered
    pixels taken evenly in row-major order (ties: the first): a stencil seen in a curved mirror
    can be small and split, and no projection of the vertex points into it. (N, 2) int64."""
    rows, cols = np.nonzero(mask)
    step = max(1, -(-len(rows) // constants.BOUNCE_START_SAMPLES))
    rows, cols = rows[::step], cols[::step]
    g = G[rows, cols].astype(np.float64)  # (S, 9): P, N, U
    d = rel.astype(np.float64)[:, None, :] - g[None, :, 0:3]
    b = d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-300)
    hv = g[None, :, 6:9] + b
    hv /= np.maximum(np.linalg.norm(hv, axis=-1, keepdims=True), 1e-300)
    best = np.argmax(np.sum(hv * g[None, :, 3:6], axis=-1), axis=1)
    return np.ascontiguousarray(np.stack([rows[best], cols[best]], axis=1), np.int64)


def unfolded(bounce: Bounce, result: SearchResult, vertices) -> np.ndarray:
    """Virtual vertices (N, 3) float64 world: on the camera's ray through each vertex's reflection
    pixel, at the path's length to the bounce point plus ``|V - R|`` (spec section 5.1); NaN
    where the search found no pixel."""
    verts = np.asarray(vertices, np.float64).reshape(-1, 3)
    out = np.full(verts.shape, np.nan)
    ok = result.pixel[:, 0] >= 0
    r, c = result.pixel[ok, 0], result.pixel[ok, 1]
    length = bounce.path[r, c] + np.linalg.norm(verts[ok] - bounce.position[r, c], axis=1)
    out[ok] = bounce.origin + length[:, None] * bounce.direction[r, c]
    return out


def may_see(position, normal, eye, mask, centre, radius) -> bool:
    """Whether a reflected ray of a G-buffer can reach a sphere (a reflector's bounds): False
    only when, at every covered texel, the ray reflected about its normal from its eye passes the
    sphere farther than ``radius`` plus BOUNCE_BOUND_FACTOR times the spread to its covered
    4-neighbours (the arc their rays' angle sweeps at the sphere's distance, and the distance
    between their points), so that a ray from anywhere between texels misses it too.

    Parameters
    ----------
    position, normal : ndarray (H, W, 3)
        World positions and unit normals (zero where not covered).
    eye : ndarray (3,) or (H, W, 3)
        The eye, or each texel's.
    mask : ndarray (H, W) bool
    centre : array_like (3,)
    radius : float
    """
    rows, cols = np.nonzero(mask)
    if not len(rows):
        return False
    P = np.asarray(position, np.float64)
    N = np.asarray(normal, np.float64)
    E = np.asarray(eye, np.float64)
    p = P[rows, cols]
    e = E if E.ndim == 1 else E[rows, cols]
    i = p - e
    i /= np.maximum(np.linalg.norm(i, axis=1, keepdims=True), 1e-300)
    n = N[rows, cols]
    r = i - 2.0 * np.sum(i * n, axis=1, keepdims=True) * n
    R = np.zeros(P.shape)
    R[rows, cols] = r
    h, w = mask.shape
    angle, step = np.zeros(len(rows)), np.zeros(len(rows))
    for dr, dc in ((0, 1), (1, 0), (0, -1), (-1, 0)):
        rr, cc = rows + dr, cols + dc
        ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
        ok[ok] &= mask[rr[ok], cc[ok]]
        q = np.zeros((len(rows), 3))
        q[ok] = R[rr[ok], cc[ok]]
        cos = np.clip(np.sum(q * r, axis=1), -1.0, 1.0)
        angle = np.maximum(angle, np.where(ok, np.arccos(cos), 0.0))
        d = np.zeros(len(rows))
        d[ok] = np.linalg.norm(P[rr[ok], cc[ok]] - p[ok], axis=1)
        step = np.maximum(step, d)
    cp = np.asarray(centre, np.float64) - p
    t = np.maximum(np.sum(cp * r, axis=1), 0.0)
    miss = np.linalg.norm(cp - t[:, None] * r, axis=1)
    spread = np.linalg.norm(cp, axis=1) * np.minimum(angle, np.pi) + step
    return bool(np.any(miss <= radius + constants.BOUNCE_BOUND_FACTOR * spread))


def bounding_sphere(mesh):
    """(centre (3,), radius) of a mesh's vertices: the centre of their box."""
    v = np.asarray(mesh.vertices, np.float64)
    c = 0.5 * (v.min(axis=0) + v.max(axis=0))
    return c, float(np.sqrt(np.max(np.sum((v - c) ** 2, axis=1))))


def object_parts(meshes, ids, virtual, flags):
    """The virtual geometry of objects ``ids`` (their vertices consecutive in ``virtual`` and
    ``flags``, in that order), one part per object: (virtual (n, 3) float64, normals, faces (m, 3)
    int64, face object (m,) int32, flags (n,) uint8)."""
    parts, start = [], 0
    for k in ids:
        mesh = meshes[k - 1]
        n = mesh.n_vertices
        part = (virtual[start:start + n], mesh.normals, mesh.faces.astype(np.int64),
                np.full(mesh.n_faces, k, dtype=np.int32), flags[start:start + n])
        parts.append(part)
        start += n
    return parts


def seen_reflectors(parts, reflector_parts, camera, stencil, box):
    """The reflectors whose virtual triangles are nearest at pixels of ``stencil``, drawn with the
    virtual triangles of ``parts`` in one z-buffer over ``box`` (spec section 5.1).

    Parameters
    ----------
    parts : list
        The non-reflectors' virtual parts (:func:`object_parts`, or the virtual pass's own).
    reflector_parts : list
        :func:`object_parts` of the reflectors, one part each.
    camera : Camera
    stencil : ndarray (H, W) bool
    box : (r0, r1, c0, c1)

    Returns
    -------
    dict
        Reflector id -> (mask (H, W) bool, face (H, W) int64: the reflector's triangle (a row of
        its mesh's faces) nearest at each pixel of the mask, -1 elsewhere), for each reflector
        nearest at one pixel or more.
    """
    if not reflector_parts:
        return {}
    vp = camera.view_proj()
    faces, face_obj, clips, flags, local = [], [], [], [], []
    offset = 0
    for part in list(parts) + list(reflector_parts):
        virtual, _, f, fobj, fl = part[:5]
        bad = ~np.all(np.isfinite(virtual), axis=1)
        clip = _setup.transform_points(np.where(bad[:, None], 0.0, virtual), vp)
        faces.append(f + offset)
        face_obj.append(fobj)
        clips.append(clip)
        flags.append(np.where(bad, np.uint8(CULLED), fl).astype(np.uint8))
        local.append(np.arange(len(f), dtype=np.int64))
        offset += len(clip)
    faces, face_obj, clip = np.concatenate(faces), np.concatenate(face_obj), np.ascontiguousarray(np.concatenate(clips))
    flags, local = np.concatenate(flags), np.concatenate(local)
    keep = ~np.any((flags[faces] & np.uint8(CULLED | HIDDEN)) != 0, axis=1)
    faces, face_obj, local = faces[keep], face_obj[keep], local[keep]
    if not len(faces):
        return {}
    faces32 = readonly(np.ascontiguousarray(faces, np.int32))
    r0, r1, c0, c1 = (int(x) for x in box)
    frags = rasterize_trusted(clip, faces32, camera.width, camera.height, (r0, r1, c0, c1), None, CULL_MODES[None])
    tri = frags.triangle
    obj = np.where(tri >= 0, face_obj[np.maximum(tri, 0)], 0)
    sten = stencil[r0:r1, c0:c1] & (tri >= 0)
    reflectors = {int(p[3][0]) for p in reflector_parts if len(p[3])}
    out = {}
    H, W = stencil.shape
    for b in (int(x) for x in np.unique(obj[sten])):
        if b not in reflectors:
            continue
        m = sten & (obj == b)
        mask = np.zeros((H, W), bool)
        mask[r0:r1, c0:c1] = m
        face = np.full((H, W), -1, np.int64)
        face[r0:r1, c0:c1][m] = local[tri[m]]
        out[b] = (mask, face)
    return out


def _arrive(mesh, face, origin, direction):
    """Where rays (P, 3) meet the planes of ``mesh``'s triangles ``face`` (P,), and the normals
    interpolated there (renormalised): ``(point (P, 3), normal (P, 3), ok (P,))``, ``ok`` False
    where a ray is parallel to its plane or meets it behind its origin."""
    f = mesh.faces[face]
    v = np.asarray(mesh.vertices, np.float64)
    t, bary = ray_triangle(origin, direction, v[f[:, 0]], v[f[:, 1]], v[f[:, 2]])
    ok = np.isfinite(t) & (t > 0)
    point = origin + np.where(ok, t, 0.0)[:, None] * direction
    n = np.einsum("pk,pkj->pj", np.where(ok[:, None], bary, 0.0), np.asarray(mesh.normals, np.float64)[f])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    ok &= length[:, 0] > 0
    return point, n / np.where(length > 0, length, 1.0), ok


def _bounce(level, b, mask, face, mesh, origin, direction, path, camera_ray, camera_eye):
    """The :class:`Bounce` of reflector ``b`` at ``level`` where the rays ``origin``,
    ``direction`` (P, 3) of the previous level's pixels of ``mask`` (row-major) meet it, with the
    path's length ``path`` (P,) to their origins and the camera's ray directions (P, 3)."""
    rows, cols = np.nonzero(mask)
    point, normal, ok = _arrive(mesh, face[rows, cols], origin, direction)
    H, W = mask.shape
    m = np.zeros((H, W), bool)
    m[rows[ok], cols[ok]] = True
    pos, nrm, eyes, dirs = (np.zeros((H, W, 3)) for _ in range(4))
    length = np.zeros((H, W))
    r, c = rows[ok], cols[ok]
    pos[r, c], nrm[r, c], eyes[r, c], dirs[r, c] = point[ok], normal[ok], origin[ok], camera_ray[ok]
    length[r, c] = path[ok] + np.linalg.norm(point[ok] - origin[ok], axis=1)
    return Bounce(level, b, m, pos, nrm, eyes, length, dirs, camera_eye)


def first_bounces(camera, meshes, k, triangle, seen):
    """The reflectors seen in reflector ``k``'s first-bounce image as level-2 :class:`Bounce` s:
    each pixel's eye ray meets ``k``'s visible triangle (``triangle``, the main view's;
    :func:`refsoft.raster.rays.primary_rays`), reflects, and meets the triangle of the reflector
    the virtual pass shows there (``seen``: :func:`seen_reflectors`); the bounce point is that
    hit (float64, on the triangle's plane) and its normal the one interpolated there."""
    origin = np.asarray(camera.eye, np.float64)
    out = []
    for b, (mask, face) in sorted(seen.items()):
        rows, cols = np.nonzero(mask)
        hit, ray, _ = primary_rays(camera, meshes[k - 1], rows, cols, triangle[rows, cols])
        first = hit - origin
        dist = np.linalg.norm(first, axis=1)
        out.append(_bounce(2, b, mask, face, meshes[b - 1], hit, ray, dist,
                           first / np.maximum(dist, 1e-300)[:, None], origin))
    return out


def later_bounces(bounce: Bounce, seen, meshes):
    """The reflectors seen in ``bounce``'s image as the next level's :class:`Bounce` s (the
    bounce's reflected rays, :func:`level_rays`, meeting their triangles)."""
    out = []
    for c, (mask, face) in sorted(seen.items()):
        rows, cols = np.nonzero(mask)
        full = (0, mask.shape[0], 0, mask.shape[1])
        _, origin, direction = level_rays(bounce, full)
        out.append(_bounce(bounce.level + 1, c, mask, face, meshes[c - 1], origin[rows, cols], direction[rows, cols],
                           bounce.path[rows, cols], bounce.direction[rows, cols], bounce.origin))
    return out


def draw_bounce(scene, meshes, bounce: Bounce, camera, vertices, opt, levels, report):
    """Level ``bounce.level``'s picture in its stencil, and the later levels' inside it.

    Parameters
    ----------
    scene, meshes, camera
        The frame's.
    bounce : Bounce
    vertices : ndarray (N, 3) float64
        The non-reflectors' vertices (:func:`refsoft.scene.scene_vertices`).
    opt : RenderOptions
        Read: ``neighbourhood``, ``cap``, ``precision``.
    levels : int
        The last level drawn (``bounces``).
    report : list
        Receives one dict per bounce drawn (level, reflector, pixels, milliseconds).

    Returns
    -------
    box, colour (h, w, 3) float32, reflected_id (h, w) int32, covered (h, w) bool, depth (h, w) int8
    """
    import time

    t0 = time.perf_counter()
    box = bounce.box()
    r0, r1, c0, c1 = box
    gb = gbuffer_of(bounce, camera, opt.precision)
    ids = [k for k, o in enumerate(scene.objects, start=1) if not o.reflector]
    # only the objects a reflected ray of this level can reach are searched; the others' vertices
    # are CULLED (their triangles are not drawn)
    sizes = [meshes[k - 1].n_vertices for k in ids]
    seen = np.repeat([may_see(bounce.position, bounce.normal, bounce.eye, bounce.mask, *bounding_sphere(meshes[k - 1]))
                      for k in ids], sizes).astype(bool)
    virtual = np.zeros((len(vertices), 3))
    flags = np.full(len(vertices), CULLED, np.uint8)
    res = search_bounce(bounce, gb, vertices[seen], opt.neighbourhood, opt.cap)
    virtual[seen], flags[seen] = unfolded(bounce, res, vertices[seen]), res.flags
    depth = np.where(bounce.mask[r0:r1, c0:c1], np.int8(bounce.level), np.int8(0)).astype(np.int8)
    entry = {"level": bounce.level, "reflector": bounce.reflector, "pixels": int(bounce.mask.sum()),
             "searched": int(seen.sum())}
    report.append(entry)
    others = [] if bounce.level >= levels else [
        k for k in scene.reflector_ids if k != bounce.reflector
        and may_see(bounce.position, bounce.normal, bounce.eye, bounce.mask, *bounding_sphere(meshes[k - 1]))]
    found = []  # the other reflectors' vertices searched at this level: (id, vertices, virtual, flags)
    for k in others:
        verts = np.asarray(meshes[k - 1].vertices, np.float64)
        r = search_bounce(bounce, gb, verts, opt.neighbourhood, opt.cap)
        found.append(([k], verts, unfolded(bounce, r, verts), r.flags))
    if opt.images == "all":  # each pixel's reflected ray decides among the virtual triangles over it
        rays = level_rays(bounce, box)
        colour, rid, covered, seen_refl = exact_level(scene, meshes, [(ids, vertices, virtual, flags)] + found, camera,
                                                      bounce.mask, box, rays)
        full = np.zeros(bounce.eye.shape)
        full[r0:r1, c0:c1] = rays[1]
        nxt = exact_bounces(bounce.level + 1, seen_refl, full, bounce.path, bounce.direction, bounce.origin)
    else:
        parts = object_parts(meshes, ids, virtual, flags)
        colour, rid, covered, _ = virtual_pass(scene, parts, camera, bounce.mask, box, "discard")
        rparts = sum((object_parts(meshes, k, v, fl) for k, _, v, fl in found), [])
        nxt = later_bounces(bounce, seen_reflectors(parts, rparts, camera, bounce.mask, box), meshes) if found else []
    for b in nxt:
        deeper = draw_bounce(scene, meshes, b, camera, vertices, opt, levels, report)
        blend(colour, rid, covered, depth, box, b, deeper, scene)
    entry["ms"] = 1000 * (time.perf_counter() - t0)
    return box, colour, rid, covered, depth


def level_rays(bounce: Bounce, box):
    """Each pixel's reflected ray at a bounce over ``box``: ``(valid (h, w) bool, origin (h, w, 3),
    direction (h, w, 3))`` float64, the bounce point and the direction from the pixel's eye
    reflected about the normal there (:func:`refsoft.search.several.draw`'s ``rays``)."""
    r0, r1, c0, c1 = box
    valid = bounce.mask[r0:r1, c0:c1].copy()
    origin = np.where(valid[..., None], bounce.position[r0:r1, c0:c1], 0.0)
    n = bounce.normal[r0:r1, c0:c1]
    i = origin - bounce.eye[r0:r1, c0:c1]
    i /= np.maximum(np.linalg.norm(i, axis=-1, keepdims=True), 1e-300)
    d = i - 2.0 * np.sum(i * n, axis=-1, keepdims=True) * n
    return valid, np.ascontiguousarray(origin), np.ascontiguousarray(np.where(valid[..., None], d, 0.0))


def _candidates(meshes, groups):
    """Candidates of :func:`refsoft.search.several.draw` from ``groups``: (object ids, their
    vertices (n, 3) world, virtual vertices (n, 3), flags (n,)) each, the objects' vertices
    consecutive in that order. A triangle with a CULLED corner is left out; one with a HIDDEN
    corner (its virtual vertex is where its walk stopped, not its image) is tried over the whole
    box (the draw's rule for a corner it cannot project)."""
    from .several import Candidates

    virtual, real, normals, obj, tri = [], [], [], [], []
    for ids, verts, virt, flags in groups:
        virt = np.where(((flags & np.uint8(HIDDEN)) != 0)[:, None], np.nan, virt)
        start = 0
        for k in ids:
            mesh = meshes[k - 1]
            f = mesh.faces.astype(np.int64)
            keep = ~np.any((flags[f + start] & np.uint8(CULLED)) != 0, axis=1)
            f = f[keep]
            virtual.append(virt[f + start])
            real.append(np.asarray(verts, np.float64)[f + start])
            normals.append(np.asarray(mesh.normals, np.float64)[f])
            obj.append(np.full(len(f), k, np.int32))
            tri.append(np.flatnonzero(keep))
            start += mesh.n_vertices
    cat = (lambda x, shape: np.ascontiguousarray(np.concatenate(x)) if x else np.zeros(shape))
    return Candidates(cat(virtual, (0, 3, 3)), cat(real, (0, 3, 3)), cat(normals, (0, 3, 3)),
                      cat(obj, (0,)).astype(np.int32), cat(tri, (0,)).astype(np.int64), 0)


def nearest_hits(cand, camera, box, rays):
    """Per pixel of ``box`` the candidate whose real triangle the pixel's ray meets nearest, among
    those whose dilated virtual triangle covers it (:func:`refsoft.search.several.draw`'s
    acceptance): ``(candidate (h, w) int64, -1 none; t (h, w); barycentrics u, v (h, w, 2))``."""
    from . import several

    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    valid, origin, direction = rays
    best_t = np.full((h, w), np.inf)
    best_c = np.full((h, w), -1, np.int64)
    best_uv = np.zeros((h, w, 2))
    if len(cand.real):
        with np.errstate(invalid="ignore"):  # the hidden corners' NaN bounds, replaced by the box
            screen, bbox, dilate = several._screen(cand.virtual, camera, (r0, r1, c0, c1))
        real = np.ascontiguousarray(cand.real)
        parallel_range(several.accept, h, r0, c0, valid, several._spans(valid), origin, direction, screen, bbox,
                       dilate, real, several._runs(real), best_t, best_c, best_uv, np.zeros((h, w), bool),
                       np.full((h, w), -1, np.int64))
    return best_c, best_t, best_uv


def exact_level(scene, meshes, groups, camera, stencil, box, rays):
    """One level drawn by exact per-pixel acceptance: the nearest hit of each pixel's ray among
    the candidates of ``groups`` (:func:`_candidates`; the non-reflectors, then the reflectors
    searched at this level), shaded as :func:`refsoft.search.several.draw` shades it.

    Returns
    -------
    colour (h, w, 3) float32, reflected_id (h, w) int32, covered (h, w) bool
        Over ``box``; a pixel showing a reflector shows nothing here (the next level draws it).
    reflectors : dict
        Reflector id -> (mask (H, W) bool, point (H, W, 3), normal (H, W, 3), distance (H, W)):
        the pixels where its triangle is the nearest hit, the hit (float64) and the normal
        interpolated there, and the hit's distance along the ray.
    """
    r0, r1, c0, c1 = (int(x) for x in box)
    cand = _candidates(meshes, groups)
    best_c, best_t, best_uv = nearest_hits(cand, camera, box, rays)
    valid, origin, direction = rays
    hit = best_c >= 0
    obj = np.zeros(best_c.shape, np.int32)
    obj[hit] = cand.object_id[best_c[hit]]
    u, v = best_uv[..., 0], best_uv[..., 1]
    nrm = cand.normals[np.maximum(best_c, 0)]
    n = (1.0 - u - v)[..., None] * nrm[..., 0, :] + u[..., None] * nrm[..., 1, :] + v[..., None] * nrm[..., 2, :]
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    is_reflector = np.isin(obj, [o for o in scene.reflector_ids])
    drawn = hit & ~is_reflector
    colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    colour = np.zeros(best_c.shape + (3,), np.float32)
    colour[drawn] = shade(n[drawn], colors[obj[drawn]])
    rid = np.where(drawn, obj, 0).astype(np.int32)
    reflectors = {}
    H, W = stencil.shape
    for b in (int(x) for x in np.unique(obj[hit & is_reflector])):
        m = hit & (obj == b)
        mask = np.zeros((H, W), bool)
        mask[r0:r1, c0:c1] = m
        point, normal, dist = np.zeros((H, W, 3)), np.zeros((H, W, 3)), np.zeros((H, W))
        point[r0:r1, c0:c1][m] = origin[m] + best_t[m][:, None] * direction[m]
        normal[r0:r1, c0:c1][m] = n[m]
        dist[r0:r1, c0:c1][m] = best_t[m] * np.linalg.norm(direction[m], axis=1)
        reflectors[b] = (mask, point, normal, dist)
    return colour, rid, drawn, reflectors


def exact_bounces(level, reflectors, eye, path, direction, camera_eye):
    """The next level's :class:`Bounce` s from :func:`exact_level`'s ``reflectors``: each
    pixel's eye ``eye`` (H, W, 3) (the ray's origin), path length to it ``path`` (H, W) and the
    camera's ray direction ``direction`` (H, W, 3)."""
    out = []
    for b, (mask, point, normal, dist) in sorted(reflectors.items()):
        m = mask[..., None]
        out.append(Bounce(level, b, mask, point, normal, np.where(m, eye, 0.0), np.where(mask, path + dist, 0.0),
                          np.where(m, direction, 0.0), camera_eye))
    return out


def blend(colour, rid, covered, depth, box, bounce: Bounce, deeper, scene):
    """Composite a later level's picture ``deeper`` (:func:`draw_bounce`) into an earlier one's
    arrays over ``box``, in place, where ``bounce.mask``: the reflector's own shade blended with
    its reflection by its reflectivity where the reflection covers (``rho * reflection + (1 -
    rho) * own``, as the frame composites), its own shade elsewhere; the reflected object id and
    the depth the later level's."""
    r0, r1, c0, c1 = box
    b0, b1, d0, d1 = deeper[0]
    col2, rid2, cov2, dep2 = deeper[1:]
    obj = scene.objects[bounce.reflector - 1]
    m = bounce.mask[b0:b1, d0:d1]
    own = shade(bounce.normal[b0:b1, d0:d1][m], np.asarray(obj.color, np.float32)).astype(np.float32)
    rho = np.float32(obj.reflectivity)
    mix = np.where(cov2[m][:, None], rho * col2[m] + (np.float32(1) - rho) * own, own)
    sl = (slice(b0 - r0, b1 - r0), slice(d0 - c0, d1 - c0))
    colour[sl][m] = mix
    rid[sl][m] = rid2[m]
    covered[sl][m] = True
    depth[sl][m] = dep2[m]


def deepen(scene, view, k, stencil, box, out, refl, parts, opt, search_first):
    """After level 1 of reflector ``k`` (its :class:`~refsoft.seam.ReflectorResult` ``out`` over
    ``box``, its reflection ``refl`` and virtual ``parts``): the reflectors seen in its image and
    every later level, composited into ``out`` in place, with the per-pixel depth.

    ``search_first(vertices)`` gives the first level's virtual vertices (N, 3) float64 and flags
    of other vertices (the reflectors'), as the method computes its own.

    Returns
    -------
    list of dict
        The first level's (level 1: the other reflectors' vertices searched on this one's
        G-buffer), then one per later bounce drawn (:func:`draw_bounce`'s report).
    """
    first = {"level": 1, "reflector": int(k), "pixels": int(stencil.sum()), "searched": 0}
    report = [first]
    r0, r1, c0, c1 = box
    depth = np.where(stencil[r0:r1, c0:c1], np.int8(1), np.int8(0)).astype(np.int8)
    found = []  # the other reflectors' vertices searched on this one: (ids, vertices, virtual, flags)
    gb = refl.gbuffer
    position = np.where(gb.mask[..., None], gb.position.astype(np.float64) + gb.origin, 0.0)
    for b in scene.reflector_ids:
        if b == k or not may_see(position, gb.normal, np.asarray(view.camera.eye, np.float64), gb.mask,
                                 *bounding_sphere(view.meshes[b - 1])):
            continue  # no reflected ray of this reflector comes near b
        virtual, flags = search_first(view.meshes[b - 1].vertices)
        first["searched"] += int(len(virtual))
        found.append(([b], np.asarray(view.meshes[b - 1].vertices, np.float64), virtual, flags))
    if not found:
        bounces = []
    elif opt.images == "all":  # the reflectors seen where each pixel's reflected ray meets them first
        from .several import pixel_rays

        camera = view.camera
        rays = pixel_rays(camera, view.meshes[k - 1], view.view.triangle, stencil, box)
        ids = [j for j, o in enumerate(scene.objects, start=1) if not o.reflector]
        virtual = refl.virtual64 if refl.virtual64 is not None else refl.virtual.astype(np.float64)
        _, _, _, seen = exact_level(scene, view.meshes, [(ids, view.vertices, virtual, refl.result.flags)] + found,
                                    camera, stencil, box, rays)
        eye = np.zeros(stencil.shape + (3,))
        eye[r0:r1, c0:c1] = rays[1]
        to = eye - np.asarray(camera.eye, np.float64)
        path = np.where(stencil, np.linalg.norm(to, axis=-1), 0.0)
        direction = to / np.maximum(path, 1e-300)[..., None]
        bounces = exact_bounces(2, seen, eye, path, direction, np.asarray(camera.eye, np.float64))
    else:
        rparts = sum((object_parts(view.meshes, b, v, fl) for b, _, v, fl in found), [])
        bounces = first_bounces(view.camera, view.meshes, k, view.view.triangle,
                                seen_reflectors(parts, rparts, view.camera, stencil, box))
    colour, rid, covered = out.colour.copy(), out.reflected_id.copy(), out.covered.copy()
    for bounce in bounces:
        deeper = draw_bounce(scene, view.meshes, bounce, view.camera, view.vertices, opt, opt.bounces, report)
        blend(colour, rid, covered, depth, box, bounce, deeper, scene)
    out.colour, out.reflected_id, out.covered = colour, rid, covered
    out.pixels = {**out.pixels, BOUNCE_DEPTH: depth}
    out.pixel_mask = stencil[r0:r1, c0:c1].copy()
    return report

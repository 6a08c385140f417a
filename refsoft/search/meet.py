"""What the rays of a level of several bounces (spec section 5.1) can meet, and the candidates of
its exact per-pixel acceptance (:mod:`refsoft.search.levels`).

Only what cannot change a pixel is left out: an object none of a level's rays passes through the
bounding sphere of (:func:`hits`, :func:`reached`), and, where the rays are few
(``BOUNCE_FEW_RAYS``), a face one of whose corners no ray passes within the face's longest edge
of (:func:`met`; kernels in :mod:`refsoft.search._bounces`): the hit of a ray on a triangle lies
within that edge of each corner. A ray may be a segment (a fourth array of lengths): at the first
level a scene triangle matters only up to the reflector a ray meets.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import constants
from .._parallel import parallel_range
from ..raster._threads import SERIAL_MAX_VERTICES
from . import CULLED, HIDDEN, _bounces, acceptance
from ._several import accept, accept_near
from .bounces import bounding_sphere


def edges(mesh, longest=False):
    """Each face's longest edge (F,) float64, or with ``longest`` the longest of them (0.0 without
    faces); the last answers kept by mesh (the meshes of static objects are the same frame after
    frame)."""
    hit = _EDGES.get(id(mesh))
    if hit is None or hit[0] is not mesh:
        corners = np.asarray(mesh.vertices, np.float64)[mesh.faces]
        out = np.max(np.linalg.norm(corners - corners[:, [1, 2, 0]], axis=2), axis=1)
        if len(_EDGES) >= 256:
            _EDGES.pop(next(iter(_EDGES)))
        hit = _EDGES[id(mesh)] = (mesh, out, float(out.max()) if len(out) else 0.0)
    return hit[2] if longest else hit[1]


_EDGES = {}


def _objects(meshes, ids, *arrays):
    """Per object of ``ids``: (id, mesh, its rows of each of ``arrays`` (the objects' vertices
    consecutive in that order))."""
    start = 0
    for k in ids:
        mesh = meshes[k - 1]
        sl = slice(start, start + mesh.n_vertices)
        start += mesh.n_vertices
        yield (k, mesh) + tuple(a[sl] for a in arrays)


def candidates(meshes, groups, near=None, rays=None):
    """Candidates of :func:`refsoft.search.acceptance.draw` from ``groups``: (object ids, their
    vertices (n, 3) world, virtual vertices (n, 3), flags (n,)) each, the objects' vertices
    consecutive in that order. A triangle with a CULLED corner is left out; one with a HIDDEN
    corner (its virtual vertex is where its walk stopped, not its image) is tried over the whole
    box (the draw's rule for a corner it cannot project). With ``near = (camera, box)`` only the
    triangles whose dilated bounds may meet ``box`` (:func:`_near`) are kept; with ``rays`` (the
    valid ones, at most BOUNCE_FEW_RAYS) only those one of the rays can meet (:func:`met`).
    Returns the candidates, in the order of the groups, their objects and faces, and, per group,
    how many it gave."""
    from .acceptance import Candidates

    virtual, real, normals, obj, tri, counts = [], [], [], [], [], []
    for ids, verts, virt, flags in groups:
        counts.append(0)
        parts = _objects(meshes, ids, np.asarray(verts, np.float64), np.asarray(virt, np.float64), flags)
        closes = rays_near(meshes, ids, rays) if rays is not None else [None] * len(ids)
        for (k, mesh, vs, vt, fl), close in zip(parts, closes):
            culled = (fl & np.uint8(CULLED)) != 0
            if culled.all():
                continue  # not searched, or out of every ray's reach
            f = mesh.faces
            keep = ~(culled[f[:, 0]] | culled[f[:, 1]] | culled[f[:, 2]])
            if rays is not None and keep.any():
                keep[keep] = met(vs, f[keep], edges(mesh)[keep], close) if len(close[0]) else False
            hidden = (fl & np.uint8(HIDDEN)) != 0
            if near is not None and keep.any():
                fk = f[keep]
                used = np.zeros(len(vt), bool)
                used[fk] = True  # the kept faces' corners only (each point's pixel is its own)
                px = np.full((len(vt), 2), np.nan)
                px[used] = _pixels(np.where(hidden[used][:, None], np.nan, vt[used]), near[0])
                keep[keep] = _near(px[fk], near[1])
            if not keep.any():
                continue
            f = f[keep]
            v = vt[f]
            v[hidden[f]] = np.nan
            virtual.append(v)
            real.append(vs[f])
            normals.append(np.asarray(mesh.normals, np.float64)[f])
            obj.append(np.full(len(f), k, np.int32))
            tri.append(np.flatnonzero(keep))
            counts[-1] += len(f)
    cat = (lambda x, shape: np.ascontiguousarray(np.concatenate(x)) if x else np.zeros(shape))
    cand = Candidates(cat(virtual, (0, 3, 3)), cat(real, (0, 3, 3)), cat(normals, (0, 3, 3)),
                      cat(obj, (0,)).astype(np.int32), cat(tri, (0,)).astype(np.int64), 0)
    return cand, counts


def met(verts, faces, edge, rays):
    """(T,) bool: the faces a ray can meet. A ray meeting a triangle passes within its longest
    edge of each of its corners (the hit lies in the triangle), so a face is kept when each of
    its corners lies within that distance (and 1e-9 of it) of one of the rays (origin (P, 3),
    direction (P, 3), the part ahead of the origin, and optionally its length (P,): a segment)."""
    origin, direction = rays[:2]
    length = np.ascontiguousarray(rays[2], np.float64) if len(rays) > 2 else np.full(len(origin), np.inf)
    d = np.ascontiguousarray(direction / np.maximum(np.linalg.norm(direction, axis=1, keepdims=True), 1e-300))
    origin = np.ascontiguousarray(origin, np.float64)
    faces = np.asarray(faces)
    if 3 * len(faces) < len(verts):  # a few faces of many vertices: their corners' distances only
        used = np.zeros(len(verts), bool)
        used[faces] = True
        index = np.cumsum(used) - 1
        verts, faces = verts[used], index[faces]
    near = np.full(len(verts), np.inf)
    some = np.ones(len(verts), bool)
    if len(faces) and np.all(np.isfinite(length)):  # segments: a corner near one lies in their box, widened
        grow = float(np.max(edge)) * (1.0 + 1e-6) + 1e-9
        end = origin + length[:, None] * d
        lo = np.minimum(origin, end).min(axis=0) - grow
        hi = np.maximum(origin, end).max(axis=0) + grow
        some = np.all((verts >= lo) & (verts <= hi), axis=1)
    v = np.ascontiguousarray(verts[some] if not some.all() else verts, np.float64)
    part = np.empty(len(v))
    parallel_range(_bounces.ray_distances, len(v), v, origin, d, length, part,
                   serial=len(v) * len(origin) <= SERIAL_MAX_VERTICES)
    near[some] = part
    out = np.empty(len(faces), bool)
    parallel_range(_bounces.faces_within, len(faces), np.ascontiguousarray(faces), near,
                   np.ascontiguousarray(edge, np.float64), out, serial=len(faces) <= SERIAL_MAX_VERTICES)
    return out


def rays_near(meshes, ids, rays):
    """Per object of ``ids``, those of a few rays (:func:`few`) that pass within its longest face
    edge of its bounding sphere (:func:`hits`, every object at once), as a few rays: any other is
    farther than that edge from every vertex of the object, so that :func:`met` keeps the same
    faces without it."""
    spheres = []
    for k in ids:
        mesh = meshes[k - 1]
        centre, radius = bounding_sphere(mesh)
        grow = edges(mesh, longest=True) * (1.0 + 1e-6)
        spheres.append((centre, radius + grow))
    near = hits((np.ones(len(rays[0]), bool),) + tuple(rays), spheres)
    return [tuple(a[m] for a in rays) for m in near]


def narrowed(meshes, ids, verts, rays, want):
    """``want`` (n,) bool over the vertices of objects ``ids`` (consecutive in ``verts`` (n, 3),
    in that order), narrowed, when the level's rays are few (:func:`few`), to the corners of
    the faces with every corner wanted that one of the rays can meet (:func:`met`, the test
    :func:`candidates` applies): no other vertex's image can be drawn."""
    some = few(rays)
    if some is None:
        return want
    out = np.zeros(len(verts), bool)
    parts = _objects(meshes, ids, np.asarray(verts, np.float64), want, out)
    for (k, mesh, vs, wa, ou), near in zip(parts, rays_near(meshes, ids, some)):
        if not len(some[0]) or not wa.any():
            continue
        if not len(near[0]):
            continue  # no ray comes within an edge of the object's bounds
        f = mesh.faces
        keep = wa[f[:, 0]] & wa[f[:, 1]] & wa[f[:, 2]]
        if keep.any():
            keep[keep] = met(vs, f[keep], edges(mesh)[keep], near)
            ou[f[keep]] = True  # a view of ``out``
    return out


def few(rays):
    """The valid rays of ``rays`` (valid, origin, direction[, length]) as (origin (P, 3),
    direction (P, 3)[, length (P,)]) when there are at most BOUNCE_FEW_RAYS of them, else None."""
    from .. import constants

    valid = rays[0]
    if valid.sum() > constants.BOUNCE_FEW_RAYS:
        return None
    return tuple(a[valid] for a in rays[1:])


def _pixels(virtual, camera):
    """View (x, y) of points (N, 3) (pixel units, x along a row); NaN for a point at or behind
    the eye plane or not finite."""
    from ..raster import _setup

    clip = _setup.transform_points(np.where(np.isfinite(virtual), virtual, 0.0), camera.view_proj())
    w = clip[:, 3]
    good = (w > 0) & np.all(np.isfinite(virtual), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (clip[:, 0] / w + 1.0) * 0.5 * camera.width
        y = (1.0 - clip[:, 1] / w) * 0.5 * camera.height
    return np.where(good[:, None], np.stack([x, y], axis=1), np.nan)


def _near(corners, box):
    """Per triangle (T, 3, 2 view x, y) whether its bounds, dilated as the draw dilates them
    (SEVERAL_DILATE_PIXELS plus SEVERAL_DILATE_FRACTION of its longest edge, no more than of its
    box's width plus height), may meet ``box`` (r0, r1, c0, c1); True for a corner it cannot
    project."""
    from .. import constants

    lo, hi = corners.min(axis=1), corners.max(axis=1)
    grow = constants.SEVERAL_DILATE_PIXELS + constants.SEVERAL_DILATE_FRACTION * np.sum(hi - lo, axis=1) + 1.0
    r0, r1, c0, c1 = box
    with np.errstate(invalid="ignore"):
        meets = ((lo[:, 0] - grow < c1) & (hi[:, 0] + grow > c0) & (lo[:, 1] - grow < r1) & (hi[:, 1] + grow > r0))
    return meets | ~np.all(np.isfinite(corners), axis=(1, 2))


def _bounds(cand, camera, box):
    """The candidates' dilated bounds over ``box``: (C, 4) view rows and columns, clipped."""
    r0, r1, c0, c1 = box
    with np.errstate(invalid="ignore"):  # the hidden corners' NaN bounds, replaced by the box
        screen, bbox, dilate = acceptance._screen(cand.virtual, camera, box)
    rows = np.clip(bbox[:, 0:2] + r0, r0, r1)  # the draw's rows are the box's, its columns the view's
    cols = np.clip(bbox[:, 2:4], c0, c1)
    return screen, bbox, dilate, np.concatenate([rows, cols], axis=1)


def hits(rays, spheres):
    """(K, M) bool: which of the valid rays (M,) (:func:`valid_rays`) pass through each of ``spheres``
    ((centre (3,), radius) each) ahead of their origin or start inside it (a ray that meets a
    triangle inside a sphere does; the radius is widened by 1e-9 of itself and of the distance for
    rounding; with a 4th array, the rays' lengths (M,), segments). Every sphere at once, each
    pair's arithmetic its own."""
    origin, direction = rays[1:3]
    if not len(spheres):
        return np.zeros((0, len(origin)), bool)
    d = direction / np.maximum(np.linalg.norm(direction, axis=-1, keepdims=True), 1e-300)
    centre = np.array([c for c, _ in spheres], np.float64)[:, None, :]
    radius = np.array([r for _, r in spheres], np.float64)[:, None]
    cp = centre - origin
    dist = np.linalg.norm(cp, axis=-1)
    t = np.maximum(np.sum(cp * d, axis=-1), 0.0)
    if len(rays) > 3:
        t = np.minimum(t, rays[3])
    miss = np.linalg.norm(cp - t[..., None] * d, axis=-1)
    return miss <= radius * (1.0 + 1e-9) + 1e-9 * dist


def towards(rays, spheres):
    """(h, w) bool: the valid rays of ``rays`` that pass through one of ``spheres``
    (:func:`hits`)."""
    out = np.zeros(rays[0].shape, bool)
    out[rays[0]] = hits(valid_rays(rays), spheres).any(axis=0)
    return out


def valid_rays(rays):
    """The valid rays of ``rays`` alone, as rays (M,) (with their lengths, if given)."""
    valid = rays[0]
    return (np.ones(int(valid.sum()), bool),) + tuple(a[valid] for a in rays[1:])


def reaching(meshes, ids, rays):
    """{object id: whether one of the valid rays (:func:`valid_rays`) passes through its bounding
    sphere} for ``ids``."""
    ids = list(ids)
    hit = hits(rays, [bounding_sphere(meshes[k - 1]) for k in ids]).any(axis=1)
    return dict(zip(ids, (bool(x) for x in hit)))


def reached(meshes, group, rays):
    """``group`` (:func:`candidates`) with the vertices of every object whose bounding sphere no
    ray of ``rays`` meets flagged CULLED (none of its triangles can be hit)."""
    ids, verts, virtual, flags = group
    sizes = [meshes[k - 1].n_vertices for k in ids]
    reached = reaching(meshes, ids, valid_rays(rays))
    hit = [reached[k] for k in ids]
    if all(hit):
        return group
    return ids, verts, virtual, np.where(np.repeat(hit, sizes), flags, np.uint8(CULLED)).astype(np.uint8)


def joined(a, b):
    """Two sets of candidates as one, ``a``'s first; their ray lists (made for the same rays) one
    after the other, a set without lists tested at every pixel it covers (``first`` -1)."""
    rays = None
    if a.rays is not None or b.rays is not None:
        parts, size = [], 0
        for c in (a, b):
            n = len(c.object_id)
            if c.rays is None:
                first, last, ray = np.full(n, -1, np.int64), np.full(n, -1, np.int64), np.zeros(0, np.int64)
            else:
                first, last, ray = (np.asarray(x, np.int64) for x in c.rays)
            shift = np.where(first >= 0, size, 0)  # -1 stays: no list
            parts.append((first + shift, last + shift, ray))
            size += len(ray)
        rays = tuple(np.concatenate([p[i] for p in parts]) for i in range(3))
    return replace(a, rays=rays, **{name: np.concatenate([getattr(a, name), getattr(b, name)])
                                    for name in ("virtual", "real", "normals", "object_id", "triangle")})


def nearest_near(cand, camera, box, rays):
    """:func:`nearest_hits` of candidates with ray lists (:class:`refsoft.search.acceptance.Candidates`'
    ``rays``, made for the valid rays of ``rays`` in row-major order): each candidate is met only
    by the rays of its list (kernel ``accept_near``, as :func:`refsoft.search.acceptance.draw`
    does; the others miss its triangle), so the answer is :func:`nearest_hits`'."""
    return _nearest(cand, camera, box, rays, cand.rays is not None)


def nearest_hits(cand, camera, box, rays):
    """Per pixel of ``box`` the candidate whose real triangle the pixel's ray meets nearest, among
    those whose dilated virtual triangle covers it (:func:`refsoft.search.acceptance.draw`'s
    acceptance): ``(candidate (h, w) int64, -1 none; t (h, w); barycentrics u, v (h, w, 2))``."""
    return _nearest(cand, camera, box, rays, False)


def _nearest(cand, camera, box, rays, near):
    """:func:`nearest_hits` (``near`` False: every pixel a candidate covers) or
    :func:`nearest_near` (True: each candidate's ray list)."""
    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    valid, origin, direction = (np.ascontiguousarray(a) for a in rays)
    best_t = np.full((h, w), np.inf)
    best_c = np.full((h, w), -1, np.int64)
    best_uv = np.zeros((h, w, 2))
    if len(cand.real) and valid.any():
        screen, bbox, dilate, _ = _bounds(cand, camera, (r0, r1, c0, c1))
        real = np.ascontiguousarray(cand.real)
        tested, seen = np.zeros((h, w), bool), np.full((h, w), -1, np.int64)
        if near:
            rows, cols = np.nonzero(valid)
            first, last, ray = (np.ascontiguousarray(a, np.int64) for a in cand.rays)
            parallel_range(accept_near, h, r0, c0, valid, acceptance._spans(valid), origin, direction, rows, cols,
                           np.ascontiguousarray(origin[valid]), np.ascontiguousarray(direction[valid]), screen,
                           bbox, dilate, real, acceptance._runs(real), first, last, ray, best_t, best_c, best_uv,
                           tested, seen)
        else:
            parallel_range(accept, h, r0, c0, valid, acceptance._spans(valid), origin, direction, screen, bbox,
                           dilate, real, acceptance._runs(real), best_t, best_c, best_uv, tested, seen)
    return best_c, best_t, best_uv


# --- a reflector that sees itself -------------------------------------------------------------
def sees_itself(scene, k):
    """Whether reflector ``k`` can reflect a ray onto itself: not a convex closed body nor a plane
    (:func:`refsoft.search.convex.several_possible` of its drawn mesh, the truth's rule)."""
    from .convex import several_possible

    return several_possible(scene.objects[k - 1].mesh)


def self_offset(mesh):
    """How far along its ray a ray leaving a reflector that sees itself starts when it is met with
    the reflectors: ``TRUTH_SELF_OFFSET`` times the mesh's bounding-box diagonal, as the truth
    traces it (:mod:`refsoft.truth.paths`): the ray's own triangle is not met again at ``t ~ 0``."""
    from .. import constants

    v = np.asarray(mesh.vertices, np.float64)
    return constants.TRUTH_SELF_OFFSET * float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


def moved(rays, offset):
    """``rays`` (valid, origin, direction) with each valid origin moved ``offset`` along its unit
    direction, and each ray's ``offset`` as a parameter of its own direction (h, w) (0 where not
    valid): the parameter from the true origin is the moved one's plus it."""
    valid, origin, direction = rays
    length = np.linalg.norm(direction, axis=-1)
    shift = np.where(valid, offset / np.maximum(length, 1e-300), 0.0)
    return (valid, np.ascontiguousarray(origin + shift[..., None] * direction), direction), shift


def nearest_split(scene_cand, ref_cand, camera, box, rays, offset):
    """:func:`nearest_hits` of ``scene_cand`` from the rays' own origins and of ``ref_cand`` (the
    reflectors') from origins moved ``offset`` along them (:func:`moved`), the nearer kept (the
    scene's at a tie, as the truth keeps it): ``(source (h, w) int8: 0 none, 1 scene, 2
    reflectors; candidate (h, w) int64 into its set; t (h, w) from the true origin; u, v (h, w,
    2))``."""
    shifted, shift = moved(rays, offset)
    rc, rt, ruv = nearest_near(ref_cand, camera, box, shifted)
    meets = rc >= 0
    sc, st, suv = nearest_near(scene_cand, camera, box, rays)
    rt = rt + shift
    ref = meets & ~(st <= rt)
    src = np.where(ref, np.int8(2), np.where(sc >= 0, np.int8(1), np.int8(0))).astype(np.int8)
    return src, np.where(ref, rc, sc), np.where(ref, rt, st), np.where(ref[..., None], ruv, suv)



# --- the rays' pruning, tile by tile ----------------------------------------------------------


def near_rays(verts, normals, faces, face_obj, rays):
    """:func:`refsoft.search.reach.near_rays` of a level's rays over its box, the same candidates
    with the same ray lists, each triangle testing only the rays of the tiles that may come near
    it.

    A tile's rays (:data:`refsoft.constants.RAY_TILE` pixels a side, and coarse tiles of four of
    them a side) are bounded by a sphere about their origins and a cone about their directions; a
    triangle by the sphere about its centroid that holds it widened by the pruning's margin
    (``SEVERAL_PRUNE_MARGIN`` in its barycentrics). A tile none of whose rays' lines can pass
    through that sphere, nor lie within twice ``SEVERAL_PRUNE_PARALLEL``'s angle of the
    triangle's plane, holds no ray the pruning keeps (kernel
    :func:`refsoft.search._bounces.rays_by_tiles`); the rays of the others are tested one by one
    with :func:`refsoft.search._several.rays_near`'s test, in ascending order, as
    :func:`refsoft.search.reach.near_rays` tests every ray.

    Parameters
    ----------
    verts, normals : (N, 3) float64
    faces : (F, 3) int64
    face_obj : (F,) int32
    rays : (valid (h, w) bool, origin (h, w, 3), direction (h, w, 3)) float64
        A ray is the index of a valid pixel in row-major order.

    Returns
    -------
    Candidates
    """
    from .. import constants

    valid, origin, direction = rays
    margin, parallel = float(constants.SEVERAL_PRUNE_MARGIN), float(constants.SEVERAL_PRUNE_PARALLEL)
    verts = np.asarray(verts, np.float64)
    faces = np.asarray(faces, np.int64).reshape(-1, 3)
    real = np.ascontiguousarray(verts[faces])
    o, d = origin[valid].astype(np.float64), direction[valid].astype(np.float64)
    length = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])  # _several's arithmetic
    columns = np.ascontiguousarray(np.concatenate([o.T, d.T, length[None]]))
    index = np.full(valid.shape, -1, np.int64)
    index[valid] = np.arange(len(o))
    tile = constants.RAY_TILE
    fine, coarse = _tiles(valid, origin, direction, tile), _tiles(valid, origin, direction, 4 * tile)
    args = (_triangles(real, margin, parallel), coarse, fine, index, tile, real, columns, margin, parallel)
    n_faces = len(real)
    count = np.zeros(n_faces, np.int64)
    work = (lambda: (np.empty(coarse.shape[1], np.int64), np.empty(fine.shape[1], np.int64)))
    if n_faces:
        parallel_range(_bounces.rays_by_tiles, n_faces, *args, count, count, np.zeros(0, np.int64), False, work=work)
    start = np.cumsum(count) - count
    out = np.empty(int(count.sum()), np.int64)
    if len(out):
        parallel_range(_bounces.rays_by_tiles, n_faces, *args, count, start, out, True, work=work)
    src = np.flatnonzero(count > 0)
    return acceptance.Candidates(np.full((len(src), 3, 3), np.nan), real[src], np.asarray(normals, np.float64)[faces[src]],
                                 np.asarray(face_obj, np.int32)[src], src, 0,
                                 (start[src], start[src] + count[src], out))


def _tiles(valid, origin, direction, size):
    """Each tile's bounds (``size`` pixels a side; :func:`near_rays`), (TR, TC, 11) float64: its
    origins' centre and radius, its directions' unit axis, the cosine and sine of the cone's
    half-angle, 1 where it holds a ray, 1 where it is kept for every triangle (a value not
    finite, or a cone as wide as a half-space)."""
    h, w = valid.shape
    tr, tc = -(-h // size), -(-w // size)
    pad = ((0, tr * size - h), (0, tc * size - w))

    def blocks(a):
        a = np.pad(a, pad + ((0, 0),) * (a.ndim - 2))
        return a.reshape((tr, size, tc, size) + a.shape[2:]).swapaxes(1, 2).reshape((tr, tc, size * size) + a.shape[2:])

    v = blocks(valid)
    o, d = blocks(np.where(valid[..., None], origin, 0.0)), blocks(np.where(valid[..., None], direction, 0.0))
    n = v.sum(axis=2)
    out = np.zeros((tr, tc, 11))
    with np.errstate(invalid="ignore", divide="ignore"):
        bad = ~np.all(np.isfinite(o) & np.isfinite(d), axis=(2, 3))
        o, d = np.where(bad[..., None, None], 0.0, o), np.where(bad[..., None, None], 0.0, d)
        centre = o.sum(axis=2) / np.maximum(n, 1)[..., None]
        radius = np.max(np.where(v, np.linalg.norm(o - centre[:, :, None], axis=3), 0.0), axis=2)
        unit = np.where(v[..., None], d / np.linalg.norm(d, axis=3, keepdims=True), 0.0)
        mean = unit.sum(axis=2)
        axis = mean / np.linalg.norm(mean, axis=2, keepdims=True)
        cross = np.linalg.norm(np.cross(unit, axis[:, :, None]), axis=3)
        dots = np.sum(unit * axis[:, :, None], axis=3)
        alpha = np.max(np.where(v, np.arctan2(cross, dots), 0.0), axis=2) + constants.TILE_ANGLE_SLACK
    always = bad | ~np.all(np.isfinite(axis), axis=2) | ~np.isfinite(alpha) | ~(alpha < 0.5 * np.pi)
    out[..., :3] = centre
    out[..., 3] = radius * (1.0 + constants.TILE_RADIUS_SLACK)
    out[..., 4:7] = np.where(always[..., None], 0.0, axis)
    out[..., 7] = np.where(always, 0.0, np.cos(np.where(always, 0.0, alpha)))
    out[..., 8] = np.where(always, 1.0, np.sin(np.where(always, 0.0, alpha)))
    out[..., 9] = n > 0
    out[..., 10] = always & (n > 0)
    return np.ascontiguousarray(out)


def _triangles(real, margin, parallel):
    """Each triangle's bounds (:func:`near_rays`), (F, 10) float64: centroid, the radius about it
    that holds it widened by ``margin`` in its barycentrics, unit normal, the sine and cosine of
    the angle to its plane within which :func:`refsoft.search._several.rays_near` keeps a ray as
    parallel (twice that, and the slack), and 1 where it is degenerate (every ray kept)."""
    centre = real.mean(axis=1)
    rho = (1.0 + 3.0 * margin) * np.max(np.linalg.norm(real - centre[:, None], axis=2), axis=1)
    e1, e2 = real[:, 1] - real[:, 0], real[:, 2] - real[:, 0]
    cross = np.cross(e1, e2)
    area = np.linalg.norm(cross, axis=1)
    edges = np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal = cross / area[:, None]
        # |cos(d, n)| <= parallel |e1| |e2| / |e1 x e2|: within asin of that of the plane
        eps = np.arcsin(np.clip(2.0 * parallel * edges / area, 0.0, 1.0)) + constants.TILE_ANGLE_SLACK
    always = ~(area > 0) | ~np.all(np.isfinite(normal), axis=1) | ~np.isfinite(rho) | ~(eps < 0.5 * np.pi)
    out = np.zeros((len(real), 10))
    out[:, :3] = centre
    out[:, 3] = np.where(always, 0.0, rho * (1.0 + constants.TILE_RADIUS_SLACK))
    out[:, 4:7] = np.where(always[:, None], 0.0, normal)
    out[:, 7] = np.where(always, 1.0, np.sin(np.where(always, 0.0, eps)))
    out[:, 8] = np.where(always, 0.0, np.cos(np.where(always, 0.0, eps)))
    out[:, 9] = always
    return np.ascontiguousarray(out)

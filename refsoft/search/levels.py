"""Several bounces (spec section 5.1): the levels drawn, one inside the other.

Level 1 is the method of one bounce. With ``bounces = N > 1`` the other reflectors' vertices are
searched on each reflector's G-buffer like the scene's; where one of them, ``b``, is the nearest
thing a pixel's reflection shows, those pixels are a :class:`~refsoft.search.bounces.Bounce`:
level 2's stencil and G-buffer (``b``'s position and normal where the pixel's reflected ray
meets it, each pixel's eye the first bounce point). Level 2 is searched and drawn in its stencil,
the reflectors seen in it give level 3, and so on to level N. A level's picture is composited
into the one before it as the frame composites a reflector: ``rho * reflection + (1 - rho) * the
reflector's own shade``.

Under the accurate preset (``images = "all"``) what a pixel shows at a level is decided by
exact per-pixel acceptance (:func:`exact_level`): its reflected ray is met with the real
triangles whose virtual triangles, from the level's search, cover it (dilated), the nearest hit
drawn (:func:`refsoft.search.acceptance.draw`'s rule). Under the paper preset the reflectors'
virtual triangles are rasterized with the scene's (:func:`refsoft.search.bounces.seen_reflectors`)
and a later level drawn by the virtual pass.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from .. import keys
from .._parallel import parallel_range
from ..raster import shade
from ..raster._threads import SERIAL_MAX_VERTICES
from . import CULLED, HIDDEN, _bounces, acceptance
from ._several import accept
from .bounces import (Bounce, bounding_sphere, first_bounces, gbuffer_of, later_bounces, level_rays, make_bounce,
                      object_parts, reaches, search_bounce, seen_reflectors, texel_reach, unfolded)
from .virtual import virtual_pass

#: The per-pixel array of the reflections taken (0 off reflectors).
BOUNCE_DEPTH = keys.BOUNCE_DEPTH


# --- exact acceptance -----------------------------------------------------------------------
def _edges(mesh, longest=False):
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


def _candidates(meshes, groups, near=None, rays=None):
    """Candidates of :func:`refsoft.search.acceptance.draw` from ``groups``: (object ids, their
    vertices (n, 3) world, virtual vertices (n, 3), flags (n,)) each, the objects' vertices
    consecutive in that order. A triangle with a CULLED corner is left out; one with a HIDDEN
    corner (its virtual vertex is where its walk stopped, not its image) is tried over the whole
    box (the draw's rule for a corner it cannot project). With ``near = (camera, box)`` only the
    triangles whose dilated bounds may meet ``box`` (:func:`_near`) are kept; with ``rays`` (the
    valid ones, at most BOUNCE_FEW_RAYS) only those one of the rays can meet (:func:`_met`).
    Returns the candidates, in the order of the groups, their objects and faces, and, per group,
    how many it gave."""
    from .acceptance import Candidates

    virtual, real, normals, obj, tri, counts = [], [], [], [], [], []
    for ids, verts, virt, flags in groups:
        counts.append(0)
        parts = _objects(meshes, ids, np.asarray(verts, np.float64), np.asarray(virt, np.float64), flags)
        closes = _rays_near(meshes, ids, rays) if rays is not None else [None] * len(ids)
        for (k, mesh, vs, vt, fl), close in zip(parts, closes):
            culled = (fl & np.uint8(CULLED)) != 0
            if culled.all():
                continue  # not searched, or out of every ray's reach
            f = mesh.faces
            keep = ~(culled[f[:, 0]] | culled[f[:, 1]] | culled[f[:, 2]])
            if rays is not None and keep.any():
                keep[keep] = _met(vs, f[keep], _edges(mesh)[keep], close) if len(close[0]) else False
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


def _met(verts, faces, edge, rays):
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


def _rays_near(meshes, ids, rays):
    """Per object of ``ids``, those of a few rays (:func:`_few`) that pass within its longest face
    edge of its bounding sphere (:func:`_hits`, every object at once), as a few rays: any other is
    farther than that edge from every vertex of the object, so that :func:`_met` keeps the same
    faces without it."""
    spheres = []
    for k in ids:
        mesh = meshes[k - 1]
        centre, radius = bounding_sphere(mesh)
        grow = _edges(mesh, longest=True) * (1.0 + 1e-6)
        spheres.append((centre, radius + grow))
    near = _hits((np.ones(len(rays[0]), bool),) + tuple(rays), spheres)
    return [tuple(a[m] for a in rays) for m in near]


def _narrowed(meshes, ids, verts, rays, want):
    """``want`` (n,) bool over the vertices of objects ``ids`` (consecutive in ``verts`` (n, 3),
    in that order), narrowed, when the level's rays are few (:func:`_few`), to the corners of
    the faces with every corner wanted that one of the rays can meet (:func:`_met`, the test
    :func:`_candidates` applies): no other vertex's image can be drawn."""
    few = _few(rays)
    if few is None:
        return want
    out = np.zeros(len(verts), bool)
    parts = _objects(meshes, ids, np.asarray(verts, np.float64), want, out)
    for (k, mesh, vs, wa, ou), near in zip(parts, _rays_near(meshes, ids, few)):
        if not len(few[0]) or not wa.any():
            continue
        if not len(near[0]):
            continue  # no ray comes within an edge of the object's bounds
        f = mesh.faces
        keep = wa[f[:, 0]] & wa[f[:, 1]] & wa[f[:, 2]]
        if keep.any():
            keep[keep] = _met(vs, f[keep], _edges(mesh)[keep], near)
            ou[f[keep]] = True  # a view of ``out``
    return out


def _few(rays):
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


def _hits(rays, spheres):
    """(K, M) bool: which of the valid rays (M,) (:func:`_valid`) pass through each of ``spheres``
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


def _towards(rays, spheres):
    """(h, w) bool: the valid rays of ``rays`` that pass through one of ``spheres``
    (:func:`_hits`)."""
    out = np.zeros(rays[0].shape, bool)
    out[rays[0]] = _hits(_valid(rays), spheres).any(axis=0)
    return out


def _valid(rays):
    """The valid rays of ``rays`` alone, as rays (M,) (with their lengths, if given)."""
    valid = rays[0]
    return (np.ones(int(valid.sum()), bool),) + tuple(a[valid] for a in rays[1:])


def _reaching(meshes, ids, rays):
    """{object id: whether one of the valid rays (:func:`_valid`) passes through its bounding
    sphere} for ``ids``."""
    ids = list(ids)
    hit = _hits(rays, [bounding_sphere(meshes[k - 1]) for k in ids]).any(axis=1)
    return dict(zip(ids, (bool(x) for x in hit)))


def _reached(meshes, group, rays):
    """``group`` (:func:`_candidates`) with the vertices of every object whose bounding sphere no
    ray of ``rays`` meets flagged CULLED (none of its triangles can be hit)."""
    ids, verts, virtual, flags = group
    sizes = [meshes[k - 1].n_vertices for k in ids]
    reached = _reaching(meshes, ids, _valid(rays))
    hit = [reached[k] for k in ids]
    if all(hit):
        return group
    return ids, verts, virtual, np.where(np.repeat(hit, sizes), flags, np.uint8(CULLED)).astype(np.uint8)


def _joined(a, b):
    """Two sets of candidates as one, ``a``'s first."""
    return replace(a, **{name: np.concatenate([getattr(a, name), getattr(b, name)])
                         for name in ("virtual", "real", "normals", "object_id", "triangle")})


def nearest_hits(cand, camera, box, rays):
    """Per pixel of ``box`` the candidate whose real triangle the pixel's ray meets nearest, among
    those whose dilated virtual triangle covers it (:func:`refsoft.search.acceptance.draw`'s
    acceptance): ``(candidate (h, w) int64, -1 none; t (h, w); barycentrics u, v (h, w, 2))``."""
    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    valid, origin, direction = (np.ascontiguousarray(a) for a in rays)
    best_t = np.full((h, w), np.inf)
    best_c = np.full((h, w), -1, np.int64)
    best_uv = np.zeros((h, w, 2))
    if len(cand.real) and valid.any():
        screen, bbox, dilate, _ = _bounds(cand, camera, (r0, r1, c0, c1))
        real = np.ascontiguousarray(cand.real)
        parallel_range(accept, h, r0, c0, valid, acceptance._spans(valid), origin, direction, screen, bbox,
                       dilate, real, acceptance._runs(real), best_t, best_c, best_uv, np.zeros((h, w), bool),
                       np.full((h, w), -1, np.int64))
    return best_c, best_t, best_uv


def exact_level(scene, meshes, groups, camera, box, rays, reflectors_only=False):
    """One level drawn by exact per-pixel acceptance: the nearest hit of each pixel's ray among
    the candidates of ``groups`` (:func:`_candidates`; the non-reflectors first, then the
    reflectors searched at this level), shaded as :func:`refsoft.search.acceptance.draw` shades it.

    Parameters
    ----------
    scene, meshes, camera
    groups : list
        As :func:`_candidates`.
    box : (r0, r1, c0, c1)
    rays : (valid (h, w), origin (h, w, 3), direction (h, w, 3))
        Each pixel's reflected ray over ``box`` (``valid``: the level's stencil).
    reflectors_only : bool
        Only the reflectors are wanted: the pixels whose rays meet a reflector's candidate are
        decided, with every candidate, and nothing is drawn.

    Returns
    -------
    colour (h, w, 3) float32, reflected_id (h, w) int32, covered (h, w) bool
        Over ``box``; a pixel showing a reflector shows nothing here (the next level draws it).
    reflectors : dict
        Reflector id -> (mask (h, w) bool, point (h, w, 3), normal (h, w, 3), distance (h, w))
        over ``box``: the pixels where its triangle is the nearest hit, the hit (float64), the
        normal interpolated there and the hit's distance along the ray.
    """
    r0, r1, c0, c1 = (int(x) for x in box)
    h, w = r1 - r0, c1 - c0
    colour, rid, drawn = np.zeros((h, w, 3), np.float32), np.zeros((h, w), np.int32), np.zeros((h, w), bool)
    sub = box
    valid, origin, direction = rays
    if reflectors_only:  # the pixels whose rays meet a reflector, then what is nearest there
        towards = _towards(rays, [bounding_sphere(meshes[k - 1]) for ids, *_ in groups[1:] for k in ids])
        groups = groups[:1] + [_reached(meshes, g, (towards, origin, direction)) for g in groups[1:]]
        ref, _ = _candidates(meshes, groups[1:], near=(camera, box), rays=_few((towards, origin, direction)))
        first, t_first, _ = nearest_hits(ref, camera, box, (valid & towards, origin, direction))
        meet = first >= 0
        if not meet.any():
            return colour, rid, drawn, {}
        rows, cols = np.flatnonzero(meet.any(axis=1)), np.flatnonzero(meet.any(axis=0))
        sub = (r0 + int(rows[0]), r0 + int(rows[-1]) + 1, c0 + int(cols[0]), c0 + int(cols[-1]) + 1)
        valid = valid & meet
        # only a scene triangle met no farther than the reflector's hit can be nearer: the rays up
        # to that hit (and 1e-9 of it), and the scene's objects they can reach
        upto = np.zeros(meet.shape)
        upto[meet] = t_first[meet] * np.linalg.norm(direction[meet], axis=-1) * (1.0 + 1e-9)
        segments = (valid, origin, direction, upto)
        scene_cand, _ = _candidates(meshes, [_reached(meshes, groups[0], segments)], near=(camera, sub),
                                    rays=_few(segments))
        cand = _joined(scene_cand, ref)
    else:
        groups = [_reached(meshes, g, rays) for g in groups]
        cand, _ = _candidates(meshes, groups, near=(camera, box), rays=_few(rays))
    sl = (slice(sub[0] - r0, sub[1] - r0), slice(sub[2] - c0, sub[3] - c0))
    valid, origin, direction = valid[sl], origin[sl], direction[sl]
    best_c, best_t, best_uv = nearest_hits(cand, camera, sub, (valid, origin, direction))
    hit = best_c >= 0
    obj = np.zeros(best_c.shape, np.int32)
    obj[hit] = cand.object_id[best_c[hit]]
    u, v = best_uv[..., 0][hit], best_uv[..., 1][hit]
    nrm = cand.normals[best_c[hit]]
    n = (1.0 - u - v)[:, None] * nrm[:, 0] + u[:, None] * nrm[:, 1] + v[:, None] * nrm[:, 2]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    normal = np.zeros(best_c.shape + (3,))
    normal[hit] = n
    is_reflector = np.isin(obj, scene.reflector_ids)
    if not reflectors_only:
        shown = hit & ~is_reflector
        colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
        colour[sl][shown] = shade(normal[shown], colors[obj[shown]])
        rid[sl][shown] = obj[shown]
        drawn[sl] = shown
    reflectors = {}
    for k in (int(x) for x in np.unique(obj[hit & is_reflector])):
        m = hit & (obj == k)
        mask, point, nr, dist = np.zeros((h, w), bool), np.zeros((h, w, 3)), np.zeros((h, w, 3)), np.zeros((h, w))
        mask[sl] = m
        point[sl][m] = origin[m] + best_t[m][:, None] * direction[m]
        nr[sl][m] = normal[m]
        dist[sl][m] = best_t[m] * np.linalg.norm(direction[m], axis=1)
        reflectors[k] = (mask, point, nr, dist)
    return colour, rid, drawn, reflectors


def exact_bounces(level, reflectors, rays, path, direction, camera_eye, box, shape):
    """The next level's :class:`~refsoft.search.bounces.Bounce` s from :func:`exact_level`'s
    ``reflectors`` over ``box``: each pixel's eye the origin of its ray (``rays``), its path's
    length to that origin ``path`` (h, w) and the camera's ray direction ``direction`` (h, w, 3)."""
    out = []
    for b, (mask, point, normal, dist) in sorted(reflectors.items()):
        bounce = make_bounce(level, b, mask, point, normal, rays[1], path + dist, direction, camera_eye,
                             (box[0], box[2]), shape)
        if bounce is not None:
            out.append(bounce)
    return out


# --- the levels --------------------------------------------------------------------------------
class LaterStarts:
    """Coherence at a later level: each later bounce's reflection pixels (in the view) by path
    and group of vertices, kept from one frame to the next. :meth:`begin` with a new frame makes
    the last frame's the previous ones (rendering the same frame again reads the same)."""

    def __init__(self):
        self.frame, self.last, self.now = None, {}, {}

    def begin(self, frame):
        """Start ``frame``: what the last frame kept becomes the previous frame's."""
        if frame != self.frame:
            self.frame, self.last, self.now = frame, self.now, {}

    def previous(self, path, group, n):
        """(n, 2) int32 view pixels of ``group`` (0 the scene's vertices, else a reflector's id) at
        the previous frame's bounce of ``path``, -1 where none; None without one."""
        got = self.last.get((tuple(path), group))
        return got if got is not None and len(got) == n else None

    def keep(self, path, group, bounce, searched, result):
        """Keep the view pixels of the ``searched`` (n,) bool vertices' ``result`` at ``bounce``."""
        pixels = np.full((len(searched), 2), -1, np.int32)
        found = result.pixel[:, 0] >= 0
        at = np.flatnonzero(searched)[found]
        pixels[at] = result.pixel[found] + np.array([bounce.box[0], bounce.box[2]], np.int32)
        self.now[(tuple(path), group)] = pixels


def _search(bounce, gb, verts, want, opt, starts, path, group):
    """:func:`refsoft.search.bounces.search_bounce` of the ``want`` (n,) bool vertices of
    ``verts`` (n, 3), from their previous pixels when ``starts`` (:class:`LaterStarts`) has them;
    their results kept there."""
    prev = None if starts is None else starts.previous(path, group, len(verts))
    res = search_bounce(bounce, gb, verts[want], opt.neighbourhood, opt.cap, None if prev is None else prev[want])
    if starts is not None:
        starts.keep(path, group, bounce, want, res)
    return res


def draw_bounce(scene, meshes, bounce: Bounce, camera, vertices, opt, report, path=(), keep=None, starts=None):
    """Level ``bounce.level``'s picture in its stencil, and the later levels' inside it.

    Parameters
    ----------
    scene, meshes, camera
        The frame's.
    bounce : Bounce
    vertices : ndarray (N, 3) float64
        The non-reflectors' vertices (:func:`refsoft.scene.scene_vertices`).
    opt : RenderOptions
        Read: ``neighbourhood``, ``cap``, ``precision``, ``images``, ``bounces`` (the last level).
    report : list
        Receives one dict per bounce drawn (level, reflector, pixels, vertices searched, ms).
    path : tuple of int
        The reflectors of the path before this one (the first reflector first).
    keep : dict, optional
        Receives each bounce drawn by its path (reflector ids, this one's last): what a trace of a
        later bounce's search replays.
    starts : LaterStarts, optional
        Coherence: the previous frame's pixels of each path, and this frame's kept.

    Returns
    -------
    colour (h, w, 3) float32, reflected_id (h, w) int32, covered (h, w) bool, depth (h, w) int8
        Over ``bounce.box``.
    """
    t0 = time.perf_counter()
    path = tuple(path) + (bounce.reflector,)
    if keep is not None:
        keep[path] = bounce
    gb = gbuffer_of(bounce, camera, opt.precision)
    ids = [k for k, o in enumerate(scene.objects, start=1) if not o.reflector]
    if opt.images == "all":  # drawn by each pixel's ray: what no ray meets cannot be drawn
        rays = level_rays(bounce)
        reached = _reaching(meshes, range(1, len(scene.objects) + 1), _valid(rays))
        reach = reached.get
    else:
        texels = texel_reach(bounce.position, bounce.normal, bounce.eye, bounce.mask)
        reach = (lambda k: reaches(texels, *bounding_sphere(meshes[k - 1])))
    # only the objects a reflected ray of this level can reach are searched; the others' vertices
    # are CULLED (their triangles are not drawn)
    seen = np.repeat([reach(k) for k in ids], [meshes[k - 1].n_vertices for k in ids]).astype(bool)
    if opt.images == "all":  # with a few rays, only the corners of the faces they can meet
        seen = _narrowed(meshes, ids, vertices, rays, seen)
    virtual = np.zeros((len(vertices), 3))
    flags = np.full(len(vertices), CULLED, np.uint8)
    res = _search(bounce, gb, vertices, seen, opt, starts, path, 0)
    virtual[seen], flags[seen] = unfolded(bounce, res, vertices[seen]), res.flags
    depth = np.where(bounce.mask, np.int8(bounce.level), np.int8(0)).astype(np.int8)
    entry = {"level": bounce.level, "reflector": bounce.reflector, "pixels": int(bounce.mask.sum()),
             "searched": int(seen.sum()), "iterations": int(res.iterations.sum())}
    report.append(entry)
    others = [] if bounce.level >= opt.bounces else [k for k in scene.reflector_ids
                                                      if k != bounce.reflector and reach(k)]
    found = []  # the other reflectors' vertices searched at this level: (ids, vertices, virtual, flags)
    for k in others:
        verts = np.asarray(meshes[k - 1].vertices, np.float64)
        want = np.ones(len(verts), bool)
        if opt.images == "all":
            want = _narrowed(meshes, [k], verts, rays, want)
        r = _search(bounce, gb, verts, want, opt, starts, path, k)
        virt, fl = np.zeros((len(verts), 3)), np.full(len(verts), CULLED, np.uint8)
        virt[want], fl[want] = unfolded(bounce, r, verts[want]), r.flags
        found.append(([k], verts, virt, fl))
        entry["searched"] += int(want.sum())
        entry["iterations"] += int(r.iterations.sum())
    if opt.images == "all":  # each pixel's reflected ray decides among the virtual triangles over it
        colour, rid, covered, refl = exact_level(scene, meshes, [(ids, vertices, virtual, flags)] + found, camera,
                                                 bounce.box, rays)
        nxt = exact_bounces(bounce.level + 1, refl, rays, bounce.path, bounce.direction, bounce.origin, bounce.box,
                            bounce.shape)
    else:
        parts = object_parts(meshes, ids, virtual, flags)
        stencil = bounce.stencil()
        colour, rid, covered, _ = virtual_pass(scene, parts, camera, stencil, bounce.box, "discard")
        rparts = sum((object_parts(meshes, k, v, fl) for k, _, v, fl in found), [])
        nxt = later_bounces(bounce, seen_reflectors(parts, rparts, camera, stencil, bounce.box), meshes) if found else []
    for b in nxt:
        blend(colour, rid, covered, depth, bounce.box, b,
              draw_bounce(scene, meshes, b, camera, vertices, opt, report, path, keep, starts), scene)
    entry["ms"] = 1000 * (time.perf_counter() - t0)
    return colour, rid, covered, depth


def blend(colour, rid, covered, depth, box, bounce: Bounce, deeper, scene):
    """Composite a later level's picture ``deeper`` (:func:`draw_bounce` of ``bounce``) into an
    earlier one's arrays over ``box``, in place, where ``bounce.mask``: the reflector's own shade
    blended with its reflection by its reflectivity where the reflection covers (``rho *
    reflection + (1 - rho) * own``, as the frame composites), its own shade elsewhere; the
    reflected object id and the depth the later level's."""
    col2, rid2, cov2, dep2 = deeper
    b0, b1, d0, d1 = bounce.box
    obj = scene.objects[bounce.reflector - 1]
    m = bounce.mask
    own = shade(bounce.normal[m], np.asarray(obj.color, np.float32)).astype(np.float32)
    rho = np.float32(obj.reflectivity)
    mix = np.where(cov2[m][:, None], rho * col2[m] + (np.float32(1) - rho) * own, own)
    sl = (slice(b0 - box[0], b1 - box[0]), slice(d0 - box[2], d1 - box[2]))
    colour[sl][m] = mix
    rid[sl][m] = rid2[m]
    covered[sl][m] = True
    depth[sl][m] = dep2[m]


def deepen(scene, view, k, stencil, box, out, refl, parts, opt, search_first, keep=None, starts=None):
    """After level 1 of reflector ``k`` (its :class:`~refsoft.seam.ReflectorResult` ``out`` over
    ``box``, its reflection ``refl`` and virtual ``parts``): the reflectors seen in its image and
    every later level, composited into ``out`` in place, with the per-pixel depth.

    ``search_first(vertices)`` gives the first level's virtual vertices (N, 3) float64 and flags
    of other vertices (the reflectors'), as the method computes its own; ``keep`` (a dict)
    receives every later bounce by its path (:func:`draw_bounce`); ``starts`` (a
    :class:`LaterStarts`, kept by the method from frame to frame) gives the later levels'
    searches their previous frame's pixels (coherence).

    Returns
    -------
    list of dict
        The first level's (level 1: the other reflectors' vertices searched on this one's
        G-buffer), then one per later bounce drawn (:func:`draw_bounce`'s report).
    """
    first = {"level": 1, "reflector": int(k), "pixels": int(stencil.sum()), "searched": 0}
    if starts is not None:
        starts.begin(view.frame)
    report = [first]
    r0, r1, c0, c1 = box
    camera = view.camera
    eye = np.asarray(camera.eye, np.float64)
    depth = np.where(stencil[r0:r1, c0:c1], np.int8(1), np.int8(0)).astype(np.int8)
    found = []  # the other reflectors' vertices searched on this one: (ids, vertices, virtual, flags)
    gb = refl.gbuffer
    if opt.images == "all":  # drawn by each pixel's ray: a reflector no ray meets cannot be seen
        from .acceptance import pixel_rays

        rays = pixel_rays(camera, view.meshes[k - 1], view.view.triangle, stencil, box)
        reached = _reaching(view.meshes, scene.reflector_ids, _valid(rays))
        reach = reached.get
    else:
        texels = texel_reach(gb.position, gb.normal, eye, gb.mask, gb.origin)
        reach = (lambda b: reaches(texels, *bounding_sphere(view.meshes[b - 1])))
    near = [b for b in scene.reflector_ids if b != k and reach(b)]  # the others no reflected ray comes near: nothing
    if near and opt.images == "all":  # the rays that can meet one of them, as exact_level takes them
        towards = (_towards(rays, [bounding_sphere(view.meshes[b - 1]) for b in near]), rays[1], rays[2])
    for b in near:
        verts = np.asarray(view.meshes[b - 1].vertices, np.float64)
        want = np.ones(len(verts), bool)
        if opt.images == "all":  # with a few rays, only the corners of the faces they can meet
            want = _narrowed(view.meshes, [b], verts, towards, want)
        virtual, flags = np.zeros((len(verts), 3)), np.full(len(verts), CULLED, np.uint8)
        virtual[want], flags[want] = search_first(verts[want])
        first["searched"] += int(want.sum())
        found.append(([b], verts, virtual, flags))
    if not found:
        bounces = []
    elif opt.images == "all":  # the reflectors seen where each pixel's reflected ray meets them first
        ids = [j for j, o in enumerate(scene.objects, start=1) if not o.reflector]
        virtual = refl.virtual64 if refl.virtual64 is not None else refl.virtual.astype(np.float64)
        *_, seen = exact_level(scene, view.meshes, [(ids, view.vertices, virtual, refl.result.flags)] + found, camera,
                               box, rays, reflectors_only=True)
        to = np.where(rays[0][..., None], rays[1] - eye, 0.0)
        path = np.linalg.norm(to, axis=-1)
        direction = to / np.maximum(path, 1e-300)[..., None]
        bounces = exact_bounces(2, seen, rays, path, direction, eye, box, stencil.shape)
    else:
        rparts = sum((object_parts(view.meshes, b, v, fl) for b, _, v, fl in found), [])
        bounces = first_bounces(camera, view.meshes, k, view.view.triangle,
                                seen_reflectors(parts, rparts, camera, stencil, box), box)
    colour, rid, covered = out.colour.copy(), out.reflected_id.copy(), out.covered.copy()
    for bounce in bounces:
        blend(colour, rid, covered, depth, box, bounce,
              draw_bounce(scene, view.meshes, bounce, camera, view.vertices, opt, report, (k,), keep, starts), scene)
    out.colour, out.reflected_id, out.covered = colour, rid, covered
    out.pixels = {**out.pixels, BOUNCE_DEPTH: depth}
    out.pixel_mask = stencil[r0:r1, c0:c1].copy()
    return report

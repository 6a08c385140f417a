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

A reflector that can see itself (not convex, drawn by every image under the accurate preset) is
its own level 2 where its pixels' rays meet it again (:func:`deepen_images`), and a later level
on such a reflector is drawn by its pixels' rays (:func:`draw_bounce`, ``_rays_level``).
"""

from __future__ import annotations

import time

import numpy as np

from .. import keys
from ..raster import shade
from . import CULLED, meet, search
from .bounces import (Bounce, bounding_sphere, first_bounces, gbuffer_of, later_bounces, level_rays, make_bounce,
                      object_parts, reaches, search_bounce, seen_reflectors, texel_reach, unfolded)
from .virtual import virtual_pass

#: The per-pixel array of the reflections taken (0 off reflectors).
BOUNCE_DEPTH = keys.BOUNCE_DEPTH


def exact_level(scene, meshes, groups, camera, box, rays, reflectors_only=False, towards=None):
    """One level drawn by exact per-pixel acceptance: the nearest hit of each pixel's ray among
    the candidates of ``groups`` (:func:`refsoft.search.meet.candidates`; the non-reflectors first,
    then the reflectors searched at this level), shaded as :func:`refsoft.search.acceptance.draw`
    shades it.

    Parameters
    ----------
    scene, meshes, camera
    groups : list
        As :func:`refsoft.search.meet.candidates`.
    box : (r0, r1, c0, c1)
    rays : (valid (h, w), origin (h, w, 3), direction (h, w, 3))
        Each pixel's reflected ray over ``box`` (``valid``: the level's stencil).
    reflectors_only : bool
        Only the reflectors are wanted: the pixels whose rays meet a reflector's candidate are
        decided, with every candidate, and nothing is drawn.
    towards : ndarray (h, w) bool, optional
        With ``reflectors_only``: the rays that pass through one of the reflectors' bounding
        spheres (:func:`refsoft.search.meet.towards`), when the caller has them.

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
        if towards is None:
            towards = meet.towards(rays, [bounding_sphere(meshes[k - 1]) for ids, *_ in groups[1:] for k in ids])
        groups = groups[:1] + [meet.reached(meshes, g, (towards, origin, direction)) for g in groups[1:]]
        ref, _ = meet.candidates(meshes, groups[1:], near=(camera, box), rays=meet.few((towards, origin, direction)))
        first, t_first, _ = meet.nearest_hits(ref, camera, box, (valid & towards, origin, direction))
        meets = first >= 0
        if not meets.any():
            return colour, rid, drawn, {}
        rows, cols = np.flatnonzero(meets.any(axis=1)), np.flatnonzero(meets.any(axis=0))
        sub = (r0 + int(rows[0]), r0 + int(rows[-1]) + 1, c0 + int(cols[0]), c0 + int(cols[-1]) + 1)
        valid = valid & meets
        # only a scene triangle met no farther than the reflector's hit can be nearer: the rays up
        # to that hit (and 1e-9 of it), and the scene's objects they can reach
        upto = np.zeros(meets.shape)
        upto[meets] = t_first[meets] * np.linalg.norm(direction[meets], axis=-1) * (1.0 + 1e-9)
        segments = (valid, origin, direction, upto)
        scene_cand, _ = meet.candidates(meshes, [meet.reached(meshes, groups[0], segments)], near=(camera, sub),
                                        rays=meet.few(segments))
        cand = meet.joined(scene_cand, ref)
    else:
        groups = [meet.reached(meshes, g, rays) for g in groups]
        cand, _ = meet.candidates(meshes, groups, near=(camera, box), rays=meet.few(rays))
    sl = (slice(sub[0] - r0, sub[1] - r0), slice(sub[2] - c0, sub[3] - c0))
    valid, origin, direction = valid[sl], origin[sl], direction[sl]
    best_c, best_t, best_uv = meet.nearest_hits(cand, camera, sub, (valid, origin, direction))
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


def _inverse(opt):
    """A later level's hidden-vertex rule: the inverse search where the options ask for it, else
    ``discard`` (``plane``, the paper preset's, is the first level's alone)."""
    return "search" if opt.inverse == "search" else "discard"


def _search(bounce, gb, verts, want, opt, starts, path, group):
    """:func:`refsoft.search.bounces.search_bounce` of the ``want`` (n,) bool vertices of
    ``verts`` (n, 3), from their previous pixels when ``starts`` (:class:`LaterStarts`) has them;
    their results kept there."""
    prev = None if starts is None else starts.previous(path, group, len(verts))
    res = search_bounce(bounce, gb, verts[want], opt.neighbourhood, opt.cap, None if prev is None else prev[want],
                        _inverse(opt))
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
        reached = meet.reaching(meshes, range(1, len(scene.objects) + 1), meet.valid_rays(rays))
        reach = reached.get
    else:
        texels = texel_reach(bounce.position, bounce.normal, bounce.eye, bounce.mask)
        reach = (lambda k: reaches(texels, *bounding_sphere(meshes[k - 1])))
    depth = np.where(bounce.mask, np.int8(bounce.level), np.int8(0)).astype(np.int8)
    if opt.images == "all" and meet.sees_itself(scene, bounce.reflector):  # not convex: by the rays
        entry = {"level": bounce.level, "reflector": bounce.reflector, "pixels": int(bounce.mask.sum()),
                 "searched": 0}
        report.append(entry)
        colour, rid, covered, nxt = _rays_level(scene, meshes, bounce, camera, rays, reach, opt, entry)
        for b in nxt:
            blend(colour, rid, covered, depth, bounce.box, b,
                  draw_bounce(scene, meshes, b, camera, vertices, opt, report, path, keep, starts), scene)
        entry["ms"] = 1000 * (time.perf_counter() - t0)
        return colour, rid, covered, depth
    # only the objects a reflected ray of this level can reach are searched; the others' vertices
    # are CULLED (their triangles are not drawn)
    seen = np.repeat([reach(k) for k in ids], [meshes[k - 1].n_vertices for k in ids]).astype(bool)
    if opt.images == "all":  # with a few rays, only the corners of the faces they can meet
        seen = meet.narrowed(meshes, ids, vertices, rays, seen)
    virtual = np.zeros((len(vertices), 3))
    flags = np.full(len(vertices), CULLED, np.uint8)
    res = _search(bounce, gb, vertices, seen, opt, starts, path, 0)
    virtual[seen], flags[seen] = unfolded(bounce, res, vertices[seen]), res.flags
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
            want = meet.narrowed(meshes, [k], verts, rays, want)
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
        colour, rid, covered, _ = virtual_pass(scene, parts, camera, stencil, bounce.box, _inverse(opt))
        rparts = sum((object_parts(meshes, k, v, fl) for k, _, v, fl in found), [])
        shows = seen_reflectors(parts, rparts, camera, stencil, bounce.box) if found else {}
        nxt = later_bounces(bounce, shows, meshes) if found else []
    for b in nxt:
        blend(colour, rid, covered, depth, bounce.box, b,
              draw_bounce(scene, meshes, b, camera, vertices, opt, report, path, keep, starts), scene)
    entry["ms"] = 1000 * (time.perf_counter() - t0)
    return colour, rid, covered, depth


def _combined(meshes, ids):
    """Objects ``ids`` as one mesh: vertices (n, 3) float64, normals (n, 3), faces (m, 3) int64
    into those vertices, each face's object (m,) int32."""
    verts, normals, faces, obj, start = [], [], [], [], 0
    for k in ids:
        mesh = meshes[k - 1]
        verts.append(np.asarray(mesh.vertices, np.float64))
        normals.append(np.asarray(mesh.normals, np.float64))
        faces.append(np.asarray(mesh.faces, np.int64) + start)
        obj.append(np.full(mesh.n_faces, k, np.int32))
        start += mesh.n_vertices
    if not ids:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int32)
    return np.concatenate(verts), np.concatenate(normals), np.concatenate(faces), np.concatenate(obj)


def _rays_level(scene, meshes, bounce, camera, rays, reach, opt, entry):
    """A later level on a reflector that sees itself (:func:`draw_bounce`'s part), drawn by its
    pixels' rays alone: each triangle of the objects a ray of the level can reach that one of
    the rays comes near (:func:`refsoft.search.several.near_rays`) is met by those rays, the
    scene's from the pixel's bounce point, the reflectors' (the next level's, this one too) from a
    point moved along the ray (:func:`refsoft.search.meet.nearest_split`). No vertex is searched
    at such a level: with one eye per pixel there is no enumeration of every image (that of
    :func:`refsoft.search.images.find_images` takes one eye), and a walk from a pixel of a stencil
    seen in a curved mirror ends at the stencil's rim or at a maximum that is no reflection point
    as often as at an image, so candidates placed by walks miss triangles (``docs/bounces.md``).

    Returns
    -------
    colour (h, w, 3) float32, reflected_id (h, w) int32, covered (h, w) bool
        Over ``bounce.box``.
    list of Bounce
        The next level's.

    ``entry`` (the level's report) receives the candidates.
    """
    from .several import near_rays

    valid, origin, direction = rays
    offset = meet.self_offset(meshes[bounce.reflector - 1])
    moved, _ = meet.moved(rays, offset)

    def group(ids, ray_list):
        verts, normals, faces, fobj = _combined(meshes, ids)
        return near_rays(verts, normals, faces, fobj, ray_list)

    ids = [k for k, o in enumerate(scene.objects, start=1) if not o.reflector and reach(k)]
    others = [] if bounce.level >= opt.bounces else [k for k in scene.reflector_ids if reach(k)]
    # the reflectors' candidates for the rays from their moved origins, as they are met
    scene_cand = group(ids, (origin[valid], direction[valid]))
    ref = group(others, (moved[1][valid], direction[valid]))
    src, best_c, best_t, best_uv = meet.nearest_split(scene_cand, ref, camera, bounce.box, rays, offset)
    entry["candidates"] = int(len(scene_cand.object_id) + len(ref.object_id))
    h, w = bounce.mask.shape
    colour, rid = np.zeros((h, w, 3), np.float32), np.zeros((h, w), np.int32)
    shown = src == 1
    if shown.any():
        c = best_c[shown]
        u, v = best_uv[..., 0][shown], best_uv[..., 1][shown]
        nrm = scene_cand.normals[c]
        n = (1.0 - u - v)[:, None] * nrm[:, 0] + u[:, None] * nrm[:, 1] + v[:, None] * nrm[:, 2]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
        colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
        obj = scene_cand.object_id[c]
        colour[shown] = shade(n, colors[obj])
        rid[shown] = obj
    seen = _seen(ref, src == 2, best_c, best_t, best_uv, rays)
    nxt = exact_bounces(bounce.level + 1, seen, rays, bounce.path, bounce.direction, bounce.origin, bounce.box,
                        bounce.shape)
    return colour, rid, shown, nxt


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
        others = [b for b in scene.reflector_ids if b != k]
        hit = meet.hits(meet.valid_rays(rays), [bounding_sphere(view.meshes[b - 1]) for b in others])  # (K, M)
        reach = dict(zip(others, (bool(x) for x in hit.any(axis=1)))).get
    else:
        texels = texel_reach(gb.position, gb.normal, eye, gb.mask, gb.origin)
        reach = (lambda b: reaches(texels, *bounding_sphere(view.meshes[b - 1])))
    near = [b for b in scene.reflector_ids if b != k and reach(b)]  # the others no reflected ray comes near: nothing
    if near and opt.images == "all":  # the rays that can meet one of them, as exact_level takes them
        through = np.zeros(rays[0].shape, bool)
        through[rays[0]] = hit[[others.index(b) for b in near]].any(axis=0)
        towards = (through, rays[1], rays[2])
    for b in near:
        verts = np.asarray(view.meshes[b - 1].vertices, np.float64)
        want = np.ones(len(verts), bool)
        if opt.images == "all":  # with a few rays, only the corners of the faces they can meet
            want = meet.narrowed(view.meshes, [b], verts, towards, want)
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
                               box, rays, reflectors_only=True, towards=towards[0])  # found: all of near
        to = np.where(rays[0][..., None], rays[1] - eye, 0.0)
        path = np.linalg.norm(to, axis=-1)
        direction = to / np.maximum(path, 1e-300)[..., None]
        bounces = exact_bounces(2, seen, rays, path, direction, eye, box, stencil.shape)
    else:
        rparts = sum((object_parts(view.meshes, b, v, fl) for b, _, v, fl in found), [])
        bounces = first_bounces(camera, view.meshes, k, view.view.triangle,
                                seen_reflectors(parts, rparts, camera, stencil, box), box)
    _later(scene, view, k, stencil, box, out, bounces, depth, opt, report, keep, starts)
    return report


def _later(scene, view, k, stencil, box, out, bounces, depth, opt, report, keep, starts):
    """Draw the level-2 ``bounces`` of reflector ``k`` and every level inside them, composited into
    ``out`` (over ``box``) in place, with the per-pixel ``depth``."""
    colour, rid, covered = out.colour.copy(), out.reflected_id.copy(), out.covered.copy()
    for bounce in bounces:
        blend(colour, rid, covered, depth, box, bounce,
              draw_bounce(scene, view.meshes, bounce, view.camera, view.vertices, opt, report, (k,), keep, starts),
              scene)
    out.colour, out.reflected_id, out.covered = colour, rid, covered
    out.pixels = {**out.pixels, BOUNCE_DEPTH: depth}
    r0, r1, c0, c1 = box
    out.pixel_mask = stencil[r0:r1, c0:c1].copy()


def deepen_images(scene, view, k, stencil, box, out, drawn, opt, keep=None, starts=None):
    """:func:`deepen` for a reflector ``k`` whose every image was drawn (a mirror that is not
    convex, :func:`refsoft.search.several.several_pass`): the reflectors seen in its image, ``k``
    itself among them when it can see itself (:func:`refsoft.search.meet.sees_itself`).

    Each such reflector's vertices are searched on ``k``'s G-buffer as the scene's are: every
    image (:func:`refsoft.search.images.find_images`) and their candidate virtual triangles
    (:func:`refsoft.search.several.candidates`: sheets, cuts, the rays' pruning); each pixel's
    reflected ray is met with them from an origin moved along it (the truth's rule for a mirror
    that sees itself, :func:`refsoft.search.meet.self_offset`) and with the scene's candidates of
    the drawing (``drawn``: ``candidates``, ``rays``, ``source``) from its own; where a
    reflector's triangle is the nearer, the pixel is that reflector's level 2.

    Returns
    -------
    list of dict
        As :func:`deepen`'s.
    """
    from .images import find_images
    from .several import candidates

    first = {"level": 1, "reflector": int(k), "pixels": int(stencil.sum()), "searched": 0}
    if starts is not None:
        starts.begin(view.frame)
    report = [first]
    r0, r1, c0, c1 = box
    camera, meshes = view.camera, view.meshes
    eye = np.asarray(camera.eye, np.float64)
    depth = np.where(stencil[r0:r1, c0:c1], np.int8(1), np.int8(0)).astype(np.int8)
    rays = drawn["rays"]
    valid, origin, direction = rays
    gb, gb_eye, find = drawn["source"]
    others = [b for b in scene.reflector_ids if b != k]
    hit = meet.hits(meet.valid_rays(rays), [bounding_sphere(meshes[b - 1]) for b in others])
    near = ([k] if meet.sees_itself(scene, k) else []) + [b for b, h in zip(others, hit) if h.any()]
    bounces = []
    if near:
        t0 = time.perf_counter()
        offset = meet.self_offset(meshes[k - 1]) if k in near else 0.0
        # the rays as they meet the reflectors: from their moved origins (the triangle a ray leaves is
        # then behind it, and no part of it is made)
        moved, _ = meet.moved(rays, offset)
        ray_list = (moved[1][valid], direction[valid])
        parts = []
        for b in near:
            mesh = meshes[b - 1]
            verts = np.asarray(mesh.vertices, np.float64)
            walk = search(gb, gb_eye, verts, opt.neighbourhood, opt.inverse, None, opt.cap)
            found = find_images(gb, gb_eye, verts, walk)
            cand, _ = candidates(gb, gb_eye, verts, mesh.normals, mesh.faces, np.full(mesh.n_faces, b, np.int32),
                                 found, find, opt.neighbourhood, opt.cap, rays=ray_list)
            parts.append(cand)
            first["searched"] += len(verts)
        ref = parts[0]
        for c in parts[1:]:
            ref = meet.joined(ref, c)
        src, best_c, best_t, best_uv = meet.nearest_split(drawn["candidates"], ref, camera, box, rays, offset)
        first["candidates"] = int(len(ref.object_id))
        first["ms"] = 1000 * (time.perf_counter() - t0)
        seen = _seen(ref, src == 2, best_c, best_t, best_uv, rays)
        to = np.where(valid[..., None], origin - eye, 0.0)
        path = np.linalg.norm(to, axis=-1)
        cam_dir = to / np.maximum(path, 1e-300)[..., None]
        bounces = exact_bounces(2, seen, rays, path, cam_dir, eye, box, stencil.shape)
    _later(scene, view, k, stencil, box, out, bounces, depth, opt, report, keep, starts)
    return report


def _seen(cand, shows, best_c, best_t, best_uv, rays):
    """:func:`exact_level`'s ``reflectors`` from the pixels ``shows`` (h, w) bool where a
    candidate of ``cand`` (all reflectors') is the nearest hit: its index ``best_c``, parameter
    ``best_t`` from the ray's origin and barycentrics ``best_uv``."""
    _, origin, direction = rays
    h, w = shows.shape
    c = best_c[shows]
    u, v = best_uv[..., 0][shows], best_uv[..., 1][shows]
    nrm = cand.normals[c]
    n = (1.0 - u - v)[:, None] * nrm[:, 0] + u[:, None] * nrm[:, 1] + v[:, None] * nrm[:, 2]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    obj = np.zeros((h, w), np.int32)
    obj[shows] = cand.object_id[c]
    normal = np.zeros((h, w, 3))
    normal[shows] = n
    out = {}
    for k in (int(x) for x in np.unique(obj[shows])):
        m = shows & (obj == k)
        point, nr, dist = np.zeros((h, w, 3)), np.zeros((h, w, 3)), np.zeros((h, w))
        point[m] = origin[m] + best_t[m][:, None] * direction[m]
        nr[m] = normal[m]
        dist[m] = best_t[m] * np.linalg.norm(direction[m], axis=1)
        out[k] = (m, point, nr, dist)
    return out

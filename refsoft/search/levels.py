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
exact per-pixel acceptance (:func:`refsoft.search.exact_levels.exact_level`): its reflected ray
is met with the real triangles whose virtual triangles, from the level's search, cover it
(dilated), the nearest hit drawn (:func:`refsoft.search.acceptance.draw`'s rule). Under the paper preset the reflectors'
virtual triangles are rasterized with the scene's (:func:`refsoft.search.bounces.seen_reflectors`)
and a later level drawn by the virtual pass.

A reflector that can see itself (not convex), drawn by every image under the accurate preset, is
its own level 2 where its pixels' rays meet it again (:func:`deepen_images`: the reflectors in its
image met by the rays alone), and a later level on such a reflector is drawn by its pixels' rays
(:func:`draw_bounce`, :func:`refsoft.search.exact_levels.rays_level`). Under the paper preset it
is one more reflector of its own level: its vertices searched on its G-buffer (level 1) or from
each pixel's eye (a later level), their virtual triangles rasterized with the scene's.
"""

from __future__ import annotations

import time

import numpy as np

from .. import keys
from ..raster import shade
from . import CULLED, meet
from .bounces import (Bounce, LevelSearch, bounding_sphere, first_bounces, gbuffer_of, later_bounces, level_rays,
                      object_parts, reaches, search_bounce, seen_reflectors, texel_reach, unfolded, unfolded_at)
from .exact_levels import combined, exact_bounces, exact_level, rays_level, seen_by_rays
from .virtual import virtual_pass

#: The per-pixel array of the reflections taken (0 off reflectors).
BOUNCE_DEPTH = keys.BOUNCE_DEPTH


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
    """A later level's walk for a hidden vertex: the inverse search where the options ask for it,
    else its walk's end kept (``discard`` and ``plane``: the virtual pass then leaves its triangles
    out, or, by ``plane``, draws them with the vertex unfolded from that end: equation 1 turns
    ``V - R`` about the normal and keeps its length, the one thing the unfolded rule takes)."""
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
        Read: ``neighbourhood``, ``cap``, ``precision``, ``images``, ``bounces`` (the last level);
        drawn by the virtual pass (``images = "one"``), ``tessellate``, ``max_level``,
        ``tessellate_span`` and ``silhouette`` too (:func:`refined_level`).
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
        colour, rid, covered, nxt = rays_level(scene, meshes, bounce, camera, rays, reach, opt, entry)
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
    pixel = np.full((len(vertices), 2), -1, np.int32)
    res = _search(bounce, gb, vertices, seen, opt, starts, path, 0)
    virtual[seen], flags[seen], pixel[seen] = unfolded(bounce, res, vertices[seen]), res.flags, res.pixel
    entry = {"level": bounce.level, "reflector": bounce.reflector, "pixels": int(bounce.mask.sum()),
             "searched": int(seen.sum()), "iterations": int(res.iterations.sum())}
    report.append(entry)
    others = [] if bounce.level >= opt.bounces else [k for k in scene.reflector_ids if reach(k) and (
        k != bounce.reflector or meet.sees_itself(scene, k))]  # the paper preset: a mirror that sees itself too
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
        if opt.tessellate is None and opt.silhouette != "clip":
            parts = object_parts(meshes, ids, virtual, flags)
        else:  # as the first level: tessellated, then cut at the silhouette, searched with each pixel's eye
            parts, counts = refined_level(bounce, gb, camera, meshes, ids, vertices, virtual, pixel, flags, opt)
            entry.update(counts)
        stencil = bounce.stencil()
        colour, rid, covered, _ = virtual_pass(scene, parts, camera, stencil, bounce.box, opt.inverse)
        rparts = sum((object_parts(meshes, k, v, fl) for k, _, v, fl in found), [])
        shows = seen_reflectors(parts, rparts, camera, stencil, bounce.box) if found else {}
        nxt = later_bounces(bounce, shows, meshes) if found else []
    for b in nxt:
        blend(colour, rid, covered, depth, bounce.box, b,
              draw_bounce(scene, meshes, b, camera, vertices, opt, report, path, keep, starts), scene)
    entry["ms"] = 1000 * (time.perf_counter() - t0)
    return colour, rid, covered, depth


def refined_level(bounce: Bounce, gb, camera, meshes, ids, vertices, virtual, pixel, flags, opt):
    """A later level's virtual geometry of the non-reflectors ``ids`` after the options that add
    vertices, as the first level's (:func:`refsoft.search.virtual.refined_parts`): Szabo's adaptive
    tessellation (``opt.tessellate``, ``max_level``, ``tessellate_span``), then the cut at the
    silhouette (``opt.silhouette == "clip"``), the new vertices searched on the level's G-buffer
    with each pixel's own eye (:class:`~refsoft.search.bounces.LevelSearch`) and unfolded
    (:func:`~refsoft.search.bounces.unfolded_at`). The cut's steps are bisections (the first
    level's prediction scores with one eye).

    Parameters
    ----------
    bounce : Bounce
    gb : GBuffer
        :func:`~refsoft.search.bounces.gbuffer_of` the bounce.
    camera, meshes
        The frame's.
    ids : list of int
        The non-reflectors, their vertices consecutive in ``vertices`` in that order.
    vertices : ndarray (N, 3) float64
    virtual : ndarray (N, 3) float64
        Their virtual vertices at this level.
    pixel : ndarray (N, 2) int32
        Their reflection pixels in ``gb`` (-1 where not searched).
    flags : ndarray (N,) uint8
    opt : RenderOptions

    Returns
    -------
    parts : list of one part
        (virtual (n', 3) float64, normals (n', 3), faces (m', 3) int64, face object (m',)
        int32, flags (n',) uint8): the input vertices first, then the new ones.
    counts : dict
        ``tessellation`` (vertices searched, levels, triangles) and ``silhouette`` (edges cut,
        searches) when those ran.
    """
    from .silhouette import clip_at_silhouette
    from .tessellate import tessellate

    _, normals, faces, face_obj = combined(meshes, ids)
    level = LevelSearch(bounce, gb, opt.neighbourhood, opt.cap, _inverse(opt))
    eye = np.asarray(camera.eye, np.float64)  # not read: the level's own eyes are
    counts = {}
    n = len(vertices)
    if opt.tessellate is not None:
        t = tessellate(gb, eye, vertices, normals, faces, face_obj, pixel, flags, opt.tessellate, opt.max_level,
                       opt.neighbourhood, _inverse(opt), opt.cap, min_span=opt.tessellate_span, level=level)
        virtual = np.concatenate([virtual, unfolded_at(bounce, t.pixel[n:], t.vertices[n:])])
        vertices, normals, faces, face_obj, pixel, flags = t.vertices, t.normals, t.faces, t.face_obj, t.pixel, t.flags
        counts["tessellation"] = {"vertices_searched": int(t.searched), "levels": int(t.levels),
                                  "triangles": int(len(t.faces))}
    if opt.silhouette == "clip":
        c = clip_at_silhouette(gb, eye, vertices, normals, faces, face_obj, pixel, flags, opt.neighbourhood, opt.cap,
                               level=level)
        virtual = np.concatenate([virtual, unfolded_at(bounce, c.pixel, c.vertices)])
        normals = np.concatenate([normals, c.normals])
        flags = np.concatenate([flags, c.flags])
        faces, face_obj = c.faces, c.face_obj
        counts["silhouette"] = {"edges_cut": int(c.cut), "vertices_searched": int(c.searched)}
    return [(virtual, normals, np.asarray(faces, np.int64), np.asarray(face_obj, np.int32), flags)], counts


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
    t0 = time.perf_counter()
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
    if opt.images != "all" and meet.sees_itself(scene, k):  # the paper's method: its own vertices searched too
        near = [k] + near
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
    first["ms"] = 1000 * (time.perf_counter() - t0)  # the reflectors seen in it; the later levels' own
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

    Each such reflector is met by the pixels' rays alone, as a later level on a reflector that
    sees itself is (:func:`refsoft.search.exact_levels.rays_level`): each of its triangles that one
    of the rays comes near (:func:`refsoft.search.meet.near_rays`) is a candidate tested with
    those rays, from an origin moved along each (the truth's rule for a mirror that sees itself,
    :func:`refsoft.search.meet.self_offset`), and the scene's candidates of the drawing
    (``drawn``: ``candidates``, ``rays``) from its own; where a reflector's triangle is the
    nearer, the pixel is that reflector's level 2. No vertex of theirs is searched: their images
    in a mirror that is not convex (every image of each vertex on the mirror, sheets, cuts) would
    place candidates that the rays then test, and the rays' own pruning leaves out no triangle a
    ray meets (up to its margin), at a fraction of the enumeration's cost.

    Returns
    -------
    list of dict
        As :func:`deepen`'s.
    """
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
    others = [b for b in scene.reflector_ids if b != k]
    hit = meet.hits(meet.valid_rays(rays), [bounding_sphere(meshes[b - 1]) for b in others])
    near = ([k] if meet.sees_itself(scene, k) else []) + [b for b, h in zip(others, hit) if h.any()]
    bounces = []
    if near:
        t0 = time.perf_counter()
        offset = meet.self_offset(meshes[k - 1]) if k in near else 0.0
        # the rays as they meet the reflectors: from their moved origins (the triangle a ray leaves is
        # then behind it)
        moved, _ = meet.moved(rays, offset)
        ref = meet.near_rays(*combined(meshes, near), moved)
        src, best_c, best_t, best_uv = meet.nearest_split(drawn["candidates"], ref, camera, box, rays, offset)
        first["candidates"] = int(len(ref.object_id))
        first["ms"] = 1000 * (time.perf_counter() - t0)
        seen = seen_by_rays(ref, src == 2, best_c, best_t, best_uv, rays)
        to = np.where(valid[..., None], origin - eye, 0.0)
        path = np.linalg.norm(to, axis=-1)
        cam_dir = to / np.maximum(path, 1e-300)[..., None]
        bounces = exact_bounces(2, seen, rays, path, cam_dir, eye, box, stencil.shape)
    _later(scene, view, k, stencil, box, out, bounces, depth, opt, report, keep, starts)
    return report

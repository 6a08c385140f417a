"""A level of several bounces decided by exact per-pixel acceptance (spec section 5.1): the nearest
hit of each pixel's reflected ray among the candidates of the level's objects and reflectors
(:func:`exact_level`), the next level's bounces from the reflectors it meets
(:func:`exact_bounces`), and a later level on a reflector that sees itself, drawn by its pixels'
rays alone (:func:`rays_level`). :mod:`refsoft.search.levels` puts the levels together.
"""

from __future__ import annotations

import numpy as np

from ..raster import shade
from . import meet
from .bounces import bounding_sphere, make_bounce


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
    n = _hit_normals(cand.normals[best_c[hit]], best_uv[hit])
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


def combined(meshes, ids):
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


def rays_level(scene, meshes, bounce, camera, rays, reach, opt, entry):
    """A later level on a reflector that sees itself (:func:`refsoft.search.levels.draw_bounce`'s part), drawn by its
    pixels' rays alone: each triangle of the objects a ray of the level can reach that one of
    the rays comes near (:func:`refsoft.search.meet.near_rays`) is met by those rays, the
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
    offset = meet.self_offset(meshes[bounce.reflector - 1])
    moved, _ = meet.moved(rays, offset)
    ids = [k for k, o in enumerate(scene.objects, start=1) if not o.reflector and reach(k)]
    others = [] if bounce.level >= opt.bounces else [k for k in scene.reflector_ids if reach(k)]
    # the reflectors' candidates for the rays from their moved origins, as they are met
    scene_cand = meet.near_rays(*combined(meshes, ids), rays)
    ref = meet.near_rays(*combined(meshes, others), moved)
    src, best_c, best_t, best_uv = meet.nearest_split(scene_cand, ref, camera, bounce.box, rays, offset)
    entry["candidates"] = int(len(scene_cand.object_id) + len(ref.object_id))
    h, w = bounce.mask.shape
    colour, rid = np.zeros((h, w, 3), np.float32), np.zeros((h, w), np.int32)
    shown = src == 1
    if shown.any():
        c = best_c[shown]
        n = _hit_normals(scene_cand.normals[c], best_uv[shown])
        colors = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
        obj = scene_cand.object_id[c]
        colour[shown] = shade(n, colors[obj])
        rid[shown] = obj
    seen = seen_by_rays(ref, src == 2, best_c, best_t, best_uv, rays)
    nxt = exact_bounces(bounce.level + 1, seen, rays, bounce.path, bounce.direction, bounce.origin, bounce.box,
                        bounce.shape)
    return colour, rid, shown, nxt


def seen_by_rays(cand, shows, best_c, best_t, best_uv, rays):
    """:func:`exact_level`'s ``reflectors`` from the pixels ``shows`` (h, w) bool where a
    candidate of ``cand`` (all reflectors') is the nearest hit: its index ``best_c``, parameter
    ``best_t`` from the ray's origin and barycentrics ``best_uv``."""
    _, origin, direction = rays
    h, w = shows.shape
    c = best_c[shows]
    n = _hit_normals(cand.normals[c], best_uv[shows])
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


def _hit_normals(normals, uv):
    """The unit normals (k, 3) float64 interpolated at barycentrics ``uv`` (k, 2) (u, v) from the
    corner normals ``normals`` (k, 3, 3) of the triangles hit (zero stays zero)."""
    u, v = uv[:, 0], uv[:, 1]
    n = (1.0 - u - v)[:, None] * normals[:, 0] + u[:, None] * normals[:, 1] + v[:, None] * normals[:, 2]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)

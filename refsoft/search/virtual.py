"""The virtual scene of one reflector (spec section 5): its virtual triangles rasterized with the
view camera into a z-buffer of their own, on the reflector's stencil only.

Input: a :class:`refsoft.search.reflect.Reflection` (virtual vertices and search flags) and the
world meshes; output, over the stencil's box: colour (h, w, 3) float32, reflected object id
(h, w) int32 and coverage (h, w) bool, which the frame driver composites.
"""

from __future__ import annotations

import numpy as np

from .._numba import readonly
from .._parallel import parallel_range
from ..raster import CULL_MODES, _setup, rasterize_trusted, shade_fragments_trusted
from ..raster._threads import SERIAL_MAX_TRIANGLES, serial_if_small
from ..scene.mesh import concatenate
from . import BORDER, CULLED, HIDDEN, SearchResult, skips, virtual_vertices
from ._exact import far_apart, interleave, mirror_marks, touching
from .tessellate import tessellate


def virtual_parts(scene, meshes, refl):
    """The reflected geometry of one reflector, one part per non-reflector object.

    Returns
    -------
    list of (virtual (n, 3) float64, normals (n, 3), faces (m, 3) int64 local, face_obj (m,)
    int32, flags (n,) uint8)
    """
    # eye-relative virtual vertices moved to world space in float64: far from the origin the
    # float32 world output would round them (1/16 unit at 1e6)
    virtual = refl.virtual64 if refl.virtual64 is not None else refl.virtual.astype(np.float64)
    flags = refl.result.flags
    parts, start = [], 0
    for k, obj in enumerate(scene.objects, start=1):
        if obj.reflector:
            continue
        mesh = meshes[k - 1]
        n = mesh.n_vertices
        parts.append((virtual[start:start + n], mesh.normals, mesh.faces.astype(np.int64),
                      np.full(mesh.n_faces, k, dtype=np.int32), flags[start:start + n]))
        start += n
    return parts


def reflected_mesh(scene, meshes, last=None):
    """The meshes of the non-reflector objects concatenated, their object ids as face ids.

    Parameters
    ----------
    scene : Scene
    meshes : list of Mesh
        Every object's world mesh.
    last : (tuple of Mesh, Combined), optional
        A previous result: reused when made from the same mesh objects (a static object's
        world mesh is the same object frame after frame).

    Returns
    -------
    (tuple of Mesh, Combined)
        The meshes concatenated and the concatenation.
    """
    ids = [k for k, obj in enumerate(scene.objects, start=1) if not obj.reflector]
    sources = tuple(meshes[k - 1] for k in ids)
    if last is not None and len(last[0]) == len(sources) and all(a is b for a, b in zip(last[0], sources)):
        return last
    return sources, concatenate(sources, ids)


def refined_parts(scene, meshes, refl, verts, opt, eye, reflected=None, with_real=False, with_mirror=False):
    """One part holding the reflected geometry after the options that add vertices: Szabo's
    adaptive tessellation (``opt.tessellate``, :func:`refsoft.search.tessellate.tessellate`),
    then the cut at the silhouette (``opt.silhouette == "clip"``,
    :func:`refsoft.search.silhouette.clip_at_silhouette`); same layout as :func:`virtual_parts`.

    Returns
    -------
    parts : list of one part
    counts : dict
        ``tessellation`` (vertices searched, levels, triangles) and ``silhouette`` (edges cut,
        searches) when those ran.
    real : (n, 3) float64
        With ``with_real``: the part's vertices in the scene (the real positions whose images
        its virtual vertices are).
    mirror : tuple
        With ``with_mirror`` (and ``with_real``): :func:`mirror_images` of the part's vertices
        and the faces the cut at the silhouette replaced with their objects ((u, 3) int64, (u,)
        int32), what :func:`with_mirror_copies` reads.
    """
    from .silhouette import clip_at_silhouette

    if reflected is None:
        reflected = reflected_mesh(scene, meshes)[1]
    res, gb = refl.result, refl.gbuffer
    vertices, normals, faces, face_obj = verts, reflected.normals, reflected.faces, reflected.face_object
    pixel, flags, surface = res.pixel, res.flags, refl.surface
    virtual = [refl.virtual64]  # its pieces, concatenated once at the end
    points = surface  # every vertex's sub-texel point (P, N), or None
    counts = {}
    if opt.tessellate is not None:
        t = tessellate(gb, eye, verts, normals, faces, face_obj, pixel, flags, opt.tessellate, opt.max_level,
                       opt.neighbourhood, opt.inverse, opt.cap, surface=surface, method=opt.method,
                       min_span=opt.tessellate_span)
        virtual.append(_new_virtual(refl, opt, eye, t.vertices[len(verts):], t.pixel[len(verts):],
                                    t.flags[len(verts):], None if surface is None else t.surface, len(verts)))
        vertices, normals, faces, face_obj, pixel, flags = t.vertices, t.normals, t.faces, t.face_obj, t.pixel, t.flags
        points = None if surface is None else t.surface
        counts["tessellation"] = {"vertices_searched": int(t.searched), "levels": int(t.levels),
                                  "triangles": int(len(t.faces))}
    uncut = (np.zeros((0, 3), np.int64), np.zeros(0, np.int32))  # the faces the cut replaced
    if opt.silhouette == "clip":
        if with_mirror:
            from .silhouette import mixed_faces

            mixed = mixed_faces(faces, flags)
            uncut = (np.asarray(faces, np.int64)[mixed], np.asarray(face_obj, np.int32)[mixed])
        c = clip_at_silhouette(gb, eye, vertices, normals, faces, face_obj, pixel, flags, opt.neighbourhood, opt.cap,
                               opt.method, predict=True)
        new_surface = None
        if opt.refine and len(c.vertices):
            from .refine import refine as refine_points

            new_surface = refine_points(gb, eye, c.vertices, _result(res, c.pixel, c.flags))
        virtual.append(_new_virtual(refl, opt, eye, c.vertices, c.pixel, c.flags, new_surface, 0))
        if with_real:  # the cut points' real positions (only the exact drawing reads them)
            vertices = np.concatenate([vertices, c.vertices])
            pixel = np.concatenate([pixel, c.pixel])
            points = None if points is None or new_surface is None else tuple(
                np.concatenate([a[:len(pixel) - len(c.pixel)], b]) for a, b in zip(points[:2], new_surface[:2]))
        normals = np.concatenate([normals, c.normals])
        flags = np.concatenate([flags, c.flags])
        faces, face_obj = c.faces, c.face_obj
        counts["silhouette"] = {"edges_cut": int(c.cut), "vertices_searched": int(c.searched)}
    virtual = virtual[0] if len(virtual) == 1 else np.concatenate(virtual)
    parts = [(virtual, normals, faces, face_obj, flags)]
    if not with_real:
        return parts, counts
    vertices = np.asarray(vertices, np.float64)
    if with_mirror:
        return parts, counts, vertices, mirror_images(refl, vertices, pixel, flags, points, eye) + (uncut,)
    return parts, counts, vertices


def mirror_images(refl, vertices, pixel, flags, points, eye):
    """What :func:`with_mirror_copies` draws a second time: the images by the ``mirror`` rule
    (across the tangent plane at the reflection point) of the visible vertices (neither HIDDEN nor
    CULLED) whose search stopped on the outline (BORDER) or that lie within
    :data:`refsoft.constants.EXACT_TWIN_GRAZING` (a sine) of the tangent plane as seen from the
    reflection point, and the vertices HIDDEN by less than :data:`~refsoft.constants.
    EXACT_TWIN_HIDDEN` whose walk stopped on the outline.

    Where the reflection point is exact, the ``unfold`` image is the ``mirror`` one; where it is
    not (a vertex reflected beyond the reflector's outline, whose search stopped on it; a vertex
    within a texel of the mirror, where the score hardly changes along a line of texels), the
    ``unfold`` image moves along the eye's ray through the wrong point, the ``mirror`` one stays
    near the true image (on a plane mirror it is the true image). A vertex seen at a grazing angle
    by a convex mirror's silhouette reflects within a texel of the outline, where the texel's
    normal may put it a little behind (HIDDEN): its triangles were no candidates, and the cut at
    the silhouette ends their neighbours short of the silhouette.

    Parameters
    ----------
    refl : Reflection
        The reflector's G-buffer and search result.
    vertices : (n, 3) float64
        The part's real vertices.
    pixel : (n, 2) int32
    flags : (n,) uint8
        Their search results.
    points : (P (n, 3), N (n, 3)) or None
        Their sub-texel reflection points (relative to the G-buffer's origin), or None: the
        texels'.
    eye : (3,)

    Returns
    -------
    rows : (b,) int64
        The visible vertices, ascending.
    images : (b, 3) float64
        Their ``mirror`` images, world space.
    edge : (n,) bool
        The vertices hidden at the silhouette.
    at_texel : callable
        ``at_texel(r)`` (k, 3) float64: the ``unfold`` images of the HIDDEN vertices ``r`` (k,)
        at their walk's last texel, as if seen there (on the eye's ray through it).
    """
    from ..constants import EXACT_TWIN_GRAZING, EXACT_TWIN_HIDDEN

    if points is None:
        at = (pixel[:, 0], pixel[:, 1])
        p, nrm = refl.gbuffer.position[at], refl.gbuffer.normal[at]
    else:
        p, nrm = points[0], points[1]
    # the vertices whose reflection point may be wrong: on the outline, or seen at a grazing angle;
    # and those hidden by a grazing margin where the walk stopped on the outline: maybe seen at the
    # silhouette (kernel _exact.mirror_marks, one pass)
    n = len(flags)
    twin, edge = np.empty(n, bool), np.empty(n, bool)
    parallel_range(mirror_marks, n, np.ascontiguousarray(vertices, np.float64),
                   np.ascontiguousarray(refl.gbuffer.origin, np.float64), np.ascontiguousarray(p),
                   np.ascontiguousarray(nrm), np.ascontiguousarray(flags, np.uint8), float(EXACT_TWIN_GRAZING),
                   float(EXACT_TWIN_HIDDEN), np.uint8(BORDER), np.uint8(HIDDEN), np.uint8(CULLED), twin, edge)
    rows = np.flatnonzero(twin)
    origin = refl.gbuffer.origin

    def at_texel(hidden_rows):
        """(k, 3) float64: the ``unfold`` images of hidden vertices at their walk's last texel,
        as if seen there (on the eye's ray through it)."""
        fl = (flags[hidden_rows] & ~np.uint8(HIDDEN)).astype(np.uint8)
        rel = virtual_vertices(refl.gbuffer, _result(refl.result, pixel[hidden_rows], fl), vertices[hidden_rows],
                               relative=True, rule="unfold", eye=eye)
        return rel.astype(np.float64) + origin

    if len(rows) == 0:
        return rows, np.zeros((0, 3)), edge, at_texel
    sub = None if points is None else tuple(np.asarray(a)[rows] for a in points[:2])
    rel = virtual_vertices(refl.gbuffer, _result(refl.result, pixel[rows], flags[rows]), vertices[rows],
                           relative=True, surface=sub, rule="mirror", eye=eye)
    return rows, rel.astype(np.float64) + origin, edge, at_texel


def with_mirror_copies(part, real, mirror, camera):
    """``part`` and ``real`` with more candidates for the exact drawing (:func:`mirror_images`),
    each over a real triangle of the scene, so that a pixel's answer can only come nearer the
    truth's where its own triangle was not tested:

    - a copy of every triangle, right after it, with a visible vertex whose ``mirror`` image lies
      more than :data:`refsoft.constants.EXACT_TWIN_PIXELS` view pixels from its image in
      ``part`` (in front of the eye both), with those images: it reaches the pixels the first
      one's virtual image stops short of (where both cover a pixel, the copy meets the ray at
      the same ``t`` and the first one's answer stands: :func:`refsoft.search.acceptance.draw`);
    - a copy of every triangle with a corner hidden at the silhouette (``edge``), right after
      it, and after all the others every triangle that the cut at the silhouette replaced by its
      visible part (drawn whole: the cut ends where the walks say HIDDEN, which near the
      silhouette can be short of it), with their HIDDEN corners' images by ``at_texel``, HIDDEN
      cleared.

    Parameters
    ----------
    part : tuple
        ``(virtual (n, 3), normals (n, 3), faces (m, 3) int64, face_obj (m,) int32, flags (n,)
        uint8)``.
    real : (n, 3) float64
    mirror : tuple
        :func:`mirror_images` of the part's vertices, then ``(faces (u, 3) int64, face_obj (u,)
        int32)``: the faces the cut replaced (:func:`refined_parts`).
    camera : Camera
        The view camera.

    Returns
    -------
    part, real
        The images appended as vertices ``n ..`` (the same real position and normal as the
        vertex they image, its flags without HIDDEN) and the copies among the faces; ``part``
        itself when there is none.
    """
    from ..constants import EXACT_TWIN_PIXELS

    rows, images, edge, at_texel, (uncut, uncut_obj) = mirror
    virtual, normals, faces, face_obj, flags = part
    n = len(virtual)
    faces = np.ascontiguousarray(faces, np.int64)
    if len(rows):
        vp = camera.view_proj()
        a = _setup.transform_points(np.asarray(virtual, np.float64)[rows], vp)
        b = _setup.transform_points(images, vp)
        # a vertex at or behind the eye plane: a screen distance means nothing, no copy
        far = np.empty(len(rows), bool)
        parallel_range(far_apart, len(rows), a, b, 0.5 * float(camera.width), 0.5 * float(camera.height),
                       float(EXACT_TWIN_PIXELS), far)
        rows, images = rows[far], images[far]
    more_to_do = edge.any() or len(uncut)
    if not len(rows) and not more_to_do:  # no second image, no face copied
        return part, real
    twin = np.arange(n, dtype=np.int64)
    if len(rows):
        twin[rows] = n + np.arange(len(rows))
    # the faces with a corner imaged again, and those with a corner hidden at the silhouette
    m = len(faces)
    copied, near = np.empty(m, bool), np.empty(m, bool)
    parallel_range(touching, m, faces, twin, n, np.ascontiguousarray(edge, bool), copied, near)
    extra = np.zeros((0, 3), np.int64)
    extra_obj = np.zeros(0, np.int32)
    if more_to_do:
        # a face with a corner hidden at the silhouette, and a face the silhouette cut replaced by a
        # part that may end short (drawn whole): their hidden corners at their texels
        hidden = np.zeros(n, bool)
        hidden[faces[np.flatnonzero(near)].ravel()] = True
        hidden[uncut.ravel()] = True
        hidden &= (flags & (HIDDEN | CULLED)) == HIDDEN
        more = np.flatnonzero(hidden)
        if len(more):
            twin[more] = n + len(rows) + np.arange(len(more))
            rows, images = np.concatenate([rows, more]), np.concatenate([images, at_texel(more)])
            copied |= near
            extra, extra_obj = twin[uncut], np.asarray(uncut_obj, np.int32)
    k = int(np.count_nonzero(copied))
    if k == 0 and len(extra) == 0:
        return part, real
    # each copy right after its face: the same real triangle (one run, where the acceptance
    # tracks runs; the same t, which does not replace the first, where it does not)
    face_obj = np.asarray(face_obj)
    new_faces = np.empty((m + k + len(extra), 3), np.int64)
    new_obj = np.empty(m + k + len(extra), np.result_type(face_obj.dtype, np.int32))
    interleave(faces, np.ascontiguousarray(face_obj, new_obj.dtype), copied, twin, new_faces, new_obj)
    new_faces[m + k:], new_obj[m + k:] = extra, extra_obj
    part = (np.concatenate([virtual, images]), np.concatenate([normals, normals[rows]]), new_faces, new_obj,
            np.concatenate([flags, flags[rows] & ~np.uint8(HIDDEN)]))
    return part, np.concatenate([real, real[rows]])


def _result(like, pixel, flags):
    """A SearchResult of the given pixels and flags (scores unknown), with ``like``'s options."""
    m = len(pixel)
    return SearchResult(pixel, np.zeros(m), np.zeros(m), np.ones(m, np.int32), flags, like.neighbourhood, like.inverse,
                        like.cap, like.method)


def _new_virtual(refl, opt, eye, new, pixel, flags, surface, first):
    """float64 world virtual vertices of vertices added to the reflected geometry (their rows of
    ``surface`` start at ``first``)."""
    sub = None if surface is None else tuple(a[first:] for a in surface[:2])
    rel = virtual_vertices(refl.gbuffer, _result(refl.result, pixel, flags), new, relative=True, surface=sub,
                           rule=opt.virtual, eye=eye)
    return rel.astype(np.float64) + refl.gbuffer.origin


def virtual_pass(scene, parts, camera, stencil, box, inverse, cull=True):
    """Rasterize the virtual scene of one reflector with the view camera, inside its stencil.

    Parameters
    ----------
    scene : Scene
        For the objects' colours.
    parts : list
        :func:`virtual_parts` or :func:`tessellated_parts`: virtual vertices, normals, faces,
        face object ids and flags per part.
    camera : Camera
        The view camera.
    stencil : ndarray (H, W) bool
        The pixels where this reflector is visible in the main view.
    box : (r0, r1, c0, c1)
        The pixels rasterized (the stencil's bounding box: the same pixels as the whole view,
        cropped).
    inverse : str
        The hidden-vertex mode (``discard`` leaves out triangles with a HIDDEN vertex).
    cull : bool
        Leave out parts, then triangles, whose virtual vertices all lie beyond one side of the
        box (:func:`refsoft.search.skips.outside_box`: they cover none of its pixels).

    Returns
    -------
    colour : ndarray (h, w, 3) float32
    reflected_id : ndarray (h, w) int32
    covered : ndarray (h, w) bool
    n_culled : int
        Parts culled.

    Notes
    -----
    A box of at most ``refsoft.raster._threads.SERIAL_MAX_PIXELS`` pixels is rendered on the
    calling thread only (the same outputs; no wait for other threads).
    """
    r0, r1, c0, c1 = box
    with serial_if_small((r1 - r0) * (c1 - c0)):  # a small box: no hand-off to other threads
        return _virtual_pass(scene, parts, camera, stencil, box, inverse, cull)


def _virtual_pass(scene, parts, camera, stencil, box, inverse, cull):
    vp = camera.view_proj()
    bounds = skips.box_planes(box, camera.width, camera.height)
    bad = CULLED | (HIDDEN if inverse == "discard" else 0)
    faces, face_obj, normals, clips, flags = [], [], [], [], []
    n_culled = 0
    offset = 0
    for virtual, nrm_v, f, fobj, fl in parts:
        clip = _setup.transform_points(virtual, vp)
        if cull and skips.outside_box(clip, bounds):
            n_culled += 1
            continue
        faces.append(f + offset if offset else f)
        face_obj.append(fobj)
        normals.append(nrm_v)
        clips.append(clip)
        flags.append(fl)
        offset += len(clip)
    r0, r1, c0, c1 = box
    h, w = r1 - r0, c1 - c0
    if not faces:
        return _nothing(h, w, n_culled)
    faces, face_obj, clip = _joined(faces), _joined(face_obj), _joined(clips)
    # triangles with a vertex without V' and (cull) those beyond one side of the box: neither is
    # set up (the order of the others is kept); a per-triangle front end, on this thread alone up
    # to SERIAL_MAX_TRIANGLES
    skip = skips.triangles_skipped(clip, faces, _joined(flags), bad, bounds if cull else None,
                                   serial=len(faces) <= SERIAL_MAX_TRIANGLES)
    if skip.any():
        keep = ~skip
        # np.compress: NumPy's boolean indexing of (T, 3) rows takes several times as long
        faces, face_obj = np.compress(keep, faces, axis=0), np.compress(keep, face_obj)
    if len(faces) == 0:
        return _nothing(h, w, n_culled)
    # the raster's own types once (its public entry points check and convert every call)
    faces = readonly(faces.astype(np.int32))
    frags = rasterize_trusted(clip, faces, camera.width, camera.height, (int(r0), int(r1), int(c0), int(c1)), None,
                              CULL_MODES[None])
    table = readonly(np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32))
    # shade() of the covered stencil pixels, 0 elsewhere, in one pass
    colour, rid, _ = shade_fragments_trusted(
        frags, readonly(np.ascontiguousarray(_joined(normals), dtype=np.float32)), faces,
        readonly(np.ascontiguousarray(face_obj, dtype=np.int32)), readonly(np.zeros(len(table), dtype=np.int64)), table,
        readonly(np.ascontiguousarray(stencil[r0:r1, c0:c1], dtype=bool)))
    return colour, rid, rid > 0, n_culled


def _joined(arrays):
    """``np.concatenate`` of a list, without the copy for a single array."""
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


def _nothing(h, w, n_culled):
    return (np.zeros((h, w, 3), dtype=np.float32), np.zeros((h, w), dtype=np.int32), np.zeros((h, w), dtype=bool),
            n_culled)

"""The virtual scene of one reflector (spec section 5): its virtual triangles rasterized with the
view camera into a z-buffer of their own, on the reflector's stencil only.

Input: a :class:`refsoft.search.reflect.Reflection` (virtual vertices and search flags) and the
world meshes; output, over the stencil's box: colour (h, w, 3) float32, reflected object id
(h, w) int32 and coverage (h, w) bool, which the frame driver composites.
"""

from __future__ import annotations

import numpy as np

from .._numba import readonly
from ..raster import CULL_MODES, _setup, rasterize_trusted, shade_fragments_trusted
from ..raster._threads import SERIAL_MAX_TRIANGLES, serial_if_small
from ..scene.mesh import concatenate
from . import CULLED, HIDDEN, SearchResult, skips, virtual_vertices
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


def refined_parts(scene, meshes, refl, verts, opt, eye, reflected=None, with_real=False):
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
    """
    from .silhouette import clip_at_silhouette

    if reflected is None:
        reflected = reflected_mesh(scene, meshes)[1]
    res, gb = refl.result, refl.gbuffer
    vertices, normals, faces, face_obj = verts, reflected.normals, reflected.faces, reflected.face_object
    pixel, flags, surface, virtual = res.pixel, res.flags, refl.surface, refl.virtual64
    counts = {}
    if opt.tessellate is not None:
        t = tessellate(gb, eye, verts, normals, faces, face_obj, pixel, flags, opt.tessellate, opt.max_level,
                       opt.neighbourhood, opt.inverse, opt.cap, surface=surface, method=opt.method,
                       min_span=opt.tessellate_span)
        virtual = np.concatenate([virtual, _new_virtual(refl, opt, eye, t.vertices[len(verts):], t.pixel[len(verts):],
                                                        t.flags[len(verts):],
                                                        None if surface is None else t.surface, len(verts))])
        vertices, normals, faces, face_obj, pixel, flags = t.vertices, t.normals, t.faces, t.face_obj, t.pixel, t.flags
        counts["tessellation"] = {"vertices_searched": int(t.searched), "levels": int(t.levels),
                                  "triangles": int(len(t.faces))}
    if opt.silhouette == "clip":
        c = clip_at_silhouette(gb, eye, vertices, normals, faces, face_obj, pixel, flags, opt.neighbourhood, opt.cap,
                               opt.method, predict=True)
        new_surface = None
        if opt.refine and len(c.vertices):
            from .refine import refine as refine_points

            new_surface = refine_points(gb, eye, c.vertices, _result(res, c.pixel, c.flags))
        virtual = np.concatenate([virtual, _new_virtual(refl, opt, eye, c.vertices, c.pixel, c.flags, new_surface, 0)])
        if with_real:  # the cut points' real positions (only the exact drawing reads them)
            vertices = np.concatenate([vertices, c.vertices])
        normals = np.concatenate([normals, c.normals])
        flags = np.concatenate([flags, c.flags])
        faces, face_obj = c.faces, c.face_obj
        counts["silhouette"] = {"edges_cut": int(c.cut), "vertices_searched": int(c.searched)}
    parts = [(virtual, normals, faces, face_obj, flags)]
    return (parts, counts, np.asarray(vertices, np.float64)) if with_real else (parts, counts)


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

"""The exact drawing of a reflector's virtual triangles (``draw="exact"``, beyond the papers).

The virtual pass (:mod:`refsoft.search.virtual`) rasterizes the virtual triangles: between its
vertices a virtual edge is straight, where the mirror bends the reflection of a straight edge, so
along a reflected outline the pixel centres between the two show the object on the other side
(the *specks* and *holes* of ``docs/accuracy.md``). Here the same triangles are candidates of
exact per-pixel acceptance (:mod:`refsoft.search.acceptance`, the drawing of every image on a
mirror that is not convex): each triangle is rasterized dilated (:data:`refsoft.constants.
SEVERAL_DILATE_PIXELS` plus :data:`~refsoft.constants.SEVERAL_DILATE_FRACTION` of its longest
edge) and, at each stencil pixel it covers, the pixel's reflected ray (the truth's,
:mod:`refsoft.raster.rays`) is met with the triangle's *real* scene triangle; the nearest hit
wins. The vertex search still decides which triangles are candidates where: a pixel's answer is
exact whenever its true triangle's virtual triangle lies within the dilation.

Input: one part of the reflected geometry after tessellation and the cut
(:func:`refsoft.search.virtual.refined_parts`) with its real vertices; output, over the stencil's
box, what :func:`refsoft.search.virtual.virtual_pass` gives.
"""

from __future__ import annotations

import numpy as np

from .. import constants
from ..raster import _setup
from .._parallel import parallel_range
from . import CULLED, HIDDEN
from ._exact import gather, gather_work, project, reaching, shade_accepted
from ._several import flat_bounds
from .acceptance import Candidates, _screen_numpy, nearest, pixel_rays
from .scratch import kept as _kept
from .virtual import virtual_pass


def edges_pass(scene, part, real, camera, reflector_mesh, triangle, stencil, box, inverse, cull=True):
    """Draw one reflector's virtual triangles rasterized, then exactly (:func:`exact_pass`) on the
    pixels where the raster can be wrong: within :data:`refsoft.constants.EDGE_BAND_PIXELS`
    (8-neighbour steps) of a pixel whose reflected object or coverage differs from a
    4-neighbour's in the stencil, or of the stencil's outline.

    Parameters and returns as :func:`exact_pass` (``cull``: the virtual pass's object culling);
    ``counts`` also holds ``band_pixels``.
    """
    colour, rid, covered, _ = virtual_pass(scene, [part], camera, stencil, box, inverse, cull)
    r0, r1, c0, c1 = (int(b) for b in box)
    band = edge_band(rid, covered, np.ascontiguousarray(stencil[r0:r1, c0:c1], bool), constants.EDGE_BAND_PIXELS)
    full = np.zeros(stencil.shape, bool)
    full[r0:r1, c0:c1] = band
    c2, rid2, cov2, counts = exact_pass(scene, part, real, camera, reflector_mesh, triangle, full, box, inverse,
                                        band=band)
    colour[band], rid[band], covered[band] = c2[band], rid2[band], cov2[band]
    return colour, rid, covered, {**counts, "band_pixels": int(band.sum())}


def edge_band(rid, covered, stencil, width):
    """(h, w) bool: the ``stencil`` pixels within ``width`` 8-neighbour steps of a stencil pixel
    whose ``rid`` or ``covered`` differs from a 4-neighbour's in the stencil, or of the stencil's
    outline (a stencil pixel with a 4-neighbour outside it or outside the box)."""
    h, w = stencil.shape
    seed = np.zeros((h, w), bool)
    for a, b in (((slice(None), slice(0, -1)), (slice(None), slice(1, None))),
                 ((slice(0, -1), slice(None)), (slice(1, None), slice(None)))):
        both = stencil[a] & stencil[b]
        differ = both & ((rid[a] != rid[b]) | (covered[a] != covered[b]))
        one = stencil[a] != stencil[b]  # the outline, on its stencil side
        seed[a] |= differ | (one & stencil[a])
        seed[b] |= differ | (one & stencil[b])
    seed[0, :] |= stencil[0, :]
    seed[-1, :] |= stencil[-1, :]
    seed[:, 0] |= stencil[:, 0]
    seed[:, -1] |= stencil[:, -1]
    band = seed
    for _ in range(int(width)):
        p = np.pad(band, 1)
        grown = band.copy()
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                grown |= p[1 + dr:1 + dr + h, 1 + dc:1 + dc + w]
        band = grown
    return band & stencil


def exact_pass(scene, part, real, camera, reflector_mesh, triangle, stencil, box, inverse, band=None):
    """Draw one reflector's virtual triangles by exact per-pixel acceptance.

    Parameters
    ----------
    scene : Scene
        For the objects' colours.
    part : tuple
        ``(virtual (n, 3) float64, normals (n, 3), faces (m, 3) int64, face_obj (m,) int32,
        flags (n,) uint8)``, one part of :func:`refsoft.search.virtual.refined_parts`.
    real : (n, 3) float64
        The real (scene) position of each of the part's vertices.
    camera : Camera
        The view camera.
    reflector_mesh : Mesh
        The reflector's world mesh (the main view's).
    triangle : (H, W) int
        The visible triangle per view pixel (the main view's).
    stencil : (H, W) bool
        The reflector's pixels.
    box : (r0, r1, c0, c1)
        The pixels drawn.
    inverse : str
        The hidden-vertex mode: with ``discard`` a triangle with a HIDDEN vertex is no
        candidate; a CULLED vertex's triangles never are.
    band : (h, w) bool, optional
        The box's pixels of ``stencil`` when it holds only some (:func:`edges_pass`): triangles
        whose dilated bounds hold none of them are left out.

    Returns
    -------
    colour : (h, w, 3) float32
    reflected_id : (h, w) int32
    covered : (h, w) bool
    counts : dict
        ``candidates`` (triangles tested), ``pixels_accepted`` and ``pixels_empty``
        (:func:`refsoft.search.acceptance.draw`).
    """
    virtual, normals, faces, face_obj, flags = part
    lost = CULLED | (HIDDEN if inverse == "discard" else 0)
    clip = _setup.transform_points(np.asarray(virtual, np.float64), camera.view_proj())
    xy = _projected(clip, camera)
    # the virtual pass's own leave-out (a vertex without V'), and the triangles whose dilated
    # bounds stay off the box: the acceptance would test no pixel of theirs
    keep = _reaching(clip, xy, faces, flags, lost, box, band)
    # the candidates' corners, objects, real triangles and screen bounds in one pass over them
    f, obj, real_corners, screen = _gathered(keep, faces, face_obj, real, clip, xy, camera, box)
    plane = flat_plane(reflector_mesh)
    if plane is not None:  # straight edges' images are straight: no dilation for their curve
        normal, offset, near = plane
        loose = np.abs(np.asarray(real, np.float64) @ normal - offset) < near
        parallel_range(flat_bounds, len(keep), loose, f, screen[0], float(constants.SEVERAL_DILATE_PIXELS), int(box[0]),
                       screen[1], screen[2])
    cand = Candidates(None, real_corners, None, None, keep, 0)
    # the rays and the winners in scratch memory: shaded before this returns
    rays = pixel_rays(camera, reflector_mesh, triangle, stencil, box, scratch=True)
    best_c, best_uv = nearest(cand, camera, stencil, box, rays=rays, screen=screen, runs=False, scratch=True)
    colour, rid, covered, counts = shade(best_c, best_uv, f, normals, obj, scene, rays[0])
    return colour, rid, covered, {"candidates": int(len(keep)), **counts}


def flat_plane(mesh):
    """A flat mirror's plane: ``(normal (3,), offset, near)`` when every vertex normal of ``mesh``
    is the first one and every vertex lies in the plane ``normal . x = offset`` through the first
    vertex, within :data:`refsoft.constants.EXACT_FLAT_TOLERANCE` times the mesh's size, with
    ``near`` :data:`~refsoft.constants.EXACT_FLAT_NEAR` times its size; None otherwise."""
    v = np.asarray(mesh.vertices, np.float64)
    n = np.asarray(mesh.normals, np.float64)
    if len(v) == 0 or not np.isfinite(v).all() or not np.isfinite(n).all():
        return None
    size = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    normal = n[0]
    if size == 0.0 or abs(float(normal @ normal) - 1.0) > 1e-6:
        return None
    tol = constants.EXACT_FLAT_TOLERANCE
    offset = float(v[0] @ normal)
    if np.abs(n - normal).max() > tol or np.abs(v @ normal - offset).max() > tol * size:
        return None
    return normal, offset, constants.EXACT_FLAT_NEAR * size


def shade(best_c, best_uv, corner, normals, cand_object, scene, valid):
    """The winners of the acceptance shaded (kernel ``_exact.shade_accepted``; as
    :func:`refsoft.search.acceptance.shade_winners`, bit for bit).

    Parameters
    ----------
    best_c : (h, w) int64
    best_uv : (h, w, 2) float64
        :func:`refsoft.search.acceptance.nearest`'s outputs.
    corner : (C, 3) int64
        Each candidate's rows of ``normals``.
    normals : (n, 3) float64
        The part's vertex normals.
    cand_object : (C,) int32
        Each candidate's object.
    scene : Scene
        For the objects' colours.
    valid : (h, w) bool
        Box pixels with a reflected ray.

    Returns
    -------
    colour, reflected_id, covered, counts
        As :func:`refsoft.search.acceptance.draw`.
    """
    h, w = best_c.shape
    colour = np.zeros((h, w, 3), np.float32)
    rid = np.zeros((h, w), np.int32)
    table = np.vstack([np.zeros(3), [o.color for o in scene.objects]]).astype(np.float32)
    parallel_range(shade_accepted, h, best_c, np.ascontiguousarray(best_uv), np.ascontiguousarray(corner, np.int64),
                   np.ascontiguousarray(normals, np.float64), np.ascontiguousarray(cand_object, np.int32), table,
                   constants.LIGHT_DIRECTION.astype(np.float32), np.float32(constants.AMBIENT),
                   np.float32(constants.DIFFUSE), colour, rid)
    covered = best_c >= 0
    counts = {"pixels_accepted": int(covered.sum()), "pixels_empty": int((valid & ~covered).sum())}
    return colour, rid, covered, counts


def candidate_triangles(clip, faces, flags, lost, box, camera, band=None):
    """The triangles that can be candidates of the box's acceptance (kernel
    ``_exact.reaching``).

    Parameters
    ----------
    clip : (n, 4) float64
        The virtual vertices' clip coordinates.
    faces : (m, 3) int64
    flags : (n,) uint8
        The vertices' search flags.
    lost : int
        The flags that leave a vertex's triangles out.
    box : (r0, r1, c0, c1)
    camera : Camera
    band : (r1 - r0, c1 - c0) bool, optional
        The box pixels drawn (default: every one).

    Returns
    -------
    (k,) int64
        The rows of ``faces`` kept, ascending: those with no vertex flagged ``lost`` whose screen
        bounds, widened by the acceptance's dilation and one pixel, reach the box, and a pixel of
        ``band`` when given (and those with a vertex at or behind the eye plane).
    """
    clip = np.ascontiguousarray(clip, np.float64)
    return _reaching(clip, _projected(clip, camera), faces, flags, lost, box, band)


def _projected(clip, camera):
    """(n, 2) float64: the view-pixel positions of clip coordinates (n, 4) float64 (kernel
    ``_exact.project``)."""
    xy = np.empty((len(clip), 2))
    parallel_range(project, len(clip), clip, float(camera.width), float(camera.height), xy)
    return xy


def _reaching(clip, xy, faces, flags, lost, box, band):
    """:func:`candidate_triangles` from the clip coordinates and their :func:`_projected`."""
    r0, r1, c0, c1 = (float(b) for b in box)
    keep = np.empty(len(faces), bool)
    sat = np.zeros((1, 1), np.int64)
    if band is not None:
        sat = np.zeros((band.shape[0] + 1, band.shape[1] + 1), np.int64)
        sat[1:, 1:] = np.cumsum(np.cumsum(band, axis=0, dtype=np.int64), axis=1)
    parallel_range(reaching, len(faces), clip, xy, np.ascontiguousarray(faces, np.int64),
                   np.ascontiguousarray(flags, np.uint8), np.uint8(lost), r0, r1, c0, c1,
                   float(constants.SEVERAL_DILATE_PIXELS), float(constants.SEVERAL_DILATE_FRACTION), band is not None,
                   sat, keep)
    return np.flatnonzero(keep)


def _gathered(keep, faces, face_obj, real, clip, xy, camera, box):
    """The candidates ``keep`` (C,) int64 (rows of ``faces``) gathered in one pass (kernel
    ``_exact.gather``): their corners (C, 3) int64, objects (C,) int32, real triangles
    (C, 3, 3) float64 and :func:`refsoft.search.acceptance.screen_bounds` (the same bits; its
    NumPy rows, :func:`refsoft.search.acceptance._screen_numpy`, where a value is not finite)."""
    r0, r1, c0, c1 = (int(x) for x in box)
    c = len(keep)
    # every entry is written by the kernel: arrays kept from the last call will do
    corner, obj, real_corners = _kept("corner", (c, 3), np.int64), _kept("obj", c, np.int32), _kept("real", (c, 3, 3))
    screen, bbox, dilate = _kept("screen", (c, 3, 2)), _kept("bbox", (c, 4), np.int64), _kept("dilate", c)
    odd = _kept("odd", c, bool)
    parallel_range(gather, c, keep, np.ascontiguousarray(faces, np.int64), np.ascontiguousarray(face_obj, np.int32),
                   np.ascontiguousarray(real, np.float64), clip, xy, r0, r1, c0, c1,
                   float(constants.SEVERAL_DILATE_PIXELS), float(constants.SEVERAL_DILATE_FRACTION), corner, obj,
                   real_corners, screen, bbox, dilate, odd, work=gather_work)
    if odd.any():
        screen[odd], bbox[odd], dilate[odd] = _screen_numpy(clip[corner[odd]], camera, box)
    return corner, obj, real_corners, (screen, bbox, dilate)

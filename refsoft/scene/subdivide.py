"""Loader subdivision of long triangles (spec section 3; Estalella section 6).

:func:`subdivide` splits every triangle with an edge longer than ``L = max_edge`` until none is;
:func:`apply_subdivision` does it to the objects of a scene that ask for it. The rule, exactly
(a port can reproduce it bit for bit in float64, round to nearest, no fused multiply-add):

*Length.* The squared length of edge ``(i, j)`` with ``lo = min(i, j)``, ``hi = max(i, j)`` is
``d = (P[hi] - P[lo]) * s`` (``s`` the per-axis scale), ``dx*dx + dy*dy + dz*dz`` summed left to
right. An edge is *long* when its squared length is ``> L*L``.

*Passes.* Each pass finds the long edges of the current mesh; if there are none, the mesh is
final. Every long edge is split once at its midpoint ``(P[lo] + P[hi]) * 0.5`` with normal
``normalise((N[lo] + N[hi]) * 0.5)`` (``N[lo]`` normalised when that mean is exactly zero); both
triangles sharing the edge use that one new vertex, so the result is conforming. The new vertices
of a pass are appended after the current ones in increasing ``(lo, hi)`` order. The input's
vertices keep indices ``0..n-1`` (positions and normals bit-identical).

*Triangles.* A face ``(v0, v1, v2)`` has edges ``e_k = (v_k, v_k+1)`` (indices mod 3) with
midpoints ``m_k``. It is replaced, in place in the face list, by its children in this order:

- no long edge: kept;
- one (``e_k``; ``a, b, c = v_k, v_k+1, v_k+2``, ``m = m_k``): ``(a, m, c), (m, b, c)``;
- two (``e_k`` kept; ``q, r, p = v_k, v_k+1, v_k+2``, so ``m_rp = m_k+1``, ``m_pq = m_k+2``): the
  corner ``(m_rp, p, m_pq)``, then the quad ``q, r, m_rp, m_pq`` cut along its shorter diagonal
  (squared length as above, on the new positions): ``q-m_rp`` gives ``(q, r, m_rp), (q, m_rp,
  m_pq)``, ``r-m_pq`` gives ``(q, r, m_pq), (r, m_rp, m_pq)``; on a tie, the diagonal from the
  one of ``q, r`` with the smaller vertex index;
- three: ``(v0, m0, m2), (v1, m1, m0), (v2, m2, m1), (m0, m1, m2)``.

Children keep the face's winding. After a pass no edge is longer than ``max(L, 0.87 x)``, ``x``
the longest edge before it (halves and midlines are at most ``x/2``, the corner-to-midpoint edge
of a one-split face is below ``L``, the chosen diagonal of a two-split face at most
``sqrt((x*x + 2*L*L) / 4) < 0.87 x``), so the rule ends.
Before the first pass the result's size is estimated (:func:`estimate_counts`) and refused
above the mesh limits; each pass checks its exact counts before allocating.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .. import validate
from .. import constants
from ..errors import LimitError, SceneError
from .mesh import Mesh, normalize_rows
from .model import Scene, SceneObject

#: A backstop: the size estimate bounds the passes far below this (about 70 at the mesh limits).
MAX_PASSES = 256


def _check_max_edge(value, who: str) -> float:
    if not validate.is_number(value) or value <= 0:
        raise SceneError(f"{who}: max_edge must be a finite positive number, got {value!r}")
    return float(value)


def _check_scale(scale, who: str) -> np.ndarray:
    try:
        s = np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,)).copy()
    except (TypeError, ValueError):
        raise SceneError(f"{who}: scale must be a positive number or 3 of them, got {scale!r}") from None
    if isinstance(scale, (bool, np.bool_)) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise SceneError(f"{who}: scale must be a positive number or 3 of them, got {scale!r}")
    return s


def _len2(xyz, i: np.ndarray, j: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Squared scaled lengths of edges ``(i, j)`` (``i <= j`` for the canonical value), float64.

    ``xyz`` is the positions as three contiguous columns (gathers from 1-D arrays are fast)."""
    x = (xyz[0][j] - xyz[0][i]) * s[0]
    y = (xyz[1][j] - xyz[1][i]) * s[1]
    z = (xyz[2][j] - xyz[2][i]) * s[2]
    return x * x + y * y + z * z


def _columns(p: np.ndarray):
    return tuple(np.ascontiguousarray(p[:, k]) for k in range(3))


def _edges(faces: np.ndarray):
    """(lo, hi) vertex indices of each face's edges ``e_k = (v_k, v_k+1)``, both shape (F, 3)."""
    nxt = faces[:, [1, 2, 0]]
    return np.minimum(faces, nxt), np.maximum(faces, nxt)


def estimate_counts(mesh: Mesh, max_edge: float, scale=1.0) -> tuple[float, float]:
    """The approximate vertex and triangle counts of ``subdivide(mesh, max_edge, scale)``.

    An edge of length ``l > L`` ends in ``p = 2**ceil(log2(l / L))`` pieces (midpoint halving);
    a face whose two largest piece counts are ``p1 >= p2`` ends in about ``p1 * p2`` triangles
    (exact for uniform refinement, above the count for long thin faces) and ``(p1 - 1) * (p2 - 1)
    / 2`` interior vertices; each face-edge adds ``(p - 1) / 2`` vertices (half, as interior edges
    are shared by two faces).

    Returns
    -------
    (vertices, triangles) : tuple of float
        May be ``inf`` for an absurdly small ``max_edge``.
    """
    who = f"mesh {mesh.name!r}"
    L = _check_max_edge(max_edge, who)
    s = _check_scale(scale, who)
    lo, hi = _edges(mesh.faces.astype(np.int64))
    return _estimate(_len2(_columns(mesh.vertices), lo, hi, s), L, mesh.n_vertices)


def _estimate(l2, L, n_vertices):
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        ratio = np.sqrt(l2) / L
        pieces = np.where(l2 > L * L, np.maximum(2.0, np.exp2(np.ceil(np.log2(ratio)))), 1.0)
    pieces.sort(axis=1)
    p1, p2 = pieces[:, 2], pieces[:, 1]
    with np.errstate(over="ignore", invalid="ignore"):
        triangles = float(np.sum(p1 * p2))
        vertices = n_vertices + float(np.sum(pieces - 1.0)) / 2 + float(np.sum((p1 - 1.0) * (p2 - 1.0))) / 2
    return vertices, triangles


def subdivide(mesh: Mesh, max_edge: float, scale=1.0, *, name: str | None = None) -> Mesh:
    """Split every triangle with an edge longer than ``max_edge`` until none is (module docstring).

    Parameters
    ----------
    mesh : Mesh
        Local-space mesh.
    max_edge : float
        Largest edge length ``L`` kept, in world units: finite and positive.
    scale : float or array_like, shape (3,)
        Per-axis scale of the object's transform; edges are measured as ``|(b - a) * scale|``
        (the rotation and translation do not change lengths).
    name : str, optional
        What to call the mesh in error messages (default: ``mesh <mesh.name>``).

    Returns
    -------
    Mesh
        Vertices (V', 3) float64 with ``mesh``'s first, faces (F', 3) int32 grouped by the input
        face they come from (in input order), normals (V', 3). ``mesh`` itself when no edge is long.

    Raises
    ------
    SceneError
        Bad ``max_edge`` or ``scale``, or ``max_edge`` below the floating-point resolution of the
        coordinates (a midpoint equal to an end).
    LimitError
        The estimated or actual result exceeds ``MAX_VERTICES`` / ``MAX_TRIANGLES``.
    """
    who = name or f"mesh {getattr(mesh, 'name', '?')!r}"
    L = _check_max_edge(max_edge, who)
    s = _check_scale(scale, who)
    if not isinstance(mesh, Mesh):
        raise SceneError(f"{who}: subdivide needs a Mesh, got {type(mesh).__name__}")
    xyz = _columns(mesh.vertices)
    faces = mesh.faces.astype(np.int64)
    lo, hi = _edges(faces)
    l2 = _len2(xyz, lo, hi, s)
    n_est, f_est = _estimate(l2, L, mesh.n_vertices)
    if not (n_est <= constants.MAX_VERTICES and f_est <= constants.MAX_TRIANGLES):
        raise LimitError(f"{who}: subdividing at max_edge={L:g} would make about {f_est:.3g} triangles and "
                         f"{n_est:.3g} vertices (limits {constants.MAX_TRIANGLES} / {constants.MAX_VERTICES}); "
                         "use a larger max_edge")
    n = mesh.normals
    # A face with no long edge is final: its edges never change again, so only children are re-checked.
    active = np.ones(len(faces), dtype=bool)
    first = (lo, hi, l2)  # the first pass looks at every face: reuse the estimate's lengths
    for passes in range(MAX_PASSES + 1):
        step = _split_pass(xyz, n, faces, active, s, L, who, first)
        first = None
        if step is None:
            break
        if passes == MAX_PASSES:
            raise SceneError(f"{who}: subdivision at max_edge={L:g} did not end in {MAX_PASSES} passes")
        xyz, n, faces, active = step
    if passes == 0:
        return mesh
    out = Mesh(np.stack(xyz, axis=1), faces, n, name=mesh.name)
    # Mesh renormalises every normal, which can move a unit normal by an ulp: the input's stay exact.
    n.setflags(write=False)
    object.__setattr__(out, "normals", n)
    return out


def _split_pass(xyz, n, faces, active, s, L, who, first=None):
    """One pass of the rule; ``None`` when no active face has a long edge. ``first``: the
    (lo, hi, squared length) of every face's edges when every face is active."""
    if first is None:
        idx = np.flatnonzero(active)
        fa = faces[idx]
        lo, hi = _edges(fa)
        l2 = _len2(xyz, lo, hi, s)
    else:
        idx, fa = np.arange(len(faces)), faces
        lo, hi, l2 = first
    long = l2 > L * L
    n_long = long.sum(axis=1)
    hit = n_long > 0
    if not hit.any():
        return None
    nv = len(n)
    keys, inv = np.unique(lo[long] * nv + hi[long], return_inverse=True)  # sorted by (lo, hi)
    n_faces = len(faces) + int(n_long.sum())
    if nv + len(keys) > constants.MAX_VERTICES or n_faces > constants.MAX_TRIANGLES:
        raise LimitError(f"{who}: subdividing at max_edge={L:g} reaches {nv + len(keys)} vertices and {n_faces} "
                         f"triangles (limits {constants.MAX_VERTICES} / {constants.MAX_TRIANGLES}); use a larger max_edge")
    elo, ehi = keys // nv, keys % nv
    mid_xyz = tuple((c[elo] + c[ehi]) * 0.5 for c in xyz)
    at_lo = (mid_xyz[0] == xyz[0][elo]) & (mid_xyz[1] == xyz[1][elo]) & (mid_xyz[2] == xyz[2][elo])
    at_hi = (mid_xyz[0] == xyz[0][ehi]) & (mid_xyz[1] == xyz[1][ehi]) & (mid_xyz[2] == xyz[2][ehi])
    if np.any(at_lo | at_hi):
        raise SceneError(f"{who}: max_edge={L:g} is below the floating-point resolution of the coordinates")
    mean = (n[elo] + n[ehi]) * 0.5
    zero = ~np.any(mean != 0, axis=1)
    mean[zero] = n[elo[zero]]
    mid = np.full(fa.shape, -1, dtype=np.int64)
    mid[long] = nv + inv.reshape(-1)
    xyz = tuple(np.concatenate([c, m]) for c, m in zip(xyz, mid_xyz))
    n = np.concatenate([n, normalize_rows(mean)])

    rows = np.flatnonzero(hit)
    fh, mh, kh, longh = fa[rows], mid[rows], n_long[rows], long[rows]
    count = np.ones(len(faces), dtype=np.int64)
    count[idx[rows]] = kh + 1
    start = np.cumsum(count) - count
    out = np.empty((n_faces, 3), dtype=np.int64)
    keep = count == 1
    out[start[keep]] = faces[keep]
    first_child = start[idx[rows]]
    for want, children in ((1, _one), (2, _two), (3, _three)):
        sel = kh == want
        if sel.any():
            for j, child in enumerate(children(fh[sel], mh[sel], longh[sel], xyz, s)):
                out[first_child[sel] + j] = child
    new_active = np.zeros(n_faces, dtype=bool)
    for j in range(4):
        has = kh + 1 > j
        new_active[first_child[has] + j] = True
    return xyz, n, out, new_active


def _corner(f, k, shift):
    """``f[i, (k[i] + shift) % 3]`` for every row ``i``."""
    return f[np.arange(len(f)), (k + shift) % 3]


def _one(f, m, long, xyz, s):
    k = np.argmax(long, axis=1)
    a, b, c, mk = _corner(f, k, 0), _corner(f, k, 1), _corner(f, k, 2), _corner(m, k, 0)
    return np.stack([a, mk, c], 1), np.stack([mk, b, c], 1)


def _two(f, m, long, xyz, s):
    k = np.argmin(long, axis=1)  # the edge that is kept
    q, r, pc = _corner(f, k, 0), _corner(f, k, 1), _corner(f, k, 2)
    m_rp, m_pq = _corner(m, k, 1), _corner(m, k, 2)
    da = _len2(xyz, np.minimum(q, m_rp), np.maximum(q, m_rp), s)
    db = _len2(xyz, np.minimum(r, m_pq), np.maximum(r, m_pq), s)
    use_a = ((da < db) | ((da == db) & (q < r)))[:, None]
    corner = np.stack([m_rp, pc, m_pq], 1)
    t1 = np.where(use_a, np.stack([q, r, m_rp], 1), np.stack([q, r, m_pq], 1))
    t2 = np.where(use_a, np.stack([q, m_rp, m_pq], 1), np.stack([r, m_rp, m_pq], 1))
    return corner, t1, t2


def _three(f, m, long, xyz, s):
    v0, v1, v2 = f[:, 0], f[:, 1], f[:, 2]
    m0, m1, m2 = m[:, 0], m[:, 1], m[:, 2]
    return (np.stack([v0, m0, m2], 1), np.stack([v1, m1, m0], 1), np.stack([v2, m2, m1], 1),
            np.stack([m0, m1, m2], 1))


# --- Scenes -----------------------------------------------------------------------------------


def check_override(value) -> float | None:
    """A subdivision override as a float (None: no override); SceneError unless a finite number >= 0."""
    if value is None:
        return None
    if not validate.is_number(value) or value < 0:
        raise SceneError(f"subdivide override must be a finite number >= 0 (0 = off), got {value!r}")
    return float(value)


def effective_max_edge(obj: SceneObject, override: float | None = None) -> float:
    """The ``max_edge`` :func:`apply_subdivision` uses for ``obj`` (0.0 = not subdivided).

    Without an override: ``obj.subdivide`` (None or 0 = off). With one: 0 turns every object
    off; ``L > 0`` replaces every non-reflector's value and every reflector's positive value (a
    reflector is subdivided only when it asks for it itself: its G-buffer is per pixel anyway).
    """
    override = check_override(override)
    own = obj.subdivide or 0.0
    if override is None:
        return own
    if override == 0 or (obj.reflector and own == 0):
        return 0.0
    return override


def object_scale(scene: Scene, object_id: int) -> np.ndarray:
    """Per-axis largest scale of object ``object_id`` over its transform and animation keys,
    shape (3,): subdividing under it keeps edges within ``max_edge`` at every frame (the scale
    is interpolated linearly between keys)."""
    obj = scene.object_by_id(object_id)
    scales = [obj.transform.scale]
    if scene.animation is not None:
        scales += [t.scale for _, t in scene.animation.object_keys.get(obj.name, ())]
    return np.max(np.asarray(scales, dtype=np.float64), axis=0)


def apply_subdivision(scene: Scene, override: float | None = None) -> Scene:
    """A new scene whose objects' meshes are subdivided as they ask (:func:`effective_max_edge`).

    An object's mesh, and its closed proxy if it has one, are subdivided under
    :func:`object_scale`; its ``subdivide`` records the value used and ``source_counts`` the
    (vertices, triangles) of the mesh as given (kept from the first subdivision when applied
    again, which only subdivides further). ``scene`` itself when nothing changes.

    Parameters
    ----------
    scene : Scene
    override : float, optional
        ``L > 0`` or 0 (off) for every object, as a ``--subdivide`` flag gives it.
    """
    override = check_override(override)
    objects, changed = [], False
    for i, obj in enumerate(scene.objects):
        L = effective_max_edge(obj, override)
        if L == 0:
            recorded = 0.0 if (override == 0 and obj.subdivide) else obj.subdivide
            if recorded != obj.subdivide:
                obj, changed = replace(obj, subdivide=recorded), True
            objects.append(obj)
            continue
        s = object_scale(scene, i + 1)
        who = f"scene {scene.name!r}: object {obj.name!r}"
        mesh = subdivide(obj.mesh, L, s, name=who)
        proxy = None if obj.closed_proxy is None else subdivide(obj.closed_proxy, L, s, name=f"{who} closed_proxy")
        source = obj.source_counts or (obj.mesh.n_vertices, obj.mesh.n_faces)
        objects.append(replace(obj, mesh=mesh, closed_proxy=proxy, subdivide=L, source_counts=source))
        changed = True
    return replace(scene, objects=tuple(objects)) if changed else scene


def counts_before_after(scene: Scene) -> dict:
    """``{"vertices": (before, after), "triangles": (before, after)}`` over the scene's objects:
    before is the meshes as given (``SceneObject.source_counts``), after as subdivided."""
    vb = vt = fb = ft = 0
    for o in scene.objects:
        v, f = o.source_counts or (o.mesh.n_vertices, o.mesh.n_faces)
        vb, fb, vt, ft = vb + v, fb + f, vt + o.mesh.n_vertices, ft + o.mesh.n_faces
    return {"vertices": (vb, vt), "triangles": (fb, ft)}

"""Scenes like the layered-depth-texture paper's (Zhang, Hsieh and Shen): a mirror ball reflecting
closed objects of one to five depth layers, an object touching the ball (their Fig. 7) and an
upright cylinder seen from the side (their Fig. 5). All procedural.

Every reflected object is one closed, consistently wound mesh whose vertices are shared (each
edge belongs to exactly two triangles by vertex index), so methods that peel depth layers can
pair front and back surfaces. Solids with holes are built on a voxel lattice: the boundary
faces of an occupancy grid, made manifold, optionally smoothed (Taubin's lambda|mu filter keeps
the volume and the connectivity).
"""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..mesh import Mesh, normalize_rows
from ..model import Animation, Scene, SceneObject, Transform
from ..primitives import icosphere

#: Whether the occupied (and the empty) cells of a 2x2x2 block, bit ``4 dx + 2 dy + dz`` set
#: for occupied, are connected through shared faces: the boundary is a manifold at the block's
#: centre vertex iff both are.
_BLOCK_OK = None


def _block_table() -> np.ndarray:
    def connected(cells):
        if not cells:
            return True
        seen, todo = {cells[0]}, [cells[0]]
        while todo:
            c = todo.pop()
            for bit in (1, 2, 4):
                n = c ^ bit
                if n in cells and n not in seen:
                    seen.add(n)
                    todo.append(n)
        return len(seen) == len(cells)

    ok = np.zeros(256, dtype=bool)
    for code in range(256):
        full = [c for c in range(8) if code >> c & 1]
        empty = [c for c in range(8) if not code >> c & 1]
        ok[code] = connected(full) and connected(empty)
    return ok


def make_manifold(occupied):
    """Fill every 2x2x2 block of cells whose occupied or empty cells fall apart (edge- or
    corner-only contact), until none is left: the boundary surface is then a 2-manifold.

    Parameters
    ----------
    occupied : ndarray (X, Y, Z) bool

    Returns
    -------
    cells : ndarray (X + 2 p, Y + 2 p, Z + 2 p) bool
        The cells padded with ``p`` cells on every side, the outermost layer empty.
    p : int
        The padding (1, more when fills reached the border).
    """
    global _BLOCK_OK
    if _BLOCK_OK is None:
        _BLOCK_OK = _block_table()
    occ, pad = np.pad(np.asarray(occupied, dtype=bool), 1), 1
    while True:
        code = np.zeros(tuple(s - 1 for s in occ.shape), dtype=np.int64)
        blocks = [(dx, dy, dz) for dx in (0, 1) for dy in (0, 1) for dz in (0, 1)]
        for dx, dy, dz in blocks:
            cell = occ[dx:dx + code.shape[0], dy:dy + code.shape[1], dz:dz + code.shape[2]]
            code |= cell.astype(np.int64) << (4 * dx + 2 * dy + dz)
        bad = ~_BLOCK_OK[code]
        if not bad.any():
            return occ, pad
        for dx, dy, dz in blocks:
            occ[dx:dx + code.shape[0], dy:dy + code.shape[1], dz:dz + code.shape[2]] |= bad
        inner = occ[1:-1, 1:-1, 1:-1]
        if inner.sum() != occ.sum():  # a fill reached the border: keep an empty layer outside
            occ, pad = np.pad(occ, 1), pad + 1


def voxel_surface(occupied, cell: float, origin=(0.0, 0.0, 0.0)):
    """The closed boundary of a set of voxels: one quad (two triangles) per face between an
    occupied and an empty cell, wound outwards, vertices shared on the lattice.

    Parameters
    ----------
    occupied : ndarray (X, Y, Z) bool
        With an empty outermost layer (as :func:`make_manifold` returns it).
    cell : float
        Edge length of a cell.
    origin : (3,) float
        Position of the lattice point (0, 0, 0).

    Returns
    -------
    vertices : ndarray (V, 3) float64
    faces : ndarray (F, 3) int64
    """
    occ = np.asarray(occupied, dtype=bool)
    corners = []
    for a in range(3):
        u, v = (a + 1) % 3, (a + 2) % 3
        lo = np.take(occ, range(occ.shape[a] - 1), axis=a)
        hi = np.take(occ, range(1, occ.shape[a]), axis=a)
        for sign, where in ((1, lo & ~hi), (-1, hi & ~lo)):
            idx = np.argwhere(where)  # lattice plane at idx[a] + 1 along a
            p = idx.copy()
            p[:, a] += 1
            quad = np.repeat(p[:, None, :], 4, axis=1)
            # (u, v) offsets counter-clockwise around +a (e_u x e_v = e_a)
            for i, (du, dv) in enumerate(((0, 0), (1, 0), (1, 1), (0, 1))):
                quad[:, i, u] += du
                quad[:, i, v] += dv
            corners.append(quad if sign > 0 else quad[:, ::-1])
    quads = np.concatenate(corners)
    keys, index = np.unique(quads.reshape(-1, 3), axis=0, return_inverse=True)
    q = index.reshape(-1, 4)
    faces = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return keys * float(cell) + np.asarray(origin, dtype=np.float64), faces.astype(np.int64)


def taubin(vertices, faces, iterations: int = 10, lam: float = 0.5, mu: float = -0.53) -> np.ndarray:
    """Taubin's lambda|mu smoothing with the uniform (umbrella) Laplacian: per iteration
    ``v += lam L(v)`` then ``v += mu L(v)``, ``L(v)`` the mean of the neighbours minus ``v``."""
    v = np.array(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    a, b = np.concatenate([e[:, 0], e[:, 1]]), np.concatenate([e[:, 1], e[:, 0]])
    degree = np.bincount(a, minlength=len(v)).astype(np.float64)
    for _ in range(iterations):
        for k in (lam, mu):
            mean = np.stack([np.bincount(a, weights=v[b, i], minlength=len(v)) for i in range(3)], 1) / degree[:, None]
            v = v + k * (mean - v)
    return v


def voxel_solid(sdf, cell: float, lo, hi, smooth: int = 0, project: bool = True, name: str = "solid") -> Mesh:
    """A closed mesh of the solid ``sdf < 0`` in the box ``[lo, hi]``.

    The cells whose centres are inside, made manifold (:func:`make_manifold`); their boundary
    (:func:`voxel_surface`), smoothed ``smooth`` Taubin iterations; with ``project``, every vertex
    moved onto the surface ``sdf = 0`` by Newton steps along the gradient, which then gives the
    normals (without, area-weighted normals).

    Parameters
    ----------
    sdf : callable
        ``sdf(x, y, z)`` on arrays: negative inside, with a gradient of about unit length near
        the surface (a signed distance, or smooth unions and differences of them).
    cell : float
    lo, hi : (3,) float
    smooth : int
    project : bool
    name : str
    """
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    n = np.ceil((hi - lo) / cell - 1e-9).astype(int)
    lo = 0.5 * (lo + hi) - 0.5 * n * cell  # the grid centred on the box
    axes = [lo[i] + (np.arange(n[i]) + 0.5) * cell for i in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    occ, pad = make_manifold(sdf(x, y, z) < 0)
    v, f = voxel_surface(occ, cell, lo - pad * cell)  # the padding moves the lattice
    if smooth:
        v = taubin(v, f, smooth)
    if not project:
        return Mesh(v, f, name=name)
    for _ in range(6):
        g = _gradient(sdf, v)
        v = v - (sdf(v[:, 0], v[:, 1], v[:, 2]) / np.maximum(np.sum(g * g, axis=1), 1e-12))[:, None] * g
    return Mesh(v, f, normalize_rows(_gradient(sdf, v)), name=name)


def _gradient(sdf, v, h=1e-6):
    """Central-difference gradient of ``sdf`` at points ``v`` (N, 3)."""
    g = np.empty_like(v)
    for i in range(3):
        d = np.zeros(3)
        d[i] = h
        p, m = v + d, v - d
        g[:, i] = (sdf(p[:, 0], p[:, 1], p[:, 2]) - sdf(m[:, 0], m[:, 1], m[:, 2])) / (2 * h)
    return g


def _smin(a, b, k):
    """Polynomial smooth minimum (a union with a fillet of about ``k``)."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def _capped_cylinder(r, y, radius, y0, y1, round_=0.0):
    """Signed distance to the upright cylinder ``r < radius``, ``y0 < y < y1``, its two rims
    rounded with radius ``round_``."""
    dr = r - (radius - round_)
    dy = np.maximum(y0 + round_ - y, y - (y1 - round_))
    return np.hypot(np.maximum(dr, 0.0), np.maximum(dy, 0.0)) + np.minimum(np.maximum(dr, dy), 0.0) - round_


def revolve(profile, normals, sections: int, name: str = "revolved") -> Mesh:
    """A closed surface of revolution about the y axis, vertices shared.

    Parameters
    ----------
    profile : array_like (P, 2)
        ``(radius, y)`` from the top pole (radius 0) down to the bottom pole (radius 0).
    normals : array_like (P, 2)
        ``(radial, y)`` normal at each profile point.
    sections : int
        Vertices per ring.
    """
    prof, nrm = np.asarray(profile, dtype=np.float64), np.asarray(normals, dtype=np.float64)
    phi = 2.0 * np.pi * np.arange(sections) / sections
    s, c = np.sin(phi), np.cos(phi)
    rings = prof[1:-1]
    v = [[0.0, prof[0, 1], 0.0]]
    n = [[0.0, nrm[0, 1], 0.0]]
    for (r, y), (nr, ny) in zip(rings, nrm[1:-1]):
        v += list(np.stack([r * s, np.full(sections, y), r * c], 1))
        n += list(np.stack([nr * s, np.full(sections, ny), nr * c], 1))
    v.append([0.0, prof[-1, 1], 0.0])
    n.append([0.0, nrm[-1, 1], 0.0])
    j = np.arange(sections)
    jn = (j + 1) % sections
    bottom = 1 + len(rings) * sections
    faces = [np.stack([np.zeros(sections, int), 1 + j, 1 + jn], 1)]
    for i in range(len(rings) - 1):
        a, b = 1 + i * sections, 1 + (i + 1) * sections
        faces += [np.stack([a + j, b + j, b + jn], 1), np.stack([a + j, b + jn, a + jn], 1)]
    last = 1 + (len(rings) - 1) * sections
    faces.append(np.stack([np.full(sections, bottom), last + jn, last + j], 1))
    return Mesh(np.array(v), np.concatenate(faces), normalize_rows(np.array(n)), name=name)


def closed_cylinder(radius: float = 0.3, height: float = 1.6, sections: int = 64, rings: int = 12,
                    bevel: float = 0.02) -> Mesh:
    """An upright cylinder as one closed surface (caps and side share their rim vertices).
    Flat caps and a smooth side; the normals turn over a rim band ``bevel`` wide."""
    h, r, b = 0.5 * height, radius, bevel
    cap = [(r * k / 4, 0) for k in range(1, 4)] + [(r - b, 0)]
    prof = [(0.0, h)] + [(x, h) for x, _ in cap] + [(r, h)]
    nrm = [(0.0, 1.0)] * (len(cap) + 1) + [(np.sqrt(0.5), np.sqrt(0.5))]
    for y in np.linspace(h - b, -h + b, rings + 1):
        prof.append((r, y))
        nrm.append((1.0, 0.0))
    prof += [(r, -h)] + [(x, -h) for x, _ in cap[::-1]] + [(0.0, -h)]
    nrm += [(np.sqrt(0.5), -np.sqrt(0.5))] + [(0.0, -1.0)] * (len(cap) + 1)
    return revolve(prof, nrm, sections, name="cylinder")


def hollow_box(size=(1.0, 0.7, 1.0), wall: float = 0.1, cell: float = 0.05) -> Mesh:
    """An open-top box with walls and a floor ``wall`` thick, one closed surface on the voxel
    lattice (sharp edges; normals averaged along them): two depth layers through its walls."""
    sx, sy, sz = size

    def sdf(x, y, z):
        outer = np.maximum(np.maximum(np.abs(x) - sx / 2, np.abs(y) - sy / 2), np.abs(z) - sz / 2)
        cavity = np.maximum(np.maximum(np.abs(x) - (sx / 2 - wall), -sy / 2 + wall - y), np.abs(z) - (sz / 2 - wall))
        return np.maximum(outer, -cavity)

    half = np.array([sx, sy, sz]) / 2
    return voxel_solid(sdf, cell, -half, half, project=False, name="hollow_box")


def genus3(major: float = 0.3, minor: float = 0.11, cell: float = 0.025, smooth: int = 6) -> Mesh:
    """Three fused solid tori in a row (a genus-3 solid) in the xy plane: three or more depth
    layers along the row."""
    centres = (-1.9 * major, 0.0, 1.9 * major)

    def sdf(x, y, z):
        out = None
        for cx in centres:
            d = np.hypot(np.hypot(x - cx, y) - major, z) - minor
            out = d if out is None else _smin(out, d, 0.04)
        return out

    ext = np.array([3 * major + minor, major + minor, minor]) + 2 * cell
    return voxel_solid(sdf, cell, -ext, ext, smooth=smooth, name="genus3")


def cup(radius: float = 0.4, height: float = 0.75, wall: float = 0.08, cell: float = 0.03, smooth: int = 6) -> Mesh:
    """A cup with a handle as one closed surface (genus 1): a cylindrical body with a floor and a
    rounded rim, the handle a half ring on its +x side; three or more depth layers through handle
    and walls."""
    ring_r, tube_r, h = 0.22 * height, 0.06, height / 2

    def sdf(x, y, z):
        r = np.hypot(x, z)
        body = _capped_cylinder(r, y, radius, -h, h, 0.03)
        cavity = _capped_cylinder(r, y, radius - wall, -h + wall, h + 1.0, 0.03)
        handle = np.maximum(np.hypot(np.hypot(x - radius, y) - ring_r, z) - tube_r, radius - wall / 2 - x)
        return -_smin(-_smin(body, handle, 0.03), cavity, 0.04)

    ext = np.array([radius + ring_r + tube_r, h, radius]) + 2 * cell
    lo = np.array([-radius - 2 * cell, -ext[1], -ext[2]])
    return voxel_solid(sdf, cell, lo, ext, smooth=smooth, name="cup")


# ------------------------------------------------------------------------------------ scenes
def _ball():
    return SceneObject("ball", icosphere(5, 1.0), (0.9, 0.9, 0.9), Transform((0.0, 0.0, 0.0)), reflector=True)


def _camera(eye=(0.0, 0.8, 5.0), target=(0.0, 0.0, 0.0), fov_y=40.0):
    return Camera(eye=eye, target=target, up=(0.0, 1.0, 0.0), fov_y=fov_y, width=640, height=480, near=0.1,
                  far=100.0)


def balls_scene() -> Scene:
    """Two balls (one depth layer each) moving in front of a mirror ball over 20 frames."""
    t_red = (Transform((-1.1, 0.35, 1.0)), Transform((-1.35, 0.5, 0.3)))
    t_blue = (Transform((1.0, -0.45, 0.9)), Transform((0.6, -0.6, 1.3)))
    red = SceneObject("red_ball", icosphere(3, 0.4), (0.9, 0.25, 0.15), t_red[0])
    blue = SceneObject("blue_ball", icosphere(3, 0.3), (0.2, 0.35, 0.9), t_blue[0])
    keys = {"red_ball": ((0, t_red[0]), (19, t_red[1])), "blue_ball": ((0, t_blue[0]), (19, t_blue[1]))}
    return Scene((_ball(), red, blue), _camera(), Animation(20, object_keys=keys), "balls")


def hollow_box_scene() -> Scene:
    """An open-top hollow box (two depth layers) in front of a mirror ball, turned towards it."""
    box = SceneObject("hollow_box", hollow_box(), (0.85, 0.55, 0.2), Transform((1.3, -0.4, 1.0), (0.0, 35.0, 0.0)))
    return Scene((_ball(), box), _camera((0.0, 1.3, 5.0)), None, "hollow_box")


def genus3_scene() -> Scene:
    """A genus-3 solid (three fused tori, three or more depth layers) under a mirror ball,
    turning about its vertical axis over 24 frames."""
    t0, t1 = Transform((0.0, -1.25, 0.9), (-80.0, 0.0, 0.0)), Transform((0.0, -1.25, 0.9), (-80.0, 40.0, 0.0))
    obj = SceneObject("genus3", genus3(), (0.3, 0.75, 0.35), t0)
    return Scene((_ball(), obj), _camera((0.0, 1.0, 5.5)), Animation(24, object_keys={"genus3": ((0, t0), (23, t1))}),
                 "genus3")


def cup_scene() -> Scene:
    """A cup with a handle (a closed mesh, three or more depth layers) beside a mirror ball."""
    obj = SceneObject("cup", cup(), (0.9, 0.85, 0.7), Transform((-1.1, -0.45, 1.0), (0.0, -60.0, 0.0)))
    return Scene((_ball(), obj), _camera((0.0, 1.2, 5.0)), None, "cup")


def touching_scene() -> Scene:
    """A hollow box resting on top of a mirror ball (its floor 0.002 below the ball's top
    vertex): an object meeting the reflector, where an environment map's parallax is large (the
    LDT paper's Fig. 7)."""
    ball = _ball()
    box = hollow_box((0.9, 0.6, 0.9), 0.09, 0.045)
    top = float(ball.mesh.vertices[:, 1].max())
    lift = top - 0.002 - float(box.vertices[:, 1].min())
    obj = SceneObject("hollow_box", box, (0.85, 0.55, 0.2), Transform((0.0, lift, 0.0), (0.0, 30.0, 0.0)))
    return Scene((ball, obj), _camera((0.0, 1.6, 4.6), (0.0, 0.4, 0.0), 45.0), None, "touching")


def cylinder_scene() -> Scene:
    """An upright cylinder beside a mirror ball, both seen from the side (the LDT paper's Fig. 5:
    one cube face sees only the cap of the cylinder's side)."""
    obj = SceneObject("cylinder", closed_cylinder(0.3, 1.6), (0.25, 0.45, 0.9), Transform((1.4, 0.0, 1.0)))
    return Scene((_ball(), obj), _camera((0.0, 0.0, 5.0), fov_y=40.0), None, "cylinder")

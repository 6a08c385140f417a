"""Mirrors that see each other (spec section 5.1): three mirror balls side by side on a floor,
among coloured objects. With ``bounces = 1`` each ball shows the objects only; with more, each
shows the other balls and what they reflect."""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..mesh import Mesh
from ..model import Animation, Scene, SceneObject, Transform
from ..primitives import box, cylinder, icosphere, plane_grid
from .basic import _orbit_keys

#: The floor's height; the balls rest on it.
FLOOR_Y = -0.7
#: Quads along each side of a floor tile.
TILE_CELLS = 4


def _tiles(parity: int, size: float = 10.0, n: int = 10, cells: int = TILE_CELLS) -> Mesh:
    """Every other square tile (those with ``(i + j) % 2 == parity``) of an ``n`` x ``n`` board in
    the xz plane facing +y: one half of a checkered floor, so that a floor seen in a mirror ball
    is told from the floor around it. Each tile is a ``cells`` x ``cells`` grid of quads (a vertex
    method reflects vertices: a tile of two triangles would be drawn straight-edged in a ball)."""
    step = size / n
    g = np.linspace(0.0, 1.0, cells + 1)
    gu, gv = np.meshgrid(g, g, indexing="ij")
    corners = np.stack([gu.ravel(), gv.ravel()], axis=1)  # (cells + 1)^2 points of one tile
    k = np.arange(cells)
    a = (k[:, None] * (cells + 1) + k[None, :]).ravel()  # each quad's first corner
    quad = np.concatenate([np.stack([a, a + 1, a + cells + 2], 1), np.stack([a, a + cells + 2, a + cells + 1], 1)])
    tiles = [(i, j) for i in range(n) for j in range(n) if (i + j) % 2 == parity]
    xz = np.concatenate([(np.array(t) + corners) * step - size / 2 for t in tiles])
    v = np.stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]], axis=1)
    f = np.concatenate([quad + t * len(corners) for t in range(len(tiles))])
    # wind each face towards +y, the side the floor is seen from
    up = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])[:, 1] > 0
    f = np.where(up[:, None], f, f[:, [0, 2, 1]])
    return Mesh(v, f, np.tile([0.0, 1.0, 0.0], (len(v), 1)), name="tiles")


def _room():
    """Four walls and a ceiling around the floor (x in [-5, 5], z in [-4, 6], up to 4 above the
    floor), each its own colour, so that every reflected ray meets something and the balls' pictures
    say which way they look."""
    walls = (
        ("back_wall", (10.0, 4.0), (0.0, FLOOR_Y + 2.0, -4.0), (90.0, 0.0, 0.0), (0.6, 0.65, 0.8)),
        ("front_wall", (10.0, 4.0), (0.0, FLOOR_Y + 2.0, 6.0), (-90.0, 0.0, 0.0), (0.85, 0.75, 0.55)),
        ("left_wall", (4.0, 10.0), (-5.0, FLOOR_Y + 2.0, 1.0), (0.0, 0.0, -90.0), (0.7, 0.5, 0.7)),
        ("right_wall", (4.0, 10.0), (5.0, FLOOR_Y + 2.0, 1.0), (0.0, 0.0, 90.0), (0.45, 0.7, 0.7)),
        ("ceiling", (10.0, 10.0), (0.0, FLOOR_Y + 4.0, 1.0), (180.0, 0.0, 0.0), (0.9, 0.9, 0.85)),
    )
    return tuple(SceneObject(name, plane_grid(size, (4, 4)), colour, Transform(at, turn))
                 for name, size, at, turn, colour in walls)


def mirrors_scene() -> Scene:
    """Three mirror balls (icospheres, 4 subdivisions; radii 0.7, 0.55, 0.6) in a row with gaps of
    about 0.15 between them, resting on the checkered floor of a room whose walls differ in colour, with a
    red cube and a blue cylinder beside them and a yellow cube and a green box behind; the camera
    orbits 40 degrees over 24 frames, so that the balls' pictures of each other move."""
    balls = ((-1.4, 0.7), (-0.05, 0.55), (1.25, 0.6))  # (x, radius)
    objects = tuple(
        SceneObject(f"ball_{i + 1}", icosphere(4, r), (0.9, 0.9, 0.9), Transform((x, FLOOR_Y + r, 0.1 * i)),
                    reflector=True) for i, (x, r) in enumerate(balls)) + (
        SceneObject("floor_dark", _tiles(0), (0.3, 0.45, 0.3), Transform((0.0, FLOOR_Y, 1.0))),
        SceneObject("floor_light", _tiles(1), (0.75, 0.8, 0.7), Transform((0.0, FLOOR_Y, 1.0))),
        SceneObject("red_cube", box((0.6, 0.6, 0.6), 2), (0.85, 0.2, 0.15),
                    Transform((-2.7, FLOOR_Y + 0.3, 0.7), (0.0, 30.0, 0.0))),
        SceneObject("blue_cylinder", cylinder(0.3, 1.4, 32, 4), (0.2, 0.35, 0.9),
                    Transform((2.5, FLOOR_Y + 0.7, 0.6))),
        SceneObject("yellow_cube", box((0.5, 0.5, 0.5), 2), (0.95, 0.8, 0.15),
                    Transform((0.6, FLOOR_Y + 0.25, -1.3), (0.0, -20.0, 0.0))),
        SceneObject("green_box", box((0.9, 0.35, 0.4), 2), (0.2, 0.7, 0.3),
                    Transform((-1.1, FLOOR_Y + 0.175, -1.5), (0.0, 15.0, 0.0))),
    ) + _room()
    camera = Camera(eye=(0.0, 1.4, 5.0), target=(0.0, -0.1, 0.0), up=(0.0, 1.0, 0.0), fov_y=32.0,
                    width=640, height=480, near=0.1, far=100.0)
    anim = Animation(24, _orbit_keys(24, 5.0, 1.4, -20, 20, (0.0, -0.1, 0.0)))
    return Scene(objects, camera, anim, "mirrors")

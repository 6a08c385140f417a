"""Mirrors that are not convex, where a vertex has several reflection points (spec section 4.8):
a concave spherical shaving mirror and a sinusoidal mirror sheet. Both are open sheets searched
as they are (``open = True``), like the ``concave`` bowl."""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..mesh import Mesh, normalize_rows
from ..model import Animation, Scene, SceneObject, Transform
from ..primitives import _drop_degenerate, _grid_faces, box, cylinder, icosphere, plane_grid

#: The shaving mirror's sphere: radius (focal length half of it) and centre of curvature.
SHAVING_RADIUS = 3.0
SHAVING_CENTRE = (0.0, 0.8, 0.0)


def spherical_cap(radius: float, half_angle_deg: float, rings: int = 32, segments: int = 96) -> Mesh:
    """The inner surface of an open spherical cap around the -z axis, centred on the origin:
    the points of the sphere within ``half_angle_deg`` of ``(0, 0, -radius)``, normals and
    winding facing the centre (a concave mirror looking along +z)."""
    theta = np.linspace(np.radians(half_angle_deg), 0.0, rings + 1)  # rim first, the pole last
    phi = np.linspace(0.0, 2 * np.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    out = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), -np.cos(t)], -1).reshape(-1, 3)
    v = out * radius
    faces = _grid_faces(rings, segments)
    # wind the faces towards the centre, the side the mirror is seen from
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    facing = np.sum(np.cross(b - a, c - a) * -out[faces[:, 0]], axis=1)
    faces = np.where((facing < 0)[:, None], faces[:, [0, 2, 1]], faces)
    return Mesh(v, _drop_degenerate(v, faces), -out, name="spherical_cap")


def shaving_scene() -> Scene:
    """A concave spherical shaving mirror (a cap of radius R = 3, focal length f = 1.5, 40 degrees
    on each side of its axis) with small objects inside f, between f and the centre of curvature
    C (near the caustic of the camera's reflected rays), near C and beyond C, and a wall behind the
    camera; the camera, beyond C, slides sideways over 24 frames. Objects inside f appear upright
    and magnified, those beyond f inverted, and the one in the caustic twice."""
    r = SHAVING_RADIUS
    cx, cy, cz = SHAVING_CENTRE
    mirror = SceneObject("shaving_mirror", spherical_cap(r, 40.0), (0.85, 0.85, 0.88),
                         Transform((cx, cy, cz)), reflector=True, open=True)
    objs = (
        mirror,
        # the mirror's vertex is at z = cz - 3, its focus at cz - 1.5: inside f
        SceneObject("red_ball", icosphere(3, 0.15), (0.9, 0.2, 0.15), Transform((cx + 0.35, cy + 0.15, cz - 2.3))),
        # between f and C, in the caustic of the camera's rays: imaged twice, inverted and magnified
        SceneObject("yellow_box", box((0.12, 0.12, 0.12), 3), (0.95, 0.8, 0.15),
                    Transform((cx + 0.1, cy - 0.1, cz - 1.4), (20, 30, 0))),
        # near C
        SceneObject("green_ball", icosphere(3, 0.12), (0.2, 0.75, 0.3), Transform((cx + 0.2, cy - 0.25, cz + 0.05))),
        # beyond C
        SceneObject("blue_cylinder", cylinder(0.08, 0.6, 32, 4), (0.2, 0.35, 0.9),
                    Transform((cx - 0.9, cy + 0.1, cz + 1.6))),
        SceneObject("back_wall", box((10.0, 5.0, 0.2), 8), (0.6, 0.7, 0.85), Transform((0.0, 0.8, 8.0))),
        SceneObject("floor", plane_grid((14.0, 14.0), (28, 28)), (0.35, 0.55, 0.35), Transform((0, -1.6, 1.0))),
    )
    cam = Camera(eye=(cx, cy + 0.4, cz + 4.0), target=(cx, cy, cz - r), fov_y=35.0, width=640, height=480)
    anim = Animation(24, ((0, {"eye": [cx - 0.8, cy + 0.5, cz + 4.0]}), (23, {"eye": [cx + 0.8, cy + 0.3, cz + 4.0]})))
    return Scene(objs, cam, anim, "shaving")


def wavy_sheet(size=(6.0, 3.0), waves: int = 4, amplitude: float = 0.15, columns: int = 160,
               rows: int = 12) -> Mesh:
    """A sinusoidal sheet ``z = amplitude sin(2 pi waves x / width)`` over ``size`` in the xy
    plane, facing +z, with its analytic normals: convex crests and concave troughs."""
    w, h = size
    k = 2 * np.pi * waves / w
    x = np.linspace(-w / 2, w / 2, columns + 1)
    y = np.linspace(-h / 2, h / 2, rows + 1)
    yy, xx = np.meshgrid(y, x, indexing="ij")
    v = np.stack([xx, yy, amplitude * np.sin(k * xx)], -1).reshape(-1, 3)
    n = normalize_rows(np.stack([-amplitude * k * np.cos(k * xx), np.zeros_like(xx), np.ones_like(xx)],
                                -1).reshape(-1, 3))
    return Mesh(v, _grid_faces(rows, columns), n, name="wavy_sheet")


def wavy_scene() -> Scene:
    """A sinusoidal mirror sheet (four waves over 6 units, amplitude 0.15) standing at z = -1.5,
    with objects in front of it on a floor; a distant point reflects in every wave, a near one in
    some. The camera slides sideways and rises over 24 frames."""
    sheet = SceneObject("wavy_mirror", wavy_sheet(), (0.85, 0.85, 0.9), Transform((0.0, 0.0, -1.5)),
                        reflector=True, open=True)
    objs = (
        sheet,
        SceneObject("red_ball", icosphere(3, 0.3), (0.9, 0.2, 0.15), Transform((-0.8, -0.9, 0.2))),
        SceneObject("blue_box", box((0.5, 0.5, 0.5), 3), (0.2, 0.3, 0.9), Transform((0.9, -0.95, 0.6), (0, 25, 0))),
        SceneObject("gold_cylinder", cylinder(0.15, 1.2, 32, 6), (0.95, 0.75, 0.2), Transform((0.1, -0.6, 1.6))),
        SceneObject("back_wall", box((24.0, 8.0, 0.2), 12), (0.6, 0.7, 0.85), Transform((0.0, 2.5, 8.0))),
        SceneObject("floor", plane_grid((12.0, 12.0), (24, 24)), (0.35, 0.55, 0.35), Transform((0, -1.2, 1.5))),
    )
    cam = Camera(eye=(0.0, 0.6, 5.0), target=(0.0, -0.2, -1.5), fov_y=45.0, width=640, height=480)
    anim = Animation(24, ((0, {"eye": [-1.5, 0.4, 5.0]}), (23, {"eye": [1.5, 0.9, 4.6]})))
    return Scene(objs, cam, anim, "wavy")

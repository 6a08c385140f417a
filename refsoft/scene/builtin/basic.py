"""Small analytic scenes: a mirror ball and friends."""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..primitives import box, cylinder, icosphere, plane_grid, torus
from ..model import Animation, Scene, SceneObject, Transform


def sphere_scene() -> Scene:
    """A unit mirror ball (icosphere, 5 subdivisions) among coloured objects on a floor."""
    objects = [
        SceneObject("ball", icosphere(5, 1.0), (0.9, 0.9, 0.9), Transform((0.0, 0.0, 0.0)), reflector=True),
        SceneObject("floor", plane_grid((12.0, 12.0), (24, 24)), (0.35, 0.55, 0.35), Transform((0.0, -1.0, 0.0))),
        SceneObject("red_box", box((0.8, 0.8, 0.8), 4), (0.85, 0.2, 0.15),
                    Transform((-1.9, -0.6, 0.6), (0.0, 30.0, 0.0))),
        SceneObject("blue_cylinder", cylinder(0.35, 1.6, 48, 8), (0.2, 0.35, 0.9), Transform((1.8, -0.2, 0.9))),
        SceneObject("gold_torus", torus(0.45, 0.15, 64, 24), (0.95, 0.75, 0.2),
                    Transform((0.6, -0.84, 1.9), (0.0, 0.0, 0.0))),
        SceneObject("back_wall", box((10.0, 4.0, 0.2), 8), (0.7, 0.7, 0.75), Transform((0.0, 1.0, -4.0))),
    ]
    camera = Camera(eye=(0.0, 1.2, 5.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), fov_y=45.0,
                    width=640, height=480, near=0.1, far=100.0)
    return Scene(tuple(objects), camera, None, "sphere")


def _orbit_keys(frames, radius, height, start_deg, end_deg, target=(0.0, 0.0, 0.0)):
    """Camera keyframes on a circular arc around the target (every 10 frames)."""
    keys = []
    marks = sorted(set(list(range(0, frames, 10)) + [frames - 1]))
    for f in marks:
        a = np.radians(start_deg + (end_deg - start_deg) * f / max(frames - 1, 1))
        keys.append((f, {"eye": [radius * np.sin(a), height, radius * np.cos(a)], "target": list(target)}))
    return tuple(keys)


def _surroundings():
    """The sphere scene's objects other than the ball."""
    return sphere_scene().objects[1:]


def ellipsoid_scene() -> Scene:
    """An elongated mirror ellipsoid (semi-axes 1.4, 1.0, 0.8, turned 30 degrees) among the sphere
    scene's objects; the camera orbits 40 degrees over 30 frames."""
    ell = SceneObject("ellipsoid", icosphere(5, 1.0), (0.9, 0.9, 0.9), Transform((0, 0, 0), (0, 30, 0), (1.4, 1.0, 0.8)),
                      reflector=True)
    cam = sphere_scene().camera
    anim = Animation(30, _orbit_keys(30, 5.14, 1.2, -20, 20))
    return Scene((ell,) + _surroundings(), cam, anim, "ellipsoid")


def planar_scene() -> Scene:
    """A flat mirror (a wall at z = -2) with objects in front; the camera slides sideways."""
    mirror = SceneObject("mirror", plane_grid((8.0, 5.0), (4, 4)), (0.85, 0.85, 0.9),
                         Transform((0, 1.0, -2.0), (90.0, 0, 0)), reflector=True, open=True)
    objs = (mirror,) + tuple(o for o in _surroundings() if o.name != "back_wall")
    cam = Camera(eye=(0.0, 1.2, 5.0), target=(0.0, 0.3, -2.0), fov_y=50.0, width=640, height=480)
    anim = Animation(30, ((0, {"eye": [-1.5, 1.2, 5.0]}), (29, {"eye": [1.5, 1.4, 4.5]})))
    return Scene(objs, cam, anim, "planar")


def concave_scene() -> Scene:
    """The inside of a mirror bowl seen from above, with a ball and a box floating over it."""
    from .shapes import bowl

    inner, _ = bowl(1.5, 32, 96, inside=True)
    objs = (
        SceneObject("bowl_inside", inner, (0.85, 0.85, 0.85), Transform((0, 0, 0)), reflector=True, open=True),
        SceneObject("red_ball", icosphere(3, 0.25), (0.9, 0.2, 0.15), Transform((0.3, 0.5, 0.2))),
        SceneObject("blue_box", box((0.35, 0.35, 0.35), 3), (0.2, 0.3, 0.9), Transform((-0.5, 0.8, -0.3), (20, 30, 0))),
        SceneObject("floor", plane_grid((10.0, 10.0), (20, 20)), (0.35, 0.55, 0.35), Transform((0, -1.6, 0))),
    )
    cam = Camera(eye=(0.0, 3.0, 2.2), target=(0.0, -0.5, 0.0), fov_y=45.0, width=640, height=480)
    anim = Animation(30, _orbit_keys(30, 2.2, 3.0, 0, 60, (0.0, -0.5, 0.0)))
    return Scene(objs, cam, anim, "concave")


def torus_scene() -> Scene:
    """Half a mirror torus (mixed curvature: convex outside, saddle inside) among objects."""
    half = torus(1.2, 0.45, 96, 48, major_angle_deg=180.0)
    refl = SceneObject("torus_section", half, (0.9, 0.9, 0.9), Transform((0, 0, 0), (0, 90, 0)), reflector=True,
                       open=True)
    cam = Camera(eye=(0.0, 2.0, 5.0), target=(0.0, 0.0, 0.0), fov_y=45.0, width=640, height=480)
    anim = Animation(30, _orbit_keys(30, 5.4, 2.0, -25, 25))
    return Scene((refl,) + _surroundings(), cam, anim, "torus")


def quad_scene() -> Scene:
    """A large two-triangle quad just behind the camera, reflected in a mirror ball: each virtual
    triangle spans a big curved image, where linear interpolation between reflected vertices is
    visibly wrong (the straight virtual edges against the truth's curved ones)."""
    from .shapes import quad

    ball = SceneObject("ball", icosphere(5, 1.0), (0.9, 0.9, 0.9), Transform((0, 0, 0)), reflector=True)
    q = SceneObject("quad", quad((6.0, 4.0)), (0.95, 0.55, 0.1), Transform((0.0, 0.6, 6.5), (0, 0, 0)))
    floor = SceneObject("floor", plane_grid((12.0, 12.0), (24, 24)), (0.35, 0.55, 0.35), Transform((0, -1.0, 0)))
    cam = Camera(eye=(0.0, 0.6, 5.5), target=(0.0, 0.0, 0.0), fov_y=35.0, width=640, height=480)
    anim = Animation(20, _orbit_keys(20, 5.53, 0.6, -8, 8))
    return Scene((ball, q, floor), cam, anim, "quad")

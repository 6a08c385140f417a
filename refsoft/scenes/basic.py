"""Small analytic scenes: a mirror ball and friends."""

from __future__ import annotations

from ..camera import Camera
from ..primitives import box, cylinder, icosphere, plane_grid, torus
from ..scene import Scene, SceneObject, Transform


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

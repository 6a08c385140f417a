"""Scenes of mirrors that see each other, shared by the tests of several bounces."""

import numpy as np

from refsoft import Camera, Scene, SceneObject, Transform
from refsoft.scene.primitives import box, plane_grid

OBJECT = np.array([1.0, -0.4, 0.8])


def corner_scene(width=64, height=48):
    """Mirror A in the plane x = 0 (facing +x, z in [0, 2]) and mirror B in the plane z = 0
    (facing +z, x in [0, 2]), meeting on the y axis; a box in the corner's quarter."""
    a = SceneObject("mirror_a", plane_grid((2.0, 2.0), (2, 2)), (0.8, 0.8, 0.85),
                    Transform((0.0, 0.0, 1.0), (0.0, 0.0, -90.0)), reflector=True, open=True)
    b = SceneObject("mirror_b", plane_grid((2.0, 2.0), (2, 2)), (0.8, 0.8, 0.85),
                    Transform((1.0, 0.0, 0.0), (90.0, 0.0, 0.0)), reflector=True, open=True)
    obj = SceneObject("box", box((0.5, 0.5, 0.5), 1), (0.9, 0.3, 0.1), Transform(tuple(OBJECT), (0.0, 20.0, 0.0)))
    cam = Camera(eye=(3.0, 0.6, 2.5), target=(0.0, -0.2, 0.0), fov_y=30.0, width=width, height=height)
    return Scene((a, b, obj), cam, None, "corner")

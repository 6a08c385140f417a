"""Procedural stand-ins for the scenes of Estalella et al.'s table 1, sized like them."""

from __future__ import annotations

import numpy as np

from ... import linalg
from ..camera import Camera
from ..primitives import box, capsule, cylinder, icosphere, plane_grid
from ..model import Animation, Scene, SceneObject, Transform
from .shapes import bowl, merge, tf


#: Loader subdivision of the kitchen's objects, world units (the paper's 11,379 -> 14,979 vertices).
KITCHEN_SUBDIVIDE = 0.39
#: Loader subdivision of the UFO scene (63,884 -> 81,977).
UFO_SUBDIVIDE = 1.0
#: Loader subdivision of the ants scene: the cans' long thin triangles (14,859 -> 30,153).
ANTS_SUBDIVIDE = 0.1


def kitchen_scene() -> Scene:
    """One large metal bowl, upside down on a kitchen table (its convex outside faces the camera;
    the open shell is drawn, a closed proxy with a lid on the table is searched), among cups,
    plates, bottles and fruit; over 24 frames the camera moves towards the bowl until it fills
    much of the view. The loader subdivides the long triangles of the table, floor and wall."""
    open_bowl, closed = bowl(1.0, 32, 96)
    L = KITCHEN_SUBDIVIDE
    flip = Transform((0.0, 0.0, 0.0), (180.0, 0.0, 0.0))  # the lower half turned up: a dome, rim on the table
    objs = [SceneObject("bowl", open_bowl, (0.85, 0.85, 0.88), flip, reflector=True, closed_proxy=closed)]
    objs.append(SceneObject("table", box((5.0, 0.2, 3.0), 5), (0.55, 0.35, 0.2), tf((0, -0.1, 0)), subdivide=L))
    for i, (x, z) in enumerate([(-1.7, 0.6), (1.6, 0.8), (1.9, -0.7)]):
        objs.append(SceneObject(f"cup{i}", cylinder(0.25, 0.5, 48, 2), [(0.9, 0.9, 0.85), (0.2, 0.4, 0.8),
                                                                    (0.8, 0.2, 0.2)][i], tf((x, 0.25, z)), subdivide=L))
    for i, (x, z) in enumerate([(-1.2, -0.8), (0.9, 1.0)]):
        objs.append(SceneObject(f"plate{i}", cylinder(0.5, 0.05, 64, 1), (0.95, 0.95, 0.95), tf((x, 0.025, z)),
                                subdivide=L))
    for i, (x, z) in enumerate([(-2.0, -0.6), (-0.2, -1.1)]):
        objs.append(SceneObject(f"bottle{i}", capsule(0.17, 0.8, 12, 32), [(0.1, 0.5, 0.2), (0.5, 0.3, 0.1)][i],
                                tf((x, 0.57, z)), subdivide=L))
    rng = np.random.default_rng(7)
    for i in range(6):
        a = 2 * np.pi * i / 6
        objs.append(SceneObject(f"fruit{i}", icosphere(2, 0.2), tuple(rng.uniform(0.3, 1.0, 3)),
                                tf((1.6 * np.cos(a) + 0.1, 0.2, 1.6 * np.sin(a) * 0.7 - 0.1)), subdivide=L))
    # the room: floor, ceiling, four walls, cabinets along the back wall and a window on the left
    room = 4 * L
    objs.append(SceneObject("floor", plane_grid((14.0, 16.0), (22, 22)), (0.6, 0.6, 0.55), tf((0, -1.5, 1.0)),
                            subdivide=room))
    objs.append(SceneObject("ceiling", plane_grid((14.0, 16.0), (22, 22)), (0.93, 0.92, 0.86),
                            tf((0, 4.5, 1.0), (180, 0, 0)), subdivide=room))
    for name, size, pos, col in (("back_wall", (14.0, 6.0, 0.3), (0, 1.5, -7.0), (0.75, 0.8, 0.85)),
                                 ("front_wall", (14.0, 6.0, 0.3), (0, 1.5, 9.0), (0.8, 0.72, 0.6)),
                                 ("left_wall", (0.3, 6.0, 16.0), (-7.0, 1.5, 1.0), (0.7, 0.8, 0.7)),
                                 ("right_wall", (0.3, 6.0, 16.0), (7.0, 1.5, 1.0), (0.85, 0.75, 0.7))):
        objs.append(SceneObject(name, box(size, 9), col, tf(pos), subdivide=room))
    for i, x in enumerate((-3.0, 3.0)):
        objs.append(SceneObject(f"cabinet{i}", box((3.5, 2.0, 1.2), 5), (0.35, 0.45, 0.6), tf((x, -0.5, -6.2)),
                                subdivide=room))
    objs.append(SceneObject("window", box((0.1, 2.0, 3.0), 4), (0.6, 0.8, 0.95), tf((-6.8, 2.0, -1.0)),
                            subdivide=room))
    cam = Camera(eye=(0.0, 3.2, 7.5), target=(0.0, 0.5, 0.0), fov_y=45.0, width=640, height=480)
    anim = Animation(24, ((0, {"eye": [0.0, 3.2, 7.5], "target": [0.0, 0.5, 0.0]}),
                          (23, {"eye": [0.6, 1.9, 3.0], "target": [0.0, 0.45, 0.0]})))
    return Scene(tuple(objs), cam, anim, "kitchen")


def ufo_scene() -> Scene:
    """A big convex saucer lands in the central square of a city while trucks drive through (60
    frames); the loader subdivides the square's and the buildings' long triangles."""
    saucer = icosphere(5, 1.0)
    objs = [SceneObject("ufo", saucer, (0.7, 0.85, 1.0), Transform((0, 9.0, 0), (0, 0, 0), (3.2, 0.9, 3.2)),
                        reflector=True)]
    L = UFO_SUBDIVIDE
    objs.append(SceneObject("square", plane_grid((80.0, 80.0), (50, 50)), (0.45, 0.45, 0.42), tf((0, 0, 0)),
                            subdivide=L))
    rng = np.random.default_rng(3)
    k = 0
    for side in range(3):  # back, left and right; the camera looks in from the open front
        for j in range(9):
            along = -16 + 4 * j
            h = float(rng.uniform(4, 14))
            pos = [(along, h / 2, -14.0), (-14.0, h / 2, along), (14.0, h / 2, along)][side]
            col = tuple(rng.uniform(0.35, 0.85, 3))
            objs.append(SceneObject(f"building{k}", box((3.2, h, 3.2), 15), col, tf(pos), subdivide=L))
            k += 1
    wheel = cylinder(0.45, 0.3, 24, 1)
    frames = 60
    keys = {}
    for i in range(8):
        lane = -6 + 1.7 * i
        parts = [(box((3.2, 1.6, 1.6), 8), tf((0, 1.2, 0))), (box((1.1, 1.3, 1.5), 6), tf((2.2, 1.05, 0)))]
        for wx in (-1.0, 1.9):
            for wz in (-0.8, 0.8):
                parts.append((wheel, tf((wx, 0.45, wz), (90, 0, 0))))
        truck = merge(parts, name=f"truck{i}")
        name = f"truck{i}"
        direction = 1 if i % 2 == 0 else -1
        x0 = -20.0 * direction + float(rng.uniform(-3, 3))
        objs.append(SceneObject(name, truck, tuple(rng.uniform(0.3, 0.95, 3)),
                                Transform((x0, 0, lane), (0, 0 if direction > 0 else 180, 0)), subdivide=L))
        keys[name] = ((0, Transform((x0, 0, lane), (0, 0 if direction > 0 else 180, 0))),
                      (frames - 1, Transform((x0 + 40.0 * direction, 0, lane), (0, 0 if direction > 0 else 180, 0))))
    keys["ufo"] = ((0, Transform((0, 9.0, 0), (0, 0, 0), (3.2, 0.9, 3.2))),
                   (frames - 1, Transform((0, 3.0, 0), (0, 60, 0), (3.2, 0.9, 3.2))))
    cam = Camera(eye=(0.0, 7.0, 26.0), target=(0.0, 4.5, 0.0), fov_y=50.0, width=640, height=480, far=200.0)
    return Scene(tuple(objs), cam, Animation(frames, (), keys), "ufo")


def _ant(name, color):
    """An ant's body (head, thorax, abdomen, six legs, two antennae) and its two eyes."""
    body = icosphere(2, 1.0)
    leg = capsule(0.04, 0.9, 4, 12)
    parts = [(body, tf((0.0, 0.45, 0.0), (0, 0, 0), (0.35, 0.25, 0.3))),
             (body, tf((-0.75, 0.5, 0.0), (0, 0, 0), (0.55, 0.35, 0.4))),
             (body, tf((0.55, 0.55, 0.0), (0, 0, 0), (0.3, 0.25, 0.27)))]
    for x in (-0.25, 0.0, 0.25):
        for side in (-1, 1):
            parts.append((leg, tf((x, 0.25, 0.45 * side), (side * 60, 0, 0))))
    for side in (-1, 1):
        parts.append((leg, tf((0.8, 0.85, 0.12 * side), (side * 25, 0, -55), 0.7)))
    eyes = [(icosphere(3, EYE_RADIUS), tf(_eye_centre(side))) for side in (-1, 1)]
    return merge(parts, name=name), eyes


#: Radius of an ant's mirror eye.
EYE_RADIUS = 0.11
#: Gap between an eye and the head's surface (the eyes sit on the head without cutting into it).
EYE_GAP = 0.01


def _eye_centre(side):
    """Centre of the eye on side -1 or 1: on the head's outward normal at the point of the head
    ellipsoid (centre (0.55, 0.55, 0), radii (0.3, 0.25, 0.27)) in the direction (0.6, 0.3,
    0.6 side), ``EYE_RADIUS + EYE_GAP`` off its surface."""
    c, radii = np.array([0.55, 0.55, 0.0]), np.array([0.3, 0.25, 0.27])
    d = np.array([0.6, 0.3, 0.6 * side])
    u = d / linalg.norm3(d / radii)  # on the ellipsoid: |u / radii| = 1
    n = u / radii ** 2
    return tuple(c + u + (EYE_RADIUS + EYE_GAP) * n / linalg.norm3(n))


def ants_scene() -> Scene:
    """Four ants with two mirror eyes each (8 reflectors) walking among cans (40 frames); the
    loader subdivides the cans' long thin triangles, which the eyes reflect as curves."""
    objs, keys = [], {}
    frames = 40
    rng = np.random.default_rng(5)
    starts = [(-2.0, -1.2, 0), (2.2, -0.8, 150), (-1.5, 1.6, -40), (1.0, 2.0, 200)]
    ant_objs, eye_objs = [], []
    for i, (x, z, yaw) in enumerate(starts):
        body, eyes = _ant(f"ant{i}", (0.3, 0.15, 0.1))
        a = np.radians(yaw)
        step = np.array([np.cos(a), 0, -np.sin(a)]) * 1.5
        t0 = np.array([x, 0.0, z])
        ant_objs.append(SceneObject(f"ant{i}", body, (0.35, 0.18, 0.1), Transform(t0, (0, yaw, 0))))
        keys[f"ant{i}"] = ((0, Transform(t0, (0, yaw, 0))), (frames - 1, Transform(t0 + step, (0, yaw, 0))))
        for j, (eye, etf) in enumerate(eyes):
            local = eye.transformed(etf.matrix())
            eye_objs.append(SceneObject(f"ant{i}_eye{j}", local, (0.1, 0.1, 0.12), Transform(t0, (0, yaw, 0)),
                                        reflector=True))
            keys[f"ant{i}_eye{j}"] = keys[f"ant{i}"]
    cans = []
    for i, (x, z) in enumerate([(0.0, 0.0), (-3.0, 1.5), (3.0, -2.0)]):
        cans.append(SceneObject(f"can{i}", cylinder(0.45, 1.4, 48, 1), tuple(rng.uniform(0.4, 0.95, 3)),
                                tf((x, 0.7, z)), subdivide=ANTS_SUBDIVIDE))
    ground = SceneObject("ground", plane_grid((14.0, 14.0), (55, 55)), (0.55, 0.5, 0.35), tf((0, 0, 0)))
    objs = eye_objs + ant_objs + cans + [ground]
    cam = Camera(eye=(0.0, 3.5, 7.0), target=(0.0, 0.4, 0.0), fov_y=45.0, width=640, height=480)
    anim = Animation(frames, ((0, {"eye": [0.0, 3.5, 7.0]}), (frames - 1, {"eye": [2.5, 2.5, 5.5]})), keys)
    return Scene(tuple(objs), cam, anim, "ants")

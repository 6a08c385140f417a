"""Procedural stand-ins for the scenes of Estalella et al.'s table 1, sized like them."""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..primitives import box, capsule, cylinder, icosphere, plane_grid
from ..model import Animation, Scene, SceneObject, Transform
from .shapes import bowl, merge, subdivide_long_edges, tf


def kitchen_scene() -> Scene:
    """A large metal bowl (open, with a closed proxy) on a kitchen table among cups, plates,
    bottles and fruit (about 15k vertices); over 24 frames the camera moves towards the bowl
    until it fills much of the view."""
    open_bowl, closed = bowl(1.0, 32, 96)
    objs = [SceneObject("bowl", open_bowl, (0.85, 0.85, 0.88), tf((0, 1.0, 0)), reflector=True, closed_proxy=closed)]
    objs.append(SceneObject("table", box((5.0, 0.2, 3.0), 16), (0.55, 0.35, 0.2), tf((0, -0.1, 0))))
    for i, (x, z) in enumerate([(-1.7, 0.6), (1.6, 0.8), (1.9, -0.7)]):
        objs.append(SceneObject(f"cup{i}", cylinder(0.25, 0.5, 48, 6), [(0.9, 0.9, 0.85), (0.2, 0.4, 0.8),
                                                                    (0.8, 0.2, 0.2)][i], tf((x, 0.25, z))))
    for i, (x, z) in enumerate([(-1.2, -0.8), (0.9, 1.0)]):
        objs.append(SceneObject(f"plate{i}", cylinder(0.5, 0.05, 64, 1), (0.95, 0.95, 0.95), tf((x, 0.025, z))))
    for i, (x, z) in enumerate([(-2.0, -0.6), (-0.2, -1.1)]):
        objs.append(SceneObject(f"bottle{i}", capsule(0.17, 0.8, 12, 32), [(0.1, 0.5, 0.2), (0.5, 0.3, 0.1)][i],
                                tf((x, 0.57, z))))
    rng = np.random.default_rng(7)
    for i in range(6):
        a = 2 * np.pi * i / 6
        objs.append(SceneObject(f"fruit{i}", icosphere(3, 0.2), tuple(rng.uniform(0.3, 1.0, 3)),
                                tf((1.6 * np.cos(a) + 0.1, 0.2, 1.6 * np.sin(a) * 0.7 - 0.1))))
    objs.append(SceneObject("floor", plane_grid((20.0, 20.0), (40, 40)), (0.6, 0.6, 0.55), tf((0, -1.5, 0))))
    objs.append(SceneObject("wall", box((16.0, 6.0, 0.3), 14), (0.75, 0.8, 0.85), tf((0, 1.5, -4.0))))
    cam = Camera(eye=(0.0, 3.2, 7.5), target=(0.0, 0.5, 0.0), fov_y=45.0, width=640, height=480)
    anim = Animation(24, ((0, {"eye": [0.0, 3.2, 7.5]}), (23, {"eye": [0.5, 2.4, 2.9]})))
    return Scene(tuple(objs), cam, anim, "kitchen")


def _building(width, height, depth, subdiv):
    return box((width, height, depth), subdiv)


def ufo_scene() -> Scene:
    """A big convex saucer lands over a city square with buildings while trucks drive through
    (about 82k vertices, 60 frames)."""
    saucer = icosphere(5, 1.0)
    objs = [SceneObject("ufo", saucer, (0.7, 0.85, 1.0), Transform((0, 9.0, 0), (0, 0, 0), (3.2, 0.9, 3.2)),
                        reflector=True)]
    objs.append(SceneObject("square", plane_grid((80.0, 80.0), (110, 110)), (0.45, 0.45, 0.42), tf((0, 0, 0))))
    rng = np.random.default_rng(3)
    k = 0
    for side in range(3):  # back, left and right; the camera looks in from the open front
        for j in range(9):
            along = -16 + 4 * j
            h = float(rng.uniform(4, 14))
            pos = [(along, h / 2, -14.0), (-14.0, h / 2, along), (14.0, h / 2, along)][side]
            col = tuple(rng.uniform(0.35, 0.85, 3))
            objs.append(SceneObject(f"building{k}", _building(3.2, h, 3.2, 17), col, tf(pos)))
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
                                Transform((x0, 0, lane), (0, 0 if direction > 0 else 180, 0))))
        keys[name] = ((0, Transform((x0, 0, lane), (0, 0 if direction > 0 else 180, 0))),
                      (frames - 1, Transform((x0 + 40.0 * direction, 0, lane), (0, 0 if direction > 0 else 180, 0))))
    keys["ufo"] = ((0, Transform((0, 9.0, 0), (0, 0, 0), (3.2, 0.9, 3.2))),
                   (frames - 1, Transform((0, 3.0, 0), (0, 60, 0), (3.2, 0.9, 3.2))))
    cam = Camera(eye=(0.0, 15.0, 27.0), target=(0.0, 3.0, 0.0), fov_y=50.0, width=640, height=480, far=200.0)
    return Scene(tuple(objs), cam, Animation(frames, (), keys), "ufo")


def _ant(name, color):
    """An ant's body (head, thorax, abdomen, six legs, two antennae) and its two eyes."""
    body = icosphere(3, 1.0)
    leg = capsule(0.04, 0.9, 4, 10)
    parts = [(body, tf((0.0, 0.45, 0.0), (0, 0, 0), (0.35, 0.25, 0.3))),
             (body, tf((-0.75, 0.5, 0.0), (0, 0, 0), (0.55, 0.35, 0.4))),
             (body, tf((0.55, 0.55, 0.0), (0, 0, 0), (0.3, 0.25, 0.27)))]
    for x in (-0.25, 0.0, 0.25):
        for side in (-1, 1):
            parts.append((leg, tf((x, 0.25, 0.45 * side), (side * 60, 0, 0))))
    for side in (-1, 1):
        parts.append((leg, tf((0.8, 0.85, 0.12 * side), (side * 25, 0, -55), 0.7)))
    eyes = [(icosphere(3, 0.1), tf((0.74, 0.62, 0.16 * side))) for side in (-1, 1)]
    return merge(parts, name=name), eyes


def ants_scene() -> Scene:
    """Four ants with two mirror eyes each (8 reflectors) walking among cans whose long thin
    triangles are subdivided (about 30k vertices, 40 frames)."""
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
        can = subdivide_long_edges(cylinder(0.45, 1.4, 24, 1), 0.2)
        cans.append(SceneObject(f"can{i}", can, tuple(rng.uniform(0.4, 0.95, 3)), tf((x, 0.7, z))))
    ground = SceneObject("ground", plane_grid((14.0, 14.0), (40, 40)), (0.55, 0.5, 0.35), tf((0, 0, 0)))
    objs = eye_objs + ant_objs + cans + [ground]
    cam = Camera(eye=(0.0, 3.5, 7.0), target=(0.0, 0.4, 0.0), fov_y=45.0, width=640, height=480)
    anim = Animation(frames, ((0, {"eye": [0.0, 3.5, 7.0]}), (frames - 1, {"eye": [2.5, 2.5, 5.5]})), keys)
    return Scene(tuple(objs), cam, anim, "ants")

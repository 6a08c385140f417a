"""TOML scene files (spec section 3).

Every key is checked: an unknown key, a wrong type or a bad value raises
:class:`refsoft.errors.SceneError` with the file and the key path in the message, e.g.
``scene.toml: objects[2].colr: unknown key``.

Loader subdivision (:mod:`refsoft.scene.subdivide`): ``[scene] subdivide = L`` is the default of
the non-reflector objects, an object's own ``subdivide = L`` overrides it (0 = off); the meshes
are subdivided when the file is loaded.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

from .camera import Camera
from .. import validate
from ..errors import RefsoftError, SceneError
from .mesh import load_mesh
from .primitives import make_primitive
from .model import Animation, Scene, SceneObject, Transform
from .subdivide import apply_subdivision, check_override

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

CAMERA_KEYS = {"eye", "target", "up", "fov_y", "width", "height", "near", "far", "projection", "ortho_height"}
OBJECT_KEYS = {"name", "mesh", "primitive", "translate", "rotate_deg", "scale", "color", "reflector",
               "closed_proxy", "reflectivity", "open", "subdivide"}
TOP_KEYS = {"name", "scene", "camera", "objects", "animation"}
SCENE_KEYS = {"subdivide"}
ANIMATION_KEYS = {"frames", "camera", "objects"}
ANIM_CAMERA_KEYS = {"frame", "eye", "target", "up", "fov_y"}
ANIM_OBJECT_KEYS = {"name", "frame", "translate", "rotate_deg", "scale"}


class _Ctx:
    def __init__(self, path):
        self.path = path

    def fail(self, key, msg):
        raise SceneError(f"{self.path}: {key}: {msg}")

    def table(self, value, key, allowed):
        if not isinstance(value, dict):
            self.fail(key, f"must be a table, got {type(value).__name__}")
        for k in value:
            if k not in allowed:
                self.fail(f"{key}.{k}" if key else k, f"unknown key (allowed: {', '.join(sorted(allowed))})")
        return value

    def number(self, value, key):
        if not validate.is_number(value):
            self.fail(key, f"must be a finite number, got {value!r}")
        return float(value)

    def integer(self, value, key):
        if not validate.is_integer(value):
            self.fail(key, f"must be an integer, got {value!r}")
        return value

    def max_edge(self, value, key):
        """A loader subdivision length: a finite number >= 0 (0 = off)."""
        if not validate.is_number(value) or value < 0:
            self.fail(key, f"must be a finite number >= 0 (0 = off), got {value!r}")
        return float(value)

    def vec3(self, value, key):
        if not isinstance(value, list) or len(value) != 3:
            self.fail(key, f"must be a list of 3 numbers, got {value!r}")
        return [self.number(v, f"{key}[{i}]") for i, v in enumerate(value)]

    def scale(self, value, key):
        if isinstance(value, list):
            s = self.vec3(value, key)
        else:
            s = [self.number(value, key)] * 3
        if any(v <= 0 for v in s):
            self.fail(key, f"must be positive, got {value!r}")
        return s


def _load_mesh_ref(ctx, value, key, base_dir):
    if isinstance(value, str):
        path = value if os.path.isabs(value) else os.path.join(base_dir, value)
        try:
            return load_mesh(path)
        except RefsoftError as exc:
            ctx.fail(key, str(exc))
    if isinstance(value, dict):
        try:
            return make_primitive(value, key)
        except RefsoftError as exc:
            raise SceneError(f"{ctx.path}: {exc}") from None
    ctx.fail(key, f"must be a file path or a primitive table, got {value!r}")


def _transform(ctx, d, key, base=Transform()):
    """A Transform from a table; fields it lacks are taken from ``base``."""
    try:
        return Transform(
            ctx.vec3(d["translate"], f"{key}.translate") if "translate" in d else base.translate,
            ctx.vec3(d["rotate_deg"], f"{key}.rotate_deg") if "rotate_deg" in d else base.rotate_deg,
            ctx.scale(d["scale"], f"{key}.scale") if "scale" in d else base.scale,
        )
    except SceneError as exc:
        if str(exc).startswith(str(ctx.path)):
            raise
        ctx.fail(key, str(exc))


def scene_from_dict(data: dict, path: str = "<scene>", base_dir: str = ".", subdivide: float | None = None) -> Scene:
    """Build a :class:`Scene` from parsed TOML data (see module docstring for the checks).

    ``subdivide`` overrides the file's subdivision values
    (:func:`refsoft.scene.subdivide.apply_subdivision`); the returned meshes are subdivided.
    """
    subdivide = check_override(subdivide)
    ctx = _Ctx(path)
    ctx.table(data, "", TOP_KEYS)
    default_subdivide = None
    if "scene" in data:
        sc = ctx.table(data["scene"], "scene", SCENE_KEYS)
        if "subdivide" in sc:
            default_subdivide = ctx.max_edge(sc["subdivide"], "scene.subdivide")
    camera = _camera(ctx, data)
    objects = _objects(ctx, data, base_dir, default_subdivide)
    animation = _animation(ctx, data["animation"], camera, objects) if "animation" in data else None
    name = data.get("name", os.path.splitext(os.path.basename(str(path)))[0])
    try:
        scene = Scene(tuple(objects), camera, animation, name)
        if animation is not None:
            for f in range(animation.frames):  # every keyed camera must be valid
                scene.camera_at(f)
    except RefsoftError as exc:
        raise SceneError(f"{path}: {exc}") from None
    try:
        return apply_subdivision(scene, subdivide)
    except RefsoftError as exc:  # keep the type: a LimitError stays one
        raise type(exc)(f"{path}: {exc}") from None


def _camera(ctx, data) -> Camera:
    """The ``[camera]`` table."""
    if "camera" not in data:
        ctx.fail("camera", "missing table [camera]")
    cam = ctx.table(data["camera"], "camera", CAMERA_KEYS)
    kw = {}
    for k in ("eye", "target"):
        if k not in cam:
            ctx.fail(f"camera.{k}", "missing key")
        kw[k] = ctx.vec3(cam[k], f"camera.{k}")
    if "up" in cam:
        kw["up"] = ctx.vec3(cam["up"], "camera.up")
    for k in ("fov_y", "near", "far", "ortho_height"):
        if k in cam:
            kw[k] = ctx.number(cam[k], f"camera.{k}")
    for k in ("width", "height"):
        if k in cam:
            kw[k] = ctx.integer(cam[k], f"camera.{k}")
    if "projection" in cam:
        kw["projection"] = cam["projection"]
    try:
        return Camera(**kw)
    except RefsoftError as exc:
        ctx.fail("camera", str(exc))


def _objects(ctx, data, base_dir, default_subdivide) -> list:
    """The ``[[objects]]`` entries, in order."""
    objs = data.get("objects")
    if not isinstance(objs, list) or not objs:
        ctx.fail("objects", "needs at least one [[objects]] entry")
    objects = []
    for i, o in enumerate(objs):
        key = f"objects[{i}]"
        ctx.table(o, key, OBJECT_KEYS)
        name = o.get("name", f"object{i + 1}")
        if not isinstance(name, str) or not name:
            ctx.fail(f"{key}.name", f"must be a non-empty string, got {name!r}")
        if any(prev.name == name for prev in objects):
            ctx.fail(f"{key}.name", f"duplicate object name {name!r}")
        objects.append(_object(ctx, o, key, name, base_dir, default_subdivide))
    return objects


def _object(ctx, o, key, name, base_dir, default_subdivide) -> SceneObject:
    """One ``[[objects]]`` entry (its name checked)."""
    if ("mesh" in o) == ("primitive" in o):
        ctx.fail(key, "needs exactly one of 'mesh' or 'primitive'")
    mesh = _load_mesh_ref(ctx, o.get("mesh", o.get("primitive")), f"{key}.{'mesh' if 'mesh' in o else 'primitive'}",
                          base_dir)
    proxy = _load_mesh_ref(ctx, o["closed_proxy"], f"{key}.closed_proxy", base_dir) if "closed_proxy" in o else None
    color = ctx.vec3(o["color"], f"{key}.color") if "color" in o else [0.8, 0.8, 0.8]
    flags = {}
    for flag in ("reflector", "open"):
        flags[flag] = o.get(flag, False)
        if not isinstance(flags[flag], bool):
            ctx.fail(f"{key}.{flag}", f"must be true or false, got {flags[flag]!r}")
    reflectivity = ctx.number(o["reflectivity"], f"{key}.reflectivity") if "reflectivity" in o else 1.0
    if "subdivide" in o:
        sub = ctx.max_edge(o["subdivide"], f"{key}.subdivide")
    else:  # the scene-wide default is for the reflected objects, not the reflectors
        sub = None if flags["reflector"] else default_subdivide
    try:
        return SceneObject(name, mesh, tuple(color), _transform(ctx, o, key), flags["reflector"], proxy, reflectivity,
                           flags["open"], sub)
    except SceneError as exc:
        if str(exc).startswith(str(ctx.path)):
            raise
        ctx.fail(key, str(exc))


def _animation(ctx, table, camera, objects) -> Animation:
    """The ``[animation]`` table: camera keys and object keys."""
    a = ctx.table(table, "animation", ANIMATION_KEYS)
    if "frames" not in a:
        ctx.fail("animation.frames", "missing key")
    frames = ctx.integer(a["frames"], "animation.frames")
    cam_keys = []
    for i, k in enumerate(a.get("camera", [])):
        key = f"animation.camera[{i}]"
        ctx.table(k, key, ANIM_CAMERA_KEYS)
        if "frame" not in k:
            ctx.fail(f"{key}.frame", "missing key")
        values = {}
        for name in ("eye", "target", "up"):
            values[name] = ctx.vec3(k[name], f"{key}.{name}") if name in k else getattr(camera, name).tolist()
        values["fov_y"] = ctx.number(k["fov_y"], f"{key}.fov_y") if "fov_y" in k else camera.fov_y
        cam_keys.append((ctx.integer(k["frame"], f"{key}.frame"), values))
    obj_keys = {}
    by_name = {o.name: o for o in objects}
    for i, k in enumerate(a.get("objects", [])):
        key = f"animation.objects[{i}]"
        ctx.table(k, key, ANIM_OBJECT_KEYS)
        for req in ("name", "frame"):
            if req not in k:
                ctx.fail(f"{key}.{req}", "missing key")
        if k["name"] not in by_name:
            ctx.fail(f"{key}.name", f"no object named {k['name']!r}")
        base = by_name[k["name"]].transform  # unkeyed fields keep the object's own
        obj_keys.setdefault(k["name"], []).append((ctx.integer(k["frame"], f"{key}.frame"),
                                                   _transform(ctx, k, key, base)))
    try:
        return Animation(frames, tuple(cam_keys), {n: tuple(v) for n, v in obj_keys.items()})
    except SceneError as exc:
        ctx.fail("animation", str(exc))


def load_scene_file(path: str | os.PathLike, subdivide: float | None = None) -> Scene:
    """Load a TOML scene file; mesh paths are relative to the file; meshes subdivided as the file
    asks, or as ``subdivide`` overrides (:func:`refsoft.scene.subdivide.apply_subdivision`)."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise SceneError(f"scene file not found: {path}")
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: malformed TOML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{path}: cannot read: {exc}") from None
    return scene_from_dict(data, path, os.path.dirname(os.path.abspath(path)), subdivide)

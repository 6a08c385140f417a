"""Built-in procedural scenes, loadable by name (``refsoft.load_scene("sphere")``)."""

from __future__ import annotations

import os

from ...errors import SceneError
from ..model import Scene
from .basic import concave_scene, ellipsoid_scene, planar_scene, quad_scene, sphere_scene, torus_scene
from .ldt import balls_scene, cup_scene, cylinder_scene, genus3_scene, hollow_box_scene, touching_scene
from .mirrors import mirrors_scene
from .nonconvex import shaving_scene, wavy_scene
from .papers import ants_scene, kitchen_scene, ufo_scene

#: name -> (builder, one-line description)
BUILTIN_SCENES = {
    "kitchen": (kitchen_scene, "a metal bowl (open, closed proxy) among kitchen objects; camera closes in"),
    "ufo": (ufo_scene, "a big convex saucer lands over a city square; trucks drive through"),
    "ants": (ants_scene, "four ants with two mirror eyes each among cans with subdivided long triangles"),
    "sphere": (sphere_scene, "a mirror ball among coloured objects on a floor (static)"),
    "ellipsoid": (ellipsoid_scene, "an elongated mirror ellipsoid; the camera orbits"),
    "planar": (planar_scene, "a flat mirror wall; the camera slides sideways"),
    "concave": (concave_scene, "the inside of a mirror bowl seen from above"),
    "torus": (torus_scene, "half a mirror torus: mixed curvature"),
    "shaving": (shaving_scene, "a concave spherical shaving mirror, objects inside f, near C and beyond C"),
    "wavy": (wavy_scene, "a sinusoidal mirror sheet (four waves) with objects in front"),
    "quad": (quad_scene, "a two-triangle quad reflected in a mirror ball"),
    "balls": (balls_scene, "two balls (1 depth layer) moving in front of a mirror ball"),
    "hollow_box": (hollow_box_scene, "an open-top hollow box (2 depth layers) beside a mirror ball (static)"),
    "genus3": (genus3_scene, "a genus-3 solid (3 fused tori, 3+ depth layers) turning under a mirror ball"),
    "cup": (cup_scene, "a cup with a handle (one closed mesh, 3+ depth layers) beside a mirror ball (static)"),
    "touching": (touching_scene, "a hollow box resting on top of a mirror ball (static; LDT paper Fig. 7)"),
    "cylinder": (cylinder_scene, "an upright cylinder beside a mirror ball, seen from the side (static; Fig. 5)"),
    "mirrors": (mirrors_scene, "three mirror balls in a row that see each other (truth --bounces N); camera orbits"),
}


def builtin_names() -> list[str]:
    """Names of the built-in scenes."""
    return list(BUILTIN_SCENES)


def load_scene(name_or_path, subdivide=None, **overrides) -> Scene:
    """Load a built-in scene by name or a TOML scene file by path, its meshes subdivided as its
    objects ask (:func:`refsoft.scene.subdivide.apply_subdivision`).

    Parameters
    ----------
    name_or_path : str or PathLike
        A name from :func:`builtin_names` or a path to a ``.toml`` file.
    subdivide : float, optional
        Loader subdivision override (a ``--subdivide`` flag): ``L > 0`` replaces every object's
        value (reflectors only where they set their own), 0 turns subdivision off.
    **overrides
        Camera fields to replace (e.g. ``width=320, height=240``).

    Returns
    -------
    Scene
    """
    from dataclasses import replace

    from ..subdivide import apply_subdivision, check_override
    from ..toml import load_scene_file

    key = os.fspath(name_or_path)
    subdivide = check_override(subdivide)
    if key in BUILTIN_SCENES:
        scene = apply_subdivision(BUILTIN_SCENES[key][0](), subdivide)
    elif key.endswith(".toml") or os.path.sep in key or os.path.exists(key):
        scene = load_scene_file(key, subdivide)
    else:
        import difflib

        near = difflib.get_close_matches(key.lower(), list(BUILTIN_SCENES), n=1, cutoff=0.6)
        hint = f" (did you mean {near[0]!r}?)" if near else ""
        raise SceneError(f"unknown scene {key!r}{hint}: not a built-in ({', '.join(BUILTIN_SCENES)}) nor a .toml file")
    if overrides:
        overrides = {k: v for k, v in overrides.items() if v is not None}
        scene = replace(scene, camera=replace(scene.camera, **overrides))
    return scene

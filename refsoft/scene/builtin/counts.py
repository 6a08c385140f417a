"""What ``refsoft scenes`` lists of each built-in scene, without building it: building all of
them takes seconds, the listing should not. ``tests/scene/test_builtin_counts.py`` builds every
scene and checks this table against it; regenerate it with

    python -c "from refsoft.scene.builtin.counts import table_source; print(table_source())"
"""

from __future__ import annotations

#: name -> (vertices as built, after the scene's own subdivision, triangles as built, after,
#: reflectors, frames)
BUILTIN_COUNTS = {
    "kitchen": (11400, 14996, 19332, 26208, 1, 24),
    "ufo": (63755, 81355, 111052, 146052, 1, 60),
    "ants": (14964, 30273, 26850, 57378, 8, 40),
    "sphere": (13667, 13667, 26528, 26528, 1, 1),
    "ellipsoid": (13667, 13667, 26528, 26528, 1, 30),
    "planar": (2964, 2964, 5312, 5312, 1, 30),
    "concave": (4380, 4380, 8236, 8236, 1, 30),
    "torus": (8178, 8178, 15264, 15264, 1, 30),
    "shaving": (6139, 6139, 11372, 11372, 1, 24),
    "wavy": (4767, 4767, 8556, 8556, 1, 24),
    "quad": (10871, 10871, 21634, 21634, 1, 20),
    "balls": (11526, 11526, 23040, 23040, 1, 20),
    "hollow_box": (12932, 12932, 25856, 25856, 1, 1),
    "genus3": (17618, 17618, 35240, 35240, 1, 24),
    "cup": (16176, 16176, 32348, 32348, 1, 1),
    "touching": (12932, 12932, 25856, 25856, 1, 1),
    "cylinder": (11716, 11716, 23424, 23424, 1, 1),
    "mirrors": (10704, 10704, 19184, 19184, 3, 24),
}


def measured_counts(name: str) -> tuple:
    """The :data:`BUILTIN_COUNTS` row of a built-in scene, measured by building it."""
    from . import load_scene
    from ..subdivide import counts_before_after

    scene = load_scene(name)
    c, ba = scene.counts(), counts_before_after(scene)
    return ba["vertices"] + ba["triangles"] + (c["reflectors"], c["frames"])


def table_source() -> str:
    """The :data:`BUILTIN_COUNTS` entries of every built-in scene as Python source, measured."""
    from . import BUILTIN_SCENES

    return "\n".join(f"    {name!r}: {measured_counts(name)}," for name in BUILTIN_SCENES)

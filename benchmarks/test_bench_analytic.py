"""Exact reflection points on the spherical reflectors of a built-in scene (frame 0, default
camera): every searched vertex solved for every sphere, as the truth's ``exact`` stage does.
``extra_info`` gives the number of spheres, of points, and the time per solved point.

Run: ``pytest benchmarks/test_bench_analytic.py --benchmark-columns=min,median,rounds``.
"""

import pytest

import refsoft
from refsoft.scene import scene_vertices
from refsoft.truth.analytic import fit_sphere, sphere_reflection_points


@pytest.mark.parametrize("name", ["sphere", "ants"])
def test_sphere_reflection_points(benchmark, name):
    scene = refsoft.load_scene(name)
    verts, _ = scene_vertices(scene, 0)
    eye = scene.camera_at(0).eye
    spheres = [fit_sphere(scene.world_mesh(k, 0, proxy=True).vertices) for k in scene.reflector_ids]
    spheres = [s for s in spheres if s is not None]

    def solve():
        return [sphere_reflection_points(c, r, eye, verts) for c, r in spheres]

    solve()  # compile outside the timing
    benchmark.group = f"analytic {name}"
    benchmark.pedantic(solve, rounds=5)
    benchmark.extra_info.update(spheres=len(spheres), points=len(verts),
                                ns_per_point=round(1e9 * benchmark.stats.stats.min / (len(spheres) * len(verts)), 1))

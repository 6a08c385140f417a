"""Linear against hierarchy search on the thesis's setups: a mirror ball reflecting a
quad subdivided into more and more vertices, and a ball filling the whole view. For each: the
search time (cold; the hierarchy has no coherence), the mean steps (linear: neighbourhoods
evaluated; hierarchy: texels tested) and the pixel distance of the found reflection pixels from
the projections of the exact reflection points (refsoft.truth.analytic), over the visible vertices.

Run: ``pytest benchmarks/test_bench_hierarchy.py --benchmark-columns=min,median,rounds``.
"""

import numpy as np
import pytest

from refsoft import Camera, primitives, raster, search
from refsoft.truth.analytic import sphere_reflection_points
from refsoft.truth.metrics import pixel_distance

SETUPS = {
    # ball at the origin, a quad of n x n cells 4 units in front of it, the camera beside the quad
    "quad_16": (16, (0.0, 0.6, 5.5)),
    "quad_64": (64, (0.0, 0.6, 5.5)),
    "quad_256": (256, (0.0, 0.6, 5.5)),
    "fills_view": (64, (0.0, 0.2, 1.35)),
}
_CACHE = {}


def _setup(name):
    if name not in _CACHE:
        n, eye = SETUPS[name]
        cam = Camera(eye=eye, target=(0.0, 0.0, 0.0), fov_y=45.0, width=640, height=480, near=0.05)
        gb = raster.gbuffer(primitives.icosphere(5, 1.0), cam, origin=cam.eye)
        quad = primitives.plane_grid((6.0, 4.0), (n, n))
        verts = quad.vertices @ np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float).T + [0.0, 0.6, 4.0]  # facing -z
        exact = sphere_reflection_points(np.zeros(3), 1.0, cam.eye, verts)
        _CACHE[name] = (cam, gb, verts, exact)
    return _CACHE[name]


@pytest.mark.parametrize("method", ["cross", "hierarchy"])
@pytest.mark.parametrize("name", list(SETUPS))
def test_linear_vs_hierarchy(benchmark, name, method):
    cam, gb, verts, exact = _setup(name)
    search.search(gb, cam.eye, verts[:50], method)  # compile outside the timing
    benchmark.group = f"hierarchy {name} ({len(verts)} vertices)"
    res = benchmark.pedantic(search.search, (gb, cam.eye, verts, method), rounds=3)
    ok = ((res.flags & (search.HIDDEN | search.CULLED)) == 0) & np.all(np.isfinite(exact), axis=1)
    d = pixel_distance(res.pixel[ok], exact[ok], gb.view_proj, gb.mask.shape)
    benchmark.extra_info.update(vertices=len(verts), visible=int(ok.sum()), mean_steps=float(res.iterations.mean()),
                                pixel_error_mean=float(d.mean()), pixel_error_max=float(d.max()),
                                within_1px=float(np.mean(d <= 1.0)), capped=int(np.sum(res.flags & search.CAPPED > 0)))

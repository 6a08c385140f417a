"""The crossing rule of open sheets (docs/ldt.md, "The per-pixel search"): a sheet is hit where
the march passes from a sample in front of it to one at or behind it, as the face searched sees
it, from either side of the sheet; a ray that starts behind it, or on it, and moves away never
hits it; grazing rays cross it where the geometry says."""

import numpy as np
import pytest

from refsoft.ldt import constants as C
from refsoft.ldt.build import build_ldt
from refsoft.ldt.search import Stack, cube_matrices, search
from refsoft.scene import primitives as P
from refsoft.scene.model import Transform

R = 32
VIEW = np.array([0.0, 0.0, -1.0])  # an orthographic view: the incident direction of every ray


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


#: name -> (ray origin, direction, where it meets the plane y = 0 inside the sheet, or None)
RAYS = {
    "above, going down": ((0.1, 0.5, 0.2), (0.2, -1.0, 0.1), True),
    "below, going up (the sheet's other side)": ((-0.2, -0.5, 0.1), (0.1, 1.0, -0.2), True),
    "above, going up (behind it as the face looking up sees it)": ((0.1, 0.3, 0.2), (0.2, 1.0, 0.1), None),
    "below, going down": ((-0.2, -0.4, 0.1), (0.1, -1.0, -0.2), None),
    "grazing from above": ((-0.9, 0.05, 0.0), (1.0, -0.06, 0.0), True),
    "grazing from below": ((0.0, -0.04, -0.85), (0.0, 0.05, 1.0), True),
    "in the sheet's plane": ((-0.5, 0.0, 0.3), (1.0, 0.0, 0.0), None),
    "on the sheet, leaving it upward": ((0.0, 0.0, 0.0), (0.3, 1.0, 0.0), None),
    "on the sheet, leaving it downward": ((0.25, 0.0, -0.3), (0.0, -1.0, 0.4), None),
}


@pytest.fixture(scope="module", params=["float32", "float64"])
def searched(request):
    """Every ray of :data:`RAYS` searched in the LDT of a 2 x 2 sheet in the plane y = 0."""
    ldt = build_ldt(P.plane_grid((2.0, 2.0), (2, 2)), R)
    assert ldt.open and ldt.n_layers == 1
    stack = Stack.of({1: ldt}, request.param)
    W = cube_matrices(stack, {1: Transform()})
    origins = np.array([o for o, _, _ in RAYS.values()])
    dirs = np.array([_unit(d) for _, d, _ in RAYS.values()])
    normals = np.array([_unit(VIEW - d) for d in dirs])  # reflects VIEW into d
    n = len(RAYS)
    res = search(origins, normals, np.zeros(3), np.zeros(n, np.int64), np.ones((1, 1), bool), W, stack, VIEW,
                 regions="none", precision=request.param)
    return origins, dirs, res, 2.0 * ldt.cube_half / R


@pytest.mark.parametrize("name", list(RAYS))
def test_a_sheet_is_hit_only_where_the_ray_crosses_it_from_in_front(searched, name):
    origins, dirs, res, texel = searched
    i = list(RAYS).index(name)
    hits = RAYS[name][2]
    assert not res.flags[i] & C.START_INSIDE  # an open sheet is never inside at the first sample
    assert np.allclose(res.ray[i], dirs[i], atol=1e-6)
    if hits is None:
        assert res.object[i] == -1 and res.distance[i] == -1 and res.face[i] == -1, res.distance[i]
        return
    t = -origins[i, 1] / dirs[i, 1]  # the plane y = 0
    want = origins[i] + t * dirs[i]
    assert res.object[i] == 0 and res.flags[i] & C.OPEN_OBJECT
    assert res.face[i] == (3 if dirs[i, 1] > 0 else 2)  # the face looking along the ray's y (-Y up, +Y down)
    assert abs(float(res.distance[i]) - t) < texel / abs(dirs[i, 1]) and t > 0
    assert np.all(np.abs(res.hit[i].astype(np.float64) - want) < texel / abs(dirs[i, 1]))
    assert res.residual[i] <= C.TAU


def test_the_faces_that_see_the_sheet_edge_on_are_searched_and_miss(searched):
    """A grazing ray is searched first on the faces of its larger components, which see the sheet
    edge-on (it covers none of their texels), then on the face looking along its y."""
    origins, dirs, res, _ = searched
    i = list(RAYS).index("grazing from above")
    assert res.faces_searched[i] == 2 and res.object[i] == 0
    j = list(RAYS).index("in the sheet's plane")
    # r_y == 0: the Y faces are never searched, the others see the sheet edge-on
    assert res.ray[j, 1] == 0 and res.faces_searched[j] >= 1 and res.object[j] == -1

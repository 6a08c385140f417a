"""The convex skip (refsoft.search.convex): which meshes can give a vertex two reflection points,
on synthetic meshes and on every built-in scene's reflectors; on the convex built-ins no vertex
has a second image even with the G-buffer's interpolated normals (the enumeration, itself checked
against the every-texel reference in test_images.py)."""

import numpy as np
import pytest

import refsoft
from refsoft.errors import RefsoftError
from refsoft.scene.builtin import builtin_names
from refsoft.scene.builtin.shapes import bowl
from refsoft.scene.mesh import Mesh
from refsoft.scene.primitives import box, icosphere, plane_grid, torus, uv_sphere
from refsoft.search.convex import several_possible
from refsoft.search.images import find_images
from refsoft.search.reflect import reflect

NOT_CONVEX = {"concave", "torus", "shaving", "wavy"}


def _proxy(scene, k):
    o = scene.objects[k - 1]
    return o.closed_proxy if o.closed_proxy is not None else o.mesh


@pytest.mark.parametrize("name", builtin_names())
def test_builtin_decision(name):
    scene = refsoft.load_scene(name)
    got = {several_possible(_proxy(scene, k)) for k in scene.reflector_ids}
    assert got == {name in NOT_CONVEX}


def test_synthetic_meshes():
    ball = icosphere(2, 1.0)
    assert not several_possible(ball)
    assert not several_possible(uv_sphere(8, 16, 1.0))  # seams and poles welded
    assert not several_possible(box((1.0, 2.0, 0.5), 2))  # hard-normal copies, flat faces
    assert not several_possible(bowl(1.0, 8, 24)[1])  # the closed proxy with a lid
    assert several_possible(bowl(1.0, 8, 24)[0])  # open
    assert several_possible(torus(1.0, 0.3, 24, 12))  # closed, not convex
    two = Mesh(np.vstack([ball.vertices, ball.vertices + [3.0, 0, 0]]),
               np.vstack([ball.faces, ball.faces + len(ball.vertices)]), name="two")
    assert several_possible(two)  # two convex pieces: two images possible
    dent = ball.vertices.copy()
    dent[0] *= 0.8  # one vertex pushed in: concave there
    assert several_possible(Mesh(dent, ball.faces, name="dent"))
    assert not several_possible(plane_grid((2.0, 2.0), (3, 3)))  # a plane mirror
    bent = plane_grid((2.0, 2.0), (3, 3))
    v = bent.vertices.copy()
    v[5, 1] += 0.1
    assert several_possible(Mesh(v, bent.faces, bent.normals, name="bent"))
    with pytest.raises(RefsoftError, match="Mesh"):
        several_possible(ball.vertices)


@pytest.mark.parametrize("name", sorted(set(builtin_names()) - NOT_CONVEX))
def test_convex_builtins_show_one_image_at_most(name):
    scene = refsoft.load_scene(name, width=64, height=48)
    frame = scene.n_frames // 2 if scene.animation is not None else 0
    verts, _, refl = reflect(scene, frame, neighbourhood="box")
    eye = scene.camera_at(frame).eye
    for k, r in refl.items():
        assert find_images(r.gbuffer, eye, verts, r.result).count.max(initial=0) <= 1


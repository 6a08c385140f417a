"""Built-in scenes: sizes like the papers', every one loads and renders a small frame."""

import numpy as np
import pytest

import refsoft
from refsoft.frame import render
from refsoft.scene.builtin import BUILTIN_SCENES

SIZES = {"kitchen": (15_000, 1), "ufo": (82_000, 1), "ants": (30_000, 8)}


@pytest.mark.parametrize("name", list(SIZES))
def test_paper_scenes_are_sized_like_the_papers(name):
    c = refsoft.load_scene(name).counts()
    target, reflectors = SIZES[name]
    assert 0.9 * target <= c["vertices"] <= 1.1 * target
    assert c["reflectors"] == reflectors and c["frames"] > 1


def test_kitchen_bowl_is_open_with_a_closed_proxy():
    s = refsoft.load_scene("kitchen")
    bowl = s.object_by_id(1)
    assert bowl.reflector and bowl.closed_proxy is not None
    assert bowl.closed_proxy.n_faces > bowl.mesh.n_faces
    # the camera closes in: the bowl covers more of the view at the end
    first = refsoft.raster.gbuffer(s.world_mesh(1, 0, proxy=True), s.camera_at(0)).mask.mean()
    last = refsoft.raster.gbuffer(s.world_mesh(1, s.n_frames - 1, proxy=True), s.camera_at(s.n_frames - 1)).mask.mean()
    assert last > 4 * first


@pytest.mark.parametrize("name", list(BUILTIN_SCENES))
def test_every_builtin_renders_without_nan(name):
    s = refsoft.load_scene(name, width=96, height=72)
    last = s.n_frames - 1
    frames, stats = render(s, frames=[0, last] if last else [0])
    for fr in frames:
        a = fr.arrays
        assert a["image"].shape == (72, 96, 3)
        for k in s.reflector_ids:
            assert np.all(np.isfinite(a[f"virtual_vertex_{k}"]))
            assert np.all(np.isfinite(a[f"score_{k}"]))
        on = np.isin(a["object_id"], s.reflector_ids)
        assert np.all((a["reflected_id"] == -1) == ~on)
    assert stats["summary"]["total_mean_iterations"] >= 0

"""The enumeration of every image inside the vertex search (option ``images``): the per-image
arrays and flag SEVERAL on a mirror that is not convex, nothing changed on a convex one (the
convex skip) nor under the ``paper`` preset, the stats and the one-line summary."""

import numpy as np
import pytest

import refsoft
from refsoft import keys
from refsoft.cli.commands import several_lines
from refsoft.errors import RefsoftError
from refsoft.frame import FrameDriver, RenderOptions
from refsoft.scene.builtin import builtin_names
from refsoft.scene import scene_vertices
from refsoft.search import SEVERAL, flag_names
from refsoft.search.images import facing_gbuffer, find_images

W, H = 96, 72


def _frame(name, size=(W, H), **options):
    scene = refsoft.load_scene(name, width=size[0], height=size[1])
    driver = FrameDriver(scene, RenderOptions(**options))
    return scene, driver.render_frame(0)


def test_option_and_presets():
    assert RenderOptions().images == "all"
    assert RenderOptions(preset="paper").images == "one"
    assert RenderOptions(preset="paper", images="all").images == "all"
    assert RenderOptions().as_dict()["images"] == "all"
    with pytest.raises(RefsoftError, match="images"):
        RenderOptions(images="some")
    assert flag_names(SEVERAL | 1) == ["HIDDEN", "SEVERAL"]


@pytest.mark.parametrize("name", sorted(set(builtin_names()) - {"concave", "torus", "shaving", "wavy"}))
def test_convex_mirror_unchanged(name):
    _, a = _frame(name, (64, 48), images="all")
    _, b = _frame(name, (64, 48), images="one")
    assert set(a.arrays) == set(b.arrays)
    assert not any(k.startswith("image_") for k in a.arrays)
    for k in a.arrays:
        assert np.array_equal(a.arrays[k], b.arrays[k]), k
    scene = refsoft.load_scene(name)
    assert sorted(a.report["skipped"]["images_convex"]) == sorted(scene.reflector_ids) and a.report["images"] == {}


@pytest.fixture(scope="module")
def concave():
    scene, fr = _frame("concave")
    return scene, fr


def test_per_image_arrays(concave):
    scene, fr = concave
    k = 1
    a = fr.arrays
    count, vert, pix = a[keys.IMAGE_COUNT(k)], a[keys.IMAGE_VERTEX(k)], a[keys.IMAGE_PIXEL(k)]
    virt, sheet, flags = a[keys.IMAGE_VIRTUAL(k)], a[keys.IMAGE_SHEET(k)], a[keys.FLAGS(k)]
    n = len(a[keys.REFLECTION_PIXEL(k)])
    assert count.dtype == np.int32 and count.shape == (n,)
    assert vert.dtype == np.int32 and pix.dtype == np.int32 and virt.dtype == np.float32 and sheet.dtype == np.int32
    assert len(vert) == len(pix) == len(virt) == len(sheet) == count.sum()
    assert np.array_equal(vert, np.repeat(np.arange(n), count))
    # sheets (spec section 4.8): each image in one, labelled by the smallest image index in it
    assert np.all((sheet >= 0) & (sheet <= np.arange(len(sheet)))) and np.array_equal(sheet[sheet], sheet)
    assert len(np.unique(sheet)) < len(sheet)  # images linked across edges share sheets
    assert np.array_equal((flags & SEVERAL) != 0, count > 1) and (count > 1).any()
    # the same images as find_images on the frame's own G-buffer and search
    refl = fr.reflectors[k].state
    verts, _ = scene_vertices(scene, 0)
    im = find_images(facing_gbuffer(refl.gbuffer, scene.camera_at(0).eye), scene.camera_at(0).eye, verts, refl.result)
    assert np.array_equal(im.pixel, pix) and np.array_equal(im.virtual.astype(np.float32), virt)
    # the walk's pixel is the first image wherever the vertex has it
    first = np.flatnonzero(count > 0)
    offset = np.concatenate([[0], np.cumsum(count)])
    has = np.array([any((pix[offset[i]:offset[i + 1]] == a[keys.REFLECTION_PIXEL(k)][i]).all(axis=1)) for i in first])
    assert np.all(pix[offset[first[has]]] == a[keys.REFLECTION_PIXEL(k)][first[has]])
    c = fr.report["images"]["1"]
    assert [c["0"], c["1"], c["2"], c["3+"]] == [int((count == 0).sum()), int((count == 1).sum()),
                                                  int((count == 2).sum()), int((count >= 3).sum())]


def test_one_image_changes_only_the_flag_and_the_mirror(concave):
    """Besides the flag, every image changes only what the mirror shows (every image drawn,
    refsoft/search/several.py)."""
    _, fr = concave
    _, one = _frame("concave", images="one")
    assert not any(k.startswith("image_") for k in one.arrays)
    outside = one.arrays["object_id"] != 1
    for k, v in one.arrays.items():
        if k == keys.FLAGS(1):
            assert np.array_equal(v, fr.arrays[k] & ~np.uint8(SEVERAL))
        elif k in ("image", "reflected_id"):
            assert np.array_equal(v[outside], fr.arrays[k][outside]), k
        else:
            assert np.array_equal(v, fr.arrays[k]), k
    assert "images" not in one.report


def test_paper_preset_never_enumerates():
    _, fr = _frame("concave", preset="paper")
    assert not any(k.startswith("image_") for k in fr.arrays)
    assert not np.any(fr.arrays[keys.FLAGS(1)] & SEVERAL)


def test_several_lines():
    frames = [{"frame": 0, "images": {"1": {"0": 3, "1": 10, "2": 16, "3+": 7}, "2": {"0": 0, "1": 5, "2": 0, "3+": 0}}}]
    assert several_lines(frames, lambda k: "bowl") == [
        "reflector 1 (bowl): 23 vertices with several images (16 two, 7 three or more)"]
    assert several_lines([{"frame": 0}]) == []
    two = frames + [{"frame": 1, "images": {"1": {"0": 0, "1": 10, "2": 30, "3+": 0}}}]
    assert several_lines(two) == ["reflector 1: 30 vertices with several images (30 two, 0 three or more), frame 1"]


def test_trace_cli_lists_the_images(tmp_path, capsys):
    from refsoft.cli import main

    scene = refsoft.load_scene("concave", width=W, height=H)
    fr = FrameDriver(scene, RenderOptions()).render_frame(0)
    i = int(np.flatnonzero(fr.arrays[keys.IMAGE_COUNT(1)] >= 2)[0])
    assert main(["trace", "concave", "--vertex", str(i), "--width", str(W), "--height", str(H), "--out",
                 str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "every image: " in out and "pyramid cells visited" in out and (tmp_path / "images.json").exists()
    assert main(["trace", "sphere", "--vertex", "0", "--width", "32", "--height", "24", "--out", str(tmp_path / "s")]) == 0
    assert "convex" in capsys.readouterr().out

"""trace.html in a real browser: Debian's chromium, headless, driven by Playwright (the system
browser, no download). The page loads from a file URL with no console error, the slider and the
arrow keys reach every step with the table's highlighted row following, the table and the
picture light each other up, and the heat map is drawn (a screenshot's pixels vary).

These tests fail, never skip, without chromium (apt-get install chromium chromium-driver) or
Playwright (pip install '.[test]')."""

import io
import os
import shutil
import tempfile

import numpy as np
import pytest

from refsoft.viewer import write_trace_page

# the network is closed and no profile is kept: nothing starts that would reach out
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _chromium():
    path = shutil.which("chromium") or "/usr/bin/chromium"
    if not os.path.exists(path):
        pytest.fail("the browser tests need Debian's chromium: apt-get install chromium chromium-driver")
    return path


@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("the browser tests need Playwright's Python package: pip install '.[test]'")
    exe = _chromium()
    with sync_playwright() as p, tempfile.TemporaryDirectory() as profile:
        ctx = p.chromium.launch_persistent_context(profile, executable_path=exe, args=CHROMIUM_ARGS, headless=True,
                                                   viewport={"width": 1200, "height": 900})
        try:
            yield ctx
        finally:
            ctx.close()


def _open(browser, folder, trace):
    write_trace_page(folder, trace)
    page = browser.new_page()
    errors = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto((folder / "trace.html").as_uri())
    page.wait_for_function("window.refsoftViewer !== undefined")
    return page, errors


def _current_row(page):
    return int(page.locator("#steps tr.current").get_attribute("data-step"))


@pytest.mark.parametrize("which", ["walk_replay", "inverse_replay", "hierarchy_replay", "ldt_trace"])
def test_slider_and_keys_reach_every_step_and_the_row_follows(which, request, browser, tmp_path):
    page, errors = _open(browser, tmp_path, request.getfixturevalue(which))
    n = page.evaluate("window.refsoftViewer.steps")
    assert n >= 3
    assert _current_row(page) == 0
    slider = page.locator("#slider")
    for k in range(n):
        slider.fill(str(k))
        assert _current_row(page) == k and page.evaluate("window.refsoftViewer.current()") == k
        assert page.locator("#step-label").inner_text().startswith(f"step {k + 1} of {n}")
    for k in range(n - 2, n - 4, -1):
        page.keyboard.press("ArrowLeft")
        assert _current_row(page) == k and slider.input_value() == str(k)
    page.keyboard.press("ArrowRight")
    assert _current_row(page) == n - 2
    page.locator("#next").click()
    page.locator("#next").click()  # past the end stays at the last step
    assert _current_row(page) == n - 1
    assert page.locator("#steps tbody tr").count() == n
    assert page.locator("#stop").inner_text().strip()
    assert errors == []
    page.close()


def test_play_runs_to_the_last_step(browser, walk_replay, tmp_path):
    page, errors = _open(browser, tmp_path, walk_replay)
    n = page.evaluate("window.refsoftViewer.steps")
    page.locator("#play").click()
    page.wait_for_function(f"window.refsoftViewer.current() === {n - 1}", timeout=250 * n + 5000)
    assert _current_row(page) == n - 1 and errors == []
    page.close()


def test_table_and_picture_light_each_other_up(browser, walk_replay, tmp_path):
    page, errors = _open(browser, tmp_path, walk_replay)
    steps = walk_replay.trace.steps
    k = len(steps) // 2
    # a table cell under the pointer: its pixel is marked on the picture and the cell lit, the
    # step stays; a click chooses the step, and it stays when the pointer leaves
    cell = page.locator(f'#steps tr[data-step="{k}"] td.cand').nth(2)
    cell.hover()
    assert _current_row(page) == 0
    assert page.evaluate("window.refsoftViewer.hover()") == steps[k]["candidates"][2]["pixel"]
    assert "linked" in cell.get_attribute("class").split()
    cell.click()
    page.mouse.move(0, 0)
    assert _current_row(page) == k and page.evaluate("window.refsoftViewer.hover()") is None
    assert "linked" not in cell.get_attribute("class").split()
    page.evaluate("window.refsoftViewer.go(0)")
    # a pixel of the picture: the rows of the steps at that pixel light up
    box = page.locator("#heat").bounding_box()
    g = page.evaluate("JSON.parse(document.getElementById('trace-data').textContent).grids[0]")
    zoom = max(1, 520 // max(g["h"], g["w"]))
    r, c = steps[0]["pixel"]
    page.mouse.move(box["x"] + (c - g["c0"] + 0.5) * zoom, box["y"] + (r - g["r0"] + 0.5) * zoom)
    assert page.evaluate("window.refsoftViewer.hover()") == [r, c]
    assert page.locator('#steps tr[data-step="0"]').get_attribute("class").split().count("linked") == 1
    assert "pixel (%d, %d)" % (r, c) in page.locator("#hover").inner_text()
    assert errors == []
    page.close()


@pytest.mark.parametrize("which", ["walk_replay", "ldt_trace"])
def test_heat_map_and_side_view_are_drawn(which, request, browser, tmp_path):
    import imageio.v3 as iio

    page, errors = _open(browser, tmp_path, request.getfixturevalue(which))
    heat = iio.imread(io.BytesIO(page.locator("#heat").screenshot()))[..., :3].reshape(-1, 3)
    assert len(np.unique(heat, axis=0)) > 20 and heat.std() > 10
    bar = iio.imread(io.BytesIO(page.locator("#bar").screenshot()))[..., :3].reshape(-1, 3)
    assert len(np.unique(bar, axis=0)) > 20
    assert page.locator("#side circle").count() >= 3 and page.locator("#side line").count() >= 4
    assert errors == []
    page.close()


def test_without_chromium_the_browser_tests_fail_naming_the_packages(monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.setattr(os.path, "exists", lambda path: False)
    with pytest.raises(pytest.fail.Exception, match="apt-get install chromium chromium-driver"):
        _chromium()


def test_home_end_keys_and_words_that_do_not_repeat(browser, hierarchy_replay, tmp_path):
    page, errors = _open(browser, tmp_path, hierarchy_replay)
    n = page.evaluate("window.refsoftViewer.steps")
    page.keyboard.press("End")
    assert _current_row(page) == n - 1
    page.keyboard.press("Home")
    assert _current_row(page) == 0
    label = page.locator("#step-label").inner_text()
    assert label.startswith(f"step 1 of {n}: popped L") and label.count("popped") == 1
    heads = page.locator("#steps thead th").all_inner_texts()
    assert heads[:4] == ["step", "phase", "texel", "pixel"] and heads[-1] == "children pushed" and "#" not in heads
    assert "pushed" in page.locator("#legend").inner_text()
    assert page.locator("#heat-box .tick").count() >= 4
    assert errors == []
    page.close()


def test_an_inverse_search_shows_both_maps(browser, inverse_replay, tmp_path):
    page, errors = _open(browser, tmp_path, inverse_replay)
    heads = page.locator("#steps thead th").all_inner_texts()
    assert heads[:3] == ["step", "phase", "pixel"] and heads[-1] == "move"
    assert page.locator("#step-label").inner_text().startswith("step 1 of ") and "step 1," not in \
        page.locator("#step-label").inner_text()
    assert page.locator("#grid-pick").is_visible()
    shots = {}
    for value, title in (("0", "standard score s"), ("1", "inverse score")):
        page.select_option("#grid-choice", value)
        assert page.locator("#heat-title").inner_text() == title
        shots[value] = page.locator("#heat").screenshot()
    assert shots["0"] != shots["1"]
    page.select_option("#grid-choice", "-1")  # the step's own again: the last step is an inverse one
    page.keyboard.press("End")
    assert page.locator("#heat-title").inner_text() == "inverse score"
    assert errors == []
    page.close()


def test_a_face_with_no_covered_texel_says_so(browser, ldt_trace, tmp_path):
    from refsoft.viewer import trace_data, write_page

    d = trace_data(ldt_trace)
    g = d["grids"][d["steps"][0]["grid"]]
    g["values"], g["empty"] = [None] * len(g["values"]), True
    write_page(tmp_path / "trace.html", d)
    page = browser.new_page()
    page.goto((tmp_path / "trace.html").as_uri())
    page.wait_for_function("window.refsoftViewer !== undefined")
    assert "no texel of this face covered" in page.locator("#bar-label").inner_text()
    assert "sample" in page.locator("#legend").inner_text()
    page.close()

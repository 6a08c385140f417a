"""Regenerate the figures under docs/figures/ from the code: ``python docs/make_figures.py``
(``python docs/make_figures.py teaching``: docs/teaching.md's only).

Needs the ``plot`` extra (matplotlib) for the fill-rule diagram.
"""

import os
import sys

import numpy as np

import refsoft
from refsoft import raster
from refsoft.io import write_png
from refsoft.visualize import normal_colors, position_colors, side_by_side

HERE = os.path.dirname(os.path.abspath(__file__))
FIG = os.path.join(HERE, "figures")


def gbuffer_figure():
    scene = refsoft.load_scene("sphere", width=320, height=240)
    gb = raster.gbuffer(scene.world_mesh(1), scene.camera)
    view = raster.color_pass([scene.world_mesh(i + 1) for i in range(len(scene.objects))],
                             [o.color for o in scene.objects], scene.camera)
    pic = side_by_side(view.image, position_colors(gb.position, gb.mask), normal_colors(gb.normal, gb.mask))
    write_png(os.path.join(FIG, "gbuffer_sphere.png"), pic)


def fill_rule_figure():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    W = H = 8
    # two triangles sharing an edge that passes exactly through pixel centres
    pts = np.array([[1.5, 0.5], [6.5, 2.5], [3.5, 6.5], [0.5, 5.5]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    clip = np.c_[pts[:, 0] * 2 / W - 1, pts[:, 1] * 2 / H - 1, np.zeros(4), np.ones(4)]
    frags = raster.rasterize(clip, faces, W, H)
    fig, ax = plt.subplots(figsize=(4.5, 4.5))
    colors = ["#d95f02", "#1b9e77"]
    for f, col in zip(faces, colors):
        ax.add_patch(Polygon(pts[f], closed=True, fill=False, edgecolor=col, lw=2))
    for row in range(H):
        for c in range(W):
            x, y = c + 0.5, H - row - 0.5
            t = frags.triangle[row, c]
            ax.plot(x, y, "o", ms=9, color=colors[t] if t >= 0 else "white", mec="k")
    ax.set_xlim(0, W)
    ax.set_ylim(0, H)
    ax.set_xticks(range(W + 1))
    ax.set_yticks(range(H + 1))
    ax.grid(True, lw=0.5)
    ax.set_aspect("equal")
    ax.set_title("pixel centres filled by the triangle that covers them\n"
                 "(GL window coordinates, y up; shared edge covered once)", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(FIG, "fill_rule.png"), dpi=100)
    plt.close(fig)


def trace_figure():
    from refsoft import search
    from refsoft.search.reflect import reflector_gbuffer
    from refsoft.scene import scene_vertices
    from refsoft.search.pictures import trace_picture

    scene = refsoft.load_scene("sphere", width=320, height=240)
    gb = reflector_gbuffer(scene, 1)
    verts, _ = scene_vertices(scene)
    pics = []
    for nb in ("cross", "box"):
        tr = search.trace_search(gb, scene.camera.eye, verts[1500], nb)
        pics.append(trace_picture(tr, gb.mask, size=300))
        with open(os.path.join(FIG, f"trace_{nb}.txt"), "w") as fh:
            fh.write(tr.table() + "\n")
    write_png(os.path.join(FIG, "trace_sphere.png"), side_by_side(*pics))


def frame_figure():
    """The sphere scene rendered with each hidden-vertex mode, and a kitchen frame."""
    from refsoft.frame import FrameDriver, RenderOptions

    scene = refsoft.load_scene("sphere", width=320, height=240)
    pics = [FrameDriver(scene, RenderOptions(preset="paper", inverse=mode)).render_frame(0).image
            for mode in ("plane", "search", "discard")]
    write_png(os.path.join(FIG, "frame_inverse_modes.png"), side_by_side(*pics))
    kitchen = refsoft.load_scene("kitchen", width=480, height=360)
    driver = FrameDriver(kitchen)
    for f in range(kitchen.n_frames):
        fr = driver.render_frame(f)
        if f in (0, kitchen.n_frames - 1):
            pics = pics + [fr.image] if f else [fr.image]
    write_png(os.path.join(FIG, "frame_kitchen.png"), side_by_side(*pics))


def truth_figure():
    """Render | truth | agreement map of the sphere and the ufo scenes (frame 30), the paper
    preset above the accurate one."""
    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth.raytrace import TruthRenderer
    from refsoft.visualize import agreement_map

    rows = []
    for name, frame in (("sphere", 0), ("ufo", 30)):
        scene = refsoft.load_scene(name, width=320, height=240)
        t = TruthRenderer(scene, exact=False).render_frame(frame).arrays
        for preset in ("paper", "accurate"):
            r = FrameDriver(scene, RenderOptions(preset=preset)).render_frame(frame).arrays
            rows.append(side_by_side(r["image"], t["image"],
                                     agreement_map(r["reflected_id"], t["reflected_id"], t["image"])))
    write_png(os.path.join(FIG, "truth_compare.png"), np.concatenate(rows, axis=0))


def ldt_trace_figure():
    """The march of one pixel's LDT search (``refsoft trace balls --method ldt --pixel 240 236``)."""
    import shutil
    import tempfile

    from refsoft.frame import RenderOptions
    from refsoft.ldt.trace import trace_pixel, write_pixel_trace

    tr = trace_pixel(refsoft.load_scene("balls"), 240, 236, options=RenderOptions(method="ldt"))
    with tempfile.TemporaryDirectory() as tmp:
        write_pixel_trace(tmp, tr)
        shutil.copy(os.path.join(tmp, "trace.png"), os.path.join(FIG, "trace_ldt.png"))


def methods_figure():
    """The four ways to a reflection on two of the LDT paper's scenes (320x240, frame 0): the
    truth, the vertex search (accurate preset), the layered depth textures and the environment
    map, pictures above their agreement maps (the truth's column: its own image)."""
    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth.raytrace import TruthRenderer
    from refsoft.visualize import agreement_map

    rows = []
    for name in ("touching", "hollow_box"):
        scene = refsoft.load_scene(name, width=320, height=240)
        t = TruthRenderer(scene, exact=False).render_frame(0).arrays
        runs = [FrameDriver(scene, RenderOptions(**o)).render_frame(0).arrays
                for o in (dict(), dict(method="ldt"), dict(method="envmap"))]
        rows.append(side_by_side(t["image"], *[r["image"] for r in runs]))
        rows.append(side_by_side(t["image"], *[agreement_map(r["reflected_id"], t["reflected_id"], t["image"])
                                               for r in runs]))
    write_png(os.path.join(FIG, "methods_compare.png"), np.concatenate(rows, axis=0))


def accuracy_figure():
    """Agreement maps (green agrees with the truth, red not) of the six convex scenes at 640x480,
    a middle frame, cropped to the reflectors: the paper preset (left of each pair) and the
    accurate preset (right)."""
    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth.raytrace import TruthRenderer
    from refsoft.visualize import agreement_map

    tiles = []
    for name in ("sphere", "ellipsoid", "quad", "kitchen", "ufo", "ants"):
        scene = refsoft.load_scene(name, width=640, height=480)
        f = scene.n_frames // 2
        t = TruthRenderer(scene, exact=False).render_frame(f).arrays
        rows, cols = np.nonzero(t["reflected_id"] >= 0)
        crop = (slice(max(rows.min() - 3, 0), rows.max() + 4), slice(max(cols.min() - 3, 0), cols.max() + 4))
        pair = []
        for preset in ("paper", "accurate"):
            d = FrameDriver(scene, RenderOptions(preset=preset))
            for g in range(f + 1):
                r = d.render_frame(g).arrays
            pic = agreement_map(r["reflected_id"], t["reflected_id"], t["image"])[crop]
            zoom = max(1, int(200 / pic.shape[0]))
            pair.append(np.repeat(np.repeat(pic, zoom, axis=0), zoom, axis=1))
        tiles.append(side_by_side(*pair))
    h = max(t.shape[0] for t in tiles)
    tiles = [np.pad(t, ((0, h - t.shape[0]), (0, 0), (0, 0))) for t in tiles]
    write_png(os.path.join(FIG, "accuracy_maps.png"), side_by_side(*tiles[:3]))
    write_png(os.path.join(FIG, "accuracy_maps_paper_scenes.png"), side_by_side(*tiles[3:]))


def refine_figure():
    """Agreement maps of the quad scene (search mode) against the truth, cropped to the ball:
    the paper's method, sub-texel points, adaptive tessellation, both."""
    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth.raytrace import TruthRenderer
    from refsoft.visualize import agreement_map

    scene = refsoft.load_scene("quad", width=320, height=240)
    t = TruthRenderer(scene, exact=False).render_frame(0).arrays
    rows, cols = np.nonzero(t["reflected_id"] >= 0)
    crop = (slice(rows.min() - 2, rows.max() + 3), slice(cols.min() - 2, cols.max() + 3))
    pics = []
    for kw in ({}, {"refine": True}, {"tessellate": 1e-3}, {"refine": True, "tessellate": 1e-5}):
        r = FrameDriver(scene, RenderOptions(preset="paper", inverse="search", **kw)).render_frame(0).arrays
        pic = agreement_map(r["reflected_id"], t["reflected_id"], t["image"])[crop]
        pics.append(np.repeat(np.repeat(pic, 2, axis=0), 2, axis=1))
    write_png(os.path.join(FIG, "refine_quad.png"), side_by_side(*pics))


def sheets_figure():
    """The concave bowl at 640x480, frame 0, every image drawn (the accurate preset): the render,
    the ray-traced truth, and the agreement map (green agrees, red not); docs/sheets.md."""
    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth.raytrace import TruthRenderer
    from refsoft.visualize import agreement_map

    scene = refsoft.load_scene("concave", width=640, height=480)
    t = TruthRenderer(scene, exact=False).render_frame(0).arrays
    r = FrameDriver(scene, RenderOptions(preset="accurate")).render_frame(0).arrays
    agree = agreement_map(r["reflected_id"], t["reflected_id"], t["image"])
    write_png(os.path.join(FIG, "sheets_concave.png"), side_by_side(r["image"], t["image"], agree))


def exact_figure():
    """Kitchen frame 23 at 640x480 (rendered alone), a part of the bowl where the reflected
    outlines run: the virtual triangles rasterized, drawn exactly (the accurate preset), and the
    truth; below, each drawing's agreement map (green agrees with the truth, red not), 3x."""
    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth import metrics
    from refsoft.truth.raytrace import TruthRenderer
    from refsoft.visualize import agreement_map

    scene = refsoft.load_scene("kitchen", width=640, height=480)
    t = TruthRenderer(scene, exact=False).render_frame(23).arrays
    got = {d: FrameDriver(scene, RenderOptions(draw=d)).render_frame(23).arrays for d in ("raster", "exact")}
    holes = np.argwhere(metrics.holes(got["raster"]["reflected_id"], t["reflected_id"]))
    # the 160x100 window holding the most of the raster's holes
    best, corner = -1, (0, 0)
    for r0 in range(0, 480 - 100, 10):
        for c0 in range(0, 640 - 160, 10):
            n = int(np.sum((holes[:, 0] >= r0) & (holes[:, 0] < r0 + 100) & (holes[:, 1] >= c0) & (holes[:, 1] < c0 + 160)))
            if n > best:
                best, corner = n, (r0, c0)
    crop = (slice(corner[0], corner[0] + 100), slice(corner[1], corner[1] + 160))

    def big(pic):
        return np.repeat(np.repeat(pic[crop], 3, axis=0), 3, axis=1)

    top = side_by_side(big(got["raster"]["image"]), big(got["exact"]["image"]), big(t["image"]))
    maps = [big(agreement_map(got[d]["reflected_id"], t["reflected_id"], t["image"])) for d in ("raster", "exact")]
    bottom = side_by_side(*maps, np.zeros_like(maps[0]))
    write_png(os.path.join(FIG, "exact_draw.png"), np.concatenate([top, bottom], axis=0))


def bounces_figure():
    """The mirrors scene at 640x480, frame 0, three bounces (the accurate preset): the render, the
    ray-traced truth with three bounces, and the reflections taken per pixel (the render's
    bounce_depth: dark 1, mid 2, bright 3) with the pixels whose reflected object differs in
    red; docs/bounces.md."""
    import numpy as np

    from refsoft.frame import FrameDriver, RenderOptions
    from refsoft.truth.raytrace import TruthRenderer

    scene = refsoft.load_scene("mirrors", width=640, height=480)
    t = TruthRenderer(scene, exact=False, bounces=3).render_frame(0).arrays
    r = FrameDriver(scene, RenderOptions(bounces=3)).render_frame(0).arrays
    depth = r["bounce_depth"]
    levels = np.zeros(depth.shape + (3,), np.uint8)
    for j, grey in ((1, 70), (2, 150), (3, 240)):
        levels[depth == j] = grey
    wrong = (t["reflected_id"] >= 0) & (r["reflected_id"] != t["reflected_id"])
    levels[wrong] = (230, 30, 30)
    write_png(os.path.join(FIG, "bounces_mirrors.png"), side_by_side(r["image"], t["image"], levels))


def check_figure():
    """What `refsoft check` draws for a port whose search ends one pixel off on every 40th
    vertex and whose image is off by 3 levels in a band: the reflection-pixel map (green
    pass, red fail, on the grey mirror) and the image's error mask and 16x difference."""
    import shutil
    import tempfile

    import imageio.v3 as iio

    from refsoft.conformance.check import check
    from refsoft.conformance.golden import write_golden
    from refsoft.io import write_npz

    with tempfile.TemporaryDirectory() as tmp:
        gold, cand = os.path.join(tmp, "golden"), os.path.join(tmp, "cand")
        write_golden(gold, ["sphere"])
        shutil.copytree(gold, cand)
        path = os.path.join(cand, "sphere", "frame_0000.npz")
        with np.load(path) as z:
            a = {k: z[k] for k in z.files}
        a["reflection_pixel_1"][::40, 1] += 1
        a["image"][40:48] = np.clip(a["image"][40:48].astype(int) + 3, 0, 255).astype(np.uint8)
        write_npz(path, **a)
        report = os.path.join(tmp, "report")
        check(gold, cand, out=report, cases=["sphere"])
        pics = [iio.imread(os.path.join(report, f"sphere_frame_0000_{k}.png"))
                for k in ("reflection_pixel_1", "image", "image_diff")]
    pics = [p[..., :3] for p in pics]  # check writes them magnified already
    write_png(os.path.join(FIG, "check_report.png"), side_by_side(*pics))


def teaching_figures():
    """docs/teaching.md's figures: one vertex's walk on the sphere as the trace command draws it
    (trace.png, three GIF frames), its trace.html, and a screenshot of that page in headless
    chromium (when Playwright and chromium are installed); the trace.png of a hidden vertex's
    walk with its inverse search, and of the same vertex's ray-cone hierarchy."""
    from refsoft.search.pictures import hierarchy_picture, trace_frames, trace_picture
    from refsoft.search.trace import trace_vertex
    from refsoft.viewer import write_page, walk_data

    scene = refsoft.load_scene("sphere", width=320, height=240)
    rp = trace_vertex(scene, TEACHING_VERTEX, neighbourhood="cross", inverse="search")
    mask = rp.gbuffer.mask
    write_png(os.path.join(FIG, "teaching_trace.png"), trace_picture(rp.trace, mask, labelled=True, replay=rp))
    frames = trace_frames(rp.trace, mask, size=300, labelled=True)
    n = len(rp.trace.steps)
    write_png(os.path.join(FIG, "teaching_steps.png"), side_by_side(frames[0], frames[n // 2], frames[n - 1]))
    page = os.path.join(FIG, "teaching_trace.html")
    write_page(page, walk_data(rp))
    with open(os.path.join(FIG, "teaching_trace.txt"), "w") as fh:
        fh.write(rp.trace.table() + "\n")
    hidden = trace_vertex(scene, TEACHING_HIDDEN, neighbourhood="cross", inverse="search")
    write_png(os.path.join(FIG, "teaching_inverse.png"),
              trace_picture(hidden.trace, hidden.gbuffer.mask, labelled=True, replay=hidden))
    hier = trace_vertex(scene, TEACHING_VERTEX, method="hierarchy")
    write_png(os.path.join(FIG, "teaching_hierarchy.png"),
              hierarchy_picture(hier.trace, hier.gbuffer.mask, labelled=True, replay=hier))
    try:
        import tempfile

        from playwright.sync_api import sync_playwright
    except ImportError:
        print("playwright missing: teaching_viewer.png not made", file=sys.stderr)
        return
    args = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync"]
    with sync_playwright() as p, tempfile.TemporaryDirectory() as profile:
        ctx = p.chromium.launch_persistent_context(profile, executable_path="/usr/bin/chromium", args=args,
                                                   headless=True, viewport={"width": 1320, "height": 940})
        pg = ctx.new_page()
        pg.goto("file://" + page)
        pg.evaluate(f"window.refsoftViewer.go({n // 2})")
        pg.screenshot(path=os.path.join(FIG, "teaching_viewer.png"))
        ctx.close()


#: The vertex of docs/teaching.md's lesson (the sphere scene at 320x240).
TEACHING_VERTEX = 1500
#: Its vertex behind the tangent plane (HIDDEN), traced with the inverse search.
TEACHING_HIDDEN = 3295


def several_figure(scene_name="concave"):
    """The score field of the vertex with the most images on ``concave`` (320x240, frame 0, the
    accurate preset's search), its images (white circles, the walk's filled) and the maxima the
    enumeration rejected (red crosses); ``docs/figures/several_concave.png`` and its trace
    ``several_concave.txt``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from refsoft.search.images import facing_gbuffer, find_images, trace_images
    from refsoft.search import scores_at
    from refsoft.search.reflect import reflect

    scene = refsoft.load_scene(scene_name, width=320, height=240)
    verts, owner, refl = reflect(scene, 0)
    r = refl[scene.reflector_ids[0]]
    eye = scene.camera_at(0).eye
    gb = facing_gbuffer(r.gbuffer, eye)  # as the method enumerates
    im = find_images(gb, eye, verts, r.result)
    i = int(np.argmax(im.count))  # the first vertex with the most images
    pix = np.argwhere(gb.mask)
    s = np.zeros(gb.mask.shape)
    s[pix[:, 0], pix[:, 1]] = scores_at(gb, eye, np.repeat(verts[i:i + 1], len(pix), axis=0), pix)
    tr = trace_images(gb, eye, verts[i], r.result.pixel[i])
    rows, cols = np.nonzero(gb.mask)
    r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    field = np.where(gb.mask, -np.log10(np.maximum(1.0 - s.astype(np.float64), 1e-8)), np.nan)[r0:r1, c0:c1]
    fig, ax = plt.subplots(figsize=(6.4, 5.0))
    pic = ax.imshow(field, cmap="viridis", extent=(c0 - 0.5, c1 - 0.5, r1 - 0.5, r0 - 0.5))
    fig.colorbar(pic, ax=ax, label="-log10(1 - s)")
    for m in tr.maxima:
        if m["verdict"] not in ("accepted", "merged"):
            ax.plot(m["texel"][1], m["texel"][0], "x", color="red", ms=6)
    for n, (pr, pc) in enumerate(tr.images):
        ax.plot(pc, pr, "o", ms=11, mfc="white" if n == 0 and tr.walk_is_image else "none", mec="white", mew=2)
    name = scene.objects[owner[i] - 1].name
    ax.set_title(f"{scene_name}: vertex {i} ({name}), {len(tr.images)} images\n"
                 "white: images (filled: the walk's), red: maxima rejected", fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(FIG, f"several_{scene_name}.png"), dpi=100)
    plt.close(fig)
    with open(os.path.join(FIG, f"several_{scene_name}.txt"), "w") as fh:
        fh.write(tr.table() + "\n")


if __name__ == "__main__" and sys.argv[1:]:  # only the figures named: python docs/make_figures.py several teaching
    os.makedirs(FIG, exist_ok=True)
    for name in sys.argv[1:]:
        (globals().get(f"{name}_figure") or globals()[f"{name}_figures"])()
    print(f"figures written to {FIG}")
elif __name__ == "__main__":
    os.makedirs(FIG, exist_ok=True)
    teaching_figures()
    gbuffer_figure()
    trace_figure()
    frame_figure()
    truth_figure()
    methods_figure()
    accuracy_figure()
    refine_figure()
    sheets_figure()
    exact_figure()
    bounces_figure()
    check_figure()
    try:
        fill_rule_figure()
        ldt_trace_figure()
        several_figure()
    except ImportError:
        print("matplotlib missing: fill_rule.png not made (pip install '.[plot]')", file=sys.stderr)
    print(f"figures written to {FIG}")

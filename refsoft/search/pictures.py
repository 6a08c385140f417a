"""Pictures of one search: the vertex's score field over the reflector with the path drawn
(``trace.png``) and one frame per step (``trace.gif``). NumPy drawing; Pillow writes the words
around it (:func:`annotate`: title, axes in G-buffer pixels, colour bar, legend; in the GIF the
step and its score), so each picture explains itself without plotting library.

Colours: ``-log10(1 - s)`` (how many nines the score has), scaled to its maximum over the
reflector, through a viridis-like ramp, so the optimum stands out; uncovered pixels dark grey;
the path white (standard search) or cyan (inverse search, drawn on a second panel: the inverse
score field around the inverse steps, magnified); the start a green square, the end a red one;
every image of a vertex with several circled in pink; in the GIF the current neighbourhood's
candidates are outlined in yellow and the chosen one in orange, the inverse steps drawn on the
inverse score field, every frame against one palette (:func:`gif_palette`).
"""

from __future__ import annotations

import numpy as np

# viridis at 0, 0.25, 0.5, 0.75, 1 (sRGB)
_RAMP = np.array([[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]], dtype=np.float64)
_GREY = np.array([40, 40, 46], dtype=np.uint8)
_PATH = {"standard": np.array([255, 255, 255], np.uint8), "inverse": np.array([0, 230, 255], np.uint8)}


def colour_scores(scores, mask) -> np.ndarray:
    """(H, W) scores -> (H, W, 3) uint8: ``-log10(1 - s)`` (at most 7), over its maximum on
    the covered pixels, through the ramp; uncovered pixels grey."""
    q = np.clip(1.0 - np.nan_to_num(scores.astype(np.float64), nan=-1.0), 1e-7, 2.0)
    nines = np.maximum(-np.log10(q), 0.0)
    top = nines[mask].max() if mask.any() else 1.0
    t = np.clip(nines / max(top, 1e-12), 0.0, 1.0)
    x = t * (len(_RAMP) - 1)
    i = np.minimum(x.astype(int), len(_RAMP) - 2)
    f = (x - i)[..., None]
    rgb = (1 - f) * _RAMP[i] + f * _RAMP[i + 1]
    out = np.rint(rgb).astype(np.uint8)
    out[~mask] = _GREY
    return out


def _crop(mask, margin=3):
    rows, cols = np.nonzero(mask)
    h, w = mask.shape
    return (max(int(rows.min()) - margin, 0), min(int(rows.max()) + margin + 1, h),
            max(int(cols.min()) - margin, 0), min(int(cols.max()) + margin + 1, w))


class _Canvas:
    def __init__(self, base, r0, c0, zoom):
        self.img = np.repeat(np.repeat(base, zoom, axis=0), zoom, axis=1)
        self.r0, self.c0, self.z = r0, c0, zoom

    def centre(self, pix):
        return ((pix[0] - self.r0) * self.z + self.z // 2, (pix[1] - self.c0) * self.z + self.z // 2)

    def line(self, a, b, colour):
        (y0, x0), (y1, x1) = self.centre(a), self.centre(b)
        n = max(abs(y1 - y0), abs(x1 - x0), 1)
        ys = np.rint(np.linspace(y0, y1, n + 1)).astype(int)
        xs = np.rint(np.linspace(x0, x1, n + 1)).astype(int)
        h, w = self.img.shape[:2]
        for dy, dx in ((0, 0), (0, 1), (1, 0)):  # two pixels wide
            yy, xx = ys + dy, xs + dx
            ok = (yy >= 0) & (yy < h) & (xx >= 0) & (xx < w)
            self.img[yy[ok], xx[ok]] = colour

    def square(self, pix, colour, filled=True, half=None):
        """A marker on pixel ``pix``: at least 9 output pixels wide, so it shows at any zoom."""
        cy, cx = self.centre(pix)
        half = max(self.z // 2, 4) if half is None else half
        h, w = self.img.shape[:2]
        y0, y1 = max(cy - half, 0), min(cy + half + 1, h)
        x0, x1 = max(cx - half, 0), min(cx + half + 1, w)
        if y0 >= y1 or x0 >= x1:
            return
        if filled:
            self.img[y0:y1, x0:x1] = colour
        else:
            self.img[y0:y1, [x0, x1 - 1]] = colour
            self.img[[y0, y1 - 1], x0:x1] = colour

    def ring(self, pix, colour, radius=None):
        """A circle two pixels wide around pixel ``pix`` (radius at least 7 output pixels)."""
        cy, cx = self.centre(pix)
        rad = max(self.z, 7) if radius is None else radius
        h, w = self.img.shape[:2]
        yy, xx = np.mgrid[max(cy - rad - 2, 0):min(cy + rad + 3, h), max(cx - rad - 2, 0):min(cx + rad + 3, w)]
        d = np.hypot(yy - cy, xx - cx)
        on = (d >= rad - 1) & (d <= rad + 1)
        self.img[yy[on], xx[on]] = colour


_WHITE, _INK = (255, 255, 255), (25, 25, 25)
_START, _END = (40, 220, 60), (230, 30, 30)


def _font(size):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: the fixed bitmap font
        return ImageFont.load_default()


def _ticks(lo, hi, n=5):
    """About ``n`` round values in [lo, hi]."""
    span = max(hi - lo, 1e-12)
    raw = span / n
    step = 10.0 ** np.floor(np.log10(raw))
    for m in (1, 2, 5, 10):
        if raw <= m * step:
            step *= m
            break
    first = np.ceil(lo / step) * step
    return [v for v in np.arange(first, hi + 0.5 * step, step) if lo - 1e-9 <= v <= hi + 1e-9]


def _layout(title, header, w, bar, legend, small):
    """Where the words go: (width, top, left, legend rows) of :func:`annotate`'s canvas."""
    from PIL import Image, ImageDraw

    probe = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    words = max(probe.textlength(title, font=_font(15)), probe.textlength(header or "", font=small))
    # the title, the header under it, then the "row" label on its own line above the picture
    top = 26 + (20 if header else 0) + 16
    left, right = 48, 110 if bar else 16
    return int(max(left + w + right, 520, words + 16)), top, left, (len(legend) + 1) // 2


def annotate(img, title, r0, c0, zoom, bar=None, legend=(), header=None) -> np.ndarray:
    """``img`` (H, W, 3) uint8, a picture of G-buffer pixels from (r0, c0) magnified ``zoom``
    times, with its words around it: ``title`` above (and ``header``, a second line), the rows
    and columns on the axes, ``bar`` = (lo, hi, label) a colour bar of the ramp on the right,
    ``legend`` [(rgb, text), ...] below. (H', W', 3) uint8; the picture's pixels unchanged."""
    from PIL import Image, ImageDraw

    h, w = img.shape[:2]
    f, small = _font(15), _font(12)
    width, top, left, rows_legend = _layout(title, header, w, bar, legend, small)
    bottom = 36 + 18 * rows_legend
    canvas = Image.new("RGB", (width, top + h + bottom), _WHITE)
    canvas.paste(Image.fromarray(np.ascontiguousarray(img)), (left, top))
    d = ImageDraw.Draw(canvas)
    d.text((8, 6), title, fill=_INK, font=f)
    if header:
        d.text((8, 26), header, fill=_INK, font=small)
    d.rectangle([left - 1, top - 1, left + w, top + h], outline=_INK)
    for r in _ticks(r0, r0 + h / zoom - 1):
        y = top + (r - r0) * zoom + zoom // 2
        d.line([left - 5, y, left - 1, y], fill=_INK)
        d.text((4, y - 7), f"{int(r)}", fill=_INK, font=small)
    for c in _ticks(c0, c0 + w / zoom - 1):
        x = left + (c - c0) * zoom + zoom // 2
        d.line([x, top + h, x, top + h + 4], fill=_INK)
        d.text((x - 10, top + h + 5), f"{int(c)}", fill=_INK, font=small)
    d.text((left + w // 2 - 60, top + h + 18), "column (pixel)", fill=_INK, font=small)
    d.text((4, top - 15), "row", fill=_INK, font=small)
    if bar:
        lo, hi, label = bar
        x0, bh = left + w + 14, max(h - 20, 40)
        t = np.linspace(1.0, 0.0, bh)
        x = t * (len(_RAMP) - 1)
        i = np.minimum(x.astype(int), len(_RAMP) - 2)
        col = np.rint((1 - (x - i))[:, None] * _RAMP[i] + (x - i)[:, None] * _RAMP[i + 1]).astype(np.uint8)
        canvas.paste(Image.fromarray(np.repeat(col[:, None], 14, axis=1)), (x0, top + 16))
        d.text((x0 - 4, top), label, fill=_INK, font=small)
        for v in _ticks(lo, hi, 4):
            y = top + 16 + int(round((1 - (v - lo) / max(hi - lo, 1e-12)) * (bh - 1)))
            d.line([x0 + 14, y, x0 + 18, y], fill=_INK)
            d.text((x0 + 21, y - 7), f"{v:g}", fill=_INK, font=small)
    for k, (rgb, text) in enumerate(legend):
        x, y = 8 + (k % 2) * (width // 2), top + h + 36 + 18 * (k // 2)
        d.rectangle([x, y + 2, x + 10, y + 12], fill=tuple(int(v) for v in rgb), outline=(120, 120, 120))
        d.text((x + 16, y), text, fill=_INK, font=small)
    return np.asarray(canvas, dtype=np.uint8)


def side_by_side_panels(panels, gap: int = 12) -> np.ndarray:
    """(H_i, W_i, 3) uint8 pictures next to each other, top-aligned, on white."""
    h = max(p.shape[0] for p in panels)
    parts = []
    for k, p in enumerate(panels):
        parts.append(np.pad(p, ((0, h - p.shape[0]), (0, 0), (0, 0)), constant_values=255))
        if k + 1 < len(panels):
            parts.append(np.full((h, gap, 3), 255, np.uint8))
    return np.concatenate(parts, axis=1)


def _nines_max(field, mask):
    q = np.clip(1.0 - np.nan_to_num(field.astype(np.float64), nan=-1.0), 1e-7, 2.0)
    nines = np.maximum(-np.log10(q), 0.0)
    return float(nines[mask].max()) if mask.any() else 1.0


_RING = (255, 102, 255)  # every image found (several images), as the page circles them


def _legend(trace, images=()):
    items = [(_START, f"start ({trace.start[0]}, {trace.start[1]})"),
             (_END, f"end ({trace.pixel[0]}, {trace.pixel[1]})"), (tuple(_PATH["standard"]), "path, standard search")]
    if _has_inverse(trace):
        items.append((tuple(_PATH["inverse"]), "path, inverse search"))
    if len(images) > 1:
        items.append((_RING, "every image: " + ", ".join(f"({r}, {c})" for r, c in images)))
    items.append((tuple(_GREY), "not covered"))
    return items


def _has_inverse(trace):
    return trace.inverse_map is not None and any(s["phase"] == "inverse" for s in trace.steps)


def _title(trace, replay=None, images=()):
    where = "" if replay is None else f"{replay.scene} frame {replay.frame}, vertex {replay.vertex}: "
    if replay is not None and getattr(replay, "through", ()):  # a later bounce: its path and box
        r0, _, c0, _ = replay.gbuffer_box
        where += f"bounce {len(replay.through)} via {'->'.join(map(str, replay.through))} (box at ({r0}, {c0})): "
    several = f"; SEVERAL: {len(images)} images" if len(images) > 1 else ""
    return (f"{where}score field -log10(1 - s), s = N . bisector; {len(trace.steps)} steps, "
            f"{trace.stop}{several}")


def _setup(trace, mask, size, field=None):
    r0, r1, c0, c1 = _crop(mask)
    zoom = int(max(1, min(16, size // max(r1 - r0, c1 - c0))))
    base = colour_scores(trace.score_map if field is None else field, mask)[r0:r1, c0:c1]
    return base, r0, c0, zoom


def _draw_path(canvas, steps, upto):
    for a, b in zip(steps[:upto], steps[1:upto + 1]):
        canvas.line(a["pixel"], b["pixel"], _PATH[b["phase"]])


def _inverse_box(trace, mask, margin=6):
    """The pixels around the inverse steps (and the pixel they start from), within the
    reflector's box: (r0, r1, c0, c1)."""
    first = next(k for k, s in enumerate(trace.steps) if s["phase"] == "inverse")
    pts = np.array([s["pixel"] for s in trace.steps[max(first - 1, 0):]] + [trace.pixel])
    R0, R1, C0, C1 = _crop(mask)
    return (max(int(pts[:, 0].min()) - margin, R0), min(int(pts[:, 0].max()) + margin + 1, R1),
            max(int(pts[:, 1].min()) - margin, C0), min(int(pts[:, 1].max()) + margin + 1, C1))


def _standard_panel(trace, mask, size, images=()):
    base, r0, c0, zoom = _setup(trace, mask, size)
    cv = _Canvas(base, r0, c0, zoom)
    _draw_path(cv, trace.steps, len(trace.steps))
    cv.square(trace.start, np.array(_START, np.uint8))
    cv.square(trace.pixel, np.array(_END, np.uint8))
    for p in images if len(images) > 1 else ():
        cv.ring(p, np.array(_RING, np.uint8))
    return cv.img, r0, c0, zoom


def _inverse_panel(trace, mask, size):
    """The inverse score field around the inverse steps, magnified so that the short cyan path
    shows: the end an outlined red square drawn under the path."""
    r0, r1, c0, c1 = _inverse_box(trace, mask)
    zoom = int(max(1, min(24, size // max(r1 - r0, c1 - c0))))
    cv = _Canvas(colour_scores(trace.inverse_map, mask)[r0:r1, c0:c1], r0, c0, zoom)
    cv.square(trace.pixel, np.array(_END, np.uint8), filled=False)
    first = next(k for k, s in enumerate(trace.steps) if s["phase"] == "inverse")
    _draw_path(cv, trace.steps[max(first - 1, 0):], len(trace.steps))
    for s in trace.steps[first:]:  # each inverse step's pixel, inside the end's outline
        cv.square(s["pixel"], _PATH["inverse"], filled=False, half=max(zoom // 4, 3))
    return cv.img, r0, c0, zoom


def trace_picture(trace, mask, size: int = 512, labelled: bool = False, replay=None, images=()) -> np.ndarray:
    """The score field with the whole path, start and end. (H', W', 3) uint8. ``labelled`` adds
    the title, axes, colour bar and legend (:func:`annotate`); ``replay`` names the scene,
    frame and vertex in the title; ``images`` (M, 2) every reflection pixel of the vertex,
    circled when there are several. When an inverse search ran, a second panel beside the
    first: the inverse score field around the inverse steps with their (cyan) path."""
    images = [tuple(int(v) for v in p) for p in np.asarray(images, dtype=np.int64).reshape(-1, 2)]
    std, r0, c0, zoom = _standard_panel(trace, mask, size, images)
    panels = [std]
    if labelled:
        panels = [annotate(std, _title(trace, replay, images), r0, c0, zoom,
                           (0.0, _nines_max(trace.score_map, mask), "-log10(1-s)"), _legend(trace, images))]
    if _has_inverse(trace):
        inv, i0, j0, iz = _inverse_panel(trace, mask, size)
        n_inv = sum(s["phase"] == "inverse" for s in trace.steps)
        panels.append(inv if not labelled else annotate(
            inv, f"inverse score field (vertex and eye swapped), magnified: {n_inv} inverse steps", i0, j0, iz,
            (0.0, _nines_max(trace.inverse_map, mask), "inverse"),
            [(tuple(_PATH["inverse"]), "path and pixels of the inverse search"), (_END, f"end ({trace.pixel[0]}, {trace.pixel[1]}), "
                                                                      "outlined")]))
    return panels[0] if len(panels) == 1 else side_by_side_panels(panels)


def trace_frames(trace, mask, size: int = 384, max_frames: int = 150, labelled: bool = False) -> list:
    """One picture per step (subsampled to ``max_frames``), then the final picture, all of one
    size. Each step is drawn on the field its phase scores: the standard score field, or the
    inverse one for the inverse steps. ``labelled`` adds the words of :func:`annotate`, with
    the step, its pixel and its score above."""
    base_std, r0, c0, zoom = _setup(trace, mask, size)
    base_inv = None if trace.inverse_map is None else _setup(trace, mask, size, trace.inverse_map)[0]
    n = len(trace.steps)
    picks = np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int))
    extra = [((255, 220, 0), "candidates"), ((255, 140, 0), "moved to")]

    def words(img, phase, header):
        if not labelled:
            return img
        fld = trace.score_map if phase == "standard" else trace.inverse_map
        label = "-log10(1-s)" if phase == "standard" else "inverse"
        title = _title(trace) if phase == "standard" else _title(trace).replace(
            "score field -log10(1 - s), s = N . bisector", "inverse score field -log10(1 - s) (vertex and eye swapped)")
        return annotate(img, title, r0, c0, zoom, (0.0, _nines_max(fld, mask), label), _legend(trace) + extra, header)

    frames = []
    for k in picks:
        step = trace.steps[k]
        inverse = step["phase"] == "inverse" and base_inv is not None
        cv = _Canvas(base_inv if inverse else base_std, r0, c0, zoom)
        _draw_path(cv, trace.steps, k)
        cv.square(trace.start, np.array(_START, np.uint8))
        for cand in step["candidates"]:
            if cand["status"] == "evaluated":
                cv.square(cand["pixel"], np.array([255, 220, 0], np.uint8), filled=False)
        if step["move_to"] is not None:
            cv.square(step["move_to"], np.array([255, 140, 0], np.uint8), filled=False)
        here = step["candidates"][0]["score"]
        header = (f"step {k + 1} of {n}, {step['phase']}, pixel ({step['pixel'][0]}, {step['pixel'][1]}), "
                  f"{'inverse score' if inverse else 'score'} {'-' if here is None else f'{here:.8f}'}, "
                  + ("stays: converged" if step["move_to"] is None else
                     f"moves to ({step['move_to'][0]}, {step['move_to'][1]})"))
        frames.append(words(cv.img, "inverse" if inverse else "standard", header))
    last_inverse = base_inv is not None and trace.steps[-1]["phase"] == "inverse"
    cv = _Canvas(base_inv if last_inverse else base_std, r0, c0, zoom)
    _draw_path(cv, trace.steps, n)
    cv.square(trace.start, np.array(_START, np.uint8))
    cv.square(trace.pixel, np.array(_END, np.uint8), filled=not last_inverse)
    frames.append(words(cv.img, "inverse" if last_inverse else "standard",
                        f"result: pixel ({trace.pixel[0]}, {trace.pixel[1]}), score {trace.score:.8f}, "
                        f"{trace.iterations} iterations, {trace.stop}"))
    return frames


def gif_palette() -> np.ndarray:
    """The GIF's one palette, (256, 3) uint8, made once for every frame: the drawing's colours
    (white, ink, the markers, the paths, uncovered grey), 32 greys for the text's edges, and the
    rest the score ramp, so that a colour is the same in every frame."""
    fixed = [_WHITE, _INK, _START, _END, tuple(_GREY), (255, 220, 0), (255, 140, 0), tuple(_PATH["inverse"]),
             _RING, (120, 120, 120)]
    greys = [(int(g),) * 3 for g in np.linspace(0, 255, 32).round()]
    n = 256 - len(fixed) - len(greys)
    t = np.linspace(0.0, 1.0, n) * (len(_RAMP) - 1)
    i = np.minimum(t.astype(int), len(_RAMP) - 2)
    ramp = np.rint((1 - (t - i))[:, None] * _RAMP[i] + (t - i)[:, None] * _RAMP[i + 1])
    return np.concatenate([np.array(fixed + greys, np.float64), ramp]).astype(np.uint8)


def write_trace_gif(path, frames, ms_per_frame: int = 150):
    """Write frames as a looping GIF, atomically, every frame against the one palette of
    :func:`gif_palette` (Pillow's quantizer, no dithering)."""
    from PIL import Image

    from ..io import atomic_path

    pal = Image.new("P", (1, 1))
    pal.putpalette(gif_palette().ravel().tolist())
    ims = [Image.fromarray(np.ascontiguousarray(f)).quantize(palette=pal, dither=Image.Dither.NONE) for f in frames]
    with atomic_path(path, ".gif") as tmp:
        durations = [ms_per_frame] * (len(frames) - 1) + [1500]
        ims[0].save(tmp, format="GIF", save_all=True, append_images=ims[1:], duration=durations, loop=0,
                    optimize=False)


#: A colour per hierarchy level (level 0 first): the popped texels' footprints.
_LEVELS = ((255, 255, 255), (0, 230, 255), (255, 200, 0), (120, 200, 60), (190, 120, 255), (255, 130, 60),
           (60, 140, 255), (0, 160, 130), (200, 80, 160), (150, 150, 40), (90, 90, 200), (120, 70, 40))
_COVERED, _OUTSIDE = (70, 70, 70), (20, 20, 20)


def _footprint(trace, lv, texel):
    """A texel's G-buffer pixels: (row, col, side). Level-0 texels are G-buffer pixels."""
    i, j = texel
    if lv == 0:
        return i, j, 1
    side = 1 << lv
    return trace.origin[0] + i * side, trace.origin[1] + j * side, side


def hierarchy_picture(trace, mask, zoom=None, labelled: bool = False, replay=None, size: int = 512) -> np.ndarray:
    """A hierarchy traversal (:class:`refsoft.search.trace.HierarchyTrace`) over the reflector's
    box of its (H, W) coverage: the footprints of the popped texels, a colour per level (finer
    levels drawn over coarser), the chosen pixel circled in red; magnified ``zoom`` times
    (default: the box about ``size`` pixels wide). (h * zoom, w * zoom, 3) uint8 (larger with
    ``labelled``: title with ``replay``'s scene and vertex, axes, a key per level, :func:`annotate`)."""
    r0, r1, c0, c1 = _crop(mask)
    if zoom is None:
        zoom = int(max(1, min(16, size // max(r1 - r0, c1 - c0))))
    img = np.where(mask[..., None], np.array(_COVERED, np.uint8), np.array(_OUTSIDE, np.uint8)).astype(np.uint8)
    drawn = np.full(mask.shape, -1, np.int64)  # the level each pixel shows
    popped = set()
    for st in trace.steps:
        if st["event"] != "popped":
            continue
        rs, cs, side = _footprint(trace, st["level"], st["texel"])
        drawn[rs:rs + side, cs:cs + side][mask[rs:rs + side, cs:cs + side]] = st["level"]
        popped.add(st["level"])
    for lv in popped:
        img[drawn == lv] = _LEVELS[lv % len(_LEVELS)]
    cv = _Canvas(img[r0:r1, c0:c1], r0, c0, zoom)
    if trace.pixel is not None:
        cv.ring(trace.pixel, np.array(_END, np.uint8))
        cv.ring(trace.pixel, np.array(_END, np.uint8), max(zoom, 7) + 2)
    if not labelled:
        return cv.img
    n_pop = sum(st["event"] == "popped" for st in trace.steps)
    where = "" if replay is None else f"{replay.scene} frame {replay.frame}, vertex {replay.vertex}: "
    title = (f"{where}ray-cone hierarchy, {n_pop} texels popped of {trace.levels} levels, {trace.tests} tests, "
             "chosen " + ("none" if trace.pixel is None else f"({trace.pixel[0]}, {trace.pixel[1]})"))
    shown = set(np.unique(drawn[r0:r1, c0:c1]).tolist())
    key = [(_LEVELS[lv % len(_LEVELS)], f"popped, level {lv} ({1 << lv}x{1 << lv} pixels)"
            + ("" if lv in shown else ", under finer levels" if lv in popped else ", none popped"))
           for lv in range(trace.levels - 1, -1, -1)]
    return annotate(cv.img, title, r0, c0, zoom, None,
                    [(_COVERED, "reflector, not popped"), (_OUTSIDE, "not the reflector")] + key
                    + [(_END, "chosen pixel (circled)")])


def write_trace(out, replay, images=()) -> list:
    """Write a replayed search (:func:`refsoft.search.trace.trace_vertex`) into folder ``out``:
    ``trace.json`` and ``trace.png`` (and ``trace.gif``, one frame per step, for the walk);
    ``images`` (M, 2) every reflection pixel of the vertex, circled on ``trace.png`` when
    there are several. Returns the names written."""
    import os

    from ..io import write_json, write_png

    os.makedirs(out, exist_ok=True)
    write_json(os.path.join(out, "trace.json"), replay.to_dict())
    mask = replay.gbuffer.mask
    if replay.method == "hierarchy":
        write_png(os.path.join(out, "trace.png"), hierarchy_picture(replay.trace, mask, labelled=True,
                                                                      replay=replay))
        return ["trace.json", "trace.png"]
    write_png(os.path.join(out, "trace.png"), trace_picture(replay.trace, mask, labelled=True, replay=replay,
                                                                  images=images))
    write_trace_gif(os.path.join(out, "trace.gif"), trace_frames(replay.trace, mask, labelled=True))
    return ["trace.json", "trace.png", "trace.gif"]

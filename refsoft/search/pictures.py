"""Pictures of one search: the vertex's score field over the reflector with the path drawn
(``trace.png``) and one frame per step (``trace.gif``). NumPy drawing; Pillow writes the words
around it (:func:`annotate`: title, axes in G-buffer pixels, colour bar, legend; in the GIF the
step and its score), so each picture explains itself without plotting library.

Colours: ``-log10(1 - s)`` (how many nines the score has), scaled to its maximum over the
reflector, through a viridis-like ramp, so the optimum stands out; uncovered pixels dark grey; the path white (standard search) or cyan
(inverse search); the start a green square, the end a red one; in the GIF the current
neighbourhood's candidates are outlined in yellow and the chosen one in orange.
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

    def square(self, pix, colour, filled=True):
        """A marker on pixel ``pix``: at least 9 output pixels wide, so it shows at any zoom."""
        cy, cx = self.centre(pix)
        half = max(self.z // 2, 4)
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


def annotate(img, title, r0, c0, zoom, bar=None, legend=(), header=None) -> np.ndarray:
    """``img`` (H, W, 3) uint8, a picture of G-buffer pixels from (r0, c0) magnified ``zoom``
    times, with its words around it: ``title`` above (and ``header``, a second line), the rows
    and columns on the axes, ``bar`` = (lo, hi, label) a colour bar of the ramp on the right,
    ``legend`` [(rgb, text), ...] below. (H', W', 3) uint8; the picture's pixels unchanged."""
    from PIL import Image, ImageDraw

    h, w = img.shape[:2]
    f, small = _font(15), _font(12)
    top = 30 + (20 if header else 0)
    left, right = 48, 110 if bar else 16
    rows_legend = (len(legend) + 1) // 2
    bottom = 36 + 18 * rows_legend
    width = max(left + w + right, 520)
    canvas = Image.new("RGB", (width, top + h + bottom), _WHITE)
    canvas.paste(Image.fromarray(np.ascontiguousarray(img)), (left, top))
    d = ImageDraw.Draw(canvas)
    d.text((8, 6), title, fill=_INK, font=f)
    if header:
        d.text((8, 28), header, fill=_INK, font=small)
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
    d.text((4, top - 16), "row", fill=_INK, font=small)
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


def _nines_max(trace, mask):
    q = np.clip(1.0 - np.nan_to_num(trace.score_map.astype(np.float64), nan=-1.0), 1e-7, 2.0)
    nines = np.maximum(-np.log10(q), 0.0)
    return float(nines[mask].max()) if mask.any() else 1.0


def _legend(trace):
    items = [(_START, f"start ({trace.start[0]}, {trace.start[1]})"),
             (_END, f"end ({trace.pixel[0]}, {trace.pixel[1]})"), ((255, 255, 255), "path, standard search")]
    if any(s["phase"] == "inverse" for s in trace.steps):
        items.append(((0, 230, 255), "path, inverse search"))
    items.append(((40, 40, 46), "not covered"))
    return items


def _title(trace, replay=None):
    where = "" if replay is None else f"{replay.scene} frame {replay.frame}, vertex {replay.vertex}: "
    return (f"{where}score field -log10(1 - s), s = N . bisector; {len(trace.steps)} steps, "
            f"{trace.stop}")


def _setup(trace, mask, size):
    r0, r1, c0, c1 = _crop(mask)
    zoom = int(max(1, min(16, size // max(r1 - r0, c1 - c0))))
    scores = trace.score_map if trace.inverse_map is None else trace.score_map
    base = colour_scores(scores, mask)[r0:r1, c0:c1]
    return base, r0, c0, zoom


def _draw_path(canvas, steps, upto):
    for a, b in zip(steps[:upto], steps[1:upto + 1]):
        canvas.line(a["pixel"], b["pixel"], _PATH[b["phase"]])


def trace_picture(trace, mask, size: int = 512, labelled: bool = False, replay=None) -> np.ndarray:
    """The score field with the whole path, start and end. (H', W', 3) uint8. ``labelled`` adds
    the title, axes, colour bar and legend (:func:`annotate`); ``replay`` names the scene,
    frame and vertex in the title."""
    base, r0, c0, zoom = _setup(trace, mask, size)
    cv = _Canvas(base, r0, c0, zoom)
    _draw_path(cv, trace.steps, len(trace.steps))
    cv.square(trace.start, np.array(_START, np.uint8))
    cv.square(trace.pixel, np.array(_END, np.uint8))
    if not labelled:
        return cv.img
    return annotate(cv.img, _title(trace, replay), r0, c0, zoom, (0.0, _nines_max(trace, mask), "-log10(1-s)"),
                    _legend(trace))


def trace_frames(trace, mask, size: int = 384, max_frames: int = 150, labelled: bool = False) -> list:
    """One picture per step (subsampled to ``max_frames``), then the final picture. ``labelled``
    adds the words of :func:`annotate`, with the step, its pixel and its score above."""
    base, r0, c0, zoom = _setup(trace, mask, size)
    n = len(trace.steps)
    picks = np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(int))
    frames = []
    for k in picks:
        cv = _Canvas(base, r0, c0, zoom)
        _draw_path(cv, trace.steps, k)
        cv.square(trace.start, np.array([40, 220, 60], np.uint8))
        step = trace.steps[k]
        for cand in step["candidates"]:
            if cand["status"] == "evaluated":
                cv.square(cand["pixel"], np.array([255, 220, 0], np.uint8), filled=False)
        if step["move_to"] is not None:
            cv.square(step["move_to"], np.array([255, 140, 0], np.uint8), filled=False)
        if labelled:
            here = step["candidates"][0]["score"]
            header = (f"step {k + 1} of {n}, {step['phase']}, pixel ({step['pixel'][0]}, {step['pixel'][1]}), "
                      f"score {'-' if here is None else f'{here:.8f}'}, "
                      + ("stays: converged" if step["move_to"] is None else
                         f"moves to ({step['move_to'][0]}, {step['move_to'][1]})"))
            frames.append(annotate(cv.img, _title(trace), r0, c0, zoom, (0.0, _nines_max(trace, mask), "-log10(1-s)"),
                                   _legend(trace) + [((255, 220, 0), "candidates"), ((255, 140, 0), "moved to")],
                                   header))
        else:
            frames.append(cv.img)
    if labelled:
        last = trace_picture(trace, mask, size)
        frames.append(annotate(last, _title(trace), r0, c0, zoom, (0.0, _nines_max(trace, mask), "-log10(1-s)"),
                               _legend(trace) + [((255, 220, 0), "candidates"), ((255, 140, 0), "moved to")],
                               f"result: pixel ({trace.pixel[0]}, {trace.pixel[1]}), score {trace.score:.8f}, "
                               f"{trace.iterations} iterations, {trace.stop}"))
    else:
        frames.append(trace_picture(trace, mask, size))
    return frames


def write_trace_gif(path, frames, ms_per_frame: int = 150):
    """Write frames as a looping GIF, atomically."""
    import imageio.v3 as iio

    from ..io import atomic_path

    with atomic_path(path, ".gif") as tmp:
        durations = [ms_per_frame] * (len(frames) - 1) + [1500]
        iio.imwrite(tmp, np.stack(frames), extension=".gif", duration=durations, loop=0)


def hierarchy_picture(trace, mask, zoom: int = 2, labelled: bool = False) -> np.ndarray:
    """A hierarchy traversal (:class:`refsoft.search.trace.HierarchyTrace`) over the reflector's
    (H, W) coverage: the footprints of the popped texels (finer levels brighter), the chosen
    pixel red; magnified ``zoom`` times. (H * zoom, W * zoom, 3) uint8 (larger with
    ``labelled``: title, axes, legend, :func:`annotate`)."""
    img = np.where(mask[..., None], 70, 0).astype(np.uint8) * np.ones(3, np.uint8)
    r0, c0 = trace.origin
    for st in trace.steps:
        if st["event"] != "popped":
            continue
        lv, (i, j) = st["level"], st["texel"]
        side = 1 << lv
        shade = int(90 + 150 * (1 - lv / max(trace.levels - 1, 1)))
        rs, cs = r0 + i * side, c0 + j * side
        region = img[rs:rs + side, cs:cs + side]
        region[mask[rs:rs + side, cs:cs + side]] = (0, shade, shade)
    if trace.pixel is not None:
        img[trace.pixel[0], trace.pixel[1]] = (255, 0, 0)
    big = np.repeat(np.repeat(img, zoom, axis=0), zoom, axis=1)
    if not labelled:
        return big
    n_pop = sum(st["event"] == "popped" for st in trace.steps)
    title = (f"ray-cone hierarchy: {n_pop} texels popped of {trace.levels} levels, {trace.tests} tests, chosen "
             + ("none" if trace.pixel is None else f"({trace.pixel[0]}, {trace.pixel[1]})"))
    return annotate(big, title, 0, 0, zoom, None,
                    [((70, 70, 70), "reflector (covered)"), ((0, 240, 240), "popped, finest level"),
                     ((0, 90, 90), "popped, coarsest level"), ((255, 0, 0), "chosen pixel")])


def write_trace(out, replay) -> list:
    """Write a replayed search (:func:`refsoft.search.trace.trace_vertex`) into folder ``out``:
    ``trace.json`` and ``trace.png`` (and ``trace.gif``, one frame per step, for the walk).
    Returns the names written."""
    import os

    from ..io import write_json, write_png

    os.makedirs(out, exist_ok=True)
    write_json(os.path.join(out, "trace.json"), replay.to_dict())
    mask = replay.gbuffer.mask
    if replay.method == "hierarchy":
        write_png(os.path.join(out, "trace.png"), hierarchy_picture(replay.trace, mask, labelled=True))
        return ["trace.json", "trace.png"]
    write_png(os.path.join(out, "trace.png"), trace_picture(replay.trace, mask, labelled=True, replay=replay))
    write_trace_gif(os.path.join(out, "trace.gif"), trace_frames(replay.trace, mask, labelled=True))
    return ["trace.json", "trace.png", "trace.gif"]

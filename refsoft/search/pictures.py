"""Pictures of one search: the vertex's score field over the reflector with the path drawn
(``trace.png``) and one frame per step (``trace.gif``). Plain NumPy drawing, no plotting library.

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


def _setup(trace, mask, size):
    r0, r1, c0, c1 = _crop(mask)
    zoom = int(max(1, min(16, size // max(r1 - r0, c1 - c0))))
    scores = trace.score_map if trace.inverse_map is None else trace.score_map
    base = colour_scores(scores, mask)[r0:r1, c0:c1]
    return base, r0, c0, zoom


def _draw_path(canvas, steps, upto):
    for a, b in zip(steps[:upto], steps[1:upto + 1]):
        canvas.line(a["pixel"], b["pixel"], _PATH[b["phase"]])


def trace_picture(trace, mask, size: int = 512) -> np.ndarray:
    """The score field with the whole path, start and end. (H', W', 3) uint8."""
    base, r0, c0, zoom = _setup(trace, mask, size)
    cv = _Canvas(base, r0, c0, zoom)
    _draw_path(cv, trace.steps, len(trace.steps))
    cv.square(trace.start, np.array([40, 220, 60], np.uint8))
    cv.square(trace.pixel, np.array([230, 30, 30], np.uint8))
    return cv.img


def trace_frames(trace, mask, size: int = 384, max_frames: int = 150) -> list:
    """One picture per step (subsampled to ``max_frames``), then the final picture."""
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
        frames.append(cv.img)
    frames.append(trace_picture(trace, mask, size))
    return frames


def write_trace_gif(path, frames, ms_per_frame: int = 150):
    """Write frames as a looping GIF, atomically."""
    import imageio.v3 as iio

    from ..io import atomic_path

    with atomic_path(path, ".gif") as tmp:
        durations = [ms_per_frame] * (len(frames) - 1) + [1500]
        iio.imwrite(tmp, np.stack(frames), extension=".gif", duration=durations, loop=0)


def hierarchy_picture(trace, mask, zoom: int = 2) -> np.ndarray:
    """A hierarchy traversal (:class:`refsoft.search.trace.HierarchyTrace`) over the reflector's
    (H, W) coverage: the footprints of the popped texels (finer levels brighter), the chosen
    pixel red; magnified ``zoom`` times. (H * zoom, W * zoom, 3) uint8."""
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
    return np.repeat(np.repeat(img, zoom, axis=0), zoom, axis=1)


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
        write_png(os.path.join(out, "trace.png"), hierarchy_picture(replay.trace, mask))
        return ["trace.json", "trace.png"]
    write_png(os.path.join(out, "trace.png"), trace_picture(replay.trace, mask))
    write_trace_gif(os.path.join(out, "trace.gif"), trace_frames(replay.trace, mask))
    return ["trace.json", "trace.png", "trace.gif"]

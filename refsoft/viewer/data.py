"""What ``trace.html`` embeds: one search as plain JSON-ready data (:func:`walk_data`,
:func:`hierarchy_data`, :func:`ldt_data`), in one shape the page's script draws whatever the
search.

The shape (every field plain lists, numbers, strings, ``None``):

- ``kind`` "walk", "hierarchy" or "ldt"; ``title``; ``meta`` [[name, value], ...];
- ``grids``: heat maps, each ``{"title", "label", "formula", "transform", "r0", "c0", "h", "w",
  "values"}``: ``values`` row by row, ``h * w`` numbers or ``None`` (not covered), for the
  pixels ``r0 .. r0 + h - 1``, ``c0 .. c0 + w - 1``; ``transform`` "nines" (drawn as
  ``-log10(1 - v)``) or "linear"; ``empty`` when no pixel holds a value;
- ``columns``: the table's candidate column names; ``label_column``: what a step's ``label`` is
  (None when it repeats the phase), ``last_column``: what a step's ``note`` (or its move) is;
- ``legend``: the heat map's marks in words, for this kind of search;
- ``steps``: in order, each ``{"grid", "label", "phase", "pixel", "rect", "cells", "chosen",
  "side"}``: the grid it is drawn on, its ``label`` (the phase for a walk; the texel or sample
  otherwise), the pixel [row, col] (or ``rect`` [row, col, height, width]
  for a hierarchy texel), ``cells`` (one per column: ``{"name", "pixel", "status", "value",
  "text"}``), the index of the cell moved to (or ``None``), and the pixel's point in the side
  view (or ``None``);
- ``start``, ``end``: pixels; ``images``: every reflection pixel found (several images), or [];
- ``side``: the side view, ``{"caption", "points": [{"name", "xy", "far"}], "arrows": [{"name",
  "from", "dir"}], "rays": [[a, b], ...], "line": [[x, y], [x, y]] or None}`` in the plane of the
  eye ray and the vertex (a ``far`` point is drawn at the view's edge, in its direction from P);
- ``stop``: the stop reason in words; ``result``: lines of text.
"""

from __future__ import annotations

import numpy as np

from ..constants import VIEWER_MAX_GRID_PIXELS
from ..errors import RefsoftError

#: The vertex search's score (docs/method.md, "The search").
SCORE_FORMULA = "s(p) = N · normalize(normalize(O − P) + normalize(V − P)); colour: −log10(1 − s), the score's nines"
INVERSE_FORMULA = ("inverse score: the score with the vertex's role and the eye's swapped (the vertex behind the "
                   "tangent plane); colour: −log10(1 − s)")
LDT_FORMULA = ("h(s) = depth of the ray's point at s from the face's plane; a sample is inside layer j when "
               "z_j ≤ h ≤ d_j; colour: layer 0's front depth z_0")

_FLAG_WORDS = {
    "HIDDEN": "the vertex is behind the reflector's tangent plane at the pixel the walk reached (HIDDEN): "
              "the inverse treatment applies",
    "BORDER": "the reflection pixel is on the border of the reflector's covered pixels (BORDER): the true "
              "reflection point may lie beyond the silhouette",
    "CAPPED": "the walk reached the iteration cap while still moving (CAPPED)",
    "RESTARTED": "the previous frame's pixel was no longer covered, so the walk restarted from the centre "
                 "(RESTARTED)",
    "CULLED": "the vertex was culled before the search (CULLED)",
}


def _num(x):
    """A float for JSON: 9 significant digits (what the page shows), None for NaN."""
    x = float(x)
    return None if not np.isfinite(x) else float(f"{x:.9g}")


def _grid(values, mask, box, title, label, formula, transform) -> dict:
    """A heat map of ``values`` (H, W) over ``box`` (r0, r1, c0, c1), None where ``mask`` is False;
    subsampled by a whole stride when larger than VIEWER_MAX_GRID_PIXELS."""
    r0, r1, c0, c1 = box
    sub = np.asarray(values, dtype=np.float64)[r0:r1, c0:c1]
    m = np.asarray(mask, dtype=bool)[r0:r1, c0:c1]
    flat = [None if not ok else _num(v) for v, ok in zip(sub.ravel(), m.ravel())]
    if len(flat) > VIEWER_MAX_GRID_PIXELS:
        raise RefsoftError(f"the heat map would hold {len(flat)} pixels, more than the viewer's "
                           f"{VIEWER_MAX_GRID_PIXELS}: trace at a smaller --width/--height")
    return {"title": title, "label": label, "formula": formula, "transform": transform, "empty": not m.any(),
            "r0": int(r0),
            "c0": int(c0), "h": int(r1 - r0), "w": int(c1 - c0), "values": flat}


def _box(mask, margin=3):
    rows, cols = np.nonzero(mask)
    h, w = mask.shape
    if len(rows) == 0:
        return 0, h, 0, w
    return (max(int(rows.min()) - margin, 0), min(int(rows.max()) + margin + 1, h),
            max(int(cols.min()) - margin, 0), min(int(cols.max()) + margin + 1, w))


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    n = float(np.sqrt(v @ v))
    return v / n if n > 0 else v


class _Plane:
    """2-D coordinates in the plane through P spanned by ``a`` and ``b``: ``up`` along the normal's
    part in the plane, ``right`` across it."""

    def __init__(self, P, a, b, N):
        self.P = np.asarray(P, dtype=np.float64)
        e1 = _unit(a)
        e2 = np.asarray(b, dtype=np.float64) - (np.asarray(b, dtype=np.float64) @ e1) * e1
        e2 = _unit(e2) if float(e2 @ e2) > 1e-24 else _unit(np.cross(e1, [0.0, 0.0, 1.0]))
        n = np.asarray(N, dtype=np.float64)
        inplane = (n @ e1) * e1 + (n @ e2) * e2
        self.up = _unit(inplane) if float(inplane @ inplane) > 1e-24 else e1
        self.right = _unit(np.cross(np.cross(e1, e2), self.up))
        self.out_deg = float(np.degrees(np.arcsin(min(1.0, abs(_unit(n) @ _unit(np.cross(e1, e2)))))))

    def xy(self, X):
        d = np.asarray(X, dtype=np.float64) - self.P
        return [_num(d @ self.right), _num(d @ self.up)]

    def dir(self, D):
        d = np.asarray(D, dtype=np.float64)
        return [_num(d @ self.right), _num(d @ self.up)]


# --- the vertex search -------------------------------------------------------------------------
def _world(gbuffer, pix):
    r, c = int(pix[0]), int(pix[1])
    P = np.asarray(gbuffer.position[r, c], dtype=np.float64) + np.asarray(gbuffer.origin, dtype=np.float64)
    return P, _unit(gbuffer.normal[r, c])


def _vertex_side(gbuffer, eye, vertex, end, rule_note="", stopped=None):
    """The side view of a vertex search ending at pixel ``end``, and its plane; ``stopped``:
    "border" or "capped" when the search ended there for that reason."""
    E, V = np.asarray(eye, np.float64), np.asarray(vertex, np.float64)
    P, N = _world(gbuffer, end)
    pl = _Plane(P, E - P, V - P, N)
    B = _unit(_unit(E - P) + _unit(V - P))
    virtual = V - 2.0 * ((V - P) @ N) * N
    side = {"caption": _side_caption(pl, N, B, float((V - P) @ N), stopped, rule_note),
            "points": [{"name": "eye O", "xy": pl.xy(E)}, {"name": "vertex V", "xy": pl.xy(V)},
                       {"name": "reflection point P", "xy": pl.xy(P)},
                       {"name": "virtual vertex V'", "xy": pl.xy(virtual)}],
            "arrows": [{"name": "normal N", "from": pl.xy(P), "dir": pl.dir(N)},
                       {"name": "bisector B", "from": pl.xy(P), "dir": pl.dir(B)}],
            "rays": [[pl.xy(E), pl.xy(P)], [pl.xy(P), pl.xy(V)], [pl.xy(P), pl.xy(virtual)]],
            "line": [pl.xy(P - 10.0 * pl.right), pl.xy(P + 10.0 * pl.right)]}
    return side, pl


def _side_caption(pl, N, B, height, stopped=None, rule_note="") -> str:
    """The side view's words for its case: a hidden vertex (behind the tangent plane: N and B
    cannot coincide), a search stopped on the border or by the cap, or a reflection pixel (N and
    B coincide to the pixel grid's precision)."""
    apart = float(np.degrees(np.arccos(np.clip(_unit(N) @ _unit(B), -1.0, 1.0))))
    head = (f"The plane of the eye ray and the vertex, through the pixel P the search ended at. The normal N leaves "
            f"this plane by {pl.out_deg:.2f}°. ")
    mirrored = "V' is V mirrored across the tangent plane at P"
    if height < 0.0:
        body = (f"The vertex V is behind the tangent plane at P (HIDDEN): no point of the surface's side facing the "
                f"eye reflects it, so N and the bisector B of the eye and V do not coincide (they are {apart:.1f}° "
                f"apart); {mirrored}, on the eye's side of that plane")
    elif stopped == "border":
        body = (f"The search stopped on the reflector's border (BORDER), N and the bisector B {apart:.1f}° apart: "
                f"the true reflection point may lie beyond the silhouette; {mirrored}")
    elif stopped == "capped":
        body = (f"The walk was capped while still moving (CAPPED), N and the bisector B {apart:.1f}° apart; "
                f"{mirrored}")
    else:
        body = (f"P is the reflection pixel: N and the bisector B coincide to the pixel grid's precision "
                f"({apart:.2f}° apart: the exact reflection point lies between pixel centres); {mirrored}")
    return head + body + f"{rule_note}."


def _stop_walk(trace) -> str:
    from ..search import flag_names

    nb = "crosshair (4 neighbours)" if trace.neighbourhood == "cross" else "3x3 box (8 neighbours)"
    r, c = trace.pixel
    if trace.stop == "capped":
        words = f"Capped: after {trace.iterations} iterations (the cap is {trace.cap}) the walk was still moving."
    else:
        words = (f"Converged: no neighbour in the {nb} of pixel ({r}, {c}) scores strictly higher than it "
                 f"(score {trace.score:.8f}, margin to the second best {trace.margin:.3g}).")
    extra = [_FLAG_WORDS[n] for n in flag_names(trace.flags) if n in _FLAG_WORDS and n != "CAPPED"]
    return words + ("" if not extra else " Also: " + "; ".join(extra) + ".")


def _walk_legend(inverse, images) -> str:
    return ("Path: white the standard search" + (", cyan the inverse search (its steps drawn on the inverse "
                                                  "score's map)" if inverse else "")
            + "; start green, end red; the current step's pixel white, its candidates yellow, the one moved to "
              "orange; magenta: the pixel under the pointer, or the table cell under it"
            + ("; pink circles: every reflection point found." if images else "."))


def walk_data(replay, images=None) -> dict:
    """The page's data for a walk (:class:`refsoft.search.trace.VertexReplay` with a
    :class:`~refsoft.search.trace.Trace`). ``images``: optional (M, 2) reflection pixels of the
    vertex (several images), drawn as markers."""
    tr, gb = replay.trace, replay.gbuffer
    mask = gb.mask
    box = _box(mask)
    grids = [_grid(tr.score_map, mask, box, "standard score s", "−log10(1 − s)", SCORE_FORMULA, "nines")]
    if tr.inverse_map is not None:
        grids.append(_grid(tr.inverse_map, mask, box, "inverse score", "−log10(1 − s)", INVERSE_FORMULA, "nines"))
    from ..search import flag_names

    named = flag_names(tr.flags)
    stopped = "capped" if tr.stop == "capped" else "border" if "BORDER" in named else None
    side, pl = _vertex_side(gb, tr.eye, tr.vertex, tr.pixel, stopped=stopped)
    n_cand = 5 if tr.neighbourhood == "cross" else 9
    steps = []
    for i, s in enumerate(tr.steps, 1):
        cells = [{"name": c["name"], "pixel": c["pixel"], "status": c["status"],
                  "value": None if c["score"] is None else _num(c["score"]),
                  "text": c["status"] if c["score"] is None else f"{c['score']:.8f}"} for c in s["candidates"]]
        chosen = None if s["move_to"] is None else [c["pixel"] for c in s["candidates"]].index(s["move_to"])
        P, N = _world(gb, s["pixel"])
        steps.append({"grid": 0 if s["phase"] == "standard" or len(grids) == 1 else 1, "label": s["phase"],
                      "phase": s["phase"], "pixel": list(s["pixel"]), "rect": None, "cells": cells,
                      "chosen": chosen, "side": {"xy": pl.xy(P), "normal": pl.dir(N)}})
    from ..search import flag_names

    every = [] if images is None else [[int(a), int(b)] for a, b in np.asarray(images).reshape(-1, 2)]
    found = [] if images is None else [f"every image: {len(every)} found" + (": " if every else "")
                                       + ", ".join(f"({r}, {c})" for r, c in every) + " (circled in pink)"]
    return {"kind": "walk", "title": f"Vertex {replay.vertex} in reflector {replay.reflector}, {replay.scene} frame "
                                     f"{replay.frame}: the walk",
            "meta": [["scene", replay.scene], ["frame", replay.frame], ["reflector", replay.reflector],
                     ["vertex", f"{replay.vertex} (object {replay.vertex_object}, its vertex {replay.local_index})"],
                     ["neighbourhood", tr.neighbourhood], ["inverse", tr.inverse], ["cap", tr.cap],
                     ["start", f"({tr.start[0]}, {tr.start[1]})" + (" after a restart" if tr.restarted else "")]],
            "grids": grids, "columns": [c["name"] for c in tr.steps[0]["candidates"]] if tr.steps else [],
            "label_column": None, "last_column": "move", "legend": _walk_legend(len(grids) > 1, bool(every)),
            "n_candidates": n_cand, "steps": steps, "start": list(tr.start), "end": list(tr.pixel),
            "images": every, "side": side, "stop": _stop_walk(tr),
            "result": [f"pixel ({tr.pixel[0]}, {tr.pixel[1]}), score {tr.score:.8f}, margin {tr.margin:.3g}, "
                       f"{tr.iterations} iterations, flags: {', '.join(flag_names(tr.flags)) or 'none'}"] + found}


def _score_field(gbuffer, eye, vertex):
    """The standard score of ``vertex`` at every covered pixel (NaN elsewhere), (H, W), by the
    search's own kernel."""
    from .._parallel import parallel_range
    from ..search import _kernels, _packed

    G, M, fp, (r0, c0) = _packed(gbuffer, np.asarray(eye, np.float64))
    dt = gbuffer.position.dtype.type
    out = np.full(gbuffer.mask.shape, np.nan, dtype=dt)
    v_rel = (np.asarray(vertex, np.float64) - gbuffer.origin).astype(dt)
    parallel_range(_kernels.score_field, M.shape[0], G, M, v_rel, False, fp,
                   out[r0:r0 + M.shape[0], c0:c0 + M.shape[1]])
    return out


def hierarchy_data(replay, eye, vertex) -> dict:
    """The page's data for a ray-cone hierarchy traversal (a replay whose ``trace`` is a
    :class:`~refsoft.search.trace.HierarchyTrace`); ``eye`` and ``vertex`` (3,) world space.
    A step per texel popped (its footprint a ``rect``; its children's tests its cells), then
    the chosen pixel."""
    tr, gb = replay.trace, replay.gbuffer
    mask = gb.mask
    box = _box(mask)
    grids = [_grid(_score_field(gb, eye, vertex), mask, box, "standard score s (for orientation)", "−log10(1 − s)",
                   SCORE_FORMULA, "nines")]
    end = tr.pixel if tr.pixel is not None else list(np.argwhere(mask)[0])
    side, pl = _vertex_side(gb, eye, vertex, end)
    r0, c0 = tr.origin
    steps, width = [], 1
    for st in tr.steps:
        lv, (i, j) = st["level"], st["texel"]
        if lv == 0:
            rect = [i, j, 1, 1]
        else:
            side_px = 1 << lv
            rect = [r0 + i * side_px, c0 + j * side_px, side_px, side_px]
        if st["event"] in ("popped", "chosen"):
            centre = [rect[0] + rect[2] // 2, rect[1] + rect[3] // 2]
            what = ((f"L{lv} ({i}, {j})" if st["event"] == "popped" else f"pixel ({i}, {j})")
                    + ("" if st["attempt"] == 0 else f", pass {st['attempt'] + 1}"))
            steps.append({"grid": 0, "label": what, "phase": st["event"], "pixel": centre,
                          "rect": rect, "cells": [], "chosen": None, "side": None,
                          "note": "the result" if st["event"] == "chosen" else "none tested"})
        elif steps:
            steps[-1]["cells"].append({"name": f"L{lv} ({i}, {j})", "pixel": [rect[0] + rect[2] // 2,
                                                                               rect[1] + rect[3] // 2],
                                       "status": st["event"], "value": None, "text": st["event"], "rect": rect})
            width = max(width, len(steps[-1]["cells"]))
            pushed = sum(c["status"] == "pushed" for c in steps[-1]["cells"])
            steps[-1]["note"] = f"{pushed} of {len(steps[-1]['cells'])} pushed"
    n_pop = sum(s["phase"] == "popped" for s in steps)
    n_chosen = len(steps) - n_pop
    stop = (f"Chosen: pixel ({tr.pixel[0]}, {tr.pixel[1]}) after {tr.tests} texel tests, the best base pixel "
            "whose cones contain the vertex." if tr.pixel is not None else
            f"No pixel: after {tr.tests} texel tests no texel's cone contains the vertex.")
    return {"kind": "hierarchy", "title": f"Vertex {replay.vertex} in reflector {replay.reflector}, {replay.scene} "
                                          f"frame {replay.frame}: the ray-cone hierarchy",
            "meta": [["scene", replay.scene], ["frame", replay.frame], ["reflector", replay.reflector],
                     ["vertex", replay.vertex], ["levels", tr.levels], ["base", f"{tr.base_size}x{tr.base_size} "
                                                                                  f"at ({r0}, {c0})"]],
            "grids": grids, "columns": [f"child {k + 1}" for k in range(width)], "n_candidates": width,
            "label_column": "texel", "last_column": "children pushed",
            "legend": (f"The current texel outlined white, those popped before it faint white; its children tested: "
                       f"yellow pushed (the cone contains the vertex), grey rejected; the green dot: the first texel "
                       f"popped (the top level, L{tr.levels - 1}); red: the chosen pixel. Levels: L0 is one pixel, "
                       f"L{tr.levels - 1} {1 << (tr.levels - 1)}x{1 << (tr.levels - 1)} pixels; a texel of level l "
                       f"covers 2^l x 2^l pixels; pass 2 and on: the traversal again with its cones and spheres "
                       f"enlarged, after a pass reached no base pixel. The map: the standard score, for orientation."),
            "steps": steps, "start": steps[0]["pixel"] if steps else list(end), "end": list(end), "images": [],
            "side": side, "stop": stop,
            "result": [f"{tr.tests} texel tests, {n_pop} texels popped"
                       + (", then the chosen pixel" if n_chosen else ", no pixel chosen")]}


# --- the LDT pixel search ----------------------------------------------------------------------
def ldt_data(trace) -> dict:
    """The page's data for one pixel's LDT search (:class:`refsoft.ldt.trace.PixelTrace`): a grid
    per face searched (layer 0's front depth), a step per linear sample and bisection point, the
    layers visited as its cells."""
    from ..ldt.trace import FACE_NAMES, _decision, flag_names

    stack = trace.stack
    grids, steps = [], []
    width = 1
    for o in trace.objects:
        for fc in o["faces"]:
            k, f = o["index"], fc["face"]
            R = stack.resolution
            cnt = stack.count[k, f] > 0
            depth = np.where(cnt, stack.depth[k, f, 0], np.nan)
            g = len(grids)
            grids.append(_grid(depth, cnt, (0, R, 0, R), f"object {o['id']} ({trace.name(o['id'])}), face "
                               f"{fc['name']}: layer 0's z", "z_0 (0 at the face's plane)", LDT_FORMULA, "linear"))
            for smp in fc["samples"]:
                cells = [{"name": f"layer {v['layer']}", "pixel": smp["texel"], "status": v["test"], "value": v["z"],
                          "text": f"z {v['z']:.6f}" + ("" if v["d"] is None else f", d {v['d']:.6f}")
                          + f": {v['test']}"} for v in smp["layers"]]
                width = max(width, len(cells))
                hit = [i for i, v in enumerate(smp["layers"]) if v["test"] == "inside"]
                steps.append({"grid": g, "label": f"face {fc['name']} sample {smp['m']}", "phase": "linear",
                              "pixel": list(smp["texel"]), "rect": None, "cells": cells,
                              "chosen": hit[0] if hit else None, "note": _decision(smp), "s": smp["s"]})
            if fc["bisection"] is not None:
                for b, pt in enumerate(fc["bisection"]["points"], 1):
                    cells = [] if pt["z"] is None else [{"name": f"layer {fc['layer']}", "pixel": pt["texel"],
                                                         "status": "inside" if pt["inside"] else "outside",
                                                         "value": pt["z"], "text": f"z {pt['z']:.6f}, d {pt['d']:.6f}"}]
                    steps.append({"grid": g, "label": f"face {fc['name']} bisection {b}", "phase": "bisection",
                                  "pixel": list(pt["texel"]), "rect": None, "cells": cells,
                                  "chosen": 0 if pt["inside"] else None,
                                  "note": "inside" if pt["inside"] else "outside",
                                  "s": pt["s"]})
    ray, res = trace.ray, trace.result
    P, N, r = (np.asarray(ray[k], np.float64) for k in ("origin", "normal", "direction"))
    I = np.asarray(ray["incident"], np.float64)
    pl = _Plane(P, -I, N, N)
    E = np.asarray(ray["eye"], np.float64) if ray["eye"] is not None else P - I * 2.0
    # the drawn ray reaches the hit (or 2 without one) and at least the last sample
    reach = max([res["distance"] if res["object"] >= 0 else 2.0] + [st["s"] for st in steps])
    # an eye much farther than the reflected ray reaches is drawn at the view's edge, in its direction
    far = bool(np.linalg.norm(E - P) > 4.0 * reach)
    pts = [{"name": "eye O" if ray["eye"] is not None else "towards the eye", "xy": pl.xy(E), "far": far},
           {"name": "reflector point P", "xy": pl.xy(P)}]
    if res["object"] >= 0:
        pts.append({"name": f"hit on object {res['object_id']}", "xy": pl.xy(np.asarray(res["hit"], np.float64))})
    for st in steps:
        st["side"] = {"xy": pl.xy(P + st.pop("s") * r), "normal": None}
    side = {"caption": "The plane of the eye ray and the normal at the reflector pixel: the reflected ray r leaves "
                       "P (drawn to the hit, or at least to the last sample); the current step's sample, the point P + s r, "
                       "is the orange circle on it.",
            "points": pts, "arrows": [{"name": "normal N", "from": pl.xy(P), "dir": pl.dir(N)},
                                      {"name": "reflected r", "from": pl.xy(P), "dir": pl.dir(r)}],
            "rays": [[pl.xy(E), pl.xy(P)], [pl.xy(P), pl.xy(P + reach * r)]],
            "line": [pl.xy(P - 10.0 * pl.right), pl.xy(P + 10.0 * pl.right)]}
    named = ", ".join(flag_names(res["flags"])) or "none"
    if res["object"] < 0:
        stop = "No hit: no object's faces hold a layer the ray enters; the pixel keeps the reflector's own colour."
    else:
        stop = (f"Hit: object {res['object_id']} ({trace.name(res['object_id'])}) at t {res['distance']:.7g}, face "
                f"{FACE_NAMES[res['face']]} layer {res['layer']}, residual {res['residual']:.4g} texels against "
                f"tau {trace.options['tau']:g}.")
    o = trace.options
    return {"kind": "ldt", "title": f"Pixel ({trace.pixel[0]}, {trace.pixel[1]}) of reflector {trace.reflector}, "
                                    f"{trace.scene} frame {trace.frame}: the layered depth textures",
            "meta": [["scene", trace.scene], ["frame", trace.frame], ["pixel", f"({trace.pixel[0]}, {trace.pixel[1]})"],
                     ["reflector", f"{trace.reflector} ({trace.name(trace.reflector)})"]]
            + [[k, o[k]] for k in ("resolution", "layers", "faces", "linear", "tau", "regions", "precision")],
            "grids": grids, "columns": [f"layer {j}" for j in range(width)], "n_candidates": width, "steps": steps,
            "label_column": "sample", "last_column": "decision",
            "legend": ("Each face's map: layer 0's front depth z_0 (grey: no texel there). The current sample's texel "
                       "outlined white, yellow while its layers are tested, orange when the ray is inside a layer; "
                       "the samples' path white (linear) and orange (bisection), the first sample green, the last "
                       "red. Side view: the reflected ray r from P, the current sample an orange circle on it."),
            "start": steps[0]["pixel"] if steps else [0, 0], "end": steps[-1]["pixel"] if steps else [0, 0],
            "images": [], "side": side, "stop": stop,
            "result": [f"{res['linear_samples']} linear samples, {res['binary_steps']} bisection steps, "
                       f"flags: {named}"]}

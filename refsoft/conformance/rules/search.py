"""``refsoft check``'s rules of the reflection-point search (kinds ``pixel``, ``flags``,
``vertex_object``, ``iterations``, ``score``, ``margin``, ``trace``; spec section 8).

- ``reflection_pixel_K``: identical; a differing pixel is a tie when the oracle's scores
  (rebuilt with its own arithmetic on the G-buffer judged, :func:`refsoft.search.scores_at`) of
  both pixels differ by at most ``K * 2^-24 * (1 + 1 / |U + B|)``, ``U`` and ``B`` the unit
  directions the score adds at the oracle's pixel (:func:`refsoft.conformance.precision.tie_bound`;
  K = 8, the ``gpu`` profile's 52); more than 1% ties fail;
- ``flags_K``, ``vertex_object_K``: identical where the pixels agree (the bit SEVERAL left out
  when the candidate declares the kind ``images`` not ported); ``iterations_K`` likewise
  up to 1% of the vertices; ``score_K`` by the float rule (``gpu``: within half the tie bound);
  ``margin_K``: shape, dtype and non-finite places only;
- traces (``traces_NNNN.json``, optional: never missing): every supplied walk follows the
  oracle's (:func:`oracle_trace`), the first step where one parts is named.

Under a profile with ``own_gbuffer``, everything is judged against the oracle's search on the
candidate's own G-buffer (:func:`refsoft.conformance.stages.reference_frame`), plus what saving
positions as world-space float32 may change (:func:`refsoft.conformance.stages.saved_rounding`).
"""

from __future__ import annotations

import os

import numpy as np

from ... import constants, keys
from ...constants import ITERATION_SHARE_MAX, TIE_SHARE_MAX
from ...errors import InputFileError
from ..stages import saved_rounding
from .common import compare_float_field, mark, where

KINDS = ("pixel", "flags", "vertex_object", "iterations", "score", "margin", "trace")
#: Per-reflector names -> kind (the virtual vertices are :mod:`.virtual`'s).
NAMES = {keys.REFLECTION_PIXEL: "pixel", keys.FLAGS: "flags", keys.VERTEX_OBJECT: "vertex_object",
         keys.ITERATIONS: "iterations", keys.SCORE: "score", keys.MARGIN: "margin"}


def kind_of(key: str):
    if key.startswith("traces_"):
        return "trace"
    p = keys.parse(key)
    return NAMES.get(p[0]) if p is not None else None


def vertex_reference(ctx, k, G):
    """The golden frame with reflector ``k``'s per-vertex arrays replaced by ``ctx.reference``'s
    when the oracle was run on the candidate's inputs, and the starts of its coherent searches:
    ``(G, previous pixels or None)``."""
    prev = ctx.previous.get(k) if ctx.previous else None
    if ctx.reference is None:
        return G, prev
    G = {**G, **{name(k): ctx.reference[name(k)] for name in keys.VERTEX_ARRAYS if name(k) in ctx.reference}}
    return G, ctx.reference_starts.get(k)


def agreement(ctx, k, G):
    """Reflector ``k``'s ``(live, agree, tie)`` (N,) bool: the vertices not culled, those whose
    pixels agree, the ties; as judged by :func:`judge_reflector` when it did (``ctx.agreement``),
    else every live pixel agreeing."""
    from ...search import CULLED

    if k in ctx.agreement:
        return ctx.agreement[k]
    live = (G[keys.FLAGS(k)] & CULLED) == 0
    return live, live, np.zeros(len(live), dtype=bool)


def load_traces(path):
    """A candidate's ``traces_NNNN.json`` as ``{reflector: {vertex: record}}``, or None when the
    candidate supplies none. Each record needs an integer ``vertex`` and a ``path`` of pixels
    (``[row, col]``, or ``[level, row, col]`` for the hierarchy)."""
    from ...io import read_json

    if not os.path.exists(path):
        return None
    t = read_json(path, required=("reflectors",))
    if not isinstance(t["reflectors"], dict):
        raise InputFileError(f"{path}: 'reflectors' must map reflector ids to lists of records")
    out = {}
    for k, records in t["reflectors"].items():
        if not k.isdigit() or not isinstance(records, list):
            raise InputFileError(f"{path}: reflectors[{k!r}] must be a list of records under a reflector id")
        out[int(k)] = {}
        for j, rec in enumerate(records):
            where = f"{path}: reflectors[{k!r}][{j}]"
            if not isinstance(rec, dict) or "vertex" not in rec:
                raise InputFileError(f"{where} lacks 'vertex'")
            if not isinstance(rec["vertex"], int) or isinstance(rec["vertex"], bool):
                raise InputFileError(f"{where}.vertex must be an integer")
            p = rec.get("path", [])
            if not isinstance(p, list) or not all(isinstance(s, list) and len(s) in (2, 3) and all(
                    isinstance(x, int) and not isinstance(x, bool) for x in s) for s in p):
                raise InputFileError(f"{where}.path must be a list of [row, col] (or [level, row, col]) integers")
            out[int(k)][rec["vertex"]] = rec
    return out


def oracle_trace(ctx, k, i, prev_pixel):
    from ...search import trace_search

    o = ctx.oracle()
    opts = o.case.options
    gb = ctx.stage_gbuffer(k)
    if opts.get("method") == "hierarchy":
        from ...search import trace_hierarchy

        return trace_hierarchy(gb, o.scene.camera_at(ctx.frame).eye, o.verts[i], cap=opts.get("cap")).path()
    tr = trace_search(gb, o.scene.camera_at(ctx.frame).eye, o.verts[i], opts.get("neighbourhood", "cross"),
                      opts.get("inverse", "plane"), prev_pixel, opts.get("cap"))
    return [[int(x) for x in s["pixel"]] for s in tr.steps]


def first_divergence(expected, observed):
    for j, (a, b) in enumerate(zip(expected, observed)):
        if list(a) != list(b):
            return j, a, b
    if len(expected) != len(observed):
        j = min(len(expected), len(observed))
        return j, (expected[j] if j < len(expected) else None), (observed[j] if j < len(observed) else None)
    return None


def judge(ctx, G, C, usable) -> None:
    """The search's outputs of every reflector of the frame (:func:`judge_reflector`)."""
    for k in keys.reflectors(G):
        judge_reflector(ctx, k, G, C, usable)


def judge_reflector(ctx, k, G, C, usable):
    """The per-vertex outputs of reflector ``k`` but the virtual vertices: reflection pixels (ties
    by the oracle's scores), flags and vertex objects, iterations, scores, and supplied traces
    (``ctx.traces``). ``usable(key)``: the candidate has the key, of the right shape and dtype,
    and its kind is checked. Without the candidate's pixels (their kind not checked), the other
    outputs are judged as if every pixel agreed. The pixels' verdict goes to ``ctx.agreement``
    (read by :mod:`.virtual`).

    They are judged against the golden arrays, or against ``ctx.reference`` when the oracle was
    run on the candidate's own inputs (:func:`refsoft.conformance.stages.reference_frame`)."""
    G, prev_pixels = vertex_reference(ctx, k, G)
    cand_traces = ctx.traces
    live, agree, tie = agreement(ctx, k, G)
    findings = []
    if usable(keys.REFLECTION_PIXEL(k)):
        gp, cp = G[keys.REFLECTION_PIXEL(k)], C[keys.REFLECTION_PIXEL(k)]
        agree = live & np.all(gp == cp, axis=1)
        findings, tie = judge_pixels(ctx, k, G, C, live, agree, cand_traces, prev_pixels)
        paint_pixels(ctx, k, G, live, agree, tie)
        ctx.agreement[k] = (live, agree, tie)
    n = int(live.sum())
    for name, kind in ((keys.FLAGS(k), "flags"), (keys.VERTEX_OBJECT(k), "ids")):
        if usable(name):
            g_val, c_val = G[name], C[name]
            if kind == "flags" and "images" in ctx.not_ported_kinds:
                from ...search import SEVERAL

                # SEVERAL is the enumeration's verdict (kind images), which the candidate declares not ported
                g_val, c_val = g_val & ~np.uint8(SEVERAL), c_val & ~np.uint8(SEVERAL)
            bad = agree & (g_val != c_val)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                findings.append(ctx.finding(name, kind, "fail", "differ where the pixels agree", int(bad.sum()), n,
                                            f"vertex {i}: expected {G[name][i]} / observed {C[name][i]}"))
            else:
                findings.append(ctx.finding(name, kind, "pass", "identical where the pixels agree", 0, n))
    name = keys.ITERATIONS(k)
    if usable(name):
        bad = agree & (G[name] != C[name])
        i = int(np.flatnonzero(bad)[0]) if bad.any() else None
        worst = f"vertex {i}: expected {G[name][i]} / observed {C[name][i]}" if bad.any() else ""
        status = "pass" if not bad.any() else ("accepted" if bad.sum() <= ITERATION_SHARE_MAX * max(n, 1) else "fail")
        findings.append(ctx.finding(name, "iterations", status, f"differ where the pixels agree (at most "
                                    f"{ITERATION_SHARE_MAX:.0%} allowed)" if bad.any() else "identical", int(bad.sum()), n,
                                    worst))
    name = keys.SCORE(k)
    if usable(name):
        findings += compare_float_field(ctx, name, G[name], C[name], agree, 0.0,
                                         extra=score_slack(ctx, k, G, agree, C[name]))
    if cand_traces is not None and k in cand_traces and "trace" in ctx.kinds:
        findings.append(judge_traces(ctx, k, live, cand_traces[k], prev_pixels))
    return findings


def score_slack(ctx, k, G, agree, cand):
    """``extra`` of :func:`compare_float_field` for the scores where the pixels agree, under a
    profile with ``score_k`` or on the candidate's own G-buffer: within ``score_k * TIE_EPS *
    (1 + 1/|U + B|)`` plus :func:`saved_rounding` (None when neither applies)."""
    from ...search import HIDDEN
    from ..precision import score_condition, tie_bound

    own = ctx.stages.get(k) is not None
    if not (ctx.profile.score_k or own):
        return None

    def run(todo):
        i = np.flatnonzero(agree)[todo]
        o = ctx.oracle()
        gb, eye = ctx.stage_gbuffer(k), o.scene.camera_at(ctx.frame).eye
        pix = G[keys.REFLECTION_PIXEL(k)][i]
        inverse = (o.case.options.get("inverse") == "search") & ((G[keys.FLAGS(k)][i] & HIDDEN) != 0)
        bound = tie_bound(score_condition(gb, eye, o.verts[i], pix, inverse), ctx.profile.score_k)
        if own:
            bound = bound + saved_rounding(gb, eye, o.verts[i], pix, inverse)
        ok = np.abs(cand[i].astype(np.float64) - G[keys.SCORE(k)][i].astype(np.float64)) <= bound
        return {"within the scores' rounding bound": mark(int(agree.sum()), np.flatnonzero(todo)[ok])}

    return run


def judge_pixels(ctx, k, G, C, live, agree, cand_traces, prev_pixels):
    """The reflection-pixel rule: identical, or a tie by the oracle's own scores of both pixels,
    within the bound of :func:`refsoft.conformance.precision.tie_bound` for the score's
    conditioning ``|U + B|`` at the oracle's pixel. Returns (findings, tie (N,) bool)."""
    from ...search import HIDDEN, scores_at
    from ..precision import score_condition, tie_bound

    gp, cp, gflags = G[keys.REFLECTION_PIXEL(k)], C[keys.REFLECTION_PIXEL(k)], G[keys.FLAGS(k)]
    n = int(live.sum())
    differ = np.flatnonzero(live & ~agree)
    tie = np.zeros(len(gp), dtype=bool)
    details = []
    if len(differ):
        o = ctx.oracle()
        gb = ctx.stage_gbuffer(k)
        eye = o.scene.camera_at(ctx.frame).eye
        inverse = (o.case.options.get("inverse") == "search") & ((gflags[differ] & HIDDEN) != 0)
        s_g = scores_at(gb, eye, o.verts[differ], gp[differ], inverse).astype(np.float64)
        s_c = scores_at(gb, eye, o.verts[differ], cp[differ], inverse).astype(np.float64)
        covered = s_c > constants.NO_SCORE
        cond = score_condition(gb, eye, o.verts[differ], gp[differ], inverse)
        bound = tie_bound(cond, ctx.profile.tie_k)
        if ctx.stages.get(k) is not None:  # both scores from the candidate's saved world-space float32 positions
            at_c = np.where(covered[:, None], cp[differ], gp[differ])
            bound = bound + saved_rounding(gb, eye, o.verts[differ], gp[differ], inverse) + saved_rounding(
                gb, eye, o.verts[differ], at_c, inverse)
        ok = covered & (np.abs(s_g - s_c) <= bound)
        tie[differ[ok]] = True
        for j, i in enumerate(differ[:5]):
            msg = (f"vertex {int(i)}: expected {where(gp[i])} / observed {where(cp[i])}, oracle scores "
                   f"{s_g[j]:.9g} / {s_c[j]:.9g} (difference {abs(s_g[j] - s_c[j]):.3g}, tie bound {bound[j]:.3g} "
                   f"at |U + B| = {cond[j]:.3g})" + (" (tie)" if ok[j] else ""))
            details.append(msg + trace_note(ctx, k, int(i), cp[i], cand_traces, prev_pixels))
    nfail = len(differ) - int(tie.sum())
    key = keys.REFLECTION_PIXEL(k)
    if nfail or tie.sum() > TIE_SHARE_MAX * max(n, 1):
        f = ctx.finding(key, "pixel", "fail", f"{nfail} differ beyond ties, {int(tie.sum())} ties "
                        f"(at most {TIE_SHARE_MAX:.0%} allowed)", len(differ), n, details=details)
    elif tie.any():
        f = ctx.finding(key, "pixel", "accepted", "differing pixels are ties (oracle scores within "
                        f"{ctx.profile.tie_k:g} x 2^-24 x (1 + 1/|U + B|))", int(tie.sum()), n, details=details)
    else:
        f = ctx.finding(key, "pixel", "pass", "identical", 0, n)
    return [f], tie


def trace_note(ctx, k, i, observed, cand_traces, prev_pixels) -> str:
    """Where the candidate's supplied trace of vertex ``i`` parts from the oracle's walk, as a
    note for a differing pixel ("" without a trace)."""
    if cand_traces is None or i not in cand_traces.get(k, {}):
        return ""
    prev = None if prev_pixels is None else prev_pixels[i]
    path = cand_traces[k][i].get("path", [])
    div = first_divergence(oracle_trace(ctx, k, i, prev), path)
    if div:
        return f"; traces part at step {div[0]}: expected {div[1]} / observed {div[2]}"
    if path and list(path[-1]) != [int(x) for x in observed]:
        return f"; the supplied trace follows the oracle's walk but ends at {path[-1]}, not at the reported pixel"
    return "; the supplied trace follows the oracle's walk step for step"


def paint_pixels(ctx, k, G, live, agree, tie):
    """The reflection pixels' error mask over the G-buffer (green agree, yellow tie, red fail),
    when some differ."""
    gbm = G.get(keys.GBUFFER_MASK(k))
    if ctx.out is None or gbm is None or not (live & ~agree).any():
        return
    gp = G[keys.REFLECTION_PIXEL(k)]
    img = np.where(gbm[..., None], 60, 0).astype(np.uint8) * np.ones(3, np.uint8)
    for sel, col in ((agree, (0, 160, 0)), (tie, (230, 200, 0)), (live & ~agree & ~tie, (220, 0, 0))):
        pix = gp[sel]
        img[pix[:, 0], pix[:, 1]] = col
    ctx.picture(keys.REFLECTION_PIXEL(k), img)


def judge_traces(ctx, k, live, traces, prev_pixels):
    """The traces the candidate supplies: the first step at which each walk leaves the
    oracle's."""
    parted = []
    for i, rec in sorted(traces.items()):
        if not (0 <= i < len(live)) or not live[i]:
            continue
        prev = None if prev_pixels is None else prev_pixels[i]
        div = first_divergence(oracle_trace(ctx, k, i, prev), rec.get("path", []))
        if div:
            parted.append(f"vertex {i}: step {div[0]}, expected {div[1]} / observed {div[2]}")
    return ctx.finding(f"traces_{k}", "trace", "fail" if parted else "pass",
                       "walks part from the oracle's" if parted else "every supplied walk follows the oracle's",
                       len(parted), len(traces), details=parted[:5])



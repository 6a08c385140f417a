"""``refsoft check GOLDEN CANDIDATE``: a port's outputs against the golden set (spec section 8).

Each output is compared by the rule of its kind and gets a status:

- ``pass``: identical;
- ``accepted``: different within the rule's tolerance (ULP, ties, ambiguous edge pixels); shown
  yellow and counted, never a failure;
- ``fail``: beyond the tolerance; ``refsoft check`` then exits with status 1;
- ``missing``: the candidate lacks it (a whole case frame, or one output): a failure like
  ``fail``, unless the candidate said it provides a subset (``cases``, ``kinds``: the outputs of
  other cases and kinds are then neither judged nor required); a missing or altered
  *reference* file is a failure.

Rules (tolerances in :mod:`refsoft.constants`, the kinds in the table of ``docs/ports.md``):
shapes, dtypes and non-finite masks identical; G-buffer coverage identical except pixels whose
centre lies within 1e-4 px of an edge of the oracle's projected (unsnapped) triangles; positions,
normals, view-projection, scores and virtual vertices within 4 float32 ULP or 1e-6 of the scene's
extent (normals also by angle, 1e-4 rad), G-buffer positions and normals at a depth tie (the
golden frame's ``gbuffer_depth_margin_K`` at most 8 x 2^-24) matching either the winning
fragment or the next one (rebuilt with :func:`refsoft.raster.gbuffer_layers`); reflection pixels identical, a differing pixel accepted
as a tie when the oracle's own scores of both pixels differ by at most 8 x 2^-24 x (1 + 1 /
|U + B|), U and B the unit directions the score adds at the oracle's pixel (the oracle's
G-buffer is rebuilt for this), failing beyond 1% ties; virtual vertices of
ties recomputed from the candidate's pixel; flags and vertex objects identical where the pixels
agree, iterations likewise up to 1% of vertices; 8-bit images within 1 per channel (``loose``:
4, with a 1-pixel window and at most 0.1% of pixels failing). ``object_id`` and
``reflected_id`` are reported, not judged. Candidate traces (``traces_NNNN.json``, see
:mod:`refsoft.conformance.golden`) are compared step by step with the oracle's walk of the same vertex.

The comparison methods' golden cases (``method`` ``"ldt"`` and ``"envmap"``: no vertex search)
are judged by the rules of :mod:`refsoft.conformance.comparison` (the per-pixel arrays, the cube
maps, the cone-test tables) and :mod:`refsoft.conformance.textures` (each ``CASE/ldt_J.npz``,
once per case), each of its own kind; there ``reflected_id`` is part of the per-pixel decision,
judged, not only reported.

Those are the ``default`` profile's rules. The ``gpu`` profile (:mod:`refsoft.conformance.profiles`)
widens the G-buffer's by what a GPU's own interpolation and depth evaluation may change (and
accepts fragments of another triangle at an edge), judges everything after the G-buffer against
the oracle run on the candidate's own G-buffer (:mod:`refsoft.conformance.stages`), with a tie
bound for built-in ``normalize`` and ``dot``, and images by the loose rule.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from .. import constants, keys
from ..constants import (EXTENT_TOL, F32_ULP_TOL, IMAGE_LOOSE_SHARE, IMAGE_TOL, IMAGE_TOL_LOOSE,
                         ITERATION_SHARE_MAX, NORMAL_ANGLE_TOL, TIE_SHARE_MAX)
from ..errors import InputFileError, RefsoftError
from . import comparison, textures
from .golden import DEPTH_MARGIN
from .profiles import edge_triangles, fragments, profile as get_profile

STATUSES = ("pass", "accepted", "fail", "missing")
#: The report's pictures are magnified this many times (nearest neighbour: every pixel a block).
MAGNIFY = 4


#: The kinds of output ``--kinds`` selects (each key of a frame belongs to one, :func:`output_kind`).
KINDS = constants.CHECK_KINDS
_PER_REFLECTOR_KINDS = {keys.GBUFFER_MASK: "coverage", keys.GBUFFER_POSITION: "gbuffer",
                        keys.GBUFFER_NORMAL: "gbuffer", keys.GBUFFER_VIEW_PROJ: "gbuffer",
                        keys.REFLECTION_PIXEL: "pixel", keys.VIRTUAL_VERTEX: "virtual", keys.FLAGS: "flags",
                        keys.VERTEX_OBJECT: "vertex_object", keys.ITERATIONS: "iterations", keys.SCORE: "score",
                        keys.MARGIN: "margin"}
_FRAME_KINDS = {keys.IMAGE: "image", keys.OBJECT_ID: "ids", keys.REFLECTED_ID: "ids"}
#: Arrays of the golden frames that only the oracle writes (what the rules read about the
#: oracle itself): a candidate need not have them, and they are not judged.
ORACLE_ONLY = (DEPTH_MARGIN,)
_PER_REFLECTOR_KINDS[DEPTH_MARGIN] = "gbuffer"


def _parse(key: str):
    """:func:`refsoft.keys.parse`, knowing the oracle-only names too."""
    for name in ORACLE_ONLY:
        prefix = name + "_"
        if key.startswith(prefix) and key[len(prefix):].isdigit():
            return name, int(key[len(prefix):])
    return keys.parse(key)


def output_kind(key: str) -> str:
    """The kind of output a frame's key is (:data:`KINDS`); ``"frame"`` for a whole frame
    (``"*"``), ``"other"`` for a key refsoft does not know."""
    if key == "*":
        return "frame"
    if key.startswith("traces_"):
        return "trace"
    if key in _FRAME_KINDS:
        return _FRAME_KINDS[key]
    method_kind = comparison.kind_of(key)
    if method_kind is not None:
        return method_kind
    p = _parse(key)
    if p is not None and p[0] in _PER_REFLECTOR_KINDS:
        return _PER_REFLECTOR_KINDS[p[0]]
    return "other"


def check_kinds(kinds):
    """``kinds`` (None: all) as a tuple of :data:`KINDS`; an unknown name is refused."""
    if kinds is None:
        return KINDS
    kinds = [k for item in kinds for k in str(item).split(",") if k]
    bad = [k for k in kinds if k not in KINDS]
    if bad or not kinds:
        raise RefsoftError(f"unknown kind of output {bad[0]!r} (kinds: {', '.join(KINDS)})" if bad else
                           f"--kinds names no kind (kinds: {', '.join(KINDS)})")
    return tuple(k for k in KINDS if k in kinds)


@dataclass
class Finding:
    """One output of one case and frame, judged by its rule: ``kind`` is the kind of output
    (:func:`output_kind`), ``rule`` the rule that judged it."""

    case: str
    frame: int
    key: str
    kind: str
    status: str
    message: str = ""
    count: int = 0
    total: int = 0
    worst: str = ""
    details: list = field(default_factory=list)
    rule: str = ""

    def line(self) -> str:
        share = f" ({self.count}/{self.total}, {100 * self.count / max(self.total, 1):.3g}%)" if self.total else ""
        worst = f"; worst {self.worst}" if self.worst else ""
        return f"{self.status.upper():8s} {self.case} frame {self.frame} {self.key} [{self.kind}]: {self.message}{share}{worst}"

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("case", "frame", "key", "kind", "rule", "status", "message", "count",
                                              "total", "worst", "details")}


def _f32_ulp(x):
    return np.spacing(np.abs(np.asarray(x, dtype=np.float32))).astype(np.float64)


def _float_close(g, c, extent):
    """Elementwise: within 4 float32 ULP of the reference or 1e-6 x extent."""
    g64, c64 = np.asarray(g, dtype=np.float64), np.asarray(c, dtype=np.float64)
    err = np.abs(g64 - c64)
    return (err <= F32_ULP_TOL * _f32_ulp(g64)) | (err <= EXTENT_TOL * extent), err


def _where(idx) -> str:
    return "(" + ", ".join(str(int(i)) for i in idx) + ")"


class _Oracle:
    """What the rules need from the oracle itself for one case and frame (built on demand):
    the scene, vertices, extent, and each reflector's G-buffer as the search saw it."""

    def __init__(self, entry, frame):
        from .golden import Case
        from ..scene import scene_vertices

        self.entry, self.frame = entry, frame
        self.case = Case(entry["name"], entry["scene"], tuple(entry["frames"]), _options(entry["options"]))
        self.scene = self.case.load()
        self.verts, _ = scene_vertices(self.scene, frame)
        allv = np.concatenate([self.scene.world_mesh(k, frame).vertices for k in range(1, len(self.scene.objects) + 1)])
        self.extent = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0)))
        self._gb = {}

    def gbuffer(self, k):
        from ..search.reflect import reflector_gbuffer

        if k not in self._gb:
            o = self.case.options
            self._gb[k] = reflector_gbuffer(self.scene, k, self.frame, o.get("widen", 1.0), o.get("gbuffer_size"),
                                            o.get("precision", "float32"))
        return self._gb[k]

    def fragments(self, k, pixels, triangles=None):
        """:func:`refsoft.conformance.profiles.fragments` of reflector ``k``'s G-buffer at
        ``pixels`` (n, 2): of the G-buffer's own triangles there, or of ``triangles`` (n,)."""
        gb = self.gbuffer(k)
        pixels = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
        tri = gb.triangle[pixels[:, 0], pixels[:, 1]] if triangles is None else triangles
        h, w = gb.mask.shape
        return fragments(self.scene.world_mesh(k, self.frame, proxy=True), gb.view_proj, w, h, pixels, tri)

    def edge_triangles(self, k, pixels, distance):
        """:func:`refsoft.conformance.profiles.edge_triangles` of reflector ``k``'s G-buffer."""
        gb = self.gbuffer(k)
        h, w = gb.mask.shape
        return edge_triangles(self.scene.world_mesh(k, self.frame, proxy=True), gb.view_proj, w, h, pixels, distance)

    def second_fragment(self, k):
        """Reflector ``k``'s next fragment behind the G-buffer's, as saved maps: world-space
        float32 positions and float32 normals (H, W, 3), zero where there is none, and its
        triangles (H, W; -1 where none) (:func:`refsoft.raster.gbuffer_layers`)."""
        from ..raster import gbuffer_layers

        key = ("second", k)
        if key not in self._gb:
            gb = self.gbuffer(k)
            h, w = gb.mask.shape
            sec = gbuffer_layers(self.scene.world_mesh(k, self.frame, proxy=True), gb.view_proj, w, h,
                                 gb.position.dtype.name, gb.origin)
            has = sec.triangle >= 0
            pos = np.where(has[..., None], sec.position.astype(np.float64) + gb.origin, 0.0).astype(np.float32)
            self._gb[key] = (pos, sec.normal.astype(np.float32), sec.triangle)
        return self._gb[key]

    def edge_distance(self, k, pixels):
        """Distance (px) from each pixel centre (row, col) to the nearest edge of the reflector's
        projected triangles, unsnapped float64 window coordinates."""
        from ..search.reflect import gbuffer_camera

        o = self.case.options
        cam = gbuffer_camera(self.scene, self.frame, o.get("widen", 1.0), o.get("gbuffer_size"))
        mesh = self.scene.world_mesh(k, self.frame, proxy=True)
        clip = np.c_[mesh.vertices, np.ones(mesh.n_vertices)] @ cam.view_proj().T
        front = clip[:, 3] > 0
        win = np.zeros((mesh.n_vertices, 2))
        win[front] = np.c_[(clip[front, 0] / clip[front, 3] + 1) * 0.5 * cam.width,
                           (clip[front, 1] / clip[front, 3] + 1) * 0.5 * cam.height]
        f = mesh.faces[np.all(front[mesh.faces], axis=1)]
        a = np.concatenate([win[f[:, 0]], win[f[:, 1]], win[f[:, 2]]])
        b = np.concatenate([win[f[:, 1]], win[f[:, 2]], win[f[:, 0]]])
        out = np.full(len(pixels), np.inf)
        for i, (r, c) in enumerate(pixels):
            p = np.array([c + 0.5, cam.height - 1 - r + 0.5])
            ab = b - a
            t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
            out[i] = np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)) if len(a) else np.inf
        return out


def _options(d):
    return {k: (tuple(v) if isinstance(v, list) else v) for k, v in d.items()}


def _compare_mask(ctx, key, g, c, k):
    diff = np.argwhere(g != c)
    if len(diff) == 0:
        return [ctx.finding(key, "coverage", "pass", "identical")]
    edge_px = ctx.profile.edge_px
    dist = ctx.oracle().edge_distance(k, diff)
    amb = dist <= edge_px
    fails = diff[~amb]
    ctx.paint(key, g.shape, diff[amb], diff[~amb])
    worst = ""
    if len(fails):
        r, cc = fails[0]
        worst = f"at {_where(fails[0])}: expected {bool(g[r, cc])} / observed {bool(c[r, cc])} ({dist[~amb][0]:.3g} px from an edge)"
        return [ctx.finding(key, "coverage", "fail", f"{len(fails)} pixels differ away from edges "
                            f"({int(amb.sum())} ambiguous within {edge_px:.3g} px)", len(fails), g.size, worst)]
    return [ctx.finding(key, "coverage", "accepted", f"only ambiguous edge pixels differ (centre within "
                        f"{edge_px:.3g} px of an edge)", int(amb.sum()), g.size)]


def _float_rule(gg, cc, extent, normals=False):
    """Rows of ``cc`` (N, ...) within the float rule of ``gg``'s: ``(ok (N,) bool, |error|)``."""
    ok, err = _float_close(gg, cc, extent)
    ok = ok.all(axis=-1) if ok.ndim > 1 else ok
    if normals:
        cosang = np.einsum("ij,ij->i", gg.astype(np.float64), cc.astype(np.float64)) / np.maximum(
            np.linalg.norm(gg, axis=1) * np.linalg.norm(cc, axis=1), 1e-300)
        ok |= np.arccos(np.clip(cosang, -1, 1)) <= NORMAL_ANGLE_TOL
    return ok, err


def _compare_float_field(ctx, key, g, c, cover, extent, normals=False, extra=None):
    """The float rule over the elements ``cover`` selects. ``extra``: elements beyond it that
    another rule accepts, ``{reason: (n,) bool}`` over the selected elements (counted in the
    message; a G-buffer's other admissible fragments, :func:`_gbuffer_alternatives`)."""
    gg, cc = g[cover], c[cover]
    ok, err = _float_rule(gg, cc, extent, normals)
    same = np.all(gg == cc, axis=-1) if gg.ndim > 1 else gg == cc
    n = len(ok)
    if same.all():
        return [ctx.finding(key, "float", "pass", "identical", 0, n)]
    extra = extra(~ok) if callable(extra) else (extra or {})
    bad = ~ok
    for accepted in extra.values():
        bad &= ~accepted
    e = err.max(axis=-1) if err.ndim > 1 else err
    i = int(np.argmax(np.where(bad, e, -1))) if bad.any() else int(np.argmax(np.where(ok, e, -1)))
    locs = np.argwhere(cover)
    where = locs[i] if len(locs) == n else [i]
    worst = f"at {_where(where)}: expected {np.round(gg[i], 9).tolist()} / observed {np.round(cc[i], 9).tolist()}"
    notes = "".join(f"; {int(v.sum())} {reason}" for reason, v in extra.items() if v.any())
    if bad.any():
        return [ctx.finding(key, "float", "fail", f"beyond {F32_ULP_TOL} float32 ULP and {EXTENT_TOL} x extent "
                            f"{extent:.4g}{notes}", int(bad.sum()), n, worst)]
    return [ctx.finding(key, "float", "accepted", f"within {F32_ULP_TOL} float32 ULP or {EXTENT_TOL} x extent{notes}",
                        int((~same).sum()), n, worst)]


def _near(c, ref, rate, extent, normals, subpixel):
    """Rows of ``c`` within the float rule of ``ref`` widened by ``subpixel`` pixels times
    ``rate`` (world units or radians per pixel): (n,) bool."""
    ok, _ = _float_rule(ref, c, extent, normals)
    c64, r64 = np.asarray(c, np.float64), np.asarray(ref, np.float64)
    if normals:
        ang = np.arctan2(np.linalg.norm(np.cross(c64, r64), axis=1), np.einsum("ij,ij->i", c64, r64))
        return ok | (ang <= NORMAL_ANGLE_TOL + subpixel * rate)
    slack = EXTENT_TOL * extent + F32_ULP_TOL * _f32_ulp(np.abs(r64).max(axis=1))
    return ok | (np.linalg.norm(c64 - r64, axis=1) <= slack + subpixel * rate)


def _gbuffer_alternatives(ctx, name, k, G, cover, cc, extent):
    """``extra`` of :func:`_compare_float_field` for reflector ``k``'s position or normal map
    ``cc`` (the candidate's values at ``cover``): for the elements ``todo`` failing the float
    rule, those the profile accepts otherwise:

    - ``within GPU interpolation`` (a profile with ``subpixel_px``): within that many pixels
      times the winning fragment's rate of change;
    - ``match the next fragment at a depth tie``: where the golden frame's depth margin is a tie
      (:meth:`Profile.depth_tie`, with both fragments' depth slopes), matching the next fragment;
    - ``match another triangle at an edge`` (a profile with ``subpixel_px``): matching a fragment
      of a triangle whose edge passes within ``edge_px`` of the pixel centre and which is in
      front of the winner, or at a depth tie with it.
    """
    prof = ctx.profile
    normals = name == keys.GBUFFER_NORMAL
    pix = np.argwhere(cover)
    margin = G.get(DEPTH_MARGIN(k))
    margin = margin[cover] if margin is not None and margin.shape == cover.shape else None

    def value(fr):
        return fr.normal if normals else fr.position

    def rate(fr):
        return fr.normal_rate if normals else fr.position_rate

    def run(todo):
        out = {}
        o = ctx.oracle()
        todo = todo.copy()
        if prof.subpixel_px and todo.any():
            i = np.flatnonzero(todo)
            win = o.fragments(k, pix[i])
            ok = _near(cc[i], value(win), rate(win), extent, normals, prof.subpixel_px)
            out["within GPU interpolation"] = _mark(len(cc), i[ok])
            todo[i[ok]] = False
        maybe = None
        if margin is not None:
            # without a subpixel tolerance the margin alone decides the ties: the next fragment
            # is rebuilt only if there are some
            maybe = todo & (np.isfinite(margin) if prof.subpixel_px else prof.depth_tie(margin))
        if maybe is not None and maybe.any():
            i = np.flatnonzero(maybe)
            pos2, nrm2, tri2 = o.second_fragment(k)
            tied = np.ones(len(i), dtype=bool)
            if prof.subpixel_px:
                sec = o.fragments(k, pix[i], tri2[pix[i, 0], pix[i, 1]])
                tied = prof.depth_tie(margin[i], o.fragments(k, pix[i]).depth_rate + sec.depth_rate)
            ref = (nrm2 if normals else pos2)[pix[i, 0], pix[i, 1]]
            ok = tied & _float_rule(ref, cc[i], extent, normals)[0]
            if prof.subpixel_px:
                ok |= tied & _near(cc[i], value(sec), rate(sec), extent, normals, prof.subpixel_px)
            out["match the next fragment at a depth tie"] = _mark(len(cc), i[ok])
            todo[i[ok]] = False
        if prof.subpixel_px and todo.any():
            i = np.flatnonzero(todo)
            at, tri = o.edge_triangles(k, pix[i], prof.edge_px)
            if len(at):
                fr = o.fragments(k, pix[i][at], tri)
                w = o.fragments(k, pix[i][at])
                front = prof.depth_tie(fr.depth - w.depth, fr.depth_rate + w.depth_rate)
                ok = front & _near(cc[i][at], value(fr), rate(fr), extent, normals, prof.subpixel_px)
                out["match another triangle at an edge"] = _mark(len(cc), i[at[ok]])
        return out

    return run


def _mark(n, idx):
    m = np.zeros(n, dtype=bool)
    m[idx] = True
    return m


class _Context:
    def __init__(self, case, frame, entry, out, kinds=KINDS, profile="default"):
        self.case, self.frame, self.entry, self.out, self.kinds = case, frame, entry, out, kinds
        self.profile = get_profile(profile)
        self.stages = {}  # reflector -> the candidate's G-buffer its search is judged on
        self.reference = None  # the frame's arrays from the candidate's inputs (_reference_frame)
        self.reference_starts = {}
        self.loose = False  # the loose image rule (set by check_frame)
        self.findings = []
        self.pictures = []  # file names written into out
        self._oracle = None

    def oracle(self):
        if self._oracle is None:
            self._oracle = _Oracle(self.entry, self.frame)
        return self._oracle

    def stage_gbuffer(self, k):
        """The G-buffer reflector ``k``'s search is judged on: the candidate's own
        (:func:`_compare_vertices`), or the oracle's."""
        own = self.stages.get(k)
        return self.oracle().gbuffer(k) if own is None else own

    def finding(self, key, rule, status, message="", count=0, total=0, worst="", details=None, kind=None):
        f = Finding(self.case, self.frame, key, kind or output_kind(key), status, message, int(count), int(total),
                    worst, details or [], rule)
        self.findings.append(f)
        return f

    def picture(self, name, img):
        """Write ``CASE_frame_NNNN_NAME.png`` into the report, magnified :data:`MAGNIFY` times."""
        if self.out is None:
            return
        from ..io import write_png

        img = np.repeat(np.repeat(np.asarray(img, np.uint8), MAGNIFY, axis=0), MAGNIFY, axis=1)
        file = f"{self.case}_frame_{self.frame:04d}_{name}.png"
        write_png(os.path.join(self.out, file), img)
        self.pictures.append(file)

    def paint(self, key, shape, yellow, red, green=None):
        """An error mask over a (H, W) grid: green pass, yellow accepted, red fail."""
        if self.out is None:
            return
        img = np.zeros(tuple(shape[:2]) + (3,), np.uint8)
        if green is not None:
            img[green] = (0, 160, 0)
        for idx, col in ((yellow, (230, 200, 0)), (red, (220, 0, 0))):
            idx = np.asarray(idx, dtype=np.int64).reshape(-1, 2)
            img[idx[:, 0], idx[:, 1]] = col
        self.picture(key, img)


def _compare_image(ctx, g, c, loose):
    d = np.abs(g.astype(np.int16) - c.astype(np.int16)).max(axis=2)
    tol = IMAGE_TOL_LOOSE if loose else IMAGE_TOL
    bad = d > tol
    if loose and bad.any():  # a 1-pixel window: the candidate may match a neighbour of the reference
        h, w = d.shape
        best = d.copy()
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                sh = np.full_like(g, 0)
                rs, re_ = max(dr, 0), h + min(dr, 0)
                cs, ce = max(dc, 0), w + min(dc, 0)
                sh[rs:re_, cs:ce] = g[rs - dr:re_ - dr, cs - dc:ce - dc]
                best = np.minimum(best, np.abs(sh.astype(np.int16) - c.astype(np.int16)).max(axis=2))
        bad = best > tol
    n = d.size
    if not d.any():
        return [ctx.finding("image", "image", "pass", "identical", 0, n)]
    r, cc = np.unravel_index(int(np.argmax(d)), d.shape)
    worst = f"at ({r}, {cc}): expected {g[r, cc].tolist()} / observed {c[r, cc].tolist()}"
    # the error mask and the difference (16x brighter), for an image that did not pass
    ctx.paint("image", d.shape, np.argwhere((d > 0) & ~bad), np.argwhere(bad), d == 0)
    ctx.picture("image_diff", np.clip(np.abs(g.astype(np.int16) - c.astype(np.int16)) * 16, 0, 255))
    nbad = int(bad.sum())
    if nbad and (not loose or nbad > IMAGE_LOOSE_SHARE * n):
        return [ctx.finding("image", "image", "fail", f"channels differ by more than {tol}", nbad, n, worst)]
    return [ctx.finding("image", "image", "accepted", f"within {tol} per channel" + (" (loose)" if loose else ""),
                        int((d > 0).sum()), n, worst)]


def _load_traces(path):
    """A candidate's ``traces_NNNN.json`` as ``{reflector: {vertex: record}}``, or None when the
    candidate supplies none. Each record needs an integer ``vertex`` and a ``path`` of pixels
    (``[row, col]``, or ``[level, row, col]`` for the hierarchy)."""
    from ..io import read_json

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


def _oracle_trace(ctx, k, i, prev_pixel):
    from ..search import trace_search

    o = ctx.oracle()
    opts = o.case.options
    gb = ctx.stage_gbuffer(k)
    if opts.get("method") == "hierarchy":
        from ..search import trace_hierarchy

        return trace_hierarchy(gb, o.scene.camera_at(ctx.frame).eye, o.verts[i], cap=opts.get("cap")).path()
    tr = trace_search(gb, o.scene.camera_at(ctx.frame).eye, o.verts[i], opts.get("neighbourhood", "cross"),
                      opts.get("inverse", "plane"), prev_pixel, opts.get("cap"))
    return [[int(x) for x in s["pixel"]] for s in tr.steps]


def _first_divergence(expected, observed):
    for j, (a, b) in enumerate(zip(expected, observed)):
        if list(a) != list(b):
            return j, a, b
    if len(expected) != len(observed):
        j = min(len(expected), len(observed))
        return j, (expected[j] if j < len(expected) else None), (observed[j] if j < len(observed) else None)
    return None


def _candidate_gbuffer(ctx, k, G, C):
    """Reflector ``k``'s G-buffer as the candidate saved it (a :class:`refsoft.raster.GBuffer`
    relative to the oracle's origin, in the case's precision), or None when the candidate's maps
    are the golden ones, bit for bit, or are not there in the golden shapes and dtypes."""
    from ..raster import GBuffer

    names = (keys.GBUFFER_POSITION(k), keys.GBUFFER_NORMAL(k), keys.GBUFFER_MASK(k))
    if not all(n in C and C[n].shape == G[n].shape and C[n].dtype == G[n].dtype for n in names):
        return None
    if all(np.array_equal(C[n], G[n]) for n in names):
        return None
    mask = C[names[2]]
    if not (np.isfinite(C[names[0]][mask]).all() and np.isfinite(C[names[1]][mask]).all()):
        return None  # failed by the non-finite rule; the oracle's own G-buffer stands in
    gb = ctx.oracle().gbuffer(k)
    dt = gb.position.dtype
    rel = np.where(mask[..., None], C[names[0]].astype(np.float64) - gb.origin, 0.0).astype(dt)
    nrm = np.where(mask[..., None], C[names[1]], 0).astype(dt)
    return GBuffer(rel, nrm, mask.copy(), (0, 0, np.zeros((0, 0), np.float32)), (0, 0, np.zeros((0, 0), np.int32)),
                   gb.view_proj, gb.origin)


#: The kinds of output that follow from the G-buffer.
_AFTER_GBUFFER = {"pixel", "virtual", "flags", "vertex_object", "iterations", "score", "margin", "image", "trace"}


def _reference_frame(ctx, G, C, prev, cand_prev, drivers):
    """Under a profile with ``own_gbuffer``: the frame as the oracle renders it from the
    candidate's own inputs to the search, its G-buffers as saved where they differ from the
    golden ones and (coherent cases) its pixels of the previous frame as the starts
    (:mod:`refsoft.conformance.stages`). Sets ``ctx.stages`` and ``ctx.reference``; leaves the
    golden frame as the reference when those inputs are the golden ones. ``drivers`` keeps one
    driver per case across its frames."""
    if not ctx.profile.own_gbuffer or not set(ctx.kinds) & _AFTER_GBUFFER:
        return
    reflectors = keys.reflectors(G)
    given = {k: gb for k in reflectors if (gb := _candidate_gbuffer(ctx, k, G, C)) is not None}
    coherent = ctx.entry["options"].get("coherence", True)
    starts = {k: (cand_prev or {}).get(k, (prev or {}).get(k)) for k in reflectors} if coherent else {}
    starts = {k: v for k, v in starts.items() if v is not None}
    same_starts = all(np.array_equal(v, (prev or {}).get(k)) for k, v in starts.items())
    if not given and same_starts:
        return
    from .stages import reference_driver

    o = ctx.oracle()
    if ctx.case not in drivers:
        drivers[ctx.case] = reference_driver(o.scene, o.case.options)
    driver = drivers[ctx.case]
    driver.method.given = given
    driver.method.previous = dict(starts)
    frame = driver.render_frame(ctx.frame)
    ctx.stages = {k: frame.reflectors[k].state.gbuffer for k in given}
    ctx.reference = frame.arrays
    ctx.reference_starts = starts


def _saved_rounding(gb, eye, vertices, pixels, inverse=None) -> np.ndarray:
    """A bound on how much the score at each pixel changes when the G-buffer ``gb`` holds a
    candidate's positions as saved, world-space float32 (each coordinate within half an ULP of
    the candidate's own, then rounded again relative to the origin), rather than the values its
    search read: that error times :func:`refsoft.conformance.precision.position_sensitivity`."""
    from .precision import position_sensitivity

    pix = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
    rel = gb.position[pix[:, 0], pix[:, 1]].astype(np.float64)
    world = rel + gb.origin
    q = 0.5 * np.sqrt(3.0) * (_f32_ulp(np.abs(world).max(axis=1)) + _f32_ulp(np.abs(rel).max(axis=1)))
    return q * position_sensitivity(gb, eye, vertices, pix, inverse)


def _compare_vertices(ctx, k, G, C, cand_traces, prev_pixels, usable):
    """The per-vertex outputs of reflector ``k``: reflection pixels (ties by the oracle's scores),
    virtual vertices, flags and vertex objects, iterations, scores, and supplied traces.
    ``usable(key)``: the candidate has the key, of the right shape and dtype, and its kind is
    checked. Without the candidate's pixels (their kind not checked), the other outputs are
    judged as if every pixel agreed.

    They are judged against the golden arrays, or against ``ctx.reference`` when the oracle was
    run on the candidate's own inputs (:func:`_reference_frame`)."""
    from ..search import CULLED

    if ctx.reference is not None:
        G = {**G, **{name(k): ctx.reference[name(k)] for name in keys.VERTEX_ARRAYS if name(k) in ctx.reference}}
        prev_pixels = ctx.reference_starts.get(k)
    live = (G[keys.FLAGS(k)] & CULLED) == 0
    if usable(keys.REFLECTION_PIXEL(k)):
        gp, cp = G[keys.REFLECTION_PIXEL(k)], C[keys.REFLECTION_PIXEL(k)]
        agree = live & np.all(gp == cp, axis=1)
        findings, tie = _compare_pixels(ctx, k, G, C, live, agree, cand_traces, prev_pixels)
        _paint_pixels(ctx, k, G, live, agree, tie)
    else:
        findings, agree, tie = [], live, np.zeros(len(live), dtype=bool)
    n = int(live.sum())
    if usable(keys.VIRTUAL_VERTEX(k)):
        findings += _compare_virtual(ctx, k, G, C, agree, tie)
    for name, kind in ((keys.FLAGS(k), "flags"), (keys.VERTEX_OBJECT(k), "ids")):
        if usable(name):
            bad = agree & (G[name] != C[name])
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
        findings += _compare_float_field(ctx, name, G[name], C[name], agree, 0.0,
                                         extra=_score_slack(ctx, k, G, agree, C[name]))
    if cand_traces is not None and k in cand_traces and "trace" in ctx.kinds:
        findings.append(_compare_traces(ctx, k, live, cand_traces[k], prev_pixels))
    return findings


def _score_slack(ctx, k, G, agree, cand):
    """``extra`` of :func:`_compare_float_field` for the scores where the pixels agree, under a
    profile with ``score_k`` or on the candidate's own G-buffer: within ``score_k * TIE_EPS *
    (1 + 1/|U + B|)`` plus :func:`_saved_rounding` (None when neither applies)."""
    from ..search import HIDDEN
    from .precision import score_condition, tie_bound

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
            bound = bound + _saved_rounding(gb, eye, o.verts[i], pix, inverse)
        ok = np.abs(cand[i].astype(np.float64) - G[keys.SCORE(k)][i].astype(np.float64)) <= bound
        return {"within the scores' rounding bound": _mark(int(agree.sum()), np.flatnonzero(todo)[ok])}

    return run


def _compare_pixels(ctx, k, G, C, live, agree, cand_traces, prev_pixels):
    """The reflection-pixel rule: identical, or a tie by the oracle's own scores of both pixels,
    within the bound of :func:`refsoft.conformance.precision.tie_bound` for the score's
    conditioning ``|U + B|`` at the oracle's pixel. Returns (findings, tie (N,) bool)."""
    from ..search import HIDDEN, scores_at
    from .precision import score_condition, tie_bound

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
            bound = bound + _saved_rounding(gb, eye, o.verts[differ], gp[differ], inverse) + _saved_rounding(
                gb, eye, o.verts[differ], at_c, inverse)
        ok = covered & (np.abs(s_g - s_c) <= bound)
        tie[differ[ok]] = True
        for j, i in enumerate(differ[:5]):
            msg = (f"vertex {int(i)}: expected {_where(gp[i])} / observed {_where(cp[i])}, oracle scores "
                   f"{s_g[j]:.9g} / {s_c[j]:.9g} (difference {abs(s_g[j] - s_c[j]):.3g}, tie bound {bound[j]:.3g} "
                   f"at |U + B| = {cond[j]:.3g})" + (" (tie)" if ok[j] else ""))
            details.append(msg + _trace_note(ctx, k, int(i), cp[i], cand_traces, prev_pixels))
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


def _trace_note(ctx, k, i, observed, cand_traces, prev_pixels) -> str:
    """Where the candidate's supplied trace of vertex ``i`` parts from the oracle's walk, as a
    note for a differing pixel ("" without a trace)."""
    if cand_traces is None or i not in cand_traces.get(k, {}):
        return ""
    prev = None if prev_pixels is None else prev_pixels[i]
    path = cand_traces[k][i].get("path", [])
    div = _first_divergence(_oracle_trace(ctx, k, i, prev), path)
    if div:
        return f"; traces part at step {div[0]}: expected {div[1]} / observed {div[2]}"
    if path and list(path[-1]) != [int(x) for x in observed]:
        return f"; the supplied trace follows the oracle's walk but ends at {path[-1]}, not at the reported pixel"
    return "; the supplied trace follows the oracle's walk step for step"


def _paint_pixels(ctx, k, G, live, agree, tie):
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


def _compare_virtual(ctx, k, G, C, agree, tie) -> list:
    """Virtual vertices: the float rule where the pixels agree; at a tie, against the oracle's
    virtual vertex recomputed from the candidate's pixel (the case's refine and virtual rule)."""
    from ..search import SearchResult
    from ..search.method import virtual_relative

    vk = keys.VIRTUAL_VERTEX(k)
    gv, cv = G[vk].astype(np.float64), C[vk].astype(np.float64)
    if tie.any():
        o = ctx.oracle()
        gb, opts = ctx.stage_gbuffer(k), o.case.options
        sub = np.flatnonzero(tie)
        m = len(sub)
        res = SearchResult(C[keys.REFLECTION_PIXEL(k)][sub].astype(np.int32), np.zeros(m), np.zeros(m),
                           np.ones(m, np.int32), G[keys.FLAGS(k)][sub], opts.get("neighbourhood", "cross"),
                           opts.get("inverse", "plane"), 1, opts.get("method", "walk"))
        rel, _ = virtual_relative(gb, res, o.verts[sub], o.scene.camera_at(ctx.frame).eye, opts.get("refine", False),
                                  opts.get("virtual", "mirror"))
        gv[sub] = (rel.astype(np.float64) + gb.origin).astype(rel.dtype).astype(np.float64)
    sel = agree | tie
    extent = ctx.oracle().extent if not np.array_equal(gv[sel], cv[sel]) else 1.0
    return _compare_float_field(ctx, vk, gv, cv, sel, extent, extra=_virtual_slack(ctx, k, G, C, sel, gv, cv))


def _virtual_slack(ctx, k, G, C, sel, gv, cv):
    """``extra`` of :func:`_compare_float_field` for virtual vertices judged on the candidate's
    own G-buffer (None otherwise): within ``6 q (1 + |V - P| / |O - P|)`` of the reference, ``q``
    the rounding of the saved positions (:func:`_saved_rounding`'s): a position error ``e`` moves
    a mirrored vertex by at most ``2 e``, one by the plane rule ``4 e``, an unfolded one
    ``(2 + |V - P| / |O - P|) e``, and a sub-texel point, from three texels, by ``3 e``."""
    if ctx.stages.get(k) is None:
        return None

    def run(todo):
        i = np.flatnonzero(sel)[todo]
        o = ctx.oracle()
        gb, eye = ctx.stage_gbuffer(k), o.scene.camera_at(ctx.frame).eye
        pix = C[keys.REFLECTION_PIXEL(k)][i] if keys.REFLECTION_PIXEL(k) in C else G[keys.REFLECTION_PIXEL(k)][i]
        pix = np.clip(pix, 0, np.array(gb.mask.shape) - 1)
        rel = gb.position[pix[:, 0], pix[:, 1]].astype(np.float64)
        q = 0.5 * np.sqrt(3.0) * (_f32_ulp(np.abs(rel + gb.origin).max(axis=1)) + _f32_ulp(np.abs(rel).max(axis=1)))
        far = np.linalg.norm(o.verts[i] - gb.origin - rel, axis=1) / np.maximum(
            np.linalg.norm(eye - gb.origin - rel, axis=1), 1e-300)
        ref = gv[i]
        ok = np.linalg.norm(cv[i] - ref, axis=1) <= 6 * q * (1 + far)
        return {"within the saved positions' rounding": _mark(int(sel.sum()), np.flatnonzero(todo)[ok])}

    return run


def _compare_traces(ctx, k, live, traces, prev_pixels):
    """The traces the candidate supplies: the first step at which each walk leaves the
    oracle's."""
    parted = []
    for i, rec in sorted(traces.items()):
        if not (0 <= i < len(live)) or not live[i]:
            continue
        prev = None if prev_pixels is None else prev_pixels[i]
        div = _first_divergence(_oracle_trace(ctx, k, i, prev), rec.get("path", []))
        if div:
            parted.append(f"vertex {i}: step {div[0]}, expected {div[1]} / observed {div[2]}")
    return ctx.finding(f"traces_{k}", "trace", "fail" if parted else "pass",
                       "walks part from the oracle's" if parted else "every supplied walk follows the oracle's",
                       len(parted), len(traces), details=parted[:5])


def _vertex_keys(k):
    return {name(k) for name in keys.VERTEX_ARRAYS}


def _oracle_only(key) -> bool:
    p = _parse(key)
    return p is not None and p[0] in ORACLE_ONLY


def check_frame(ctx, G, C, loose, cand_traces=None, prev_pixels=None):
    """Judge every output of one frame whose kind ``ctx.kinds`` names; appends to
    ``ctx.findings``. An output the candidate lacks is ``missing`` (a failure). ``prev_pixels``:
    ``{reflector: pixels}`` of the golden's previous frame (coherence). After the G-buffer, the
    outputs are judged against ``ctx.reference`` when it is set (:func:`_reference_frame`)."""
    ctx.loose = bool(loose)
    reflectors = keys.reflectors(G)
    vertex_keys = set().union(*[_vertex_keys(k) for k in reflectors]) if reflectors else set()

    def kind(key):  # reflected_id belongs to a comparison method's per-pixel decision
        return comparison.frame_kind(G, key) or output_kind(key)

    broken = {key for key in G if _oracle_only(key) or kind(key) not in ctx.kinds + ("other",)}
    for key in sorted(G):
        if key in broken:
            continue
        if key not in C:
            ctx.finding(key, "presence", "missing", "not in the candidate's outputs", kind=kind(key))
            broken.add(key)
            continue
        g, c = G[key], C[key]
        if g.shape != c.shape or g.dtype != c.dtype:
            ctx.finding(key, "shape/dtype", "fail", f"expected {g.dtype}{list(g.shape)} / observed {c.dtype}{list(c.shape)}",
                        kind=kind(key))
            broken.add(key)
            continue
        if g.dtype.kind == "f" and not np.array_equal(np.isfinite(g), np.isfinite(c)):
            bad = np.argwhere(np.isfinite(g) != np.isfinite(c))
            ctx.finding(key, "non-finite", "fail", "non-finite values at other places", len(bad), g.size,
                        f"at {_where(bad[0])}", kind=kind(key))
            broken.add(key)
    by_method = comparison.judged_keys(G)
    for key in sorted(G):
        if key in broken or key in by_method:
            continue
        g, c = G[key], C[key]
        name, k = keys.parse(key) or (None, None)
        if name == keys.GBUFFER_MASK:
            _compare_mask(ctx, key, g, c, k)
        elif name in (keys.GBUFFER_POSITION, keys.GBUFFER_NORMAL):
            mk = keys.GBUFFER_MASK(k)
            cover = G[mk] & C[mk] if mk in C and C[mk].shape == G[mk].shape else G[mk]
            extent = ctx.oracle().extent if not np.array_equal(g[cover], c[cover]) else 1.0
            _compare_float_field(ctx, key, g, c, cover, extent, normals=name == keys.GBUFFER_NORMAL,
                                 extra=_gbuffer_alternatives(ctx, name, k, G, cover, c[cover], extent))
        elif name == keys.GBUFFER_VIEW_PROJ:
            _compare_float_field(ctx, key, g.reshape(1, -1), c.reshape(1, -1), np.ones(1, bool), 1.0)
        elif key == keys.IMAGE:
            _compare_image(ctx, g if ctx.reference is None else ctx.reference[key], c, loose)
        elif key in (keys.OBJECT_ID, keys.REFLECTED_ID):
            d = int((g != c).sum())
            ctx.finding(key, "ids (reported)", "pass" if d == 0 else "accepted",
                        "identical" if d == 0 else "differ (reported, not judged)", d, g.size)
        elif key in vertex_keys:
            continue
        else:
            same = np.array_equal(g, c, equal_nan=True)
            ctx.finding(key, "other", "pass" if same else "accepted", "identical" if same else "differs (not judged)")
    for k in reflectors:
        _compare_vertices(ctx, k, G, C, cand_traces, prev_pixels.get(k) if prev_pixels else None,
                          lambda key: key in G and key not in broken)
    if by_method:
        comparison.judge_frame(ctx, G, C, lambda key: key in G and key not in broken)


def _check_report_folder(out, golden, candidate):
    from ..io import inside

    for folder, role in ((golden, "golden set"), (candidate, "candidate")):
        if inside(out, folder):
            raise RefsoftError(f"report folder {out} is inside the {role} {folder}: give --out a folder outside "
                               "both (default out/check)")


def _clear_old_report(out):
    """Remove the pictures an earlier report in ``out`` lists in its ``summary.json`` (only
    those), so that a new report never shows an old failure."""
    from ..io import read_json

    path = os.path.join(out, "summary.json")
    if not os.path.isfile(path):
        return
    try:
        old = read_json(path)
    except InputFileError:
        return
    pictures = old.get("pictures", []) if isinstance(old, dict) else []
    for name in pictures if isinstance(pictures, list) else []:
        if isinstance(name, str) and name.endswith(".png") and os.path.basename(name) == name:
            p = os.path.join(out, name)
            if os.path.isfile(p):
                os.unlink(p)


def by_kind(findings) -> dict:
    """``{kind: {status: count}}`` over ``findings``, kinds sorted."""
    out = {}
    for f in findings:
        out.setdefault(f.kind, dict.fromkeys(STATUSES, 0))[f.status] += 1
    return dict(sorted(out.items()))


def version_note(manifest) -> dict:
    """The NumPy and Numba versions that made a golden set and those of this checker, and a
    one-line ``note`` when they differ (None when they agree): the set's references were
    computed by other library versions than the ones ``check`` recomputes with (ties, virtual
    vertices), which the constraints file of ``docs/ports.md`` pins."""
    import numba

    golden = {"numpy": manifest.get("numpy"), "numba": manifest.get("numba")}
    here = {"numpy": np.__version__, "numba": numba.__version__}
    differ = [f"{lib} {golden[lib]} (this checker: {here[lib]})" for lib in ("numpy", "numba") if golden[lib] != here[lib]]
    note = None
    if differ:
        note = ("the golden set was made with " + " and ".join(differ)
                + ": install the versions it records (pip install . -c constraints.txt) for a like-for-like check")
    return {"golden": golden, "checker": here, "note": note}


def check(golden, candidate, loose=False, out=None, cases=None, progress=False, kinds=None, profile="default") -> dict:
    """Compare a candidate folder with a golden set; returns the summary (also written to
    ``out/summary.json`` when ``out`` is given).

    Parameters
    ----------
    golden, candidate : str or PathLike
    loose : bool
        The loose image rule.
    out : str or PathLike, optional
        Report folder, outside the golden and candidate folders: ``summary.json`` (every
        finding, the counts per kind and status, the pictures written) and, for each output
        that did not pass, its error mask (and the image's difference), magnified
        :data:`MAGNIFY` times. Pictures an earlier report there listed are removed first.
    cases : list of str, optional
        Only these cases (the others are excluded, not missing).
    kinds : list of str, optional
        Only these kinds of output (:data:`KINDS`; names may also be comma-separated): the
        others are neither judged nor required. By default every kind: an output or a case
        frame the candidate lacks is ``missing``, which fails the check like ``fail``.
    profile : {"default", "gpu"}
        The rules (:mod:`refsoft.conformance.profiles`): the exact ones, or those for a port
        using its GPU's own interpolation and built-ins (which implies ``loose``).

    Raises
    ------
    RefsoftError
        No golden set, no candidate folder, an unknown case, ``out`` inside either folder.
    InputFileError
        The manifest, a frame's ``.npz`` or a candidate's traces cannot be read or are malformed.
    """
    from .golden import read_manifest, sha256
    from ..io import read_npz, write_json

    golden, candidate = os.fspath(golden), os.fspath(candidate)
    kinds = check_kinds(kinds)
    prof = get_profile(profile)
    loose = bool(loose or prof.loose_images)
    manifest = read_manifest(golden)
    if not os.path.isdir(candidate):
        raise RefsoftError(f"{candidate} is not a folder")
    if out is not None:
        out = os.fspath(out)
        _check_report_folder(out, golden, candidate)
    entries = manifest["cases"]
    if cases is not None:
        names = {e["name"] for e in entries}
        unknown = [c for c in cases if c not in names]
        if unknown:
            raise RefsoftError(f"unknown case {unknown[0]!r} (the golden set has: {', '.join(sorted(names))})")
        entries = [e for e in entries if e["name"] in cases]
    if out is not None:
        os.makedirs(out, exist_ok=True)
        _clear_old_report(out)
    findings, missing_cases, pictures = [], [], []
    todo = [(e, f) for e in entries for f in e["frames"]]
    it = todo
    if progress and len(todo) > 1:
        from tqdm import tqdm

        it = tqdm(todo, desc="check", unit="frame", disable=None)
    prev, cand_prev, drivers = {}, {}, {}
    for entry, f in it:
        name = entry["name"]
        ctx = _Context(name, f, entry, out, kinds, prof)
        rel = f"{name}/frame_{f:04d}.npz"
        gpath = os.path.join(golden, rel)
        if not os.path.isfile(gpath) or manifest["files"].get(rel) != sha256(gpath):
            ctx.finding("*", "reference", "fail", f"golden file {rel} is missing or altered (SHA-256)")
            findings += ctx.findings
            continue
        if f == entry["frames"][0] and entry["options"].get("method") == "ldt":
            textures.judge_textures(ctx, golden, candidate, manifest)  # ldt_J.npz, once per case
        cpath = os.path.join(candidate, rel)
        if not os.path.isfile(cpath):
            ctx.finding("*", "presence", "missing", f"{rel} not in the candidate")
            missing_cases.append(rel)
            findings += ctx.findings
            continue
        G, C = read_npz(gpath), read_npz(cpath)
        traces = _load_traces(os.path.join(candidate, name, f"traces_{f:04d}.json"))
        coherent = entry["options"].get("coherence", True)
        _reference_frame(ctx, G, C, prev.get(name), cand_prev.get(name), drivers)
        check_frame(ctx, G, C, loose, traces, prev.get(name) if coherent else None)
        prev[name] = {k: G[keys.REFLECTION_PIXEL(k)] for k in keys.reflectors(G)}
        cand_prev[name] = {k: C[key] for k in keys.reflectors(G) if (key := keys.REFLECTION_PIXEL(k)) in C
                           and C[key].shape == G[key].shape and C[key].dtype == G[key].dtype}
        findings += ctx.findings
        pictures += ctx.pictures
    counts = {s: sum(1 for f in findings if f.status == s) for s in STATUSES}
    summary = {"golden": os.path.abspath(golden), "candidate": os.path.abspath(candidate), "loose": bool(loose),
               "profile": prof.name,
               "golden_refsoft": manifest.get("refsoft"), "golden_git": manifest.get("git"),
               "versions": version_note(manifest),
               "cases": [e["name"] for e in entries], "kinds": list(kinds),
               "passed": counts["fail"] == 0 and counts["missing"] == 0, "counts": counts, "by_kind": by_kind(findings),
               "missing_files": missing_cases, "pictures": pictures, "findings": [f.to_dict() for f in findings]}
    if out is not None:
        write_json(os.path.join(out, "summary.json"), summary)
    summary["_findings"] = findings
    return summary

"""``refsoft check``'s rules for the comparison methods (DESIGN-ldt 2.9 and 5; the table of
``docs/ports.md``, "The comparison methods"): the layered depth textures (``CASE/ldt_J.npz``
once per case, the ``ldt_*`` arrays of every frame) and the environment map (the cube maps and
the lookups of every frame).

Kinds and rules (tolerances in :mod:`refsoft.constants`):

- ``ldt_texture``, each ``ldt_J.npz``: ``triangle`` (coverage and triangle ids) identical except
  texels whose centre lies within the profile's edge distance of an edge of the object's
  triangles projected on that face (float64, unsnapped; 1e-4 texel by default); ``depth``
  within 4 float32 ULP and ``normal`` by the G-buffer rule (4 ULP or 1e-4 rad) where the
  triangle ids agree (the ``gpu`` profile: also within 1/256 texel times the value's rate of
  change across the face); ``count_raw``, ``count`` and ``mismatch`` identical except at those
  ambiguous texels; ``back`` the pairing of the candidate's own depths and counts (the rule of
  docs/ldt.md, "Back depths", in float32) within 4 ULP of the larger of the back depth and its
  partner depth; ``cube_center`` and ``cube_half`` within 4 float32 ULP or 1e-6 of the cube's
  side; ``open`` and ``layers_capped`` identical.
- ``ldt_region``: ``ldt_region_K`` and ``ldt_object_ids`` identical.
- ``ldt_ray``: at the reflector pixels, ``ldt_ray_origin`` by the G-buffer position rule and
  ``ldt_ray_dir`` by the normal rule (``gpu``: also within 1/256 px times the surface's rate of
  change in the main view: ``|dP|`` for the origin, ``2 |dN| + |dP| / |P - eye|`` radians for
  the direction).
- ``ldt_pixel``: at each reflector pixel ``reflected_id``, ``ldt_face``, ``ldt_layer`` and
  ``ldt_texel`` identical; a pixel where one differs is a tie (accepted) when the oracle's
  ``ldt_margin`` is at most ``LDT_TIE_MARGIN``; more than 1% of the reflector pixels tied fail.
  Where they agree: ``ldt_hit_position`` and ``ldt_hit_distance`` within ``LDT_HIT_TOL`` times
  the hit object's cube side in world units plus 4 float32 ULP; ``ldt_object_distance`` the same
  for each object, accepted beyond it on at most 1% of the reflector pixels; ``ldt_residual``
  within 4 ULP plus 4 ULP of 1.0 times R.
- ``ldt_counts``: where the pixel's result agrees, ``ldt_flags`` identical and
  ``ldt_linear_samples``, ``ldt_binary_steps``, ``ldt_faces_searched``, ``ldt_objects_tested``
  identical up to 1% of the reflector pixels. ``ldt_margin`` is of kind ``margin``: shape,
  dtype and non-finite places only.
- ``envmap_cube``: ``envmap_id_K`` identical except texels within the edge distance of a
  projected edge (the reflected objects' world triangles, clipped at the near plane);
  ``envmap_color_K`` as 8-bit images (``refsoft.raster.to_uint8``), face by face, by the image
  rule (``--loose`` and the ``gpu`` profile: the loose rule), at the texels whose ids agree;
  ``envmap_center_K`` within 4 float32 ULP or 1e-6 of the scene's extent.
- ``envmap_pixel``: ``envmap_face``, ``envmap_texel`` and ``reflected_id`` identical; a
  differing texel of the same face is a tie when it is a neighbour and the oracle's ``s R`` (or
  ``t R``, whichever differs) lies within ``ENVMAP_TIE_ULP * TIE_EPS * R`` of an integer; a
  differing face is a tie when it is the neighbouring face toward which the oracle's direction
  lies within that distance of the cube's edge, unless the direction lies exactly on the edge
  (``|r_a| == |r_b|``: the face order, z over y over x, decides); more than 1% ties fail. Where
  face and texel agree, a different ``reflected_id`` is accepted only where it is the
  candidate's own cube-map id of that texel and that texel's id was accepted as ambiguous.

In every frame, off the reflector pixels the per-pixel arrays must equal the oracle's (their
fill values). The oracle's data the rules read: its meshes and cubes (edge distances, rates),
its reflected rays (the environment map's texel coordinates, recomputed with
:func:`refsoft.envmap.method.reflected_rays`), and the golden ``ldt_margin``.
"""

from __future__ import annotations

import re

import numpy as np

from .. import keys
from ..constants import (ENVMAP_TIE_ULP, EXTENT_TOL, F32_ULP_TOL, IMAGE_LOOSE_SHARE, IMAGE_TOL, IMAGE_TOL_LOOSE,
                         ITERATION_SHARE_MAX, LDT_HIT_TOL, LDT_TIE_MARGIN, NORMAL_ANGLE_TOL, TIE_EPS, TIE_SHARE_MAX)

#: Frame-wide keys of the comparison methods -> their kind.
FRAME_KINDS = {keys.LDT_RAY_ORIGIN: "ldt_ray", keys.LDT_RAY_DIR: "ldt_ray", keys.LDT_OBJECT_IDS: "ldt_region",
               keys.LDT_MARGIN: "margin", keys.ENVMAP_FACE: "envmap_pixel", keys.ENVMAP_TEXEL: "envmap_pixel",
               **dict.fromkeys((keys.LDT_HIT_POSITION, keys.LDT_HIT_DISTANCE, keys.LDT_FACE, keys.LDT_LAYER,
                                keys.LDT_TEXEL, keys.LDT_RESIDUAL, keys.LDT_OBJECT_DISTANCE), "ldt_pixel"),
               **dict.fromkeys((keys.LDT_LINEAR_SAMPLES, keys.LDT_BINARY_STEPS, keys.LDT_FACES_SEARCHED,
                                keys.LDT_OBJECTS_TESTED, keys.LDT_FLAGS), "ldt_counts")}
#: Per-reflector names of the comparison methods -> their kind.
PER_REFLECTOR_KINDS = {keys.LDT_REGION: "ldt_region", keys.ENVMAP_COLOR: "envmap_cube", keys.ENVMAP_ID: "envmap_cube",
                       keys.ENVMAP_CENTER: "envmap_cube"}
#: ``ldt_J.npz`` of a golden case, and the key of one of its arrays in findings (``ldt_J.NAME``).
TEXTURE_FILE = re.compile(r"^ldt_(\d+)\.npz$")
TEXTURE_KEY = re.compile(r"^ldt_(\d+)\.(npz|\w+)$")
#: The per-pixel decision of each method: the arrays judged together at a reflector pixel.
LDT_DECISION = (keys.REFLECTED_ID, keys.LDT_FACE, keys.LDT_LAYER, keys.LDT_TEXEL)
ENVMAP_DECISION = (keys.REFLECTED_ID, keys.ENVMAP_FACE, keys.ENVMAP_TEXEL)
_LDT_COUNTERS = (keys.LDT_LINEAR_SAMPLES, keys.LDT_BINARY_STEPS, keys.LDT_FACES_SEARCHED, keys.LDT_OBJECTS_TESTED)


def texture_key(j: int, name: str) -> str:
    """The key of array ``name`` of object ``j``'s ``ldt_J.npz`` in findings (``"ldt_2.depth"``;
    ``"ldt_2.npz"`` for the whole file)."""
    return f"{keys.ldt_file(j)}.{name}"


def kind_of(key: str):
    """The kind of a comparison method's key, or None for any other key."""
    if key in FRAME_KINDS:
        return FRAME_KINDS[key]
    if TEXTURE_KEY.match(key):
        return "ldt_texture"
    p = keys.parse(key)
    return PER_REFLECTOR_KINDS.get(p[0]) if p is not None else None


def method_of(G) -> str | None:
    """``"ldt"`` or ``"envmap"`` for a golden frame of that method, else None."""
    if keys.LDT_FACE in G:
        return "ldt"
    if keys.ENVMAP_FACE in G:
        return "envmap"
    return None


def frame_kind(G, key):
    """The kind of ``key`` in the golden frame ``G`` when a comparison method's rule judges it
    (``reflected_id`` belongs to the method's per-pixel decision), else None."""
    method = method_of(G)
    if method is not None and key == keys.REFLECTED_ID:
        return "ldt_pixel" if method == "ldt" else "envmap_pixel"
    return kind_of(key)


def judged_keys(G) -> set:
    """The keys of the golden frame ``G`` the rules of this module judge (the others are left to
    :func:`refsoft.conformance.check.check_frame`'s own; ``ldt_margin`` is one of those)."""
    out = {k for k in G if kind_of(k) is not None and k != keys.LDT_MARGIN}
    if method_of(G) is not None:
        out.add(keys.REFLECTED_ID)
    return out


# --- small pieces -----------------------------------------------------------------------------

def _ulp(x):
    return np.spacing(np.abs(np.asarray(x, dtype=np.float32))).astype(np.float64)


def _where(idx) -> str:
    return "(" + ", ".join(str(int(i)) for i in idx) + ")"


def _per_pixel(a, shape):
    """``a`` with one row per pixel of an (H, W) frame: (H, W, ...) and (K, H, W) both to
    (H, W, m)."""
    a = np.asarray(a)
    if a.shape[:2] == tuple(shape):
        return a.reshape(shape + (-1,))
    return np.moveaxis(a, 0, -1).reshape(shape + (-1,))


def _same(g, c, shape):
    """(H, W) bool: the pixel's values are identical."""
    return np.all(_per_pixel(g, shape) == _per_pixel(c, shape), axis=-1)


#: How far from an edge the rules measure distances (texels; beyond: "more than").
_REACH = 1e-3


def _edge_note(d, edge_px) -> str:
    reach = max(edge_px, _REACH)
    return f"{d:.3g} texels from an edge" if np.isfinite(d) else f"more than {reach:.3g} texels from an edge"


def _status(bad: int, differ: int) -> str:
    return "fail" if bad else ("accepted" if differ else "pass")


def _world_scale(scene, j, frame) -> float:
    """The largest factor object ``j``'s transform stretches a length by at ``frame``."""
    return float(np.linalg.norm(scene.transform_at(j, frame).matrix()[:3, :3], 2))


def _float_ok(g, c, extent, normals=False):
    from .check import _float_rule

    return _float_rule(np.asarray(g), np.asarray(c), extent, normals)[0]


def _angle(u, v):
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v))


# --- per frame ------------------------------------------------------------------------------------

def judge_frame(ctx, G, C, usable) -> None:
    """Judge a comparison method's outputs of one frame (the keys of :func:`judged_keys`);
    appends to ``ctx.findings``. ``usable(key)``: the candidate has the key, of the golden shape
    and dtype, and its kind is checked."""
    method = method_of(G)
    for key in sorted(G):
        p = keys.parse(key)
        if p is not None and p[0] == keys.LDT_REGION and usable(key) or key == keys.LDT_OBJECT_IDS and usable(key):
            same = np.array_equal(G[key], C[key])
            diff = int(np.sum(G[key] != C[key]))
            ctx.finding(key, "identical", "pass" if same else "fail", "identical" if same else "differ", diff,
                        G[key].size)
    if method == "ldt":
        _LdtFrame(ctx, G, C, usable).judge()
    elif method == "envmap":
        _EnvmapFrame(ctx, G, C, usable).judge()


class _Frame:
    """What the per-pixel rules of both methods share."""

    decision = ()
    kind = ""

    def __init__(self, ctx, G, C, usable):
        self.ctx, self.G, self.C, self.usable = ctx, G, C, usable
        self.shape = G[keys.OBJECT_ID].shape
        self.on = G[keys.REFLECTED_ID] >= 0  # the reflector pixels
        self.n = int(self.on.sum())
        self.dec = [k for k in self.decision if usable(k)]
        self.same = {k: _same(G[k], C[k], self.shape) for k in self.dec}
        self.agree = np.logical_and.reduce([self.same[k] for k in self.dec]) if self.dec else np.ones(self.shape, bool)

    def finding(self, key, rule, status, message="", count=0, total=0, worst="", details=None):
        return self.ctx.finding(key, rule, status, message, count, total, worst, details, kind=kind_of(key) or self.kind)

    def off_reflectors(self, key):
        """(H, W) bool: pixels off the reflectors where the candidate differs (they must hold the
        fill values, as the oracle's)."""
        return ~self.on & ~_same(self.G[key], self.C[key], self.shape)

    def decide(self, tie, notes=None):
        """The decision's findings: each array identical at the reflector pixels, except at the
        ties ``tie`` (H, W); more than TIE_SHARE_MAX ties fail."""
        notes = notes or {}
        n_tie = int(tie.sum())
        many = n_tie > TIE_SHARE_MAX * max(self.n, 1)
        for key in self.dec:
            differ = self.on & ~self.same[key]  # off the reflectors: judge() requires the fill values
            bad = differ & ~tie
            nbad = int(bad.sum())
            worst = ""
            if nbad:
                r, c = np.argwhere(bad)[0]
                worst = f"at ({r}, {c}): expected {self.describe(self.G, r, c)} / observed {self.describe(self.C, r, c)}"
                worst += notes.get((int(r), int(c)), "")
            if nbad or (many and differ.any()):
                self.finding(key, self.rule, "fail", f"{nbad} differ beyond ties, {n_tie} ties of the pixels "
                             f"(at most {TIE_SHARE_MAX:.0%} allowed)", nbad or int(differ.sum()), self.n, worst)
            elif differ.any():
                self.finding(key, self.rule, "accepted", f"differing pixels are ties ({self.tie_rule})",
                             int(differ.sum()), self.n)
            else:
                self.finding(key, self.rule, "pass", "identical", 0, self.n)
        differ = self.on & ~self.agree
        if self.ctx.out is not None and differ.any():
            self.ctx.paint(self.kind, self.shape, np.argwhere(differ & tie), np.argwhere(differ & ~tie),
                           self.on & self.agree)

    def counters(self, names, share):
        """Arrays identical where the decision agrees (and off the reflectors); ``share``: the
        share of reflector pixels that may differ (accepted)."""
        for key in names:
            if not self.usable(key):
                continue
            g, c = self.G[key], self.C[key]
            differ = self.on & self.agree & ~_same(g, c, self.shape)
            off = self.off_reflectors(key)
            nd, no = int(differ.sum()), int(off.sum())
            worst = ""
            if nd or no:
                r, cc = np.argwhere(differ | off)[0]
                worst = f"at ({r}, {cc}): expected {_per_pixel(g, self.shape)[r, cc].tolist()} / observed " \
                        f"{_per_pixel(c, self.shape)[r, cc].tolist()}"
            status = "fail" if no or nd > share * max(self.n, 1) else _status(0, nd)
            msg = "identical where the pixels agree" if not (nd or no) else (
                f"differ where the pixels agree (at most {share:.0%} allowed)" + (f"; {no} off the reflectors" if no else ""))
            self.finding(key, "identical", status, msg, nd + no, self.n, worst)

    def floats(self, key, sel, tol_fn, message, share=0.0, extra=None):
        """A float array (per pixel) within ``tol_fn(g, c, index) -> (ok (m,) bool, error)`` at
        the pixels ``sel``, identical off the reflectors; beyond it accepted on at most ``share``
        of the reflector pixels. ``extra(index, not ok) -> (m,) bool``: accepted otherwise."""
        if not self.usable(key):
            return
        g, c = _per_pixel(self.G[key], self.shape), _per_pixel(self.C[key], self.shape)
        idx = np.argwhere(sel)
        gg, cc = g[sel], c[sel]
        ok, err = tol_fn(gg, cc, idx)
        if extra is not None and (~ok).any():
            ok = ok | extra(idx, ~ok)
        off = self.off_reflectors(key)
        nbad, no = int((~ok).sum()), int(off.sum())
        same = np.all(gg == cc, axis=-1)
        worst = ""
        if nbad:
            i = int(np.argmax(np.where(~ok, err, -1)))
            worst = f"at {_where(idx[i])}: expected {np.round(gg[i], 9).tolist()} / observed {np.round(cc[i], 9).tolist()}"
        if no or nbad > share * max(self.n, 1):
            self.finding(key, "float", "fail", f"beyond {message}" + (f"; {no} off the reflectors" if no else ""),
                         nbad + no, len(idx), worst)
        elif nbad or not same.all():
            self.finding(key, "float", "accepted", f"within {message}" + (
                f", except {nbad} (at most {share:.0%} allowed)" if nbad else ""), int((~same).sum()), len(idx), worst)
        else:
            self.finding(key, "float", "pass", "identical", 0, len(idx))


class _LdtFrame(_Frame):
    decision = LDT_DECISION
    kind = "ldt_pixel"
    rule = "ldt pixel"
    tie_rule = f"the oracle's ldt_margin at most {LDT_TIE_MARGIN:.3g}"

    @staticmethod
    def describe(A, r, c):
        t = A[keys.LDT_TEXEL][r, c] if keys.LDT_TEXEL in A else ("?", "?")
        return (f"object {A[keys.REFLECTED_ID][r, c] if keys.REFLECTED_ID in A else '?'} face "
                f"{A[keys.LDT_FACE][r, c] if keys.LDT_FACE in A else '?'} layer "
                f"{A[keys.LDT_LAYER][r, c] if keys.LDT_LAYER in A else '?'} texel ({t[0]}, {t[1]})")

    def judge(self):
        G = self.G
        margin = G[keys.LDT_MARGIN].astype(np.float64)
        tie = self.on & ~self.agree & (margin <= LDT_TIE_MARGIN)
        notes = {(int(r), int(c)): f", oracle margin {margin[r, c]:.3g}" for r, c in np.argwhere(self.on & ~self.agree)[:50]}
        self.decide(tie, notes)
        for key in self.dec:  # off the reflectors: the fill values
            off = self.off_reflectors(key)
            if off.any():
                self.finding(key, "identical", "fail", "differ off the reflectors", int(off.sum()), off.size)
        hit = self.on & self.agree & (G[keys.LDT_FACE] >= 0)
        side = self.sides()
        ids = G[keys.REFLECTED_ID]

        def hit_rule(gg, cc, idx):
            s = side[ids[idx[:, 0], idx[:, 1]]]
            err = np.abs(gg.astype(np.float64) - cc.astype(np.float64)).max(axis=1)
            return err <= LDT_HIT_TOL * s + F32_ULP_TOL * _ulp(np.abs(gg).max(axis=1)), err

        msg = f"{LDT_HIT_TOL} x the hit object's cube side + {F32_ULP_TOL} float32 ULP where the texels agree"
        self.floats(keys.LDT_HIT_POSITION, hit, hit_rule, msg)
        self.floats(keys.LDT_HIT_DISTANCE, hit, hit_rule, msg)
        self.object_distances(side)
        R = int(self.ctx.entry["options"].get("ldt_resolution", 256))

        def residual_rule(gg, cc, idx):
            err = np.abs(gg.astype(np.float64) - cc.astype(np.float64))[:, 0]
            return err <= F32_ULP_TOL * _ulp(gg[:, 0]) + F32_ULP_TOL * 2.0 ** -23 * R, err

        self.floats(keys.LDT_RESIDUAL, hit, residual_rule, f"{F32_ULP_TOL} ULP + {F32_ULP_TOL} ULP of 1.0 x R "
                    "where the texels agree")
        self.rays()
        self.counters((keys.LDT_FLAGS,), 0.0)
        self.counters(_LDT_COUNTERS, ITERATION_SHARE_MAX)

    def sides(self) -> np.ndarray:
        """Each object's cube side in world units this frame, indexed by object id (0 unused)."""
        from ..ldt.build import cube_of

        scene = self.ctx.oracle().scene
        R = int(self.ctx.entry["options"].get("ldt_resolution", 256))
        out = np.zeros(len(scene.objects) + 1)
        for j in range(1, len(scene.objects) + 1):
            if not scene.object_by_id(j).reflector:
                out[j] = 2.0 * cube_of(scene.object_by_id(j).mesh.vertices, R)[1] * _world_scale(scene, j, self.ctx.frame)
        return out

    def object_distances(self, side):
        key = keys.LDT_OBJECT_DISTANCE
        if not self.usable(key) or keys.LDT_OBJECT_IDS not in self.G:
            return
        obj_side = side[self.G[keys.LDT_OBJECT_IDS]]

        def rule(gg, cc, idx):
            g64, c64 = gg.astype(np.float64), cc.astype(np.float64)
            err = np.abs(g64 - c64)
            ok = (err <= LDT_HIT_TOL * obj_side[None, :] + F32_ULP_TOL * _ulp(gg)).all(axis=1)
            return ok, err.max(axis=1)

        self.floats(key, self.on & self.agree, rule, f"{LDT_HIT_TOL} x each object's cube side + {F32_ULP_TOL} "
                    "float32 ULP where the pixels agree", share=TIE_SHARE_MAX)

    def rays(self):
        """``ldt_ray_origin`` and ``ldt_ray_dir`` at the reflector pixels (the G-buffer rules;
        the ``gpu`` profile's interpolation slack from the main view's rates)."""
        o = self.ctx.oracle()
        extent = o.extent
        prof = self.ctx.profile

        def origin(gg, cc, idx):
            return _float_ok(gg, cc, extent), np.abs(gg.astype(np.float64) - cc.astype(np.float64)).max(axis=1)

        def direction(gg, cc, idx):
            return _float_ok(gg, cc, extent, normals=True), _angle(gg, cc)

        slack = None
        if prof.subpixel_px:
            def slack(which):
                def run(idx, todo):
                    i = np.flatnonzero(todo)
                    fr, dist = self.main_view_fragments(idx[i])
                    c = _per_pixel(self.C[which], self.shape)[idx[i, 0], idx[i, 1]].astype(np.float64)
                    g = _per_pixel(self.G[which], self.shape)[idx[i, 0], idx[i, 1]].astype(np.float64)
                    out = np.zeros(len(idx), bool)
                    if which == keys.LDT_RAY_ORIGIN:
                        ok = np.abs(c - g).max(axis=1) <= EXTENT_TOL * extent + prof.subpixel_px * fr.position_rate
                    else:
                        ok = _angle(g, c) <= NORMAL_ANGLE_TOL + prof.subpixel_px * (
                            2.0 * fr.normal_rate + fr.position_rate / np.maximum(dist, 1e-300))
                    out[i[ok]] = True
                    return out
                return run
        self.floats(keys.LDT_RAY_ORIGIN, self.on, origin, f"{F32_ULP_TOL} float32 ULP or {EXTENT_TOL} x extent",
                    extra=slack(keys.LDT_RAY_ORIGIN) if slack else None)
        self.floats(keys.LDT_RAY_DIR, self.on, direction, f"{F32_ULP_TOL} float32 ULP or {NORMAL_ANGLE_TOL} rad",
                    extra=slack(keys.LDT_RAY_DIR) if slack else None)

    def main_view_fragments(self, pixels):
        """The reflector's fragments of the main view at ``pixels`` (n, 2) (exact float64
        interpolation and rates, :func:`refsoft.conformance.profiles.fragments`) and their
        distance from the eye."""
        from ..raster import _setup, rasterize
        from .profiles import fragments

        o = self.ctx.oracle()
        cam = o.scene.camera_at(self.ctx.frame)
        ids = self.G[keys.OBJECT_ID][pixels[:, 0], pixels[:, 1]]
        n = len(pixels)
        rate = np.zeros(n), np.zeros(n)
        pos = np.zeros((n, 3))
        for k in np.unique(ids):
            sel = ids == k
            mesh = o.scene.world_mesh(int(k), self.ctx.frame)
            frags = rasterize(_setup.transform_points(mesh.vertices, cam.view_proj()), mesh.faces, cam.width,
                              cam.height)
            tri = frags.triangle[pixels[sel, 0], pixels[sel, 1]]
            fr = fragments(mesh, cam.view_proj(), cam.width, cam.height, pixels[sel], np.maximum(tri, 0))
            rate[0][sel], rate[1][sel], pos[sel] = fr.position_rate, fr.normal_rate, fr.position
        from .profiles import Fragment

        dist = np.linalg.norm(pos - np.asarray(cam.eye, np.float64), axis=1)
        return Fragment(pos, np.zeros((n, 3)), np.zeros(n), rate[0], rate[1], np.zeros(n)), dist


class _EnvmapFrame(_Frame):
    decision = ENVMAP_DECISION
    kind = "envmap_pixel"
    rule = "envmap pixel"

    @property
    def tie_rule(self):
        return f"the oracle's texel coordinate within {ENVMAP_TIE_ULP} x 2^-24 x R of an integer"

    @staticmethod
    def describe(A, r, c):
        t = A[keys.ENVMAP_TEXEL][r, c] if keys.ENVMAP_TEXEL in A else ("?", "?")
        return (f"object {A[keys.REFLECTED_ID][r, c] if keys.REFLECTED_ID in A else '?'} face "
                f"{A[keys.ENVMAP_FACE][r, c] if keys.ENVMAP_FACE in A else '?'} texel ({t[0]}, {t[1]})")

    def judge(self):
        self.reflector_ids = sorted(p[1] for key in self.G if (p := keys.parse(key)) and p[0] == keys.ENVMAP_ID)
        self.accepted_ids = {}  # reflector -> (6, R, R) bool: cube-map ids accepted as ambiguous
        for k in self.reflector_ids:
            self.cube(k)
        tie, notes = self.ties()
        self.decide(tie, notes)
        for key in self.dec:
            off = self.off_reflectors(key)
            if off.any():
                self.finding(key, "identical", "fail", "differ off the reflectors", int(off.sum()), off.size)

    def cube(self, k):
        """Reflector ``k``'s cube map: ids (edge ambiguity), colours (8-bit, image rule), centre."""
        from ..raster import to_uint8

        G, C = self.G, self.C
        key_id, key_col, key_c = keys.ENVMAP_ID(k), keys.ENVMAP_COLOR(k), keys.ENVMAP_CENTER(k)
        ids_ok = np.ones(G[key_id].shape, bool)
        if self.usable(key_id):
            g, c = G[key_id], C[key_id]
            diff = np.argwhere(g != c)
            ids_ok = g == c
            if not len(diff):
                self.finding(key_id, "coverage", "pass", "identical", 0, g.size)
            else:
                dist = self.cube_distance(k, diff)
                amb = dist <= self.ctx.profile.edge_px
                acc = np.zeros(g.shape, bool)
                acc[tuple(diff[amb].T)] = True
                self.accepted_ids[k] = acc
                bad = diff[~amb]
                worst = "" if not len(bad) else (f"at face {bad[0][0]} texel ({bad[0][1]}, {bad[0][2]}): expected "
                                                  f"{g[tuple(bad[0])]} / observed {c[tuple(bad[0])]} "
                                                  f"({_edge_note(dist[~amb][0], self.ctx.profile.edge_px)})")
                self.finding(key_id, "coverage", _status(len(bad), len(diff)),
                             f"{len(bad)} texels differ away from edges ({int(amb.sum())} ambiguous within "
                             f"{self.ctx.profile.edge_px:.3g} texels)" if len(bad) else
                             "only ambiguous texels differ", len(bad) or int(amb.sum()), g.size, worst)
        if self.usable(key_col):
            self.colours(key_col, to_uint8(G[key_col]), to_uint8(C[key_col]), ids_ok)
        if self.usable(key_c):
            ok = _float_ok(G[key_c], C[key_c], self.ctx.oracle().extent)
            same = np.array_equal(G[key_c], C[key_c])
            self.finding(key_c, "float", "fail" if not ok.all() else _status(0, not same), "identical" if same else
                         f"within {F32_ULP_TOL} float32 ULP or {EXTENT_TOL} x extent" if ok.all() else
                         f"beyond {F32_ULP_TOL} float32 ULP and {EXTENT_TOL} x extent",
                         worst="" if same else f"expected {G[key_c].tolist()} / observed {C[key_c].tolist()}")

    def cube_distance(self, k, texels):
        """Distance (texels) of cube-map texels (n, 3: face, row, col) of reflector ``k`` from the
        nearest projected edge of the reflected objects."""
        from ..envmap.cube import FAR_MARGIN, NEAR_RATIO
        from ..scene.mesh import concatenate
        from .cubes import envmap_edge_distance

        o = self.ctx.oracle()
        ids = [j for j in range(1, len(o.scene.objects) + 1) if not o.scene.object_by_id(j).reflector]
        mesh = concatenate([o.scene.world_mesh(j, self.ctx.frame) for j in ids], ids)
        centre = self.G[keys.ENVMAP_CENTER(k)].astype(np.float64)
        R = self.G[keys.ENVMAP_ID(k)].shape[-1]
        radius = float(np.sqrt(np.max(np.sum((mesh.vertices - centre) ** 2, axis=1)))) if len(mesh.vertices) else 0.0
        near = NEAR_RATIO * (FAR_MARGIN * radius if radius > 0 else 1.0)
        out = np.full(len(texels), np.inf)
        for f in np.unique(texels[:, 0]):
            on = texels[:, 0] == f
            out[on] = envmap_edge_distance(mesh.vertices, mesh.faces, centre, R, int(f), near, texels[on, 1:],
                                           max(self.ctx.profile.edge_px, _REACH))
        return out

    def colours(self, key, g8, c8, where):
        """The image rule face by face (per channel within 1; loose: within 4 with a 1-texel
        window and at most 0.1% of the texels failing) at the texels ``where`` (6, R, R)."""
        loose = self.ctx.loose
        tol = IMAGE_TOL_LOOSE if loose else IMAGE_TOL
        d = np.abs(g8.astype(np.int16) - c8.astype(np.int16)).max(axis=-1)
        bad = (d > tol) & where
        if loose and bad.any():
            best = d.copy()
            R = d.shape[-1]
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    sh = np.zeros_like(g8)
                    rs, re_, cs, ce = max(dr, 0), R + min(dr, 0), max(dc, 0), R + min(dc, 0)
                    sh[:, rs:re_, cs:ce] = g8[:, rs - dr:re_ - dr, cs - dc:ce - dc]
                    best = np.minimum(best, np.abs(sh.astype(np.int16) - c8.astype(np.int16)).max(axis=-1))
            bad = (best > tol) & where
        n = int(where.sum())
        differ = int(((d > 0) & where).sum())
        nbad = int(bad.sum())
        worst = ""
        if differ:
            f, r, c = np.unravel_index(int(np.argmax(np.where(where, d, -1))), d.shape)
            worst = f"at face {f} texel ({r}, {c}): expected {g8[f, r, c].tolist()} / observed {c8[f, r, c].tolist()}"
        if nbad and (not loose or nbad > IMAGE_LOOSE_SHARE * n):
            self.finding(key, "image", "fail", f"channels differ by more than {tol}", nbad, n, worst)
        else:
            self.finding(key, "image", _status(0, differ), "identical where the ids agree" if not differ else
                         f"within {tol} per channel" + (" (loose)" if loose else ""), differ, n, worst)

    def ties(self):
        """(H, W) bool: the reflector pixels whose differing lookup is a tie, and a note per
        pixel for the report."""
        from ..envmap.cube import lookup
        from ..envmap.method import reflected_rays

        G, C = self.G, self.C
        tie = np.zeros(self.shape, bool)
        notes = {}
        differ = self.on & ~self.agree
        if not differ.any():
            return tie, notes
        o = self.ctx.oracle()
        cam = o.scene.camera_at(self.ctx.frame)
        precision = self.ctx.entry["options"].get("precision", "float32")
        for k in self.reflector_ids:
            stencil = G[keys.OBJECT_ID] == k
            if not (differ & stencil).any():
                continue
            R = G[keys.ENVMAP_ID(k)].shape[-1]
            rays = reflected_rays(cam, o.scene.world_mesh(k, self.ctx.frame), stencil, precision)
            face, row, col, s, t = lookup(rays.direction, R)
            pick = differ[rays.rows, rays.cols]
            for i in np.flatnonzero(pick):
                r, c = int(rays.rows[i]), int(rays.cols[i])
                ok, why = self._tie(k, r, c, int(face[i]), int(row[i]), int(col[i]), s[i], t[i], rays.direction[i],
                                    R)
                tie[r, c] = ok
                if len(notes) < 50:
                    notes[(r, c)] = f"; oracle s R = {float(s[i]) * R:.9g}, t R = {float(t[i]) * R:.9g}: {why}"
        return tie, notes

    def _tie(self, k, r, c, face, row, col, s, t, ray, R):
        """Whether the candidate's lookup at pixel (r, c) is a tie with the oracle's, and why."""
        C = self.C
        cf = int(C[keys.ENVMAP_FACE][r, c]) if keys.ENVMAP_FACE in self.dec else face
        crow, ccol = (int(x) for x in C[keys.ENVMAP_TEXEL][r, c]) if keys.ENVMAP_TEXEL in self.dec else (row, col)
        if (cf, crow, ccol) == (face, row, col):
            return self._id_tie(k, r, c, face, row, col)
        return lookup_tie(ray, s, t, face, row, col, cf, crow, ccol, R)

    def _id_tie(self, k, r, c, face, row, col):
        """Face and texel agree and ``reflected_id`` differs: accepted where it is the
        candidate's own cube-map id of the texel and that id was accepted as ambiguous."""
        acc = self.accepted_ids.get(k)
        cube = self.C.get(keys.ENVMAP_ID(k))
        if acc is None or cube is None or not acc[face, row, col]:
            return False, "the same texel, another object"
        if cube[face, row, col] != self.C[keys.REFLECTED_ID][r, c]:
            return False, "not the object the candidate's own cube map holds at the texel"
        return True, "the texel's id is an accepted ambiguity of the cube map"


def lookup_tie(ray, s, t, face, row, col, cand_face, cand_row, cand_col, resolution):
    """Whether a candidate's cube-map lookup (``cand_face``, ``cand_row``, ``cand_col``) is a tie
    with the oracle's (``face``, ``row``, ``col``, its face coordinates ``s``, ``t`` and the
    direction ``ray`` (3,)), and why: the rule of ``envmap_pixel`` (:data:`ENVMAP_TIE_ULP`).

    Returns
    -------
    (bool, str)
    """
    R = int(resolution)
    reach = ENVMAP_TIE_ULP * TIE_EPS * R  # texels

    def across(x, own, other):
        """The two indices lie on either side of the texel edge within ``reach`` of ``x R``."""
        k = round(float(x) * R)
        return abs(float(x) * R - k) <= reach and sorted((own, other)) == [k - 1, k]

    if cand_face == face:
        if cand_col != col and not across(s, col, cand_col):
            return False, "not the texel across an edge within the tie distance of the oracle's coordinate"
        if cand_row != row and not across(t, R - 1 - row, R - 1 - cand_row):
            return False, "not the texel across an edge within the tie distance of the oracle's coordinate"
        return True, "a tie at a texel edge"
    a, b = face // 2, cand_face // 2
    if not 0 <= cand_face < 6 or a == b:
        return False, "not a neighbouring face"
    ra, rb = abs(float(ray[a])), abs(float(ray[b]))
    if ra == rb:
        return False, "the direction lies exactly on the cube's edge: the face order (z over y over x) decides"
    if cand_face != 2 * b + int(np.signbit(ray[b])):
        return False, "not the neighbouring face toward the direction"
    if (1.0 - rb / ra) * 0.5 * R > reach:
        return False, "not within the tie distance of the cube's edge"
    return True, "a tie at the cube's edge"

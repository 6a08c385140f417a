"""``refsoft check``'s per-pixel rules of the layered depth textures (kinds ``ldt_region``,
``ldt_ray``, ``ldt_pixel``, ``ldt_counts`` and ``margin``; DESIGN-ldt 2.9, the table of
``docs/ports.md``, "The comparison methods"); the textures themselves are :mod:`.ldt_texture`'s.

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
  identical up to 1% of the reflector pixels.
- ``margin``: ``ldt_margin``, shape, dtype and non-finite places only (reported: identical or not).

Off the reflector pixels every per-pixel array must equal the oracle's fill values.
"""

from __future__ import annotations

import numpy as np

from ... import keys
from ...constants import (EXTENT_TOL, F32_ULP_TOL, ITERATION_SHARE_MAX, LDT_HIT_TOL, LDT_TIE_MARGIN,
                          NORMAL_ANGLE_TOL, TIE_SHARE_MAX)
from .common import angle, f32_ulp, float_ok, per_pixel, world_scale
from .perpixel import PixelFrame

KINDS = ("ldt_region", "ldt_ray", "ldt_pixel", "ldt_counts", "margin")
#: Frame-wide keys -> their kind.
FRAME_KINDS = {keys.LDT_RAY_ORIGIN: "ldt_ray", keys.LDT_RAY_DIR: "ldt_ray", keys.LDT_OBJECT_IDS: "ldt_region",
               keys.LDT_MARGIN: "margin",
               **dict.fromkeys((keys.LDT_HIT_POSITION, keys.LDT_HIT_DISTANCE, keys.LDT_FACE, keys.LDT_LAYER,
                                keys.LDT_TEXEL, keys.LDT_RESIDUAL, keys.LDT_OBJECT_DISTANCE), "ldt_pixel"),
               **dict.fromkeys((keys.LDT_LINEAR_SAMPLES, keys.LDT_BINARY_STEPS, keys.LDT_FACES_SEARCHED,
                                keys.LDT_OBJECTS_TESTED, keys.LDT_FLAGS), "ldt_counts")}
#: The per-pixel decision: the arrays judged together at a reflector pixel.
LDT_DECISION = (keys.REFLECTED_ID, keys.LDT_FACE, keys.LDT_LAYER, keys.LDT_TEXEL)
LDT_COUNTERS = (keys.LDT_LINEAR_SAMPLES, keys.LDT_BINARY_STEPS, keys.LDT_FACES_SEARCHED, keys.LDT_OBJECTS_TESTED)


def kind_of(key: str):
    if key in FRAME_KINDS:
        return FRAME_KINDS[key]
    p = keys.parse(key)
    return "ldt_region" if p is not None and p[0] == keys.LDT_REGION else None


def is_ldt_frame(G) -> bool:
    """A golden frame of the layered depth textures."""
    return keys.LDT_FACE in G


def claims(G) -> dict:
    """The frame's keys judged here: the method's arrays and, in an LDT frame, ``reflected_id``
    (part of the per-pixel decision)."""
    out = {key: kind for key in G if (kind := kind_of(key)) is not None}
    if is_ldt_frame(G):
        out[keys.REFLECTED_ID] = "ldt_pixel"
    return out


def judge(ctx, G, C, usable) -> None:
    """The region tables, the margin, then the per-pixel rules of an LDT frame."""
    for key in sorted(G):
        p = keys.parse(key)
        if (p is not None and p[0] == keys.LDT_REGION or key == keys.LDT_OBJECT_IDS) and usable(key):
            same = np.array_equal(G[key], C[key])
            diff = int(np.sum(G[key] != C[key]))
            ctx.finding(key, "identical", "pass" if same else "fail", "identical" if same else "differ", diff,
                        G[key].size)
    if usable(keys.LDT_MARGIN):  # shape, dtype and non-finite places only (checked before)
        same = np.array_equal(G[keys.LDT_MARGIN], C[keys.LDT_MARGIN], equal_nan=True)
        ctx.finding(keys.LDT_MARGIN, "other", "pass" if same else "accepted",
                    "identical" if same else "differs (not judged)")
    if is_ldt_frame(G):
        LdtFrame(ctx, G, C, usable).judge()


class LdtFrame(PixelFrame):
    decision = LDT_DECISION
    kind = "ldt_pixel"
    key_kind = staticmethod(lambda key: kind_of(key))
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
            return err <= LDT_HIT_TOL * s + F32_ULP_TOL * f32_ulp(np.abs(gg).max(axis=1)), err

        msg = f"{LDT_HIT_TOL} x the hit object's cube side + {F32_ULP_TOL} float32 ULP where the texels agree"
        self.floats(keys.LDT_HIT_POSITION, hit, hit_rule, msg)
        self.floats(keys.LDT_HIT_DISTANCE, hit, hit_rule, msg)
        self.object_distances(side)
        R = int(self.ctx.entry["options"].get("ldt_resolution", 256))

        def residual_rule(gg, cc, idx):
            err = np.abs(gg.astype(np.float64) - cc.astype(np.float64))[:, 0]
            return err <= F32_ULP_TOL * f32_ulp(gg[:, 0]) + F32_ULP_TOL * 2.0 ** -23 * R, err

        self.floats(keys.LDT_RESIDUAL, hit, residual_rule, f"{F32_ULP_TOL} ULP + {F32_ULP_TOL} ULP of 1.0 x R "
                    "where the texels agree")
        self.rays()
        self.counters((keys.LDT_FLAGS,), 0.0)
        self.counters(LDT_COUNTERS, ITERATION_SHARE_MAX)

    def sides(self) -> np.ndarray:
        """Each object's cube side in world units this frame, indexed by object id (0 unused)."""
        from ...ldt.build import cube_of

        scene = self.ctx.oracle().scene
        R = int(self.ctx.entry["options"].get("ldt_resolution", 256))
        out = np.zeros(len(scene.objects) + 1)
        for j in range(1, len(scene.objects) + 1):
            if not scene.object_by_id(j).reflector:
                out[j] = 2.0 * cube_of(scene.object_by_id(j).mesh.vertices, R)[1] * world_scale(scene, j, self.ctx.frame)
        return out

    def object_distances(self, side):
        key = keys.LDT_OBJECT_DISTANCE
        if not self.usable(key) or keys.LDT_OBJECT_IDS not in self.G:
            return
        obj_side = side[self.G[keys.LDT_OBJECT_IDS]]

        def rule(gg, cc, idx):
            g64, c64 = gg.astype(np.float64), cc.astype(np.float64)
            err = np.abs(g64 - c64)
            ok = (err <= LDT_HIT_TOL * obj_side[None, :] + F32_ULP_TOL * f32_ulp(gg)).all(axis=1)
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
            return float_ok(gg, cc, extent), np.abs(gg.astype(np.float64) - cc.astype(np.float64)).max(axis=1)

        def direction(gg, cc, idx):
            return float_ok(gg, cc, extent, normals=True), angle(gg, cc)

        slack = None
        if prof.subpixel_px:
            def slack(which):
                def run(idx, todo):
                    i = np.flatnonzero(todo)
                    fr, dist = self.main_view_fragments(idx[i])
                    c = per_pixel(self.C[which], self.shape)[idx[i, 0], idx[i, 1]].astype(np.float64)
                    g = per_pixel(self.G[which], self.shape)[idx[i, 0], idx[i, 1]].astype(np.float64)
                    out = np.zeros(len(idx), bool)
                    if which == keys.LDT_RAY_ORIGIN:
                        ok = np.abs(c - g).max(axis=1) <= EXTENT_TOL * extent + prof.subpixel_px * fr.position_rate
                    else:
                        ok = angle(g, c) <= NORMAL_ANGLE_TOL + prof.subpixel_px * (
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
        from ...raster import _setup, rasterize
        from ..profiles import fragments

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
        from ..profiles import Fragment

        dist = np.linalg.norm(pos - np.asarray(cam.eye, np.float64), axis=1)
        return Fragment(pos, np.zeros((n, 3)), np.zeros(n), rate[0], rate[1], np.zeros(n)), dist

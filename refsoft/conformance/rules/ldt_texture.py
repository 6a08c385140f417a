"""``refsoft check``'s rules of the layered depth textures themselves (kind ``ldt_texture``;
DESIGN-ldt 2.9): each reflected object's ``CASE/ldt_J.npz``, written once per case, against the
golden set's.

- ``triangle`` (coverage and triangle ids) identical except texels whose centre lies within the
  profile's edge distance of an edge of the object's triangles projected on that face (float64,
  unsnapped; 1e-4 texel by default);
- ``depth`` within 4 float32 ULP and ``normal`` by the G-buffer rule (4 ULP or 1e-4 rad) where
  the triangle ids agree (the ``gpu`` profile: also within 1/256 texel times the value's rate of
  change across the face);
- ``count_raw``, ``count`` and ``mismatch`` identical except at those ambiguous texels;
- ``back`` the pairing of the candidate's own depths and counts (docs/ldt.md, "Back depths", in
  float32) within 4 ULP of the larger of the back depth and its partner depth;
- ``cube_center`` and ``cube_half`` within 4 float32 ULP or 1e-6 of the cube's side; ``open``
  and ``layers_capped`` identical.

The oracle's geometry of the faces (edge distances, rates) comes from
:mod:`refsoft.conformance.cubes`.
"""

from __future__ import annotations

import os
import re

import numpy as np

from ... import keys
from ...constants import EXTENT_TOL, F32_ULP_TOL, NORMAL_ANGLE_TOL
from ...errors import InputFileError
from .common import REACH, angle, edge_note, f32_ulp, float_ok, status_of

KINDS = ("ldt_texture",)
#: ``ldt_J.npz`` of a golden case, and the key of one of its arrays in findings (``ldt_J.NAME``).
TEXTURE_FILE = re.compile(r"^ldt_(\d+)\.npz$")
TEXTURE_KEY = re.compile(r"^ldt_(\d+)\.(npz|\w+)$")


def texture_key(j: int, name: str) -> str:
    """The key of array ``name`` of object ``j``'s ``ldt_J.npz`` in findings (``"ldt_2.depth"``;
    ``"ldt_2.npz"`` for the whole file)."""
    return f"{keys.ldt_file(j)}.{name}"


def kind_of(key: str):
    return "ldt_texture" if TEXTURE_KEY.match(key) else None


def judge(ctx, G, C, usable) -> None:
    """Nothing per frame: the textures are judged once per case (:func:`judge_case`)."""


def texture_files(manifest, case: str) -> list:
    """The ``ldt_J.npz`` files of a golden case (manifest names, sorted by J)."""
    out = []
    for rel in manifest["files"]:
        head, _, name = rel.rpartition("/")
        m = TEXTURE_FILE.match(name)
        if head == case and m:
            out.append((int(m.group(1)), rel))
    return [rel for _, rel in sorted(out)]


def judge_case(ctx, golden, candidate, manifest) -> None:
    """Judge the candidate's ``ldt_J.npz`` of the case ``ctx`` is about against the golden set's
    (kind ``ldt_texture``); appends to ``ctx.findings``."""
    from ...io import read_npz
    from ..golden import sha256

    if "ldt_texture" not in ctx.kinds:
        return
    for rel in texture_files(manifest, ctx.case):
        j = int(TEXTURE_FILE.match(rel.rpartition("/")[2]).group(1))
        whole = texture_key(j, "npz")
        gpath, cpath = os.path.join(golden, rel), os.path.join(candidate, rel)
        if not os.path.isfile(gpath) or sha256(gpath) != manifest["files"][rel]:
            ctx.finding(whole, "reference", "fail", f"golden file {rel} is missing or altered (SHA-256)")
            continue
        if not os.path.isfile(cpath):
            ctx.lacks(whole, f"{rel} not in the candidate", kind="ldt_texture")
            continue
        judge_texture(ctx, j, read_npz(gpath), read_npz(cpath))


def judge_texture(ctx, j, G, C):
    usable = []
    for name in keys.LDT_TEXTURE_ARRAYS:
        key = texture_key(j, name)
        if name not in G:
            raise InputFileError(f"golden {keys.ldt_file(j)}.npz lacks {name!r}")
        if name not in C:
            ctx.lacks(key, "not in the candidate's texture", kind="ldt_texture")
        elif C[name].shape != G[name].shape or C[name].dtype != G[name].dtype:
            ctx.finding(key, "shape/dtype", "fail",
                        f"expected {G[name].dtype}{list(G[name].shape)} / observed {C[name].dtype}{list(C[name].shape)}")
        elif G[name].dtype.kind == "f" and not np.array_equal(np.isfinite(G[name]), np.isfinite(C[name])):
            ctx.finding(key, "non-finite", "fail", "non-finite values at other places")
        else:
            usable.append(name)
    mesh = ctx.oracle().scene.object_by_id(j).mesh
    centre, half = G["cube_center"].astype(np.float64), float(G["cube_half"])
    R = G["depth"].shape[-1]
    tex = Texture(ctx, j, mesh, centre, half, R)
    for name in ("open", "layers_capped"):
        if name in usable:
            same = bool(G[name] == C[name])
            ctx.finding(texture_key(j, name), "identical", "pass" if same else "fail", "identical" if same else
                        f"expected {bool(G[name])} / observed {bool(C[name])}")
    for name in ("cube_center", "cube_half"):
        if name in usable:
            g, c = np.atleast_1d(G[name]), np.atleast_1d(C[name])
            ok = float_ok(g, c, 2.0 * half)
            same = np.array_equal(g, c)
            ctx.finding(texture_key(j, name), "float", "fail" if not ok.all() else status_of(0, not same),
                        "identical" if same else f"within {F32_ULP_TOL} float32 ULP or {EXTENT_TOL} x the cube side"
                        if ok.all() else f"beyond {F32_ULP_TOL} float32 ULP and {EXTENT_TOL} x the cube side",
                        worst="" if same else f"expected {g.tolist()} / observed {c.tolist()}")
    agree = None
    if "triangle" in usable:
        agree = tex.coverage(G["triangle"], C["triangle"])
    for name in ("depth", "normal"):
        if name in usable:
            sel = (G["triangle"] >= 0) & (agree if agree is not None else True)
            tex.values(name, G[name], C[name], sel, G["triangle"])
    for name in ("count_raw", "count", "mismatch"):
        if name in usable:
            tex.counts(name, G[name], C[name])
    if "back" in usable and {"depth", "count_raw", "open"} <= set(usable):
        tex.back(C["back"], C["depth"], C["count_raw"], bool(C["open"]))


class Texture:
    """The rules of one object's texture, with the oracle's geometry of its faces."""

    def __init__(self, ctx, j, mesh, centre, half, R):
        self.ctx, self.j, self.mesh, self.centre, self.half, self.R = ctx, j, mesh, centre, half, R
        self.prof = ctx.profile
        self._dist = {}  # face -> {(row, col): distance}

    def distance(self, faces, rows, cols):
        """Distance (texels) of each texel centre from the nearest projected edge of its face."""
        from ..cubes import ldt_edge_distance

        out = np.full(len(faces), np.inf)
        for f in np.unique(faces):
            on = faces == f
            out[on] = ldt_edge_distance(self.mesh, self.centre, self.half, self.R, int(f), np.c_[rows[on], cols[on]],
                                        max(self.prof.edge_px, REACH))
        return out

    def coverage(self, g, c):
        """``triangle``: returns (6, L, R, R) bool, where the candidate's triangle is the
        oracle's."""
        key = texture_key(self.j, "triangle")
        diff = np.argwhere(g != c)
        agree = g == c
        if not len(diff):
            self.ctx.finding(key, "coverage", "pass", "identical", 0, g.size)
            return agree
        dist = self.distance(diff[:, 0], diff[:, 2], diff[:, 3])
        amb = dist <= self.prof.edge_px
        self._picture(key, g, diff[amb], diff[~amb])
        n_amb = int(amb.sum())
        if (~amb).any():
            f, layer, r, cc = diff[~amb][0]
            worst = (f"at face {f} layer {layer} texel ({r}, {cc}): expected {g[f, layer, r, cc]} / observed "
                     f"{c[f, layer, r, cc]} ({edge_note(dist[~amb][0], self.prof.edge_px)})")
            self.ctx.finding(key, "coverage", "fail", f"{int((~amb).sum())} texels differ away from edges ({n_amb} "
                             f"ambiguous within {self.prof.edge_px:.3g} texels)", int((~amb).sum()), g.size, worst)
        else:
            self.ctx.finding(key, "coverage", "accepted", f"only ambiguous texels differ (centre within "
                             f"{self.prof.edge_px:.3g} texels of an edge)", n_amb, g.size)
        return agree

    def values(self, name, g, c, sel, triangle):
        """``depth`` (4 ULP) or ``normal`` (the G-buffer normal rule) where ``sel``; the ``gpu``
        profile adds its interpolation slack, the value's rate across the face."""
        key = texture_key(self.j, name)
        idx = np.argwhere(sel)
        gg, cc = g[sel], c[sel]
        n = len(idx)
        if name == "depth":
            err = np.abs(gg.astype(np.float64) - cc.astype(np.float64))
            ok = err <= F32_ULP_TOL * f32_ulp(gg)
        else:
            err = angle(gg, cc) if n else np.zeros(0)
            ok = float_ok(gg, cc, 0.0, normals=True) if n else np.zeros(0, bool)
        same = np.all(gg == cc, axis=-1) if gg.ndim > 1 else gg == cc
        slack = 0
        if self.prof.subpixel_px and (~ok).any():
            from ..cubes import ldt_fragments

            for f in np.unique(idx[~ok, 0]):
                i = np.flatnonzero(~ok & (idx[:, 0] == f))
                fr = ldt_fragments(self.mesh, self.centre, self.half, self.R, int(f), idx[i][:, 2:],
                                   triangle[tuple(idx[i].T)])
                if name == "depth":
                    fine = err[i] <= F32_ULP_TOL * f32_ulp(gg[i]) + self.prof.subpixel_px * fr.depth_rate
                else:
                    fine = err[i] <= NORMAL_ANGLE_TOL + self.prof.subpixel_px * fr.normal_rate
                ok[i[fine]] = True
                slack += int(fine.sum())
        rule = f"{F32_ULP_TOL} float32 ULP" if name == "depth" else f"{F32_ULP_TOL} float32 ULP or {NORMAL_ANGLE_TOL} rad"
        note = f"; {slack} within GPU interpolation" if slack else ""
        if (~ok).any():
            i = int(np.argmax(np.where(~ok, err, -1)))
            f, layer, r, col = idx[i]
            worst = (f"at face {f} layer {layer} texel ({r}, {col}): expected {np.round(gg[i], 9).tolist()} / observed "
                     f"{np.round(cc[i], 9).tolist()}")
            self.ctx.finding(key, "float", "fail", f"beyond {rule} where the triangles agree{note}", int((~ok).sum()), n,
                             worst)
        elif not same.all():
            self.ctx.finding(key, "float", "accepted", f"within {rule} where the triangles agree{note}",
                             int((~same).sum()), n)
        else:
            self.ctx.finding(key, "float", "pass", "identical where the triangles agree", 0, n)

    def counts(self, name, g, c):
        """``count_raw``, ``count``, ``mismatch``: identical except at ambiguous texels."""
        key = texture_key(self.j, name)
        diff = np.argwhere(g != c)
        if not len(diff):
            self.ctx.finding(key, "identical", "pass", "identical", 0, g.size)
            return
        amb = self.distance(diff[:, 0], diff[:, 1], diff[:, 2]) <= self.prof.edge_px
        bad = diff[~amb]
        worst = "" if not len(bad) else (f"at face {bad[0][0]} texel ({bad[0][1]}, {bad[0][2]}): expected "
                                          f"{g[tuple(bad[0])]} / observed {c[tuple(bad[0])]}")
        self.ctx.finding(key, "identical", status_of(len(bad), len(diff)),
                         f"{len(bad)} texels differ away from edges ({int(amb.sum())} ambiguous)" if len(bad) else
                         "only ambiguous texels differ", len(bad) if len(bad) else int(amb.sum()), g.size, worst)

    def back(self, c_back, c_depth, c_count_raw, is_open):
        """``back``: the pairing of the candidate's own depths and counts."""
        from ...ldt.build import pair_back_depths

        key = texture_key(self.j, "back")
        want = pair_back_depths(c_depth, c_count_raw, is_open, np.float32)[0]
        err = np.abs(c_back.astype(np.float64) - want.astype(np.float64))
        tol = F32_ULP_TOL * f32_ulp(np.maximum(want, np.float32(1) - want))
        bad = np.argwhere(err > tol)
        n = c_back.size
        if len(bad):
            f, layer, r, col = bad[0]
            self.ctx.finding(key, "pairing", "fail", "not the pairing of the candidate's own depths and counts "
                             f"(1 - depth of the opposite face's layer L' - 1 - j, within {F32_ULP_TOL} ULP)", len(bad), n,
                             f"at face {f} layer {layer} texel ({r}, {col}): expected {want[f, layer, r, col]:.9g} / "
                             f"observed {c_back[f, layer, r, col]:.9g}")
        else:
            same = np.array_equal(c_back, want)
            self.ctx.finding(key, "pairing", "pass" if same else "accepted", "the pairing of the candidate's own "
                             "depths and counts" + ("" if same else f" within {F32_ULP_TOL} ULP"),
                             0 if same else int((c_back != want).sum()), n)

    def _picture(self, key, g, yellow, red):
        """The coverage's error mask, layers as rows and faces as columns: dark empty, grey
        covered, yellow ambiguous, red failed."""
        if self.ctx.out is None:
            return
        six, L, R, _ = g.shape
        img = np.zeros((L * R, six * R, 3), np.uint8)
        for f in range(six):
            for layer in range(L):
                img[layer * R:(layer + 1) * R, f * R:(f + 1) * R][g[f, layer] >= 0] = 90
        for idx, col in ((yellow, (230, 200, 0)), (red, (220, 0, 0))):
            for f, layer, r, cc in idx:
                img[layer * R + r, f * R + cc] = col
        self.ctx.picture(key, img)

"""``refsoft check``'s rules of the environment map (kinds ``envmap_cube`` and ``envmap_pixel``;
DESIGN-ldt 5, the table of ``docs/ports.md``, "The comparison methods").

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

The oracle's reflected rays are recomputed (:func:`refsoft.envmap.method.reflected_rays`) for
the texel coordinates. Off the reflector pixels the per-pixel arrays must equal the oracle's.
"""

from __future__ import annotations

import numpy as np

from ... import keys
from ...constants import (ENVMAP_TIE_ULP, EXTENT_TOL, F32_ULP_TOL, IMAGE_LOOSE_SHARE, IMAGE_TOL, IMAGE_TOL_LOOSE,
                          TIE_EPS)
from .common import REACH, edge_note, float_ok, status_of
from .perpixel import PixelFrame

KINDS = ("envmap_cube", "envmap_pixel")
FRAME_KINDS = {keys.ENVMAP_FACE: "envmap_pixel", keys.ENVMAP_TEXEL: "envmap_pixel"}
PER_REFLECTOR_KINDS = {keys.ENVMAP_COLOR: "envmap_cube", keys.ENVMAP_ID: "envmap_cube",
                       keys.ENVMAP_CENTER: "envmap_cube"}


def kind_of(key: str):
    if key in FRAME_KINDS:
        return FRAME_KINDS[key]
    p = keys.parse(key)
    return PER_REFLECTOR_KINDS.get(p[0]) if p is not None else None


def is_envmap_frame(G) -> bool:
    """A golden frame of the environment map."""
    return keys.ENVMAP_FACE in G


def claims(G) -> dict:
    """The frame's keys judged here: the method's arrays and, in an environment-map frame,
    ``reflected_id`` (part of the per-pixel decision)."""
    out = {key: kind for key in G if (kind := kind_of(key)) is not None}
    if is_envmap_frame(G):
        out[keys.REFLECTED_ID] = "envmap_pixel"
    return out


def judge(ctx, G, C, usable) -> None:
    """The cube maps and the per-pixel lookups of an environment-map frame."""
    if is_envmap_frame(G):
        EnvmapFrame(ctx, G, C, usable).judge()


ENVMAP_DECISION = (keys.REFLECTED_ID, keys.ENVMAP_FACE, keys.ENVMAP_TEXEL)


class EnvmapFrame(PixelFrame):
    decision = ENVMAP_DECISION
    kind = "envmap_pixel"
    key_kind = staticmethod(lambda key: kind_of(key))
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
        from ...raster import to_uint8

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
                                                  f"({edge_note(dist[~amb][0], self.ctx.profile.edge_px)})")
                self.finding(key_id, "coverage", status_of(len(bad), len(diff)),
                             f"{len(bad)} texels differ away from edges ({int(amb.sum())} ambiguous within "
                             f"{self.ctx.profile.edge_px:.3g} texels)" if len(bad) else
                             "only ambiguous texels differ", len(bad) or int(amb.sum()), g.size, worst)
        if self.usable(key_col):
            self.colours(key_col, to_uint8(G[key_col]), to_uint8(C[key_col]), ids_ok)
        if self.usable(key_c):
            ok = float_ok(G[key_c], C[key_c], self.ctx.oracle().extent)
            same = np.array_equal(G[key_c], C[key_c])
            self.finding(key_c, "float", "fail" if not ok.all() else status_of(0, not same), "identical" if same else
                         f"within {F32_ULP_TOL} float32 ULP or {EXTENT_TOL} x extent" if ok.all() else
                         f"beyond {F32_ULP_TOL} float32 ULP and {EXTENT_TOL} x extent",
                         worst="" if same else f"expected {G[key_c].tolist()} / observed {C[key_c].tolist()}")

    def cube_distance(self, k, texels):
        """Distance (texels) of cube-map texels (n, 3: face, row, col) of reflector ``k`` from the
        nearest projected edge of the reflected objects."""
        from ...envmap.cube import FAR_MARGIN, NEAR_RATIO
        from ...scene.mesh import concatenate
        from ..cubes import envmap_edge_distance

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
                                           max(self.ctx.profile.edge_px, REACH))
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
            self.finding(key, "image", status_of(0, differ), "identical where the ids agree" if not differ else
                         f"within {tol} per channel" + (" (loose)" if loose else ""), differ, n, worst)

    def ties(self):
        """(H, W) bool: the reflector pixels whose differing lookup is a tie, and a note per
        pixel for the report."""
        from ...envmap.cube import lookup
        from ...envmap.method import reflected_rays

        G = self.G
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

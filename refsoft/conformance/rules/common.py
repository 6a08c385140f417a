"""What every rule module of ``refsoft check`` shares: the float rule (4 float32 ULP or 1e-6 of
the scene's extent; normals also by angle), its finding over a field of values, and the small
helpers of the per-pixel and per-texel rules. Tolerances are in :mod:`refsoft.constants`."""

from __future__ import annotations

import numpy as np

from ...constants import EXTENT_TOL, F32_ULP_TOL, NORMAL_ANGLE_TOL


def f32_ulp(x):
    """One float32 ULP at each element of ``x``, as float64."""
    return np.spacing(np.abs(np.asarray(x, dtype=np.float32))).astype(np.float64)


def float_close(g, c, extent):
    """Elementwise: within 4 float32 ULP of the reference or 1e-6 x extent."""
    g64, c64 = np.asarray(g, dtype=np.float64), np.asarray(c, dtype=np.float64)
    err = np.abs(g64 - c64)
    return (err <= F32_ULP_TOL * f32_ulp(g64)) | (err <= EXTENT_TOL * extent), err


def where(idx) -> str:
    """An index as ``(i, j, ...)`` for the report."""
    return "(" + ", ".join(str(int(i)) for i in idx) + ")"


def float_rule(gg, cc, extent, normals=False):
    """Rows of ``cc`` (N, ...) within the float rule of ``gg``'s: ``(ok (N,) bool, |error|)``."""
    ok, err = float_close(gg, cc, extent)
    ok = ok.all(axis=-1) if ok.ndim > 1 else ok
    if normals:
        cosang = np.einsum("ij,ij->i", gg.astype(np.float64), cc.astype(np.float64)) / np.maximum(
            np.linalg.norm(gg, axis=1) * np.linalg.norm(cc, axis=1), 1e-300)
        ok |= np.arccos(np.clip(cosang, -1, 1)) <= NORMAL_ANGLE_TOL
    return ok, err


def compare_float_field(ctx, key, g, c, cover, extent, normals=False, extra=None):
    """The float rule over the elements ``cover`` selects. ``extra``: elements beyond it that
    another rule accepts, ``{reason: (n,) bool}`` over the selected elements (counted in the
    message; a G-buffer's other admissible fragments, :func:`refsoft.conformance.rules.gbuffer.gbuffer_alternatives`)."""
    gg, cc = g[cover], c[cover]
    ok, err = float_rule(gg, cc, extent, normals)
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
    loc = locs[i] if len(locs) == n else [i]
    worst = f"at {where(loc)}: expected {np.round(gg[i], 9).tolist()} / observed {np.round(cc[i], 9).tolist()}"
    notes = "".join(f"; {int(v.sum())} {reason}" for reason, v in extra.items() if v.any())
    if bad.any():
        return [ctx.finding(key, "float", "fail", f"beyond {F32_ULP_TOL} float32 ULP and {EXTENT_TOL} x extent "
                            f"{extent:.4g}{notes}", int(bad.sum()), n, worst)]
    return [ctx.finding(key, "float", "accepted", f"within {F32_ULP_TOL} float32 ULP or {EXTENT_TOL} x extent{notes}",
                        int((~same).sum()), n, worst)]


def mark(n, idx):
    """(n,) bool, True at ``idx``."""
    m = np.zeros(n, dtype=bool)
    m[idx] = True
    return m


def per_pixel(a, shape):
    """``a`` with one row per pixel of an (H, W) frame: (H, W, ...) and (K, H, W) both to
    (H, W, m)."""
    a = np.asarray(a)
    if a.shape[:2] == tuple(shape):
        return a.reshape(shape + (-1,))
    return np.moveaxis(a, 0, -1).reshape(shape + (-1,))


def same_pixels(g, c, shape):
    """(H, W) bool: the pixel's values are identical."""
    return np.all(per_pixel(g, shape) == per_pixel(c, shape), axis=-1)


#: How far from an edge the rules measure distances (texels; beyond: "more than").
REACH = 1e-3


def edge_note(d, edge_px) -> str:
    """A texel's distance from the nearest edge, as the report says it."""
    reach = max(edge_px, REACH)
    return f"{d:.3g} texels from an edge" if np.isfinite(d) else f"more than {reach:.3g} texels from an edge"


def status_of(bad: int, differ: int) -> str:
    """``fail`` when some are bad, else ``accepted`` when some differ, else ``pass``."""
    return "fail" if bad else ("accepted" if differ else "pass")


def world_scale(scene, j, frame) -> float:
    """The largest factor object ``j``'s transform stretches a length by at ``frame``."""
    return float(np.linalg.norm(scene.transform_at(j, frame).matrix()[:3, :3], 2))


def float_ok(g, c, extent, normals=False):
    """(n,) bool: :func:`float_rule` of ``c`` against ``g``."""
    return float_rule(np.asarray(g), np.asarray(c), extent, normals)[0]


def angle(u, v):
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v))

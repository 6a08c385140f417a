"""What the per-pixel rules of the comparison methods (:mod:`.ldt`, :mod:`.envmap`) share: the
decision judged at every reflector pixel with its ties, counters identical where the decision
agrees, float arrays within a rule, and the fill values required off the reflector pixels."""

from __future__ import annotations

import numpy as np

from ... import keys
from ...constants import TIE_SHARE_MAX
from .common import per_pixel, same_pixels, status_of, where


class PixelFrame:
    """What the per-pixel rules of both methods share: one frame's reflector pixels, the
    method's decision arrays (``decision``) and where the candidate's agree with the oracle's.

    Subclasses set ``decision``, ``kind`` (the kind of the decision's findings), ``rule``,
    ``tie_rule``, ``describe(A, r, c)`` and ``key_kind(key)`` (their module's ``kind_of``)."""

    decision = ()
    kind = ""

    @staticmethod
    def key_kind(key):
        return None

    def __init__(self, ctx, G, C, usable):
        self.ctx, self.G, self.C, self.usable = ctx, G, C, usable
        self.shape = G[keys.OBJECT_ID].shape
        self.on = G[keys.REFLECTED_ID] >= 0  # the reflector pixels
        self.n = int(self.on.sum())
        self.dec = [k for k in self.decision if usable(k)]
        self.same = {k: same_pixels(G[k], C[k], self.shape) for k in self.dec}
        self.agree = np.logical_and.reduce([self.same[k] for k in self.dec]) if self.dec else np.ones(self.shape, bool)

    def finding(self, key, rule, status, message="", count=0, total=0, worst="", details=None):
        return self.ctx.finding(key, rule, status, message, count, total, worst, details, kind=self.key_kind(key) or self.kind)

    def off_reflectors(self, key):
        """(H, W) bool: pixels off the reflectors where the candidate differs (they must hold the
        fill values, as the oracle's)."""
        return ~self.on & ~same_pixels(self.G[key], self.C[key], self.shape)

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
            differ = self.on & self.agree & ~same_pixels(g, c, self.shape)
            off = self.off_reflectors(key)
            nd, no = int(differ.sum()), int(off.sum())
            worst = ""
            if nd or no:
                r, cc = np.argwhere(differ | off)[0]
                worst = f"at ({r}, {cc}): expected {per_pixel(g, self.shape)[r, cc].tolist()} / observed " \
                        f"{per_pixel(c, self.shape)[r, cc].tolist()}"
            status = "fail" if no or nd > share * max(self.n, 1) else status_of(0, nd)
            msg = "identical where the pixels agree" if not (nd or no) else (
                f"differ where the pixels agree (at most {share:.0%} allowed)" + (f"; {no} off the reflectors" if no else ""))
            self.finding(key, "identical", status, msg, nd + no, self.n, worst)

    def floats(self, key, sel, tol_fn, message, share=0.0, extra=None):
        """A float array (per pixel) within ``tol_fn(g, c, index) -> (ok (m,) bool, error)`` at
        the pixels ``sel``, identical off the reflectors; beyond it accepted on at most ``share``
        of the reflector pixels. ``extra(index, not ok) -> (m,) bool``: accepted otherwise."""
        if not self.usable(key):
            return
        g, c = per_pixel(self.G[key], self.shape), per_pixel(self.C[key], self.shape)
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
            worst = f"at {where(idx[i])}: expected {np.round(gg[i], 9).tolist()} / observed {np.round(cc[i], 9).tolist()}"
        if no or nbad > share * max(self.n, 1):
            self.finding(key, "float", "fail", f"beyond {message}" + (f"; {no} off the reflectors" if no else ""),
                         nbad + no, len(idx), worst)
        elif nbad or not same.all():
            self.finding(key, "float", "accepted", f"within {message}" + (
                f", except {nbad} (at most {share:.0%} allowed)" if nbad else ""), int((~same).sum()), len(idx), worst)
        else:
            self.finding(key, "float", "pass", "identical", 0, len(idx))

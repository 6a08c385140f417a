"""What ``refsoft check`` reports (spec section 8): one :class:`Finding` per output judged, the
:class:`Context` the rules of one case and frame write their findings and pictures into.

Statuses (:data:`STATUSES`):

- ``pass``: identical;
- ``accepted``: different within the rule's tolerance (ULP, ties, ambiguous edge pixels); shown
  yellow and counted, never a failure;
- ``fail``: beyond the tolerance; ``refsoft check`` then exits with status 1;
- ``missing``: the candidate lacks it (a whole case frame, or one output): a failure like
  ``fail``, unless the candidate excluded it (``--case``, ``--kinds``: the outputs of other
  cases and kinds are then neither judged nor required) or declared it (``not_ported``); a
  missing or altered *reference* file is a failure;
- ``not_ported``: the candidate lacks it and its ``ported.json`` declares it (a method, an option
  value or a kind of output the port does not implement, :mod:`refsoft.conformance.ported`):
  counted and listed, not a failure.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from .profiles import profile as get_profile


#: Every status a finding can have, in the report's order.
STATUSES = ("pass", "accepted", "fail", "missing", "not_ported")
#: The statuses that fail a check.
FAILING = ("fail", "missing")


#: The report's pictures are magnified this many times (nearest neighbour: every pixel a block).
MAGNIFY = 4


@dataclass
class Finding:
    """One output of one case and frame, judged by its rule: ``kind`` is the kind of output
    (:func:`refsoft.conformance.registry.output_kind`), ``rule`` the rule that judged it."""

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
        status = self.status.upper().replace("_", " ")
        return f"{status:8s} {self.case} frame {self.frame} {self.key} [{self.kind}]: {self.message}{share}{worst}"

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("case", "frame", "key", "kind", "rule", "status", "message", "count",
                                              "total", "worst", "details")}


class Context:
    """The rules' view of one case and frame: what is judged (``kinds``, ``profile``), where the
    report goes (``out``), the oracle (:meth:`oracle`, built on demand), and the findings and
    pictures written so far.

    Parameters
    ----------
    case : str
    frame : int
    entry : dict
        The case's entry of the golden manifest (name, scene, frames, options).
    out : str or None
        The report folder (None: no pictures).
    kinds : tuple of str
        The kinds of output judged.
    profile : str or Profile
    kind_of : callable, optional
        ``kind_of(key) -> str``: a key's kind when a rule names none
        (:func:`refsoft.conformance.registry.output_kind`).
    """

    def __init__(self, case, frame, entry, out, kinds, profile="default", kind_of=None):
        self.case, self.frame, self.entry, self.out, self.kinds = case, frame, entry, out, kinds
        self.kind_of = kind_of or (lambda key: "other")
        self.profile = get_profile(profile)
        self.stages = {}  # reflector -> the candidate's G-buffer its search is judged on
        self.reference = None  # the frame's arrays from the candidate's inputs (reference_frame)
        self.reference_starts = {}
        self.loose = False  # the loose image rule (set by check_frame)
        self.traces = None  # the candidate's traces of this frame, {reflector: {vertex: record}}
        self.previous = None  # the golden pixels of the previous frame (coherent cases), {reflector: (N, 2)}
        self.agreement = {}  # reflector -> (live, agree, tie) (N,) bool: the reflection pixels' verdict
        self.not_ported_kinds = ()  # kinds the candidate's ported.json declares it does not write
        self.findings = []
        self.pictures = []  # file names written into out
        self._oracle = None

    def oracle(self):
        """The oracle's scene, vertices and G-buffers of this case and frame
        (:class:`refsoft.conformance.oracle.Oracle`)."""
        if self._oracle is None:
            from .oracle import Oracle

            self._oracle = Oracle(self.entry, self.frame)
        return self._oracle

    def stage_gbuffer(self, k):
        """The G-buffer reflector ``k``'s search is judged on: the candidate's own
        (:func:`refsoft.conformance.rules.search.judge_reflector`), or the oracle's."""
        own = self.stages.get(k)
        return self.oracle().gbuffer(k) if own is None else own

    def finding(self, key, rule, status, message="", count=0, total=0, worst="", details=None, kind=None):
        f = Finding(self.case, self.frame, key, kind or self.kind_of(key), status, message, int(count), int(total),
                    worst, details or [], rule)
        self.findings.append(f)
        return f

    def lacks(self, key, message, kind=None):
        """The candidate lacks output ``key``: ``missing`` (a failure), or ``not_ported`` when its
        kind is one the candidate declares it does not write (``ported.json``)."""
        kind = kind or self.kind_of(key)
        if kind in self.not_ported_kinds:
            return self.finding(key, "presence", "not_ported", f"{message}: kind {kind!r} declared not ported",
                                kind=kind)
        return self.finding(key, "presence", "missing", message, kind=kind)

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


def by_kind(findings) -> dict:
    """``{kind: {status: count}}`` over ``findings``, kinds sorted."""
    out = {}
    for f in findings:
        out.setdefault(f.kind, dict.fromkeys(STATUSES, 0))[f.status] += 1
    return dict(sorted(out.items()))

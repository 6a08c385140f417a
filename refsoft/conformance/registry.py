"""The registry of ``refsoft check``'s rules: which module judges which output, and in what order.

A rule module (:mod:`refsoft.conformance.rules`) has

- ``KINDS``: the kinds of output it judges (the names ``--kinds`` selects);
- ``kind_of(key) -> str | None``: the kind of a frame's key it judges (None: not one of its);
- ``judge(ctx, G, C, usable) -> None``: judges the golden frame ``G`` against the candidate's
  ``C``, writing findings into ``ctx`` (:class:`refsoft.conformance.findings.Context`);
  ``usable(key)`` says the key is one this module claims, the candidate has it, of the golden
  shape, dtype and non-finite places, and its kind is judged (the driver has already reported
  the others);

and optionally

- ``claims(G) -> {key: kind}``: the golden frame's keys it judges, when they are not only those
  of ``kind_of`` (a comparison method's ``reflected_id`` belongs to its per-pixel decision);
- ``ORACLE_ONLY``: per-reflector names of golden arrays only the oracle writes (never required,
  never judged);
- ``judge_case(ctx, golden, candidate, manifest) -> None``: outputs written once per case
  (the layered depth textures' ``ldt_J.npz``), judged at the case's first frame.

:data:`RULES` lists the modules in the order they judge a frame (the search before the virtual
vertices, which read its verdict; the comparison methods first, as they claim ``reflected_id``
in their frames). A key no module claims is judged by the driver's fallback rule (identical, or
reported as differing) under kind ``other``. Adding a rule module for new arrays: write it with
the interface above, add it to :data:`RULES` and its kinds to
:data:`refsoft.constants.CHECK_KINDS` (``tests/conformance/test_registry.py`` checks the two
agree).
"""

from __future__ import annotations

from .. import constants
from .rules import bounces, envmap, gbuffer, image, images, ldt, ldt_texture, search, virtual

#: The rule modules, in the order they judge a frame.
RULES = (ldt, ldt_texture, envmap, gbuffer, search, virtual, images, bounces, image)

#: Every kind of output a rule module judges (each once, in the modules' order).
OWNED = tuple(dict.fromkeys(kind for module in RULES for kind in module.KINDS))
#: The kinds of output, in the order ``refsoft check`` lists them (the same set as :data:`OWNED`).
KINDS = constants.CHECK_KINDS


def output_kind(key: str) -> str:
    """The kind of output a frame's key is, by the first module that knows it; ``"frame"`` for a
    whole case frame (``"*"``), ``"other"`` for a key no module judges."""
    if key == "*":
        return "frame"
    for module in RULES:
        kind = module.kind_of(key)
        if kind is not None:
            return kind
    return "other"


def claims(G) -> dict:
    """``{key: (module, kind)}`` for every key of the golden frame ``G`` a rule module judges (the
    first module that claims it), oracle-only keys left out."""
    out = {}
    for module in RULES:
        named = module.claims(G) if hasattr(module, "claims") else {
            key: kind for key in G if (kind := module.kind_of(key)) is not None}
        for key, kind in named.items():
            out.setdefault(key, (module, kind))
    return {key: v for key, v in out.items() if not oracle_only(key)}


def oracle_only(key: str) -> bool:
    """``key`` is an array only the oracle writes (a module's ``ORACLE_ONLY``)."""
    for module in RULES:
        for name in getattr(module, "ORACLE_ONLY", ()):
            prefix = name + "_"
            if key.startswith(prefix) and key[len(prefix):].isdigit():
                return True
    return False


def case_rules():
    """The modules that judge outputs written once per case (``judge_case``)."""
    return [module for module in RULES if hasattr(module, "judge_case")]

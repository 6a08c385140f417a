"""Declared partial ports (spec section 8): ``CANDIDATE/ported.json`` lists what a port does not
port, so that ``refsoft check`` reports those outputs as ``not_ported`` instead of ``missing``.

The file (format ``refsoft-ported-1``)::

    {"format": "refsoft-ported-1",
     "not_ported": {"methods": ["ldt", "envmap"],
                    "options": {"silhouette": ["clip"], "adaptive_widen": [true]},
                    "kinds": ["trace"]}}

- ``methods``: reflection methods (``refsoft.constants.METHODS``) the port does not implement:
  every case of one of them is not ported;
- ``options``: per option (a :class:`refsoft.RenderOptions` field) the values the port does not
  implement: a case whose options hold one of them is not ported;
- ``kinds``: kinds of output (``refsoft check --kinds``) the port does not write: in every case,
  an output of one of them is not ported.

A declaration only excuses absence: a declared case or output the candidate does write is
judged as usual; one it lacks without a declaration (or an exclusion by ``--case`` or
``--kinds``) is ``missing``, a failure. Every entry is optional; an unknown method, option or
kind, or a file of another shape, is refused (:class:`refsoft.errors.InputFileError`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, fields

from ..errors import InputFileError

#: The file's name in a candidate folder, and its format.
FILE = "ported.json"
FORMAT = "refsoft-ported-1"


def _normal(value):
    """JSON values as Python compares them: lists as tuples (``[1, 2] == (1, 2)``, ``1 == 1.0``)."""
    if isinstance(value, (list, tuple)):
        return tuple(_normal(v) for v in value)
    return value


@dataclass(frozen=True)
class Ported:
    """What a candidate declares it does not port (empty: a whole port, or no ``ported.json``).

    Attributes
    ----------
    methods : tuple of str
    options : dict of str -> tuple
        Option name -> the values not ported.
    kinds : tuple of str
    path : str or None
        The file it was read from.
    """

    methods: tuple = ()
    options: dict = field(default_factory=dict)
    kinds: tuple = ()
    path: str | None = None

    def case_reason(self, options: dict):
        """Why a case with these ``options`` (a manifest entry's) is not ported, or None."""
        method = options.get("method")
        if method in self.methods:
            return f"method {method!r} declared not ported"
        for name, values in self.options.items():
            if name in options and _normal(options[name]) in values:
                return f"option {name}={options[name]!r} declared not ported"
        return None

    def to_dict(self) -> dict:
        return {"methods": list(self.methods), "options": {k: [list(v) if isinstance(v, tuple) else v for v in vals]
                                                           for k, vals in self.options.items()},
                "kinds": list(self.kinds)}


def read_ported(candidate, kinds) -> Ported:
    """The declaration of ``candidate/ported.json`` (an empty one when there is none).

    Parameters
    ----------
    candidate : str or PathLike
        The candidate folder.
    kinds : tuple of str
        The kinds of output ``refsoft check`` knows.

    Raises
    ------
    InputFileError
        The file is not JSON, of another format or shape, or names an unknown method, option or
        kind.
    """
    from .. import constants
    from ..io import read_json
    from ..options import RenderOptions

    path = os.path.join(os.fspath(candidate), FILE)
    if not os.path.exists(path):
        return Ported()
    data = read_json(path, format=FORMAT, required=("not_ported",))
    gaps = data["not_ported"]
    if not isinstance(gaps, dict) or set(gaps) - {"methods", "options", "kinds"}:
        raise InputFileError(f"{path}: 'not_ported' must be an object with 'methods', 'options' and 'kinds'")

    def names(entry, allowed, what):
        value = gaps.get(entry, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise InputFileError(f"{path}: not_ported.{entry} must be a list of {what} names")
        bad = [v for v in value if v not in allowed]
        if bad:
            raise InputFileError(f"{path}: unknown {what} {bad[0]!r} in not_ported.{entry} ({what}s: "
                                 f"{', '.join(allowed)})")
        return tuple(dict.fromkeys(value))

    methods = names("methods", constants.METHODS, "method")
    kinds = names("kinds", tuple(kinds), "kind")
    options = gaps.get("options", {})
    known = tuple(f.name for f in fields(RenderOptions))
    if not isinstance(options, dict):
        raise InputFileError(f"{path}: not_ported.options must map option names to lists of values")
    out = {}
    for name, values in options.items():
        if name not in known:
            raise InputFileError(f"{path}: unknown option {name!r} in not_ported.options (options: "
                                 f"{', '.join(known)})")
        if not isinstance(values, list):
            raise InputFileError(f"{path}: not_ported.options.{name} must be a list of the values not ported")
        out[name] = tuple(_normal(v) for v in values)
    return Ported(methods, out, kinds, path)

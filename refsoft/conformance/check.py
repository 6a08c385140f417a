"""``refsoft check GOLDEN CANDIDATE``: a port's outputs against the golden set (spec section 8).

The driver: for every case and frame of the golden set (or those ``cases`` names) it reads the
golden and the candidate's ``frame_NNNN.npz``, checks that every golden output of a judged kind
is there with the golden shape, dtype and non-finite places, then hands the frame to the rule
modules of :mod:`refsoft.conformance.registry` (G-buffer, search, virtual vertices, image, the
layered depth textures, the environment map), each of which writes its findings
(:mod:`refsoft.conformance.findings`). A key no rule module claims is judged by the fallback
rule: identical passes, otherwise it is reported (``accepted``, not judged).

What a candidate lacks is ``missing`` (a failure) unless it is excluded (``cases``, ``kinds``:
neither judged nor required) or declared in the candidate's ``ported.json``
(:mod:`refsoft.conformance.ported`: methods, option values, kinds of output the port does not
implement), which makes it ``not_ported``: counted and listed, not a failure.

Under the ``gpu`` profile (:mod:`refsoft.conformance.profiles`), the stages after the G-buffer are
judged against the oracle run on the candidate's own G-buffer
(:func:`refsoft.conformance.stages.reference_frame`).
"""

from __future__ import annotations

import os

import numpy as np

from .. import keys
from ..errors import InputFileError, RefsoftError
from . import registry
from .findings import FAILING, MAGNIFY, STATUSES, Context, Finding, by_kind  # noqa: F401 (the public names)
from .ported import read_ported
from .profiles import profile as get_profile
from .rules.common import where
from .rules.search import load_traces
from .stages import reference_frame

#: The kinds of output ``--kinds`` selects (each key of a frame belongs to one,
#: :func:`refsoft.conformance.registry.output_kind`).
KINDS = registry.KINDS
output_kind = registry.output_kind


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


def check_frame(ctx, G, C, loose):
    """Judge every output of one frame whose kind ``ctx.kinds`` names; appends to
    ``ctx.findings``. An output the candidate lacks is ``missing`` (a failure), or
    ``not_ported`` when its kind is declared (``ctx.not_ported_kinds``). The rule modules read
    ``ctx.traces`` and ``ctx.previous`` (the golden pixels of the previous frame, coherent
    cases); after the G-buffer, the outputs are judged against ``ctx.reference`` when it is set
    (:func:`refsoft.conformance.stages.reference_frame`)."""
    ctx.loose = bool(loose)
    claimed = registry.claims(G)

    def kind(key):
        return claimed[key][1] if key in claimed else "other"

    judged = ctx.kinds + ("other",)
    broken = {key for key in G if registry.oracle_only(key) or kind(key) not in judged}
    for key in sorted(G):
        if key in broken:
            continue
        if key not in C:
            ctx.lacks(key, "not in the candidate's outputs", kind=kind(key))
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
                        f"at {where(bad[0])}", kind=kind(key))
            broken.add(key)

    def usable(key):
        return key in G and key not in broken

    for key in sorted(G):  # the fallback rule: keys no module judges
        if key not in claimed and usable(key):
            same = np.array_equal(G[key], C[key], equal_nan=True)
            ctx.finding(key, "other", "pass" if same else "accepted", "identical" if same else "differs (not judged)",
                        kind="other")
    for module in registry.RULES:  # each judges the keys it claims (its usable keys)
        module.judge(ctx, G, C, lambda key, m=module: usable(key) and claimed.get(key, (None,))[0] is m)


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


def not_ported_summary(findings) -> dict:
    """What the candidate declared and lacks: the case frames (``{case: reason}``, one reason per
    case) and the outputs of declared kinds (``{kind: count}``)."""
    cases, outputs = {}, {}
    for f in findings:
        if f.status != "not_ported":
            continue
        if f.key == "*":
            cases.setdefault(f.case, f.message)
        else:
            outputs[f.kind] = outputs.get(f.kind, 0) + 1
    return {"cases": cases, "outputs": dict(sorted(outputs.items()))}


def check(golden, candidate, loose=False, out=None, cases=None, progress=False, kinds=None, profile="default") -> dict:
    """Compare a candidate folder with a golden set; returns the summary (also written to
    ``out/summary.json`` when ``out`` is given).

    Parameters
    ----------
    golden, candidate : str or PathLike
        The candidate may hold a ``ported.json`` (:mod:`refsoft.conformance.ported`) declaring
        the methods, option values and kinds of output it does not port.
    loose : bool
        The loose image rule.
    out : str or PathLike, optional
        Report folder, outside the golden and candidate folders: ``summary.json`` (every
        finding, the counts per kind and status, what was not ported, the pictures written)
        and, for each output that did not pass, its error mask (and the image's difference),
        magnified :data:`MAGNIFY` times. Pictures an earlier report there listed are removed
        first.
    cases : list of str, optional
        Only these cases (the others are excluded, not missing).
    kinds : list of str, optional
        Only these kinds of output (:data:`KINDS`; names may also be comma-separated): the
        others are neither judged nor required. By default every kind: an output or a case
        frame the candidate lacks is ``missing``, which fails the check like ``fail``, unless
        its ``ported.json`` declares it (``not_ported``).
    profile : {"default", "gpu"}
        The rules (:mod:`refsoft.conformance.profiles`): the exact ones, or those for a port
        using its GPU's own interpolation and built-ins (which implies ``loose``).

    Raises
    ------
    RefsoftError
        No golden set, no candidate folder, an unknown case, ``out`` inside either folder.
    InputFileError
        The manifest, a frame's ``.npz``, a candidate's traces or ``ported.json`` cannot be read
        or are malformed.
    """
    from ..io import read_npz, write_json
    from .golden import read_manifest, sha256

    golden, candidate = os.fspath(golden), os.fspath(candidate)
    kinds = check_kinds(kinds)
    prof = get_profile(profile)
    loose = bool(loose or prof.loose_images)
    manifest = read_manifest(golden)
    if not os.path.isdir(candidate):
        raise RefsoftError(f"{candidate} is not a folder")
    ported = read_ported(candidate, KINDS)
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
        ctx = Context(name, f, entry, out, kinds, prof, kind_of=output_kind)
        ctx.not_ported_kinds = ported.kinds
        rel = f"{name}/frame_{f:04d}.npz"
        gpath = os.path.join(golden, rel)
        cpath = os.path.join(candidate, rel)
        if not os.path.isfile(gpath) or manifest["files"].get(rel) != sha256(gpath):
            ctx.finding("*", "reference", "fail", f"golden file {rel} is missing or altered (SHA-256)")
            findings += ctx.findings
            continue
        reason = ported.case_reason(entry["options"])
        if reason is not None and not os.path.isfile(cpath):
            ctx.finding("*", "presence", "not_ported", f"{rel} not in the candidate: {reason}")
            findings += ctx.findings
            continue
        if f == entry["frames"][0]:
            for module in registry.case_rules():  # outputs written once per case (ldt_J.npz)
                if set(module.KINDS) & set(kinds):
                    module.judge_case(ctx, golden, candidate, manifest)
        if not os.path.isfile(cpath):
            ctx.finding("*", "presence", "missing", f"{rel} not in the candidate")
            missing_cases.append(rel)
            findings += ctx.findings
            continue
        G, C = read_npz(gpath), read_npz(cpath)
        ctx.traces = load_traces(os.path.join(candidate, name, f"traces_{f:04d}.json"))
        ctx.previous = prev.get(name) if entry["options"].get("coherence", True) else None
        reference_frame(ctx, G, C, prev.get(name), cand_prev.get(name), drivers)
        check_frame(ctx, G, C, loose)
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
               "passed": not any(counts[s] for s in FAILING), "counts": counts, "by_kind": by_kind(findings),
               "declared": ported.to_dict() if ported.path else None,
               "not_ported": not_ported_summary(findings),
               "missing_files": missing_cases, "pictures": pictures, "findings": [f.to_dict() for f in findings]}
    if out is not None:
        write_json(os.path.join(out, "summary.json"), summary)
    summary["_findings"] = findings
    return summary

"""Step-by-step replay of one pixel's LDT search (docs/ldt.md, "Tracing a pixel").

:func:`trace_pixel` renders a frame with :class:`~refsoft.ldt.method.LayeredDepthTextures` (or
takes a frame already rendered), then runs the search of one reflector pixel again in plain
Python on scalars of the working precision, in the kernel's order of operations
(:mod:`refsoft.ldt._search`), recording every step: each object's cube clip and region test, the
faces in order, every linear sample (s, texel, h, the layers' z and d visited, the decision),
the bisection, the residual against tau, and the nearest hit over the objects. It ends where the
kernel ends, bit for bit.

A :class:`PixelTrace` prints as a table (one line per linear sample), saves as ``trace.json``
and, with matplotlib, draws the march over each face's depth layers (``trace.png``,
:func:`write_pixel_trace`).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np

from .. import validate
from ..errors import RefsoftError
from ..keys import OBJECT_ID
from . import constants as C

#: Face names in OpenGL order.
FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
#: The keyword arguments of :class:`~refsoft.ldt.method.LayeredDepthTextures` a trace accepts.
PARAMETERS = ("resolution", "layers", "faces", "linear", "tau", "regions", "precision")


# --- the replay ---------------------------------------------------------------------------------
def _texel(q0, u, s, f, R, dt):
    """Face ``f``'s (row, col, h, margin) at ``q0 + s u``, as the kernel's ``_texel``."""
    one, half, Rf = dt(1), dt(0.5), dt(R)
    q = [q0[i] + s * u[i] for i in range(3)]
    sa, ss, ta, ts = (int(x) for x in C.FACE_TABLE[f])
    sc = q[sa] if ss > 0 else -q[sa]
    tc = q[ta] if ts > 0 else -q[ta]
    x = ((sc + one) * half) * Rf
    y = ((tc + one) * half) * Rf
    col = min(max(int(np.floor(x)), 0), R - 1)
    row = R - 1 - min(max(int(np.floor(y)), 0), R - 1)
    qa = q[f // 2]
    h = half * (one - qa) if f % 2 == 0 else half * (one + qa)

    def int_margin(v):
        k = np.floor(v + half)
        return abs(v - k) if dt(0) < k < Rf else one

    return row, col, h, min(int_margin(x), int_margin(y))


def _face(q0, u, s_in, s_out, umax, n_lin, f, k, stack, dt):
    """One face's linear search and bisection, recorded (the kernel's ``_face_search``)."""
    R = stack.resolution
    one, half, zero, Rf = dt(1), dt(0.5), dt(0), dt(R)
    depth, back, count = stack.depth[k, f], stack.back[k, f], stack.count[k, f]
    if n_lin > 0:
        n = n_lin
    else:
        n = min(max(int(np.ceil(((umax * (s_out - s_in)) * Rf) * half)), 1), C.TEXEL_STEPS_PER_R * R)
    D = (s_out - s_in) / dt(n)
    rec = {"face": f, "name": FACE_NAMES[f], "axis": f // 2, "steps": n, "step": float(D), "samples": [],
           "bisection": None}
    margin, found, h, row, col = one, -1, zero, 0, 0
    sheet, in_front = bool(stack.open[k]), False  # an open sheet: the crossing rule
    for m in range(n + 1):
        sm = s_in + dt(m) * D
        row, col, h, mt = _texel(q0, u, sm, f, R, dt)
        margin = min(margin, mt)
        layers = []
        front = False
        for j in range(int(count[row, col])):
            z = dt(depth[j, row, col])
            margin = min(margin, abs(h - z))
            if h < z:
                layers.append({"layer": j, "z": float(z), "d": None, "test": "front"})
                front = True
                break
            d = back[j, row, col]
            margin = min(margin, abs(h - d))
            crossed = in_front or not sheet
            test = "behind" if h > d else ("inside" if crossed else "not crossed")
            layers.append({"layer": j, "z": float(z), "d": float(d), "test": test})
            if h <= d:
                found = j if crossed else -1
                break
        rec["samples"].append({"m": m, "s": float(sm), "texel": [row, col], "h": float(h),
                               "count": int(count[row, col]), "layers": layers, "inside": found >= 0})
        if found >= 0:
            break
        in_front = front
    rec.update(found=found >= 0, start_inside=False, s_hit=None, h_hit=None, layer=None, texel=None, residual=None)
    if found < 0:
        return rec, None, len(rec["samples"]), 0, margin
    j = found
    if m == 0:
        e = (h - dt(depth[j, row, col])) * Rf
        rec.update(start_inside=True, s_hit=float(s_in), h_hit=float(h), layer=j, texel=[row, col], residual=float(e))
        return rec, (s_in, j, row, col, e, True), 1, 0, margin
    lo, hi = s_in + dt(m - 1) * D, s_in + dt(m) * D
    length = ((D * umax) * Rf) * half
    bis = {"lo": float(lo), "hi": float(hi), "texels": float(length), "points": []}
    steps = 0
    while length > dt(C.BISECTION_TEXELS) and steps < C.BISECTION_MAX:
        length, steps = length * half, steps + 1
    best = (row, col, h)
    for _ in range(steps):
        mid = half * (lo + hi)
        r, c, hm, mt = _texel(q0, u, mid, f, R, dt)
        margin = min(margin, mt)
        inside, z, d = False, None, None
        if j < int(count[r, c]):
            z, d = dt(depth[j, r, c]), back[j, r, c]
            margin = min(margin, min(abs(hm - z), abs(hm - d)))
            inside = z <= hm and hm <= d
        bis["points"].append({"s": float(mid), "texel": [r, c], "h": float(hm), "z": None if z is None else float(z),
                              "d": None if d is None else float(d), "inside": bool(inside)})
        if inside:
            hi, best = mid, (r, c, hm)
        else:
            lo = mid
    e = (best[2] - dt(depth[j, best[0], best[1]])) * Rf
    rec["bisection"] = bis
    rec.update(s_hit=float(hi), h_hit=float(best[2]), layer=j, texel=[best[0], best[1]], residual=float(e))
    return rec, (hi, j, best[0], best[1], e, False), len(rec["samples"]), steps, margin


def replay(P, N, eye, view_dir, triangle, region, use_regions, W, stack, n_lin, tau, max_faces, dt):
    """The search of one pixel, recorded: the kernel's arithmetic on ``dt`` scalars.

    Parameters
    ----------
    P, N : array_like (3,)
        World position and unit normal (in ``dt``).
    eye : array_like (3,)
    view_dir : array_like (3,) or None
        An orthographic camera's view direction (then ``I = view_dir``).
    triangle : int
        The reflector triangle (row of ``region``).
    region : ndarray (T, K) bool
    use_regions : bool
    W : ndarray (K, 4, 4) in ``dt``
    stack : Stack
    n_lin : int
        Linear steps per face, 0 for "texel".
    tau : float
    max_faces : int
        3, or 1 (the entry face only).
    dt : numpy scalar type (np.float32 or np.float64)

    Returns
    -------
    ray : dict
        ``incident`` and ``direction`` (floats).
    objects : list of dict
        Per reflected object in id order: the cube clip, the region test, the faces searched.
    result : dict
        The pixel's outputs, as :class:`refsoft.ldt.search.PixelSearch` gives them.
    """
    zero, one, two, inf = dt(0), dt(1), dt(2), dt(np.inf)
    px, py, pz = (dt(x) for x in P)
    if view_dir is not None:
        ix, iy, iz = (dt(x) for x in view_dir)
    else:
        dx, dy, dz = px - dt(eye[0]), py - dt(eye[1]), pz - dt(eye[2])
        length = np.sqrt((dx * dx + dy * dy) + dz * dz)
        ix, iy, iz = dx / length, dy / length, dz / length
    nx, ny, nz = (dt(x) for x in N)
    kk = two * ((nx * ix + ny * iy) + nz * iz)
    r = [ix - kk * nx, iy - kk * ny, iz - kk * nz]
    flags, samples, steps, faces, tested = 0, 0, 0, 0, 0
    best = None
    any_margin = one
    K = len(stack.ids)
    distances = [-1.0] * K
    objects = []
    for k in range(K):
        Wk = W[k]
        q0 = [((Wk[i, 0] * px + Wk[i, 1] * py) + Wk[i, 2] * pz) + Wk[i, 3] for i in range(3)]
        u = [(Wk[i, 0] * r[0] + Wk[i, 1] * r[1]) + Wk[i, 2] * r[2] for i in range(3)]
        near, far, entry, miss = -inf, inf, -1, False
        nears, fars = [None] * 3, [None] * 3
        for a in range(3):
            if u[a] == zero:
                miss = miss or abs(q0[a]) > one
                continue
            lo, hi = (-one - q0[a]) / u[a], (one - q0[a]) / u[a]
            if hi < lo:
                lo, hi = hi, lo
            nears[a], fars[a] = float(lo), float(hi)
            if lo > near:  # ties keep the smaller axis
                near, entry = lo, a
            far = min(far, hi)
        s_in = max(zero, near)
        obj = {"index": k, "id": int(stack.ids[k]), "q0": [float(x) for x in q0], "u": [float(x) for x in u],
               "near": nears, "far": fars, "s_in": float(s_in), "s_out": float(far),
               "region": bool(region[triangle, k]) if use_regions else None, "status": None, "entry_axis": None,
               "origin_in_cube": False, "face_order": [], "faces": [], "chosen_face": None, "distance": None,
               "accepted": False}
        objects.append(obj)
        if miss or entry < 0 or not s_in < far:
            obj["status"] = "misses the cube"
            continue
        if use_regions and not region[triangle, k]:
            flags |= C.REGION_CULLED
            obj["status"] = "region culled"
            continue
        obj["status"] = "searched"
        tested += 1
        if not near > zero:
            flags |= C.ORIGIN_IN_CUBE
            entry = -1
            obj["origin_in_cube"] = True
        s_out = far
        au = [abs(x) for x in u]
        umax = max(au[0], max(au[1], au[2]))
        order = [entry] if entry >= 0 else []
        while True:  # then decreasing |u_i|, ties to the smaller axis; u_i == 0 never
            pick, best_u = -1, zero
            for a in range(3):
                if a not in order and au[a] > best_u:
                    pick, best_u = a, au[a]
            if pick < 0:
                break
            order.append(pick)
        order = order[:max_faces]
        obj["entry_axis"] = entry if entry >= 0 else None
        obj["face_order"] = [2 * a + (1 if u[a] > zero else 0) for a in order]
        cand, cand_f, cand_e, accepted = None, -1, inf, False
        for f in obj["face_order"]:
            rec, res, n_s, n_b, margin = _face(q0, u, s_in, s_out, umax, n_lin, f, k, stack, dt)
            obj["faces"].append(rec)
            faces, samples, steps = faces + 1, samples + n_s, steps + n_b
            any_margin = min(any_margin, margin)
            if res is None:
                rec["verdict"] = "miss"
                continue
            if res[4] <= dt(tau):
                rec["verdict"] = "accepted"
                cand, cand_f, accepted = (res, margin), f, True
                break
            rec["verdict"] = "rejected"
            if res[4] < cand_e:
                cand_e, cand, cand_f = res[4], (res, margin), f
        if cand is None:
            continue
        (t_k, j, row, col, e, start), margin = cand
        distances[k] = float(t_k)
        obj.update(chosen_face=cand_f, distance=float(t_k), accepted=accepted)
        if best is None or t_k < best[0]:
            best = (t_k, k, cand_f, j, row, col, e, margin,
                    (C.START_INSIDE if start else 0) | (0 if accepted else C.NO_FACE_WITHIN_TAU))
    result = {"object": -1, "object_id": 0, "distance": -1.0, "face": -1, "layer": -1, "texel": [-1, -1],
              "residual": 0.0, "margin": float(any_margin), "hit": [0.0, 0.0, 0.0]}
    if best is not None:
        t, k, f, j, row, col, e, margin, hit_flags = best
        flags |= hit_flags
        if stack.mismatch[k, f, row, col]:
            flags |= C.LAYER_MISMATCH
        if stack.open[k]:
            flags |= C.OPEN_OBJECT
        result.update(object=k, object_id=int(stack.ids[k]), distance=float(t), face=f, layer=j, texel=[row, col],
                      residual=float(e), margin=float(margin),
                      hit=[float(px + t * r[0]), float(py + t * r[1]), float(pz + t * r[2])])
    result.update(flags=flags, linear_samples=samples, binary_steps=steps, faces_searched=faces,
                  objects_tested=tested, object_distance=distances)
    ray = {"incident": [float(ix), float(iy), float(iz)], "direction": [float(x) for x in r]}
    return ray, objects, result


# --- the record ---------------------------------------------------------------------------------
def flag_names(flags: int) -> list:
    """The names (``stats.json``'s) of the bits set in an ``ldt_flags`` value."""
    from .method import FLAG_NAMES

    return [name for bit, name in FLAG_NAMES.items() if flags & bit]


def _layers_text(sample) -> str:
    parts = []
    for v in sample["layers"]:
        j = v["layer"]
        parts.append(f"z{j} {v['z']:.6f}" + ("" if v["d"] is None else f" d{j} {v['d']:.6f}"))
    return "; ".join(parts) if parts else "-"


def _decision(sample) -> str:
    if not sample["layers"]:
        return "outside (empty texel)"
    last = sample["layers"][-1]
    if last["test"] == "inside":
        return f"inside layer {last['layer']}"
    if last["test"] == "front":
        return f"outside (in front of layer {last['layer']})"
    if last["test"] == "not crossed":
        return "outside (behind the sheet, not crossed from in front)"
    return f"outside (behind layer {last['layer']})"


@dataclass
class PixelTrace:
    """One pixel's LDT search, step by step (:func:`trace_pixel`).

    Attributes
    ----------
    scene : str
    frame : int
    pixel : [row, col]
    reflector : int
        The reflector's object id.
    names : dict of int -> str
        Object names by id.
    options : dict
        ``resolution``, ``layers``, ``faces``, ``linear``, ``tau``, ``regions``, ``precision``.
    ray : dict
        ``origin`` P, ``normal`` N, ``eye`` (None for an orthographic camera), ``view_dir``
        (orthographic only), ``incident`` I, ``direction`` r, ``triangle`` (the reflector's).
    objects : list of dict
        Per reflected object (id order): ``id``, ``q0``, ``u``, the slab clip (``near``, ``far``
        per axis, None where ``u_i = 0``; ``s_in``, ``s_out``), ``region`` (the cone test, None
        without), ``status`` ("misses the cube", "region culled", "searched"), ``entry_axis``,
        ``origin_in_cube``, ``face_order`` and ``faces``: per face searched its ``steps`` N and
        ``step`` D, the ``samples`` (``m``, ``s``, ``texel``, ``h``, ``count``, the ``layers``
        visited with ``z``, ``d`` and their ``test`` "front", "behind", "inside" or, for an open
        sheet the ray lies behind without having crossed it, "not crossed"), the
        ``bisection`` (``lo``, ``hi``, the step's ``texels``, its ``points``), ``s_hit``,
        ``layer``, ``texel``, ``residual`` and ``verdict`` ("miss", "accepted", "rejected");
        then the object's ``chosen_face``, ``distance`` and ``accepted``.
    result : dict
        The pixel's outputs: ``object`` (index, -1 none), ``object_id``, ``distance``, ``face``,
        ``layer``, ``texel``, ``residual``, ``margin``, ``hit``, ``flags``, ``linear_samples``,
        ``binary_steps``, ``faces_searched``, ``objects_tested``, ``object_distance``.
    stack : Stack
        The LDTs searched (for :func:`march_figure`; not saved).
    """

    scene: str
    frame: int
    pixel: list
    reflector: int
    names: dict
    options: dict
    ray: dict
    objects: list
    result: dict
    stack: object = field(default=None, repr=False)

    def name(self, object_id: int) -> str:
        """The object's name ("?" for an unknown id)."""
        return self.names.get(int(object_id), "?")

    def to_dict(self) -> dict:
        """``trace.json``: every field but the stack, with the flags' names."""
        res = dict(self.result, flag_names=flag_names(self.result["flags"]))
        return {"method": "ldt", "scene": self.scene, "frame": self.frame, "pixel": self.pixel,
                "reflector": self.reflector, "reflector_name": self.name(self.reflector), "options": self.options,
                "ray": self.ray, "objects": [dict(o, name=self.name(o["id"])) for o in self.objects], "result": res}

    def to_json(self) -> str:
        """:meth:`to_dict` as indented JSON."""
        return json.dumps(self.to_dict(), indent=1)

    def samples(self) -> list:
        """Every linear sample in search order, as ``(object id, face, sample dict)``."""
        return [(o["id"], fc["face"], s) for o in self.objects for fc in o["faces"] for s in fc["samples"]]

    def describe(self) -> str:
        """One line: the pixel, the reflector, the frame, the options and the ray."""
        o = self.options
        p, r = self.ray["origin"], self.ray["direction"]
        return (f"pixel ({self.pixel[0]}, {self.pixel[1]}) of reflector {self.reflector} "
                f"({self.name(self.reflector)!r}), frame {self.frame}, LDT R {o['resolution']}, layers "
                f"{o['layers']}, faces {o['faces']}, linear {o['linear']}, tau {o['tau']:g}, regions "
                f"{o['regions']}, {o['precision']}; P ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}), "
                f"r ({r[0]:.6g}, {r[1]:.6g}, {r[2]:.6g})")

    def table(self, bisection: bool = False) -> str:
        """The search as a text table: one line per linear sample (object, face, m, s, texel, h, the
        layers' z and d visited, the decision; the sample that ends a face's search also says
        how the face ended), then one line per object and the result. ``bisection`` adds one
        line per bisection step after the sample it starts from."""
        texts = [_layers_text(s) for _, _, s in self.samples()]
        lw = max([len(t) for t in texts] + [len("layers (z, d)"), 24 if bisection else 0])
        head = f"{'obj':>3} {'face':<4} {'m':>4} {'s':>12} {'texel':>12} {'h':>10}  {'layers (z, d)':<{lw}} decision"
        lines = [head, "-" * len(head)]
        for o in self.objects:
            for fc in o["faces"]:
                last = len(fc["samples"]) - 1
                for i, s in enumerate(fc["samples"]):
                    texel = f"({s['texel'][0]}, {s['texel'][1]})"
                    text = _decision(s)
                    if i == last:
                        text += " -> " + _face_outcome(fc, self.options["tau"])
                    lines.append(f"{o['id']:>3} {fc['name']:<4} {s['m']:>4} {s['s']:>12.7g} {texel:>12} "
                                 f"{s['h']:>10.7f}  {_layers_text(s):<{lw}} {text}")
                if bisection and fc["bisection"] is not None:
                    j = fc["layer"]
                    for b, pt in enumerate(fc["bisection"]["points"], 1):
                        texel = f"({pt['texel'][0]}, {pt['texel'][1]})"
                        zd = "-" if pt["z"] is None else f"z{j} {pt['z']:.6f} d{j} {pt['d']:.6f}"
                        lines.append(f"{o['id']:>3} {fc['name']:<4} {'b' + str(b):>4} {pt['s']:>12.7g} {texel:>12} "
                                     f"{pt['h']:>10.7f}  {zd:<{lw}} {_point_decision(pt, j)}")
        for o in self.objects:
            lines.append(f"object {o['id']} ({self.name(o['id'])!r}): " + _object_outcome(o))
        res = self.result
        named = ", ".join(flag_names(res["flags"])) or "none"
        if res["object"] < 0:
            lines.append(f"result: no hit (the reflector's own colour), {res['linear_samples']} samples, "
                         f"{res['binary_steps']} bisection steps, flags: {named}")
        else:
            lines.append(f"result: object {res['object_id']} ({self.name(res['object_id'])!r}) at t "
                         f"{res['distance']:.7g}, face {FACE_NAMES[res['face']]} layer {res['layer']} texel "
                         f"({res['texel'][0]}, {res['texel'][1]}), residual {res['residual']:.4g} texels, "
                         f"{res['linear_samples']} samples, {res['binary_steps']} bisection steps, flags: {named}")
        return "\n".join(lines)


def _point_decision(pt, j) -> str:
    if pt["inside"]:
        return f"inside layer {j}: hi = s"
    if pt["z"] is None:
        why = f"no layer {j} here"
    else:
        why = f"in front of layer {j}" if pt["h"] < pt["z"] else f"behind layer {j}"
    return f"outside ({why}): lo = s"


def _face_outcome(fc, tau) -> str:
    if not fc["found"]:
        return "face miss"
    where = f"s {fc['s_hit']:.7g} texel ({fc['texel'][0]}, {fc['texel'][1]})"
    if fc["start_inside"]:
        how = f"hit at the first sample, {where}"
    else:
        how = f"{len(fc['bisection']['points'])} bisection steps to {where}"
    sign = "<=" if fc["verdict"] == "accepted" else ">"
    return f"{how}, residual {fc['residual']:.4g} {sign} tau {tau:g}: {fc['verdict']}"


def _object_outcome(o) -> str:
    if o["status"] != "searched":
        return "ray misses its cube" if o["status"] == "misses the cube" else \
            "the region test fails for this triangle: not searched"
    faces = ", ".join(fc["name"] for fc in o["faces"])
    start = "ray starts inside the cube; " if o["origin_in_cube"] else ""
    if o["chosen_face"] is None:
        return f"{start}faces {faces} searched, no hit"
    how = "accepted" if o["accepted"] else "no face within tau, the smallest residual"
    return f"{start}faces {faces} searched, hit at t {o['distance']:.7g} on face {FACE_NAMES[o['chosen_face']]} ({how})"


# --- the entry point ----------------------------------------------------------------------------
def _method_options(m) -> dict:
    return {"resolution": m.resolution, "layers": m.layers, "faces": m.faces, "linear": m.linear, "tau": m.tau,
            "regions": m.regions, "precision": m.precision}


def trace_pixel(scene, row, col, frame=0, *, options=None, method=None, rendered=None, **params) -> PixelTrace:
    """Replay the LDT search of one reflector pixel, as a render of ``frame`` runs it.

    Parameters
    ----------
    scene : Scene
    row, col : int
        The pixel (row 0 at the top); the main view must show a reflector there.
    frame : int
    options : RenderOptions, optional
        With ``method="ldt"``: the LDT's parameters (as ``refsoft render --method ldt`` takes them).
    method : LayeredDepthTextures, optional
        A method of ``scene`` to reuse (its LDTs are built once).
    rendered : Frame, optional
        ``frame`` already rendered with ``method`` (which is then required): nothing is rendered.
    **params
        Otherwise, :class:`~refsoft.ldt.method.LayeredDepthTextures`'s keyword arguments
        (``resolution``, ``layers``, ``faces``, ``linear``, ``tau``, ``regions``, ``precision``).

    Returns
    -------
    PixelTrace
    """
    from ..frame.driver import FrameDriver, make_method
    from ..options import RenderOptions
    from ..scene.model import Scene
    from .method import LDTState, LayeredDepthTextures
    from .search import check_linear

    if not isinstance(scene, Scene):
        raise RefsoftError(f"scene must be a refsoft.Scene, got {type(scene).__name__}")
    validate.integer(frame, "frame", 0, None if scene.animation is None else scene.n_frames - 1)
    cam = scene.camera_at(frame)
    for name, v in (("row", row), ("col", col)):
        if not validate.is_integer(v):
            raise RefsoftError(f"{name} must be an integer, got {v!r}")
    if not (0 <= row < cam.height and 0 <= col < cam.width):
        raise RefsoftError(f"pixel ({row}, {col}) is off the {cam.width}x{cam.height} image (rows 0..{cam.height - 1}, "
                           f"columns 0..{cam.width - 1})")
    unknown = sorted(set(params) - set(PARAMETERS))
    if unknown:
        raise RefsoftError(f"unknown LDT parameter {unknown[0]!r} (known: {', '.join(PARAMETERS)})")
    given = [n for n, v in (("options", options), ("method", method), ("parameters", params or None)) if v is not None]
    if len(given) > 1:
        raise RefsoftError(f"give the LDT as one of options, method or parameters, not {' and '.join(given)}")
    if options is not None:
        if not isinstance(options, RenderOptions) or options.method != "ldt":
            raise RefsoftError("options must be a RenderOptions with method='ldt'")
        method = make_method(scene, options)
    elif method is None:
        method = LayeredDepthTextures(scene, **params)
    elif not isinstance(method, LayeredDepthTextures) or method.scene is not scene:
        raise RefsoftError("method must be a LayeredDepthTextures of this scene")
    if rendered is None:
        opts = options or RenderOptions(method="ldt", precision=method.precision, ldt_resolution=method.resolution,
                                        ldt_layers=method.layers, ldt_faces=method.faces, ldt_linear=method.linear,
                                        ldt_tau=method.tau, ldt_regions=method.regions)
        rendered = FrameDriver(scene, opts, method=method).render_frame(frame)
    elif getattr(rendered, "index", None) != frame or method.stack is None:
        raise RefsoftError(f"rendered must be frame {frame} as rendered with the given method")
    oid = int(rendered.arrays[OBJECT_ID][row, col])
    refl = ", ".join(f"{k} {scene.object_by_id(k).name!r}" for k in scene.reflector_ids)
    if oid <= 0 or oid not in rendered.reflectors:
        shows = "the background" if oid <= 0 else f"object {oid} {scene.object_by_id(oid).name!r}"
        raise RefsoftError(f"pixel ({row}, {col}) shows {shows}, not a reflector (reflectors: {refl})")
    st = rendered.reflectors[oid].state
    if not isinstance(st, LDTState):
        raise RefsoftError("rendered was not rendered with the layered depth textures")
    i = int(np.flatnonzero((st.rows == row) & (st.cols == col))[0])
    dt = method.stack.back.dtype.type
    eye = np.asarray(cam.eye, dt)
    view_dir = None if st.view_dir is None else np.asarray(st.view_dir, dt)
    use_regions = method.regions == "cone"
    tri = int(st.triangle[i])
    ray, objects, result = replay(st.P[i], st.N[i], eye, view_dir, tri, st.region, use_regions,
                                  np.ascontiguousarray(st.W, dt), method.stack, check_linear(method.linear),
                                  method.tau, 3 if method.faces == "three" else 1, dt)
    ray = dict(origin=[float(x) for x in st.P[i]], normal=[float(x) for x in st.N[i]],
               eye=None if view_dir is not None else [float(x) for x in eye],
               view_dir=None if view_dir is None else [float(x) for x in view_dir], triangle=tri, **ray)
    names = {k: o.name for k, o in enumerate(scene.objects, start=1)}
    return PixelTrace(scene.name, int(frame), [int(row), int(col)], oid, names, _method_options(method), ray,
                      objects, result, method.stack)


# --- the picture --------------------------------------------------------------------------------
def _pyplot():
    """matplotlib.pyplot on the Agg backend, or None when matplotlib (an optional extra) is missing."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    return plt


def _profile(stack, k, f, q0, u, s_in, s_out):
    """Dense float64 samples along one face's march (for the picture only): s (n,), h (n,), per
    layer z, d (L, n) with NaN where the texel has no such layer, and the texel (n,) as
    ``row * R + col``."""
    R = stack.resolution
    umax = max(abs(x) for x in u)
    n = int(np.clip(np.ceil(umax * (s_out - s_in) * R / 2) * 12, 240, 12000))
    s = np.linspace(s_in, s_out, n)
    q = np.asarray(q0)[None] + s[:, None] * np.asarray(u)[None]
    sa, ss, ta, ts = C.FACE_TABLE[f]
    col = np.clip(np.floor((ss * q[:, sa] + 1) * 0.5 * R).astype(np.int64), 0, R - 1)
    row = R - 1 - np.clip(np.floor((ts * q[:, ta] + 1) * 0.5 * R).astype(np.int64), 0, R - 1)
    sigma = 1.0 if f % 2 == 0 else -1.0
    h = 0.5 * (1 - sigma * q[:, f // 2])
    L = stack.depth.shape[2]
    cnt = stack.count[k, f, row, col]
    ok = np.arange(L)[:, None] < cnt[None]
    z = np.where(ok, stack.depth[k, f][:, row, col], np.nan)
    d = np.where(ok, stack.back[k, f][:, row, col].astype(np.float64), np.nan)
    return s, h, z, d, row * R + col


def march_figure(trace: PixelTrace, max_panels: int = 6):
    """A matplotlib figure of the march: one panel per face searched (at most ``max_panels``),
    the ray's depth h against s with the layers' solid spans [z, d] over the texels it crosses,
    the linear samples (outside grey, inside green), the bisection points (orange) and the face's
    hit (red). Raises RefsoftError without matplotlib."""
    plt = _pyplot()
    if plt is None:
        raise RefsoftError("the march picture needs matplotlib (pip install '.[plot]')")
    panels = [(o, fc) for o in trace.objects for fc in o["faces"]][:max_panels]
    fig, axes = plt.subplots(max(len(panels), 1), 1, figsize=(9, 2.6 * max(len(panels), 1)), squeeze=False)
    if not panels:
        axes[0, 0].text(0.5, 0.5, "no object's cube searched: no march", ha="center", va="center")
        axes[0, 0].set_axis_off()
    colours = ("tab:blue", "tab:purple", "tab:brown", "tab:olive", "tab:cyan", "tab:pink", "tab:gray", "navy")
    for ax, (o, fc) in zip(axes[:, 0], panels):
        s, h, z, d, texel = _profile(trace.stack, o["index"], fc["face"], o["q0"], o["u"], o["s_in"], o["s_out"])
        for j in range(len(z)):
            if np.isfinite(z[j]).any():
                ax.fill_between(s, z[j], d[j], where=np.isfinite(z[j]), step="mid", alpha=0.3,
                                color=colours[j % len(colours)], label=f"layer {j}: z..d", linewidth=0)
                ax.step(s, z[j], where="mid", color=colours[j % len(colours)], linewidth=0.8)
        edges = np.flatnonzero(np.diff(texel))
        if len(edges) <= 64:  # the texel boundaries crossed, where z and d may change
            for e in edges:
                ax.axvline(0.5 * (s[e] + s[e + 1]), color="0.85", linewidth=0.5, zorder=0)
        ax.plot(s, h, color="black", linewidth=1, label="ray h(s)")
        sm = np.array([[p["s"], p["h"], p["inside"]] for p in fc["samples"]])
        ax.scatter(sm[:, 0], sm[:, 1], s=14, c=np.where(sm[:, 2] > 0, "tab:green", "0.45"), zorder=3,
                   label="linear samples")
        if fc["bisection"] is not None:
            bp = np.array([[p["s"], p["h"]] for p in fc["bisection"]["points"]]).reshape(-1, 2)
            ax.scatter(bp[:, 0], bp[:, 1], s=10, marker="x", color="tab:orange", zorder=4, label="bisection")
        n = len(fc["samples"])
        title = f"object {o['id']} ({trace.name(o['id'])}), face {fc['name']}: {n} sample{'s' if n > 1 else ''}"
        if fc["found"]:
            ax.scatter([fc["s_hit"]], [fc["h_hit"]], s=60, marker="*", color="red", zorder=5, label="hit")
            title += f", residual {fc['residual']:.3g} texels, {fc['verdict']}"
        else:
            title += ", miss"
        ax.set_title(title, fontsize=9)
        ax.set_xlim(o["s_in"], o["s_out"])
        ax.set_ylim(1, 0)  # depth grows downwards from the face's plane
        ax.set_xlabel("s (world distance along r)", fontsize=8)
        ax.set_ylabel(f"depth from {fc['name']}", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.suptitle(f"{trace.scene} frame {trace.frame}, pixel ({trace.pixel[0]}, {trace.pixel[1]})", fontsize=10)
    fig.tight_layout()
    return fig


def write_pixel_trace(out, trace: PixelTrace) -> list:
    """Write ``trace.json`` and, with matplotlib, ``trace.png`` (:func:`march_figure`) into
    folder ``out``. Returns the names written."""
    from ..io import atomic_path, write_json

    os.makedirs(out, exist_ok=True)
    write_json(os.path.join(out, "trace.json"), trace.to_dict())
    plt = _pyplot()
    if plt is None:
        return ["trace.json"]
    fig = march_figure(trace)
    try:
        with atomic_path(os.path.join(out, "trace.png"), ".png") as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    finally:
        plt.close(fig)
    return ["trace.json", "trace.png"]

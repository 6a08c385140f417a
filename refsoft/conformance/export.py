"""A case's inputs in formats any language reads (spec section 8): ``refsoft export`` and every
golden case's ``CASE/inputs/``.

Layout (format ``refsoft-inputs-1``; ``docs/ports.md``, "What a port reads")::

    inputs/case.json            the case: size, options, shading, objects, per frame the camera
                                (with its float64 matrices) and the mesh file of each object
    inputs/mesh_K.ply           world mesh of object K (1-based id) when it does not move in the
                                case's frames (bit for bit the same world mesh in every frame)
    inputs/mesh_K_NNNN.ply      world mesh of object K at frame NNNN, when it moves
    inputs/proxy_K.ply          the closed proxy of an open reflector K that has one (same rule:
    inputs/proxy_K_NNNN.ply     proxy_K_NNNN.ply when it moves)
    inputs/model_K.ply          method "ldt" only: the model-space mesh of each reflected object K
                                (the layered depth textures are built from it, before any
                                transform); each frame then lists its model-to-world matrix
                                (``transforms``) and the search's world-to-cube matrix
                                (``world_to_cube``, :func:`refsoft.ldt.search.cube_matrices`)

The PLY files are written here by hand with NumPy structured arrays rather than by trimesh's
exporter, which does not promise to keep float64 values or the vertex order: every vertex
position and normal is the exact float64 value of refsoft's world mesh, in refsoft's vertex and
face order (``binary_little_endian``, ``double x y z nx ny nz``, ``list uchar int
vertex_indices``). JSON numbers are Python's shortest round-trip ``repr`` of the float64
values, so a reader gets the exact floats the oracle used.

:func:`read_inputs` reads the layout back (the tests use it; a port reads the files itself).
"""

from __future__ import annotations

import json
import os

import numpy as np

from .. import constants
from ..errors import InputFileError, RefsoftError

INPUTS_FORMAT = "refsoft-inputs-1"
#: The folder of a golden case that holds its inputs.
INPUTS_FOLDER = "inputs"

_VERTEX = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("nx", "<f8"), ("ny", "<f8"), ("nz", "<f8")])
_FACE = np.dtype([("n", "u1"), ("v", "<i4", (3,))])


def ply_bytes(vertices, normals, faces) -> bytes:
    """A binary little-endian PLY file of a triangle mesh with float64 positions and normals.

    Parameters
    ----------
    vertices, normals : ndarray, shape (V, 3), float64
    faces : ndarray, shape (F, 3), integer (stored as int32)

    Returns
    -------
    bytes
    """
    v = np.asarray(vertices, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    f = np.asarray(faces)
    header = ("ply\nformat binary_little_endian 1.0\ncomment " + INPUTS_FORMAT + "\n"
              f"element vertex {len(v)}\n"
              + "".join(f"property double {p}\n" for p in _VERTEX.names)
              + f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    vert = np.empty(len(v), dtype=_VERTEX)
    for j, p in enumerate(("x", "y", "z")):
        vert[p] = v[:, j]
        vert["n" + p] = n[:, j]
    face = np.empty(len(f), dtype=_FACE)
    face["n"] = 3
    face["v"] = f.astype(np.int32)
    return header.encode("ascii") + vert.tobytes() + face.tobytes()


def read_ply(path):
    """``(vertices, normals, faces)`` of a PLY file :func:`ply_bytes` wrote: float64 (V, 3),
    float64 (V, 3), int32 (F, 3)."""
    path = os.fspath(path)
    with open(path, "rb") as fh:
        data = fh.read()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise InputFileError(f"{path}: not a PLY file")
    lines = data[:end].decode("ascii", "replace").splitlines()
    counts = {ln.split()[1]: int(ln.split()[2]) for ln in lines if ln.startswith("element ")}
    if "format binary_little_endian 1.0" not in lines or set(counts) != {"vertex", "face"}:
        raise InputFileError(f"{path}: not a {INPUTS_FORMAT} PLY file")
    body = data[end + len(b"end_header\n"):]
    nv, nf = counts["vertex"], counts["face"]
    if len(body) != nv * _VERTEX.itemsize + nf * _FACE.itemsize:
        raise InputFileError(f"{path}: truncated or damaged ({len(body)} bytes after the header for {nv} vertices "
                             f"and {nf} faces)")
    vert = np.frombuffer(body, dtype=_VERTEX, count=nv)
    face = np.frombuffer(body, dtype=_FACE, count=nf, offset=nv * _VERTEX.itemsize)
    if nf and np.any(face["n"] != 3):
        raise InputFileError(f"{path}: a face is not a triangle")
    v = np.stack([vert[p] for p in ("x", "y", "z")], axis=1)
    n = np.stack([vert[p] for p in ("nx", "ny", "nz")], axis=1)
    return v, n, np.ascontiguousarray(face["v"], dtype=np.int32)


def _floats(a):
    """Nested lists of Python floats (JSON writes their shortest round-trip repr)."""
    return np.asarray(a, dtype=np.float64).tolist()


def camera_record(camera) -> dict:
    """The ``camera`` entry of a frame: its parameters and the float64 matrices refsoft's raster
    uses (row-major, column vectors: ``clip = view_proj @ [x, y, z, 1]``)."""
    rec = {"projection": camera.projection, "eye": _floats(camera.eye), "target": _floats(camera.target),
           "up": _floats(camera.up), "fov_y": float(camera.fov_y), "near": float(camera.near),
           "far": float(camera.far), "width": int(camera.width), "height": int(camera.height)}
    if camera.projection == "orthographic":
        rec["ortho_height"] = float(camera.ortho_height)
    rec.update(view=_floats(camera.view_matrix()), projection_matrix=_floats(camera.projection_matrix()),
               view_proj=_floats(camera.view_proj()))
    return rec


def _same_mesh(a, b) -> bool:
    return (np.array_equal(a.vertices, b.vertices) and np.array_equal(a.normals, b.normals)
            and np.array_equal(a.faces, b.faces))


def _mesh_files(scene, frames, k, proxy):
    """``{frame: (file name, Mesh)}`` of object ``k``'s world mesh (or closed proxy): one file
    when the mesh is the same, bit for bit, in every frame."""
    prefix = "proxy" if proxy else "mesh"
    meshes = {f: scene.world_mesh(k, f, proxy=proxy) for f in frames}
    first = meshes[frames[0]]
    if all(_same_mesh(first, m) for m in meshes.values()):
        return {f: (f"{prefix}_{k}.ply", first) for f in frames}
    return {f: (f"{prefix}_{k}_{f:04d}.ply", m) for f, m in meshes.items()}


def write_inputs(folder, scene, frames, options, case=None) -> list:
    """Write the inputs of rendering ``frames`` of ``scene`` with ``options`` into ``folder``.

    Parameters
    ----------
    folder : str or PathLike
        Created if needed; ``case.json`` and the PLY files are written atomically.
    scene : Scene
    frames : sequence of int
        The frames in the order they are rendered (coherence runs in this order).
    options : RenderOptions or dict
        The render's options (``case.json`` holds every field, the preset resolved).
    case : str, optional
        The case's name (default: the scene's).

    Returns
    -------
    list of str
        The files written, relative to ``folder``, ``case.json`` first.
    """
    from .. import __version__
    from ..io import atomic_path
    from ..options import RenderOptions

    opts = options if isinstance(options, RenderOptions) else RenderOptions(**dict(options))
    frames = [int(f) for f in frames]
    if not frames or len(set(frames)) != len(frames) or min(frames) < 0:
        raise RefsoftError(f"frames must be distinct frame indices, at least one, got {frames}")
    if scene.animation is not None and max(frames) >= scene.n_frames:
        raise RefsoftError(f"frame must be in [0, {scene.n_frames - 1}], got {max(frames)}")
    folder = os.fspath(folder)
    os.makedirs(folder, exist_ok=True)
    files = {}  # name -> Mesh, each written once
    per_frame = {f: {"meshes": {}, "proxies": {}} for f in frames}
    for k, obj in enumerate(scene.objects, start=1):
        for proxy in (False, True):
            if proxy and obj.closed_proxy is None:
                continue
            for f, (name, mesh) in _mesh_files(scene, frames, k, proxy).items():
                per_frame[f]["proxies" if proxy else "meshes"][str(k)] = name
                files[name] = mesh
    models = _model_records(scene, frames, opts) if opts.method == "ldt" else {}
    for k, rec in models.items():
        files[rec["file"]] = scene.object_by_id(k).mesh
        for f in frames:
            per_frame[f].setdefault("transforms", {})[str(k)] = rec["transforms"][f]
            per_frame[f].setdefault("world_to_cube", {})[str(k)] = rec["world_to_cube"][f]
    cam0 = scene.camera_at(frames[0])
    record = {
        "format": INPUTS_FORMAT, "refsoft": __version__, "case": case or scene.name, "scene": scene.name,
        "width": int(cam0.width), "height": int(cam0.height), "options": opts.as_dict(),
        "shading": {"light": _floats(constants.LIGHT_DIRECTION), "ambient": float(constants.AMBIENT),
                    "diffuse": float(constants.DIFFUSE), "background": _floats(constants.BACKGROUND_COLOR)},
        "objects": [{"id": k, "name": o.name, "reflector": bool(o.reflector), "open": bool(o.open),
                     "color": _floats(o.color), "reflectivity": float(o.reflectivity),
                     **({"model": models[k]["file"]} if k in models else {})}
                    for k, o in enumerate(scene.objects, start=1)],
        "frames": [{"frame": f, "camera": camera_record(scene.camera_at(f)), **per_frame[f]} for f in frames],
    }
    with atomic_path(os.path.join(folder, "case.json")) as tmp:
        with open(tmp, "w") as fh:
            fh.write(json.dumps(record, indent=1, sort_keys=False) + "\n")
    for name, mesh in files.items():
        with atomic_path(os.path.join(folder, name), ".ply") as tmp:
            with open(tmp, "wb") as fh:
                fh.write(ply_bytes(mesh.vertices, mesh.normals, mesh.faces))
    return ["case.json"] + list(files)


def _model_records(scene, frames, opts) -> dict:
    """Per reflected object K of a method "ldt" case: its model mesh's file name, and per frame
    its model-to-world matrix and the world-to-cube matrix the search uses (float64, 4 x 4, as
    nested lists), from the cube of its model-space vertices at ``opts.ldt_resolution``."""
    from types import SimpleNamespace

    from ..ldt.build import cube_of
    from ..ldt.search import cube_matrices

    ids = [k for k in range(1, len(scene.objects) + 1) if not scene.object_by_id(k).reflector]
    cubes = [cube_of(scene.object_by_id(k).mesh.vertices, opts.ldt_resolution) for k in ids]
    stack = SimpleNamespace(ids=np.asarray(ids, np.int32), centre=np.array([c for c, _ in cubes]).reshape(-1, 3),
                            half=np.array([h for _, h in cubes], np.float64))
    out = {k: {"file": f"model_{k}.ply", "transforms": {}, "world_to_cube": {}} for k in ids}
    for f in frames:
        transforms = {k: scene.transform_at(k, f) for k in ids}
        W = cube_matrices(stack, transforms)
        for i, k in enumerate(ids):
            out[k]["transforms"][f] = _floats(transforms[k].matrix())
            out[k]["world_to_cube"][f] = _floats(W[i])
    return out


def read_inputs(folder) -> dict:
    """Read a folder :func:`write_inputs` wrote.

    Returns
    -------
    dict
        ``case``: the content of ``case.json``; ``meshes`` and ``proxies``: ``{frame: {object
        id: (vertices (V, 3) float64, normals (V, 3) float64, faces (F, 3) int32)}}``; for a
        method "ldt" case also ``models``: ``{object id: (vertices, normals, faces)}`` (model
        space).
    """
    from ..io import read_json

    folder = os.fspath(folder)
    case = read_json(os.path.join(folder, "case.json"), format=INPUTS_FORMAT, required=("objects", "frames"))
    cache = {}

    def mesh(name):
        if name not in cache:
            cache[name] = read_ply(os.path.join(folder, name))
        return cache[name]

    out = {"case": case, "meshes": {}, "proxies": {}}
    for fr in case["frames"]:
        for kind in ("meshes", "proxies"):
            out[kind][fr["frame"]] = {int(k): mesh(name) for k, name in fr[kind].items()}
    models = {o["id"]: mesh(o["model"]) for o in case["objects"] if "model" in o}
    if models:  # method "ldt"
        out["models"] = models
    return out


def export_frames(scene, frames=None, frame=None) -> list:
    """The frames ``refsoft export`` writes: ``frame`` alone (K), ``frames`` as a count ``"N"``
    (0 .. N-1) or a range ``"A:B"`` (A .. B-1), or by default every frame of the animation (frame
    0 of a static scene); checked against the animation's length."""
    from ..frame import frame_indices

    if frame is not None and frames is not None:
        raise RefsoftError("give --frames or --frame K, not both")
    if frame is not None:
        return frame_indices(scene, [frame])
    if frames is None:
        return frame_indices(scene, None)
    text = str(frames).strip()
    try:
        if ":" in text:
            a, b = (int(x) for x in text.split(":"))
        else:
            a, b = 0, int(text)
    except ValueError:
        raise RefsoftError(f"--frames takes a count N or a range A:B (frames A..B-1), got {frames!r}") from None
    if not 0 <= a < b:
        raise RefsoftError(f"--frames {text}: the range is empty or negative")
    return frame_indices(scene, list(range(a, b)))


def export_inputs(folder, scene, frames, options, overwrite=False) -> list:
    """``refsoft export``: :func:`write_inputs` into a folder of its own. A folder that already
    holds a ``case.json`` is refused unless ``overwrite``, which then also removes the mesh files
    the old ``case.json`` lists and the new one does not (so no stale frame is left)."""
    from ..io import read_json

    folder = os.fspath(folder)
    old_case = os.path.join(folder, "case.json")
    old = []
    if os.path.exists(old_case):
        if not overwrite:
            raise RefsoftError(f"{folder} already holds exported inputs (case.json); give --overwrite to replace "
                               "them, or another --out")
        try:
            data = read_json(old_case, format=INPUTS_FORMAT, required=("frames",))
            old = [n for fr in data["frames"] for kind in ("meshes", "proxies") for n in fr.get(kind, {}).values()]
            old += [o["model"] for o in data.get("objects", []) if isinstance(o, dict) and "model" in o]
        except (InputFileError, AttributeError, TypeError):
            old = []  # an unreadable case.json lists nothing to remove; it is overwritten
    written = write_inputs(folder, scene, frames, options)
    for name in set(old) - set(written):
        p = os.path.join(folder, name)
        if isinstance(name, str) and os.path.basename(name) == name and name.endswith(".ply") and os.path.isfile(p):
            os.unlink(p)
    return written

"""A golden case's inputs (``CASE/inputs/``, format ``refsoft-inputs-1``): ``case.json`` and
binary PLY meshes, read with NumPy only (docs/ports.md, "What a port reads")."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np

INPUTS_FORMAT = "refsoft-inputs-1"
_VERTEX = np.dtype([("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("nx", "<f8"), ("ny", "<f8"), ("nz", "<f8")])
_FACE = np.dtype([("n", "u1"), ("v", "<i4", (3,))])


class InputError(ValueError):
    """An input file that cannot be read as the format says."""


@dataclass(frozen=True, eq=False)
class Mesh:
    """A world mesh: float64 (V, 3) vertices and normals, int32 (F, 3) faces."""

    vertices: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    name: str = ""

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)


def read_ply(path) -> Mesh:
    """A binary little-endian PLY of float64 ``x y z nx ny nz`` vertices and triangle faces."""
    with open(path, "rb") as fh:
        data = fh.read()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise InputError(f"{path}: not a PLY file")
    header = data[:end].decode("ascii", "replace").splitlines()
    if "format binary_little_endian 1.0" not in header:
        raise InputError(f"{path}: not a binary little-endian PLY file")
    counts = {ln.split()[1]: int(ln.split()[2]) for ln in header if ln.startswith("element ")}
    props = [ln.split()[-1] for ln in header if ln.startswith("property double")]
    if set(counts) != {"vertex", "face"} or props != list(_VERTEX.names):
        raise InputError(f"{path}: expected double x y z nx ny nz vertices and faces")
    nv, nf = counts["vertex"], counts["face"]
    body = data[end + len(b"end_header\n"):]
    if len(body) != nv * _VERTEX.itemsize + nf * _FACE.itemsize:
        raise InputError(f"{path}: {len(body)} bytes after the header for {nv} vertices and {nf} faces")
    vert = np.frombuffer(body, dtype=_VERTEX, count=nv)
    face = np.frombuffer(body, dtype=_FACE, count=nf, offset=nv * _VERTEX.itemsize)
    if nf and np.any(face["n"] != 3):
        raise InputError(f"{path}: a face is not a triangle")
    v = np.stack([vert[p] for p in ("x", "y", "z")], axis=1)
    n = np.stack([vert[p] for p in ("nx", "ny", "nz")], axis=1)
    return Mesh(np.ascontiguousarray(v), np.ascontiguousarray(n), np.ascontiguousarray(face["v"], dtype=np.int32),
                os.path.basename(path))


@dataclass(eq=False)
class Frame:
    """One frame of a case: its index, the view camera's record (``case.json``) and float64
    matrices, the world mesh of every object and the closed proxies, by object id; for method
    ``ldt`` each reflected object's transform and world-to-cube matrix."""

    index: int
    camera: dict
    view: np.ndarray
    projection: np.ndarray
    view_proj: np.ndarray
    eye: np.ndarray
    meshes: dict
    proxies: dict
    transforms: dict = field(default_factory=dict)     # object id -> model to world (method ldt)
    world_to_cube: dict = field(default_factory=dict)  # object id -> W_K, float64 (method ldt)


@dataclass(eq=False)
class Case:
    """A case: its name, image size, options, shading, objects, frames (in render order) and the
    reflected objects' model-space meshes (``model_K.ply``, cases of method ``ldt``)."""

    name: str
    width: int
    height: int
    options: dict
    shading: dict
    objects: list
    frames: list = field(default_factory=list)
    models: dict = field(default_factory=dict)   # object id -> model-space Mesh (method ldt)

    @property
    def reflector_ids(self) -> list:
        return [o["id"] for o in self.objects if o["reflector"]]

    @property
    def reflected_ids(self) -> list:
        """The ids of the non-reflector objects, whose vertices are searched, in id order."""
        return [o["id"] for o in self.objects if not o["reflector"]]


def _matrix(value, what):
    m = np.asarray(value, dtype=np.float64)
    if m.shape != (4, 4):
        raise InputError(f"{what} must be 4 x 4, got shape {m.shape}")
    return m


def read_case(folder) -> Case:
    """Read ``folder/case.json`` and every mesh it names (each file once)."""
    folder = os.fspath(folder)
    path = os.path.join(folder, "case.json")
    try:
        with open(path) as fh:
            data = json.load(fh)
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: {exc}") from None
    if data.get("format") != INPUTS_FORMAT:
        raise InputError(f"{path}: format {data.get('format')!r}, expected {INPUTS_FORMAT!r}")
    cache = {}

    def mesh(name):
        if name not in cache:
            cache[name] = read_ply(os.path.join(folder, name))
        return cache[name]

    objects = sorted(data["objects"], key=lambda o: o["id"])
    if [o["id"] for o in objects] != list(range(1, len(objects) + 1)):
        raise InputError(f"{path}: object ids must be 1..{len(objects)}")
    case = Case(data["case"], int(data["width"]), int(data["height"]), data["options"], data["shading"], objects)
    case.models = {int(o["id"]): mesh(o["model"]) for o in objects if "model" in o}
    for fr in data["frames"]:
        cam = fr["camera"]
        meshes = {int(k): mesh(n) for k, n in fr["meshes"].items()}
        if sorted(meshes) != [o["id"] for o in objects]:
            raise InputError(f"{path}: frame {fr['frame']} lacks the mesh of an object")
        case.frames.append(Frame(int(fr["frame"]), cam, _matrix(cam["view"], "view"),
                                 _matrix(cam["projection_matrix"], "projection_matrix"),
                                 _matrix(cam["view_proj"], "view_proj"), np.asarray(cam["eye"], dtype=np.float64),
                                 meshes, {int(k): mesh(n) for k, n in fr.get("proxies", {}).items()},
                                 {int(k): _matrix(m, "transforms") for k, m in fr.get("transforms", {}).items()},
                                 {int(k): _matrix(m, "world_to_cube") for k, m in fr.get("world_to_cube", {}).items()}))
    return case

"""Write the mesh files of the example scenes (run from anywhere: ``python examples/make_meshes.py``).

- ``bowl_open.ply``: a bowl upside down, modelled as a sheet: a hemisphere of radius 1, its rim
  on y = 0 and its top at y = 1, open at the rim, with outward vertex normals.
- ``bowl_closed.ply``: its closed proxy: the same hemisphere with a flat lid over the rim (the
  lid has its own vertices, normal -y), watertight once vertices at the same position are welded.
- ``cube_shared.obj``: a unit cube with 8 shared vertices and no normals (loads smooth-shaded).
- ``cube_flat.obj``: the same cube with 4 vertices per face and a normal per face (flat-shaded).

Only NumPy is needed; the files are plain ASCII, written with 9 significant digits, so running
this again gives the same bytes.
"""

from __future__ import annotations

import os

import numpy as np

RINGS = 8       # latitude rings of the hemisphere, from the top down to the rim
SEGMENTS = 32   # points per ring


def _fmt(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def hemisphere():
    """Vertices, normals and faces of the open dome: the top point, then ``RINGS`` rings of
    ``SEGMENTS`` points (the last ring is the rim on y = 0); faces wound outwards."""
    v = [np.array([0.0, 1.0, 0.0])]
    for i in range(1, RINGS + 1):
        theta = 0.5 * np.pi * i / RINGS          # from the top (0) to the rim (pi / 2)
        for j in range(SEGMENTS):
            phi = 2.0 * np.pi * j / SEGMENTS
            v.append(np.array([np.sin(theta) * np.sin(phi), np.cos(theta), np.sin(theta) * np.cos(phi)]))
    v = np.array(v)
    v[np.abs(v) < 1e-15] = 0.0  # exact zeros (the rim at y = 0), not -1e-17
    faces = []
    for j in range(SEGMENTS):  # the fan around the top
        faces.append((0, 1 + j, 1 + (j + 1) % SEGMENTS))
    for i in range(RINGS - 1):
        a, b = 1 + i * SEGMENTS, 1 + (i + 1) * SEGMENTS
        for j in range(SEGMENTS):
            k = (j + 1) % SEGMENTS
            faces.append((a + j, b + j, b + k))
            faces.append((a + j, b + k, a + k))
    return v, v.copy(), np.array(faces)


def lid(rim):
    """A flat disk over the rim ring ``rim`` (SEGMENTS, 3): its centre, then the rim's points
    again (own vertices, normal -y), faces wound downwards."""
    v = np.concatenate([[[0.0, 0.0, 0.0]], rim])
    n = np.tile([0.0, -1.0, 0.0], (len(v), 1))
    faces = [(0, 1 + (j + 1) % SEGMENTS, 1 + j) for j in range(SEGMENTS)]
    return v, n, np.array(faces)


def write_ply(path, v, n, faces):
    lines = ["ply", "format ascii 1.0", f"element vertex {len(v)}", "property float x", "property float y",
             "property float z", "property float nx", "property float ny", "property float nz",
             f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    lines += [_fmt(p) + " " + _fmt(q) for p, q in zip(v, n)]
    lines += ["3 " + " ".join(str(int(i)) for i in f) for f in faces]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


CORNERS = np.array([[x, y, z] for z in (-0.5, 0.5) for y in (-0.5, 0.5) for x in (-0.5, 0.5)])
#: The cube's six faces as corner indices, counter-clockwise seen from outside, and their normals.
QUADS = [((0, 2, 3, 1), (0, 0, -1)), ((4, 5, 7, 6), (0, 0, 1)), ((0, 1, 5, 4), (0, -1, 0)),
         ((2, 6, 7, 3), (0, 1, 0)), ((0, 4, 6, 2), (-1, 0, 0)), ((1, 3, 7, 5), (1, 0, 0))]


def write_cube_shared(path):
    lines = ["# a unit cube: 8 shared vertices, no normals (refsoft averages them: smooth shading)"]
    lines += ["v " + _fmt(c) for c in CORNERS]
    for (a, b, c, d), _ in QUADS:  # OBJ indices start at 1
        lines += [f"f {a + 1} {b + 1} {c + 1}", f"f {a + 1} {c + 1} {d + 1}"]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


def write_cube_flat(path):
    lines = ["# a unit cube: 4 vertices and one normal per face (flat shading)"]
    lines += ["v " + _fmt(CORNERS[i]) for quad, _ in QUADS for i in quad]
    lines += ["vn " + _fmt(normal) for _, normal in QUADS]
    for k in range(len(QUADS)):
        a, b, c, d = (4 * k + i + 1 for i in range(4))
        lines += [f"f {a}//{k + 1} {b}//{k + 1} {c}//{k + 1}", f"f {a}//{k + 1} {c}//{k + 1} {d}//{k + 1}"]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(lines) + "\n")


def main(out=os.path.dirname(os.path.abspath(__file__))):
    v, n, f = hemisphere()
    write_ply(os.path.join(out, "bowl_open.ply"), v, n, f)
    lv, ln, lf = lid(v[-SEGMENTS:])
    write_ply(os.path.join(out, "bowl_closed.ply"), np.concatenate([v, lv]), np.concatenate([n, ln]),
              np.concatenate([f, lf + len(v)]))
    write_cube_shared(os.path.join(out, "cube_shared.obj"))
    write_cube_flat(os.path.join(out, "cube_flat.obj"))


if __name__ == "__main__":
    main()

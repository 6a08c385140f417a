"""The layered depth textures against the paper's Tables 1 and 2 (Zhang, Hsieh and Shen 2008;
DESIGN-ldt sections 3 and 4.10).

- Table 1, the build: one object's LDT at R = 256 (``build_ldt``) for the reflected objects of
  the LDT scenes (``balls``, ``hollow_box``, ``genus3``, ``cup``, ``touching``, ``cylinder``), for
  icosphere(2..6) (triangles at one layer) and for boxes in a row (layers at few triangles).
- Table 2, the frame: a mirror ball (icosphere(5)) reflecting 1, 2 or 3 icosphere(s) balls,
  s = 2..6, at the paper's 768 x 512, every stage of a frame once the LDTs are built: ``main``
  (the main view, the paper's "Objects"), ``regions`` (the cone test) and ``ldt_search`` (P and
  N, the search and the colours: the paper's "Reflection"), and the search kernel alone. The
  paper's claim is a search time flat in the triangles.

Run (single-threaded Numba keeps the figures steady on a shared machine):

    NUMBA_NUM_THREADS=1 pytest benchmarks/test_ldt.py --benchmark-columns=min,median,rounds

or print both tables as in docs/ldt.md (best of ``--rounds`` per stage, without pytest):

    NUMBA_NUM_THREADS=1 python benchmarks/test_ldt.py --rounds 7
"""

from __future__ import annotations

import time

import numpy as np
import pytest

import refsoft
from refsoft import Camera, FrameDriver, RenderOptions, Scene, SceneObject, Transform
from refsoft.ldt.build import build_ldt
from refsoft.ldt.search import search
from refsoft.scene import primitives as P
from refsoft.scene.mesh import Mesh

R = 256
#: The LDT scenes' reflected objects: (scene, object index).
SCENE_OBJECTS = [("balls", 1), ("hollow_box", 1), ("genus3", 1), ("cup", 1), ("touching", 1), ("cylinder", 1)]
SUBDIVISIONS = (2, 3, 4, 5, 6)
ROW = (1, 3, 5, 8)
WIDTH, HEIGHT = 768, 512
#: Where the reflected balls stand around the mirror (as the ``balls`` scene's).
PLACES = ((-1.1, 0.35, 1.0), (1.0, -0.45, 0.9), (0.15, 1.15, 0.95))


def boxes_in_a_row(n: int) -> Mesh:
    """``n`` unit cubes in a row along x, 0.5 apart, as one closed mesh: n layers along the row."""
    box = P.box((1.0, 1.0, 1.0))
    v = np.concatenate([box.vertices + [1.5 * i, 0.0, 0.0] for i in range(n)])
    f = np.concatenate([box.faces + i * box.n_vertices for i in range(n)])
    return Mesh(v, f, np.tile(box.normals, (n, 1)), name=f"{n} boxes")


def build_cases() -> dict:
    """Table 1's objects: name -> model-space mesh."""
    cases = {}
    for name, j in SCENE_OBJECTS:
        obj = refsoft.load_scene(name).objects[j]
        cases[f"{name}: {obj.name}"] = obj.mesh
    for s in SUBDIVISIONS:
        cases[f"icosphere({s})"] = P.icosphere(s)
    for n in ROW:
        cases["1 box" if n == 1 else f"{n} boxes in a row"] = boxes_in_a_row(n)
    return cases


def spheres_scene(n_objects: int, subdivisions: int) -> Scene:
    """Table 2's scene: a mirror ball reflecting ``n_objects`` icosphere(``subdivisions``) balls."""
    objs = [SceneObject("mirror", P.icosphere(5), (0.9, 0.9, 0.9), reflector=True)]
    for i in range(n_objects):
        objs.append(SceneObject(f"ball{i + 1}", P.icosphere(subdivisions, 0.4), (0.9, 0.3 + 0.2 * i, 0.2),
                                Transform(PLACES[i])))
    cam = Camera(eye=(0.0, 0.8, 5.0), target=(0.0, 0.0, 0.0), fov_y=40.0, width=WIDTH, height=HEIGHT)
    return Scene(tuple(objs), cam, name=f"{n_objects} x icosphere({subdivisions})")


FRAME_CASES = [(n, s) for n in (1, 2, 3) for s in SUBDIVISIONS if n == 1 or s in (2, 4, 6)]


def warm_driver(scene):
    """A driver whose first frame (compilation, the LDT build) is done."""
    driver = FrameDriver(scene, RenderOptions(method="ldt", ldt_resolution=R))
    driver.render_frame(0)
    return driver


def kernel_call(driver, frame):
    """The search kernel alone (:func:`refsoft.ldt.search.search`) on the frame's inputs."""
    method, st = driver.method, frame.reflectors[1].state
    eye = driver.scene.camera.eye
    return lambda: search(st.P, st.N, eye, st.triangle, st.region, st.W, method.stack, st.view_dir, method.linear,
                          method.tau, method.faces, method.regions, method.precision)


# --- pytest-benchmark -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def builds():
    cases = build_cases()
    build_ldt(P.icosphere(1), R)  # compile outside the timing
    return cases


@pytest.mark.parametrize("name", list(build_cases()))
def test_build(benchmark, builds, name):
    mesh = builds[name]
    benchmark.group = f"LDT build R={R} (Table 1)"
    ldt = benchmark.pedantic(lambda: build_ldt(mesh, R), rounds=5, iterations=1)
    benchmark.extra_info.update(triangles=int(mesh.n_faces), layers=int(ldt.n_layers))


@pytest.mark.parametrize("n_objects,subdivisions", FRAME_CASES)
def test_frame(benchmark, n_objects, subdivisions):
    scene = spheres_scene(n_objects, subdivisions)
    driver = warm_driver(scene)
    benchmark.group = f"LDT frame {WIDTH}x{HEIGHT} (Table 2)"
    frame = benchmark.pedantic(lambda: driver.render_frame(0), rounds=5, iterations=1)
    benchmark.extra_info.update({f"{k}_ms": round(v, 2) for k, v in frame.time_ms.items()})
    benchmark.extra_info.update(objects=n_objects, triangles=int(scene.objects[1].mesh.n_faces))


@pytest.mark.parametrize("n_objects,subdivisions", FRAME_CASES)
def test_search_kernel(benchmark, n_objects, subdivisions):
    scene = spheres_scene(n_objects, subdivisions)
    driver = warm_driver(scene)
    fn = kernel_call(driver, driver.render_frame(0))
    fn()
    benchmark.group = f"LDT search kernel {WIDTH}x{HEIGHT} (Table 2)"
    benchmark.pedantic(fn, rounds=7, iterations=1)
    benchmark.extra_info.update(objects=n_objects, triangles=int(scene.objects[1].mesh.n_faces))


# --- the tables, without pytest ---------------------------------------------------------------
def best(fn, rounds):
    """(the smallest wall time in ms over ``rounds`` calls, the last result)."""
    times, out = [], None
    for _ in range(rounds):
        t = time.perf_counter()
        out = fn()
        times.append(1000 * (time.perf_counter() - t))
    return min(times), out


def table1(rounds):
    build_ldt(P.icosphere(1), R)
    print(f"Build, R = {R}, best of {rounds}:\n")
    print("| object | triangles | layers | ms |\n| --- | --- | --- | --- |")
    for name, mesh in build_cases().items():
        ms, ldt = best(lambda: build_ldt(mesh, R), rounds)
        print(f"| {name} | {mesh.n_faces} | {ldt.n_layers} | {ms:.1f} |")


def table2(rounds):
    stages = ("main", "regions", "ldt_search", "composite", "total")
    print(f"\nFrame, {WIDTH} x {HEIGHT}, R = {R}, LDTs built, best of {rounds} per stage (ms):\n")
    print("| objects | triangles each | build ms | reflector pixels | mean linear samples | kernel | "
          + " | ".join(stages) + " |\n|" + " --- |" * (6 + len(stages)))
    for n, s in FRAME_CASES:
        scene = spheres_scene(n, s)
        driver = warm_driver(scene)
        build = sum(driver.method.build_ms.values())
        frames = [driver.render_frame(0) for _ in range(rounds)]
        ms = {k: min(f.time_ms[k] for f in frames) for k in stages}
        rep = frames[-1].report["ldt"]
        kernel = best(kernel_call(driver, frames[-1]), rounds)[0]
        print(f"| {n} | {scene.objects[1].mesh.n_faces} | {build:.0f} | {rep['reflector_pixels']} | "
              f"{rep['linear_samples']['mean']:.1f} | {kernel:.2f} | " + " | ".join(f"{ms[k]:.1f}" for k in stages)
              + " |")


if __name__ == "__main__":
    import argparse
    import os
    import platform

    import numba

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--table", choices=("1", "2", "both"), default="both")
    args = parser.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Numba threads "
          f"{numba.config.NUMBA_NUM_THREADS}, load average {os.getloadavg()[0]:.1f}\n")
    if args.table in ("1", "both"):
        table1(args.rounds)
    if args.table in ("2", "both"):
        table2(args.rounds)

"""What writing a run's files costs ``refsoft render``: the command against the same frames
rendered in a loop of ``FrameDriver.render_frame`` without writing, and where the writer's CPU goes.

For each scene, in one process, after a frame 0 rendered once to compile the kernels, each round
runs in turn (so that both see the same state of the machine):

- ``loop``: a new ``FrameDriver`` renders frames 0..N-1, nothing written;
- ``command``: ``refsoft render SCENE --frames N --out DIR --overwrite`` (the command line's
  ``main``, in this process), its frames written by the background writer.

It prints per round the wall and process CPU milliseconds per frame of both, their ratios
(command / loop), the same of the command's frames alone (``run_frames``: from the first frame's
render to the last frame's files and ``stats.json``; without the command's start, its parser and
the scene's loading, which the loop does not pay either), and the command's ``stats.json``
medians (``total``: the render's stages; ``write_cpu``: the writer thread's CPU per frame). The
CPU ratio is the better guide on a shared machine: the loop's CPU is the render's, the command's
adds the writer's and what it costs the render (the GIL, caches).

Run: ``python benchmarks/writer.py [SCENE ...] [--frames 10] [--rounds 3] [--size 1024x768] [--bare]``;
``--bare``: each round also runs the command with its files not written (``write_frame`` a no-op),
its process CPU per frame: what the command costs beside its writer (the scene's loading, the
folder, ``stats.json``, the progress).
With ``--parts``: instead, one frame's files written whole (``write_frame``) from fresh copies of
its arrays, the writer thread's CPU milliseconds (min and median of 7, the variants in turn),
with each part of the writer turned off in turn: the pictures (image, id maps, masks, the PNG)
deflated as copies from the left or above (zlib instead), the repeating pieces written past
zipfile's member writer (their CRC-32 combined by zlib, their untouched pages not read), the
untouched pages not read, the float members' other bytes stored (``FRAME_FLOAT_LEVEL = 0``), the
PNG's unfiltered rows (Pillow's encoder instead); and the npz's bytes.
With ``--png``: instead, the frame's PNG deflated four ways (the command's copies from the left
or above, zlib level 1, stored, "Up" filter with ``Z_RLE``): CPU milliseconds and bytes.
With ``--members``: instead, one frame (frame 1 after frame 0) written whole, the best of 3
writes of fresh copies (whose untouched pages are the render's): per member its bytes, the share
of them in repeating runs, its bytes in the file and the writer thread's CPU milliseconds; the
PNG's; the sum and the whole write's.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import tempfile
import time

import numpy as np

import refsoft
from refsoft.cli import main as cli_main
from refsoft.frame import FrameDriver

SCENES = ["kitchen", "ufo", "ants"]


def _command(argv, n, write=True):
    """Wall and process CPU seconds per frame of ``refsoft ARGV`` in this process (``write=False``:
    its frames' files not written, ``write_frame`` a no-op), and of its frames alone
    (``run_frames``: from the first frame's render to the last frame's files and ``stats.json``,
    without the command's start: its parser, the scene's loading, the folder)."""
    from unittest import mock

    from refsoft.frame import driver

    frames = []
    real_run = driver.run_frames

    def timed_run(*args, **kwargs):
        t, c = time.perf_counter(), time.process_time()
        try:
            return real_run(*args, **kwargs)
        finally:
            frames.append(((time.perf_counter() - t) / n, (time.process_time() - c) / n))

    with mock.patch.object(driver, "write_frame", driver.write_frame if write else lambda out, fr: None), \
            mock.patch.object(driver, "run_frames", timed_run):
        t, c = time.perf_counter(), time.process_time()
        code = cli_main(argv)
        took = (time.perf_counter() - t) / n, (time.process_time() - c) / n
    if code:
        raise SystemExit(f"refsoft {' '.join(argv)} exited with {code}")
    return took, frames[0]


def _round(scene, name, n, size, out, bare=False):
    d = FrameDriver(scene)
    t, c = time.perf_counter(), time.process_time()
    for f in range(n):
        d.render_frame(f)
    loop = (time.perf_counter() - t) / n, (time.process_time() - c) / n
    w, h = size
    argv = ["render", name, "--frames", str(n), "--width", str(w), "--height", str(h), "--out", out, "--overwrite"]
    cmd, run = _command(argv, n)
    with open(os.path.join(out, "stats.json")) as fh:
        frames = json.load(fh)["frames"]
    med = {k: statistics.median(f["time_ms"][k] for f in frames) for k in ("total", "write", "write_cpu")}
    med["bare_cpu"] = 1000 * _command(argv, n, write=False)[0][1] if bare else float("nan")
    return loop, cmd, run, med


def ratios(names, n, rounds, size, bare=False):
    out = tempfile.mkdtemp(prefix="refsoft-writer-")
    try:
        print("scene round | loop wall, CPU ms/frame | command wall, CPU ms/frame | wall ratio | CPU ratio | "
              "its frames wall, CPU ms/frame | frames' wall ratio | frames' CPU ratio | "
              "stats total, write, write_cpu ms" + (" | command without writing, CPU ms/frame" if bare else ""))
        for name in names:
            scene = refsoft.load_scene(name, width=size[0], height=size[1])
            FrameDriver(scene).render_frame(0)  # compiled (or loaded from the cache) outside the timing
            rows = []
            for r in range(rounds):
                loop, cmd, run, med = _round(scene, name, n, size, os.path.join(out, name), bare)
                rows.append((cmd[0] / loop[0], cmd[1] / loop[1], run[0] / loop[0], run[1] / loop[1]))
                print(f"{name} {r} | {1000 * loop[0]:.0f}, {1000 * loop[1]:.0f} | {1000 * cmd[0]:.0f}, "
                      f"{1000 * cmd[1]:.0f} | {rows[-1][0]:.3f} | {rows[-1][1]:.3f} | {1000 * run[0]:.0f}, "
                      f"{1000 * run[1]:.0f} | {rows[-1][2]:.3f} | {rows[-1][3]:.3f} | "
                      f"{med['total']:.0f}, {med['write']:.0f}, {med['write_cpu']:.1f}"
                      + (f" | {med['bare_cpu']:.0f}" if bare else ""), flush=True)
            spread = [f"{min(r[i] for r in rows):.3f}-{max(r[i] for r in rows):.3f}" for i in range(4)]
            print(f"{name}: command: wall ratio {spread[0]}, CPU ratio {spread[1]}; its frames: wall ratio "
                  f"{spread[2]}, CPU ratio {spread[3]}", flush=True)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def _fresh(a):
    """A copy of ``a`` whose all-zero pages are untouched (as the render leaves its G-buffers)."""
    from refsoft import limits

    if not a.flags.c_contiguous or a.nbytes < limits.LAZY_ZEROS_BYTES:
        return a.copy()
    b = limits.zeros(a.shape, a.dtype)
    src, dst = a.reshape(-1).view(np.uint8), b.reshape(-1).view(np.uint8)
    for lo in range(0, src.size, 4096):
        if src[lo:lo + 4096].any():
            dst[lo:lo + 4096] = src[lo:lo + 4096]
    return b


def _second_frame(name, size):
    """The arrays of a scene's frame 1, rendered after frame 0 (coherent, compiled)."""
    d = FrameDriver(refsoft.load_scene(name, width=size[0], height=size[1]))
    d.render_frame(0)
    return d.render_frame(1).arrays


def members(names, size):
    import zipfile
    from unittest import mock

    from refsoft import io
    from refsoft.constants import NPZ_PERIOD_BYTES, NPZ_UNIT_BYTES
    from refsoft.frame import Frame, outputs, write_frame

    real_member, real_png = io.npz._write_member, outputs.write_png_rows
    out = tempfile.mkdtemp(prefix="refsoft-writer-")
    try:
        for name in names:
            arrays = _second_frame(name, size)
            times = {}

            def timed(fn, key):
                def run(*args):
                    c = time.thread_time()
                    fn(*args)
                    times[key(args)] = min(times.get(key(args), float("inf")), 1000 * (time.thread_time() - c))
                return run

            whole = float("inf")
            with mock.patch.object(io.npz, "_write_member", timed(real_member, lambda a: a[1][:-4])), \
                    mock.patch.object(outputs, "write_png_rows", timed(real_png, lambda a: "png")):
                for _ in range(3):
                    fr = Frame(1, {k: _fresh(a) for k, a in arrays.items()}, {})
                    c = time.thread_time()
                    write_frame(out, fr)
                    whole = min(whole, 1000 * (time.thread_time() - c))
            with zipfile.ZipFile(os.path.join(out, "frame_0001.npz")) as zf:
                packed = {i.filename[:-4]: i.compress_size for i in zf.infolist()}
            print(f"{name}: member | dtype | MB | repeating % | kB in the file | CPU ms (best of 3)")
            for k, a in arrays.items():
                data = io.npz._npy_parts(a)[1]
                runs = io.runs.repeating_runs(data, NPZ_UNIT_BYTES, NPZ_PERIOD_BYTES)
                rep = sum(hi - lo for lo, hi, p in runs if p is not None)
                print(f"  {k} | {a.dtype} | {a.nbytes / 1e6:.2f} | {100 * rep / max(1, data.size):.0f} | "
                      f"{packed[k] / 1e3:.1f} | {times[k]:.2f}")
            png = os.path.getsize(os.path.join(out, "frame_0001.png"))
            print(f"  png | uint8 | {arrays['image'].nbytes / 1e6:.2f} | | {png / 1e3:.1f} | {times['png']:.2f}")
            print(f"  sum {sum(times.values()):.1f} ms; the whole write (files, archive) {whole:.1f} ms; "
                  f"npz {os.path.getsize(os.path.join(out, 'frame_0001.npz')) / 1e6:.2f} MB", flush=True)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def _variants():
    import zlib
    from unittest import mock

    from refsoft import io
    from refsoft.frame import outputs

    def zlib_stream(rows, pixel, level):
        return zlib.compress(rows, level)

    return {"as it is": [],
            "pictures by zlib": [mock.patch.object(io.npz, "_picture", lambda array: None),
                                 mock.patch.object(io.png, "_zlib_stream", zlib_stream)],
            "every byte through zipfile's member writer": [mock.patch.object(io.crc, "_COMBINE", [None])],
            "untouched pages read": [mock.patch.object(io.pages.PageMap, "untouched", lambda self, data: None)],
            "float bytes deflated": [mock.patch.object(outputs, "FRAME_FLOAT_LEVEL", None)],
            "PNG by Pillow": [mock.patch.object(outputs, "write_png_rows", io.write_png)]}


def parts(names, size, rounds=7):
    from contextlib import ExitStack

    from refsoft.frame import Frame, write_frame

    out = tempfile.mkdtemp(prefix="refsoft-writer-")
    try:
        for name in names:
            arrays = _second_frame(name, size)
            write_frame(out, Frame(1, {k: _fresh(a) for k, a in arrays.items()}, {}))  # one-time costs
            times, sizes = {v: [] for v in _variants()}, {}
            for _ in range(rounds):
                for v, patches in _variants().items():
                    fr = Frame(1, {k: _fresh(a) for k, a in arrays.items()}, {})
                    with ExitStack() as stack:
                        for p in patches:
                            stack.enter_context(p)
                        c = time.thread_time()
                        write_frame(out, fr)
                        times[v].append(1000 * (time.thread_time() - c))
                    sizes[v] = os.path.getsize(os.path.join(out, "frame_0001.npz"))
            for v, t in times.items():
                print(f"{name} | {v} | {min(t):.1f} | {statistics.median(t):.1f} | npz {sizes[v] / 1e6:.2f} MB",
                      flush=True)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def png(names, size, rounds=7):
    """The frame's PNG (frame 1's image) deflated as copies of the pixel to the left or above (as
    the command writes it: :func:`refsoft.io.png._zlib_stream`, with its Adler-32), by zlib at
    level 1 unfiltered, at level 0 (stored), and with every row's "Up" filter and zlib's
    run-length strategy (``Z_RLE``): the image's deflate CPU milliseconds (min of 7; the rows'
    and the filter's own NumPy time included) and the zlib stream's bytes."""
    import zlib

    from refsoft.io.png import _zlib_stream as png_stream

    print("scene | PNG | CPU ms (min of 7) | bytes")
    for name in names:
        img = _second_frame(name, size)["image"]
        h = img.shape[0]
        flat = img.reshape(h, -1)

        def unfiltered():
            rows = np.zeros((h, 1 + flat.shape[1]), np.uint8)
            rows[:, 1:] = flat
            return rows

        def up():
            rows = np.empty((h, 1 + flat.shape[1]), np.uint8)
            rows[:, 0] = 2
            rows[0, 1:] = flat[0]
            np.subtract(flat[1:], flat[:-1], out=rows[1:, 1:])
            return rows

        def rle(rows):
            z = zlib.compressobj(1, zlib.DEFLATED, 15, 8, zlib.Z_RLE)
            return z.compress(rows) + z.flush()

        pixel = 3 if img.ndim == 3 else 1
        for what, rows, deflate in (("copies from the left or above, unfiltered", unfiltered,
                                     lambda r: png_stream(r, pixel, 1)),
                                    ("level 1, unfiltered", unfiltered, lambda r: zlib.compress(r, 1)),
                                    ("level 0 (stored)", unfiltered, lambda r: zlib.compress(r, 0)),
                                    ("level 1, Up filter, Z_RLE", up, rle)):
            best = float("inf")
            for _ in range(rounds):
                c = time.thread_time()
                data = deflate(rows())
                best = min(best, 1000 * (time.thread_time() - c))
            print(f"{name} | {what} | {best:.2f} | {len(data)}", flush=True)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenes", nargs="*", default=SCENES)
    p.add_argument("--frames", type=int, default=10)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--size", default="1024x768")
    p.add_argument("--members", action="store_true")
    p.add_argument("--parts", action="store_true")
    p.add_argument("--png", action="store_true")
    p.add_argument("--bare", action="store_true", help="each round also runs the command without writing files")
    return p.parse_args(argv)


if __name__ == "__main__":
    args = parse_args()
    size = tuple(int(v) for v in args.size.split("x"))
    if args.members:
        members(args.scenes, size)
    elif args.png:
        png(args.scenes, size)
    elif args.parts:
        parts(args.scenes, size)
    else:
        ratios(args.scenes, args.frames, args.rounds, size, args.bare)

"""run_frames writes each frame in a background thread while the next one renders: the files
are those of a write in the main thread, a frame counts as done only once written, and an error
or an interrupt still leaves the frame being written whole."""

import threading

import numpy as np
import pytest

from refsoft import keys
from refsoft.frame import Frame, driver, run_frames, write_frame


class Renderer:
    """Frames of random arrays; frame ``fail_at`` raises."""

    def __init__(self, fail_at=None):
        self.fail_at = fail_at

    def render_frame(self, f):
        if f == self.fail_at:
            raise RuntimeError(f"frame {f} failed")
        rng = np.random.default_rng(f)
        arrays = {keys.IMAGE: rng.integers(0, 256, (24, 32, 3), dtype=np.uint8),
                  keys.OBJECT_ID: rng.integers(0, 5, (24, 32), dtype=np.int32)}
        return Frame(f, arrays, {"total": 1.0})


def test_background_writes_equal_main_thread_writes(tmp_path):
    frames = run_frames(Renderer(), range(4), tmp_path / "bg")
    assert [f.index for f in frames] == [0, 1, 2, 3]
    for fr in frames:
        write_frame(tmp_path / "main", fr)
        name = f"frame_{fr.index:04d}"
        assert (tmp_path / "bg" / f"{name}.png").read_bytes() == (tmp_path / "main" / f"{name}.png").read_bytes()
        with np.load(tmp_path / "bg" / f"{name}.npz") as a, np.load(tmp_path / "main" / f"{name}.npz") as b:
            assert list(a.keys()) == list(b.keys())
            for k in a.keys():
                np.testing.assert_array_equal(a[k], b[k])


def test_writes_run_beside_the_next_render(tmp_path, monkeypatch):
    seen = []
    real = driver.write_frame

    def write(out, fr):
        seen.append(threading.current_thread() is threading.main_thread())
        real(out, fr)

    monkeypatch.setattr(driver, "write_frame", write)
    done = run_frames(Renderer(), range(3), tmp_path, keep=False)
    assert seen == [False, False, False]
    assert all(fr.arrays == {} for fr in done)  # keep=False: dropped once written


def test_an_error_keeps_the_frame_being_written(tmp_path):
    done = []
    with pytest.raises(RuntimeError, match="frame 2 failed"):
        run_frames(Renderer(fail_at=2), range(4), tmp_path, done=done)
    assert [f.index for f in done] == [0, 1]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "frame_0000.npz", "frame_0000.png", "frame_0001.npz", "frame_0001.png"]


def test_a_failed_write_is_raised_and_its_frame_not_done(tmp_path, monkeypatch):
    real = driver.write_frame

    def write(out, fr):
        if fr.index == 1:
            raise OSError("disk full")
        real(out, fr)

    monkeypatch.setattr(driver, "write_frame", write)
    done, calls = [], []
    with pytest.raises(OSError, match="disk full"):
        run_frames(Renderer(), range(4), tmp_path, done=done, on_frame=lambda d: calls.append(len(d)))
    assert [f.index for f in done] == [0]
    assert calls == [1]
    assert not (tmp_path / "frame_0001.npz").exists()


def test_frame_files_hold_the_arrays_of_level_6(tmp_path):
    """The frame's npz (zlib level 1) holds the arrays np.savez_compressed (level 6, what the golden
    set writes) holds, bit for bit, in the same order, and its PNG decodes to the same pixels."""
    from PIL import Image

    import refsoft
    from refsoft.frame import outputs
    from refsoft.io import write_npz, write_png

    (fr,), _ = refsoft.render("kitchen", frames=[3], width=64, height=48)
    assert outputs.FRAME_LEVEL == 1
    write_frame(tmp_path, fr)
    write_npz(tmp_path / "six.npz", **fr.arrays)
    write_png(tmp_path / "six.png", fr.arrays[keys.IMAGE])
    with np.load(tmp_path / "frame_0003.npz") as a, np.load(tmp_path / "six.npz") as b:
        assert list(a.keys()) == list(b.keys()) == list(fr.arrays)
        for k in a.keys():
            x, y = a[k], b[k]
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k
    assert (tmp_path / "frame_0003.npz").stat().st_size != (tmp_path / "six.npz").stat().st_size  # another level
    with Image.open(tmp_path / "frame_0003.png") as p, Image.open(tmp_path / "six.png") as q:
        assert np.array_equal(np.asarray(p), np.asarray(q)) and np.array_equal(np.asarray(p), fr.arrays[keys.IMAGE])


def test_npz_level_refuses_object_arrays(tmp_path):
    from refsoft.io import write_npz_level

    with pytest.raises(ValueError):
        write_npz_level(tmp_path / "o.npz", {"o": np.array([{}, None], dtype=object)}, 1)
    assert list(tmp_path.iterdir()) == []  # atomic: nothing left behind


def _odd_arrays():
    """Arrays of every kind a frame's npz may hold, sized for pieces of 512 bytes and samples of
    64: runs of zero pieces, pieces of -0.0 (zero values, not zero bytes), a partial last piece,
    stored (random float64) and deflated members, empty and 0-d arrays, Fortran order, a view
    neither C- nor Fortran-contiguous."""
    rng = np.random.default_rng(7)
    gbuf = np.zeros((40, 30, 3), np.float32)
    gbuf[12:15, 5:9] = rng.random((3, 4, 3), dtype=np.float32)
    neg = np.zeros(700, np.float32)
    neg[128:300] = -0.0
    neg[650] = 1.5
    return {"gbuffer": gbuf, "zeros": np.zeros(5000, np.uint8), "neg_zero": neg,
            "mask": gbuf[..., 0] > 0, "int8": rng.integers(-128, 128, 3000, dtype=np.int8),
            "f64": rng.random(900), "empty": np.zeros((0, 3), np.float32), "empty_bool": np.zeros(0, bool),
            "scalar": np.array(2.5), "fortran": np.asfortranarray(rng.integers(0, 9, (30, 20), dtype=np.int32)),
            "big_endian": np.arange(400, dtype=">i4"), "complex": (rng.random(300) + 1j).astype(np.complex64),
            "uint16": np.arange(1000, dtype=np.uint16),
            "strided": rng.integers(0, 99, (40, 30), dtype=np.int64)[::3, 1::2]}


@pytest.fixture
def small_pieces(monkeypatch):
    """Units of 128 bytes, repeating pieces of at most 512 (384: a multiple of the unit and the
    24-byte period), other bytes 512 at a time, runs of 2 units or more, samples of 64 bytes."""
    import refsoft.io

    monkeypatch.setattr(refsoft.io.npz, "NPZ_PIECE_BYTES", 512)
    monkeypatch.setattr(refsoft.io.npz, "NPZ_REPEAT_BYTES", 512)
    monkeypatch.setattr(refsoft.io.npz, "NPZ_UNIT_BYTES", 128)
    monkeypatch.setattr(refsoft.io.npz, "NPZ_SHORTEST_RUN", 2)
    monkeypatch.setattr(refsoft.io.npz, "NPZ_SAMPLE_BYTES", 64)


@pytest.mark.parametrize("level, float_level", [(1, None), (6, None), (0, None), (1, 0), (6, 1)])
def test_npz_writer_holds_the_arrays_numpy_writes(tmp_path, small_pieces, level, float_level):
    import zipfile

    from refsoft.io import write_npz, write_npz_level

    arrays = _odd_arrays()
    write_npz_level(tmp_path / "a.npz", arrays, level, float_level)
    write_npz(tmp_path / "np.npz", **arrays)
    with zipfile.ZipFile(tmp_path / "a.npz") as zf:
        assert zf.testzip() is None
        kinds = {i.filename: i.compress_type for i in zf.infolist()}
    assert list(kinds) == [k + ".npy" for k in arrays]
    if level:  # random float64 stored, the G-buffer deflated
        assert kinds["f64.npy"] == zipfile.ZIP_STORED and kinds["gbuffer.npy"] == zipfile.ZIP_DEFLATED
    else:
        assert set(kinds.values()) == {zipfile.ZIP_STORED}
    with np.load(tmp_path / "a.npz") as a, np.load(tmp_path / "np.npz") as b:
        assert list(a.keys()) == list(b.keys()) == list(arrays)
        for k in a.keys():
            x, y = a[k], b[k]
            assert (x.dtype, x.shape, x.flags.f_contiguous) == (y.dtype, y.shape, y.flags.f_contiguous), k
            assert x.tobytes("A") == y.tobytes("A") == arrays[k].tobytes("A"), k


def test_repeating_runs_reuse_their_deflate_output(tmp_path, small_pieces, monkeypatch):
    """Every run of 2 units or more that repeats 24 bytes (zeros, one int32 value, -0.0) is written
    as the deflate output of its pieces (384 bytes at most), and only those; the member still reads
    back (its CRC checked by zipfile)."""
    import zipfile
    import zlib

    import refsoft.io

    calls = []
    real = refsoft.io.deflate.repeat_piece
    monkeypatch.setattr(refsoft.io.deflate, "repeat_piece",
                        lambda p, n, *a: calls.append((p[:4], n)) or real(p, n, *a))
    data = np.zeros(128 * 9 + 100, np.uint8)  # units 0-8 and 100 bytes
    data[128 * 3 + 7] = 1  # units 0-2 zero (a run), 3 not, 4-8 zero (a run), the tail other bytes
    data[128 * 9 + 50] = 2
    ids = np.full(32 * 8, 7, np.int32)  # 8 units of 7s, then one of other bytes
    ids = np.concatenate([ids, np.arange(32, dtype=np.int32)])
    neg = np.full(64, -0.0, np.float32)  # 2 units of 0x80000000 words
    refsoft.io.write_npz_level(tmp_path / "z.npz", {"data": data, "ids": ids, "neg": neg}, 1)
    seven, minus = bytes([7, 0, 0, 0]), bytes([0, 0, 0, 0x80])
    zero = bytes(4)
    assert calls == [(zero, 384), (zero, 384), (zero, 256), (seven, 384), (seven, 384), (seven, 256), (minus, 256)]
    with zipfile.ZipFile(tmp_path / "z.npz") as zf:
        assert zf.testzip() is None
        assert zf.read("data.npy")[-data.size:] == data.tobytes()
        assert zf.read("ids.npy")[-ids.nbytes:] == ids.tobytes()
        assert zf.read("neg.npy")[-neg.nbytes:] == neg.tobytes()
    for (pattern, n, level, strategy), (out, crc) in refsoft.io.deflate._PIECES.items():
        piece = refsoft.io.deflate.repeat_bytes(pattern, n)
        assert zlib.decompressobj(-15).decompress(out) == piece.tobytes() and crc == zlib.crc32(piece)


def test_repeating_runs_are_written_in_few_sizes():
    """A repeating run is cut into pieces that each start its pattern over (multiples of the unit
    and the period), of sizes base * 2**k up to the cap, largest first, then the rest: every run
    of a frame is a few pieces of a few sizes."""
    from refsoft.io import npz

    base = 12288  # lcm(4096, 24)
    top = 64 * base  # the largest base * 2**k of at most NPZ_REPEAT_BYTES (1 MiB)
    sizes_seen = set()
    for n in range(4096, 40 * 1024 * 1024, 4096 * 997):
        sizes = npz._repeat_sizes(n)
        assert sum(sizes) == n
        whole = [s for s in sizes if s % base == 0]
        assert list(sizes[:len(whole)]) == whole and len(sizes) - len(whole) <= 1  # the rest, last
        assert all(s // base & (s // base - 1) == 0 and s <= top for s in whole)  # a power of two
        assert whole == sorted(whole, reverse=True) and len(sizes) <= n // top + 7
        sizes_seen.update(sizes)
    assert len(sizes_seen) <= 9  # 64 * base and the smaller powers, 4096 and 8192


def test_repeating_runs_match_the_naive_cut():
    """repeating_runs cuts as the byte-by-byte reference does, for units read or known untouched,
    on arrays of runs of zeros, of one value, of a pattern whose phase crosses units, and noise."""
    from naive_runs import naive_repeating_runs

    from refsoft.io.runs import repeating_runs

    rng = np.random.default_rng(17)
    unit, period = 48, 24
    for trial in range(40):
        parts = []
        for _ in range(rng.integers(1, 12)):
            kind, m = rng.integers(0, 4), int(rng.integers(1, 5)) * unit + int(rng.integers(0, 2)) * 8
            if kind == 0:
                parts.append(np.zeros(m, np.uint8))
            elif kind == 1:
                parts.append(np.tile(rng.integers(0, 3, 8, dtype=np.uint8), m // 8 + 1)[:m])
            elif kind == 2:
                parts.append(np.tile(rng.integers(0, 256, 24, dtype=np.uint8), m // 24 + 1)[:m])
            else:
                parts.append(rng.integers(0, 256, m, dtype=np.uint8))
        data = np.concatenate(parts)[:int(rng.integers(0, 30 * unit))]
        n = data.size // unit
        zero = np.array([not data[u * unit:(u + 1) * unit].any() for u in range(n)], bool)
        untouched = zero & (rng.random(n) < 0.7)
        for shortest in (1, 2, 3):
            want = naive_repeating_runs(data, unit, period, shortest)
            assert repeating_runs(data, unit, period, None, shortest) == want, (trial, shortest)
            assert repeating_runs(data, unit, period, untouched, shortest) == want, (trial, shortest)


def test_cached_pieces_follow_the_bytes(tmp_path, small_pieces, monkeypatch):
    """The cache of repeating pieces is keyed by their bytes: a frame whose background changes
    value (or whose cache was emptied) writes its own arrays, the same file as a fresh process."""
    import refsoft.io

    ids = np.full((40, 32), 3, np.int32)
    ids[10:12, 5:9] = 8
    refsoft.io.write_npz_level(tmp_path / "a.npz", {"ids": ids}, 1)
    ids[:20] = 5  # the background's value changes: other pieces, other bytes
    refsoft.io.write_npz_level(tmp_path / "b.npz", {"ids": ids}, 1)
    with np.load(tmp_path / "b.npz") as z:
        assert z["ids"].tobytes() == ids.tobytes()
    monkeypatch.setattr(refsoft.io.deflate, "_PIECES", {})
    monkeypatch.setattr(refsoft.io.deflate, "_MAX_PIECES", 2)  # emptied as it fills
    refsoft.io.write_npz_level(tmp_path / "c.npz", {"ids": ids}, 1)
    assert (tmp_path / "c.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    assert len(refsoft.io.deflate._PIECES) <= 2


def test_npz_writes_are_the_same_bytes_every_time(tmp_path, small_pieces):
    import time

    import refsoft.io

    arrays = _odd_arrays()
    refsoft.io.write_npz_level(tmp_path / "a.npz", arrays, 1)
    time.sleep(2.1)  # the zip format dates to 2 seconds: a member dated by the clock would differ
    refsoft.io.write_npz_level(tmp_path / "b.npz", dict(reversed(list(arrays.items()))), 1)  # other pieces cached
    refsoft.io.write_npz_level(tmp_path / "c.npz", arrays, 1)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "c.npz").read_bytes()


def test_a_failed_npz_write_leaves_the_old_file(tmp_path, small_pieces):
    from refsoft.io import write_npz_level

    (tmp_path / "f.npz").write_bytes(b"old")
    arrays = {**_odd_arrays(), "o": np.array([{}, None], dtype=object)}
    with pytest.raises(ValueError):
        write_npz_level(tmp_path / "f.npz", arrays, 1)
    assert [p.name for p in tmp_path.iterdir()] == ["f.npz"] and (tmp_path / "f.npz").read_bytes() == b"old"


def test_crc_combine_is_zlibs():
    """zlib's crc32_combine64 (through ctypes) gives zlib.crc32 of the joined bytes, from any
    running CRC and for pieces of any size."""
    import zlib

    import refsoft.io

    combine = refsoft.io.crc.combine()
    assert combine is not None  # found on the platforms the tests run on
    rng = np.random.default_rng(5)
    for n in (1, 7, 512, 4096, 1 << 18, 3 * (1 << 18) + 5):
        piece = np.tile(rng.integers(0, 256, 24, dtype=np.uint8), n // 24 + 1)[:n]
        for crc in (0, 1, 0xFFFFFFFF, int(rng.integers(0, 1 << 32))):
            assert combine(crc, zlib.crc32(piece), n) == zlib.crc32(piece, crc), (n, crc)


@pytest.mark.parametrize("float_level", [None, 0])
def test_repeating_pieces_write_the_same_bytes_every_way(tmp_path, small_pieces, monkeypatch, float_level):
    """Repeating pieces written past zipfile's member writer (CRC combined) or through it (where
    the C library is missing or the writer's state unknown: every byte read) give one file, the
    float members' other bytes deflated or stored."""
    import zipfile

    import refsoft.io

    arrays = _odd_arrays()
    refsoft.io.write_npz_level(tmp_path / "direct.npz", arrays, 1, float_level)
    with monkeypatch.context() as m:
        m.setattr(refsoft.io.crc, "_COMBINE", [None])
        refsoft.io.write_npz_level(tmp_path / "crc32.npz", arrays, 1, float_level)
    with monkeypatch.context() as m:
        m.setattr(refsoft.io.npz, "_WRITER_STATE", ("_no_such_state",))
        m.setattr(refsoft.io.npz, "_write_runs", None)  # never called
        refsoft.io.write_npz_level(tmp_path / "through.npz", arrays, 1, float_level)
    one = (tmp_path / "direct.npz").read_bytes()
    assert (tmp_path / "crc32.npz").read_bytes() == one and (tmp_path / "through.npz").read_bytes() == one
    with zipfile.ZipFile(tmp_path / "direct.npz") as zf:
        assert zf.testzip() is None  # every member's CRC-32 checked


@pytest.mark.parametrize("shape", [(24, 32, 3), (5, 7), (1, 1, 3)])
def test_png_of_unfiltered_rows_decodes_to_the_image(tmp_path, shape):
    """The frame's PNG (unfiltered rows, zlib): Pillow reads it (every chunk's CRC verified) as
    the same pixels, in colour or grey, from a view that is not contiguous as well; a rerun is
    the same bytes."""
    from PIL import Image

    from refsoft.io import write_png_rows

    rng = np.random.default_rng(11)
    img = rng.integers(0, 256, shape[:1] + (2 * shape[1],) + shape[2:], dtype=np.uint8)[:, ::2]
    img[: shape[0] // 2] = 17  # runs that deflate
    write_png_rows(tmp_path / "a.png", img, 1)
    with Image.open(tmp_path / "a.png") as p:
        p.verify()
    with Image.open(tmp_path / "a.png") as p:
        assert p.mode == ("RGB" if len(shape) == 3 else "L")
        assert np.array_equal(np.asarray(p), img)
    write_png_rows(tmp_path / "b.png", img.copy(), 1)
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_png_of_unfiltered_rows_refuses_other_shapes(tmp_path):
    from refsoft.errors import RefsoftError
    from refsoft.io import write_png_rows

    for bad in (np.zeros((4, 4, 4), np.uint8), np.zeros((0, 4, 3), np.uint8), np.zeros(5, np.uint8),
                np.zeros((4, 4), np.float32)):
        with pytest.raises(RefsoftError, match="PNG needs"):
            write_png_rows(tmp_path / "x.png", bad, 1)
    assert list(tmp_path.iterdir()) == []


def test_pages_never_touched_are_told_apart():
    """An anonymous private mapping's pages: those never written nor read are untouched; a page
    written (even with zeros) or read is not. Arrays not in such a mapping are not asked about."""
    import mmap

    from refsoft.io.pages import PageMap

    page = mmap.PAGESIZE
    buf = mmap.mmap(-1, 16 * page, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    data = np.frombuffer(buf, np.uint8)
    data[3 * page + 5] = 1
    data[7 * page:8 * page] = 0  # written, with zeros
    assert data[9 * page + 100] == 0  # read: the kernel maps its zero page
    pm = PageMap()
    try:
        addr, flags = pm.untouched(data)
        assert addr == data.__array_interface__["data"][0] and addr % page == 0
        assert flags.tolist() == [i not in (3, 7, 9) for i in range(16)]
        addr, flags = pm.untouched(data[page + 10:5 * page])  # a view: the pages it overlaps
        assert flags.tolist() == [True, True, False, True]
        assert pm.untouched(np.zeros(4 * page, np.uint8)) is None  # the C heap's: not asked
        assert pm.untouched(data.copy()) is None
    finally:
        pm.close()
    del data
    buf.close()


def test_a_file_mapping_is_never_untouched(tmp_path):
    """A file's pages not yet read hold the file, not zeros: never reported untouched."""
    from refsoft.io.pages import PageMap

    (tmp_path / "f.bin").write_bytes(b"\x01" * (1 << 16))
    m = np.memmap(tmp_path / "f.bin", dtype=np.uint8, mode="c")  # private, writable, a file
    pm = PageMap()
    try:
        assert pm.untouched(m.view(np.ndarray)) is None
    finally:
        pm.close()
    del m


def test_untouched_pages_are_not_read(tmp_path, monkeypatch):
    """A G-buffer as the render leaves it (a lazy zero mapping, its box written): the writer reads
    none of its untouched pages but the few its 4 samples fall in (they stay untouched), and the
    file is the one the bytes give."""
    import mmap

    import refsoft.io
    from refsoft import limits

    page = mmap.PAGESIZE
    gbuf = limits.zeros((256, page // 4), np.float32)  # a row per page
    assert gbuf.nbytes >= limits.LAZY_ZEROS_BYTES
    gbuf[20:23, 100:300] = np.random.default_rng(2).random((3, 200), dtype=np.float32)
    gbuf[200, :] = 0  # touched, zeros
    arrays = {"gbuffer": gbuf, "image": np.arange(3000, dtype=np.uint8)}
    data = gbuf.reshape(-1).view(np.uint8)
    pm = refsoft.io.pages.PageMap()
    try:
        before = pm.untouched(data)[1]
        assert before.sum() == 256 - 4
        refsoft.io.write_npz_level(tmp_path / "a.npz", arrays, 1)
        after = pm.untouched(data)[1]
    finally:
        pm.close()
    assert np.all(before | ~after) and before.sum() - after.sum() <= 4 * 2  # ≤ 2 pages a sample
    with monkeypatch.context() as m:
        m.setattr(refsoft.io.pages.PageMap, "untouched", lambda self, data: None)
        refsoft.io.write_npz_level(tmp_path / "b.npz", arrays, 1)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    with np.load(tmp_path / "a.npz") as z:
        assert z["gbuffer"].tobytes() == gbuf.tobytes()


def test_render_command_files_hold_the_frames_arrays(tmp_path):
    """At a size whose G-buffers are lazy zero mappings (their untouched pages not read by the
    writer): every array of the command's npz is the frame's, bit for bit, as np.savez_compressed
    holds it; the PNG decodes to the image; a rerun writes the same bytes."""
    from PIL import Image

    import refsoft
    from refsoft import limits
    from refsoft.io import write_npz

    frames, _ = refsoft.render("kitchen", frames=[2, 3], width=400, height=300, out=tmp_path / "a")
    fr = frames[-1]
    big = [k for k, a in fr.arrays.items() if k.startswith("gbuffer_position")]
    assert big and all(fr.arrays[k].nbytes >= limits.LAZY_ZEROS_BYTES for k in big)
    write_npz(tmp_path / "np.npz", **fr.arrays)
    with np.load(tmp_path / "a" / "frame_0003.npz") as a, np.load(tmp_path / "np.npz") as b:
        assert list(a.keys()) == list(b.keys()) == list(fr.arrays)
        for k in a.keys():
            x, y = a[k], b[k]
            assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k
    with Image.open(tmp_path / "a" / "frame_0003.png") as p:
        assert np.array_equal(np.asarray(p), fr.arrays[keys.IMAGE])
    refsoft.render("kitchen", frames=[2, 3], width=400, height=300, out=tmp_path / "b")
    for name in ("frame_0002.npz", "frame_0003.npz", "frame_0002.png", "frame_0003.png"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes(), name

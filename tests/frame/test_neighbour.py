"""The flat-picture deflate encoder (refsoft.io.neighbour) writes standard streams: zlib decodes
its segments after any byte-aligned deflate output, NumPy and zipfile read the npz members it
writes, Pillow and imageio the PNGs; a picture with many literals is left to zlib."""

import struct
import zipfile
import zlib

import numpy as np
import pytest

from refsoft.io.neighbour import neighbour_deflate


def _stored(data: bytes, final: bool = False) -> bytes:
    """A stored deflate block (RFC 1951 3.2.4) holding ``data`` (< 64 KiB)."""
    return bytes([1 if final else 0]) + struct.pack("<HH", len(data), 0xFFFF ^ len(data)) + data


def _flat(rng, h, w, channels, colours=4):
    """(h, w[, channels]) uint8: rectangles of a few colours over a background, some noise."""
    shape = (h, w) if channels == 0 else (h, w, channels)
    img = np.zeros(shape, np.uint8)
    for _ in range(6):
        y, x = rng.integers(0, h, 2), rng.integers(0, w, 2)
        img[min(y):max(y) + 1, min(x):max(x) + 1] = rng.integers(0, 256, () if channels == 0 else channels)
    noise = rng.random((h, w)) < 0.005
    img[noise] = rng.integers(0, colours, (int(noise.sum()),) + shape[2:])
    return img


def test_segments_decode_to_their_bytes():
    """After the bytes before it (stored), a segment and the stream's end decode, in zlib, to the
    bytes: runs and noise, every distance (those beyond 32 KiB unused), segments that start and
    end anywhere, empty ones, as the stream's last block or followed by another."""
    rng = np.random.default_rng(11)
    for trial in range(300):
        n = int(rng.integers(0, 3000))
        if trial % 3 == 0:
            data = rng.integers(0, 3, n, dtype=np.uint8)
        else:
            data = np.repeat(rng.integers(0, 4, n + 1, dtype=np.uint8), int(rng.integers(1, 9)))[:n]
        lo = int(rng.integers(0, n + 1))
        hi = int(rng.integers(lo, n + 1))
        pixel = int(rng.choice([1, 3, 4, 40000]))
        row = int(rng.choice([1, 2, 7, 64, 1000, 40000]))
        seg = neighbour_deflate(data, lo, hi, pixel, row)
        assert seg[-4:] == b"\x00\x00\xff\xff"  # ends byte-aligned, as zlib's sync flush
        stream = _stored(data[:lo].tobytes()) + seg + _stored(b"", final=True)
        assert zlib.decompress(stream, -15) == data[:hi].tobytes(), (trial, lo, hi, pixel, row)
        last = _stored(data[:lo].tobytes()) + neighbour_deflate(data, lo, hi, pixel, row, final=True)
        assert zlib.decompress(last, -15) == data[:hi].tobytes(), (trial, lo, hi, pixel, row)


def test_a_segment_follows_and_precedes_zlib_output():
    """Between zlib's output up to a full flush and a fresh zlib stream (what the npz writer
    joins): the member decodes to its bytes, its matches reaching back into zlib's part."""
    rng = np.random.default_rng(3)
    img = _flat(rng, 60, 50, 3)
    data = img.reshape(-1)
    a, b = 1000, 6000
    head = zlib.compressobj(1, zlib.DEFLATED, -15)
    tail = zlib.compressobj(1, zlib.DEFLATED, -15)
    stream = (head.compress(data[:a]) + head.flush(zlib.Z_FULL_FLUSH) + neighbour_deflate(data, a, b, 3, 150)
              + tail.compress(data[b:]) + tail.flush())
    assert zlib.decompress(stream, -15) == data.tobytes()


def test_long_runs_and_literal_limit():
    """A picture of one colour is a few bytes per row; ``most_literals`` refuses a noisy one (None)
    and accepts one with as many literals as it allows."""
    flat = np.full((100, 200, 3), 7, np.uint8).reshape(-1)
    seg = neighbour_deflate(flat, 0, flat.size, 3, 600, final=True)
    assert len(seg) < 1000 and zlib.decompress(seg, -15) == flat.tobytes()
    noise = np.random.default_rng(5).integers(0, 256, 5000, dtype=np.uint8)
    assert neighbour_deflate(noise, 0, noise.size, 3, 100, most_literals=1000) is None
    assert neighbour_deflate(noise, 0, noise.size, 3, 100, most_literals=5000) is not None
    one = np.zeros(600, np.uint8)
    one[300] = 9  # two literals: the first byte (nothing before it), the 9
    assert neighbour_deflate(one, 0, one.size, 1, 50, most_literals=1) is None
    two = neighbour_deflate(one, 0, one.size, 1, 50, final=True, most_literals=2)
    assert zlib.decompress(two, -15) == one.tobytes()


def test_bad_segments_are_refused():
    from refsoft.errors import RefsoftError

    data = np.zeros(100, np.uint8)
    for args in [(data, 0, 101, 3, 30), (data, 50, 40, 3, 30), (data, -1, 10, 3, 30), (data, 0, 10, 0, 30),
                 (data.astype(np.int32), 0, 10, 3, 30), (data.reshape(10, 10), 0, 10, 3, 30)]:
        with pytest.raises(RefsoftError):
            neighbour_deflate(*args)


def _pictures(rng):
    """A frame's kinds of pictures: its image, id maps (with -1), a mask, and a noisy image."""
    ids = _flat(rng, 70, 90, 0).astype(np.int32) - 1
    return {"image": _flat(rng, 70, 90, 3), "object_id": ids, "reflected_id": np.where(ids > 0, ids, -1),
            "mask": _flat(rng, 70, 90, 0) > 0, "rgba": _flat(rng, 30, 20, 4),
            "noisy": rng.integers(0, 4, (70, 90, 3), dtype=np.uint8)}  # deflates, but not flat


@pytest.fixture
def small_units(monkeypatch):
    """Units of 128 bytes, runs of 2 units or more: pictures cut into several runs, each written
    by the encoder however short."""
    import refsoft.io

    monkeypatch.setattr(refsoft.io.npz, "NPZ_UNIT_BYTES", 128)
    monkeypatch.setattr(refsoft.io.npz, "NPZ_SHORTEST_RUN", 2)
    monkeypatch.setattr(refsoft.io.deflate, "NPZ_PICTURE_BYTES", 0)


def test_npz_pictures_read_back_every_way(tmp_path, small_units, monkeypatch):
    """np.load reads each picture member (dtype, shape, bytes) as written, zipfile checks its
    CRC-32; written past zipfile's member writer or through it, one file; a rerun writes the
    same bytes; the flat pictures written by the encoder, the noisy one by zlib alone."""
    import refsoft.io
    import refsoft.io.neighbour

    arrays = _pictures(np.random.default_rng(8))
    calls = []
    real = refsoft.io.neighbour.neighbour_deflate
    monkeypatch.setattr(refsoft.io.neighbour, "neighbour_deflate",
                        lambda data, *a, **k: calls.append(real(data, *a, **k) is not None) or real(data, *a, **k))
    clean = np.zeros((70, 90, 3), np.uint8)  # rectangles: a few literals where each starts
    clean[10:40, 20:60] = (200, 10, 30)
    clean[30:65, 50:85] = (5, 90, 250)
    refsoft.io.write_npz_level(tmp_path / "flat.npz", {"image": clean, "ids": clean[..., 0].astype(np.int32)}, 1, 0)
    assert calls and all(calls)  # every segment of the flat pictures encoded
    calls.clear()
    refsoft.io.write_npz_level(tmp_path / "noisy.npz", {"noisy": arrays["noisy"]}, 1, 0)
    assert calls and not any(calls)  # left to zlib
    calls.clear()
    monkeypatch.setattr(refsoft.io.deflate, "NPZ_PICTURE_BYTES", clean.nbytes + 1)
    refsoft.io.write_npz_level(tmp_path / "short.npz", {"image": clean}, 1, 0)
    assert calls == []  # shorter than NPZ_PICTURE_BYTES: zlib's
    with np.load(tmp_path / "short.npz") as z:
        assert z["image"].tobytes() == clean.tobytes()
    monkeypatch.setattr(refsoft.io.deflate, "NPZ_PICTURE_BYTES", 0)
    vertices = np.repeat(np.arange(300, dtype=np.int32), 2).reshape(300, 2)  # one vertex per row
    refsoft.io.write_npz_level(tmp_path / "v.npz", {"pixel": vertices}, 1, 0)
    assert calls == []  # not a picture: zlib's
    with np.load(tmp_path / "v.npz") as z:
        assert z["pixel"].tobytes() == vertices.tobytes()
    refsoft.io.write_npz_level(tmp_path / "a.npz", arrays, 1, 0)
    refsoft.io.write_npz_level(tmp_path / "again.npz", arrays, 1, 0)
    with monkeypatch.context() as m:
        m.setattr(refsoft.io.npz, "_WRITER_STATE", ("_no_such_state",))
        refsoft.io.write_npz_level(tmp_path / "through.npz", arrays, 1, 0)
    one = (tmp_path / "a.npz").read_bytes()
    assert (tmp_path / "again.npz").read_bytes() == one and (tmp_path / "through.npz").read_bytes() == one
    with zipfile.ZipFile(tmp_path / "a.npz") as zf:
        assert zf.testzip() is None
        assert {i.compress_type for i in zf.infolist()} == {zipfile.ZIP_DEFLATED}
    with np.load(tmp_path / "a.npz") as z:
        assert list(z.keys()) == list(arrays)
        for k, a in arrays.items():
            assert (z[k].dtype, z[k].shape) == (a.dtype, a.shape) and z[k].tobytes() == a.tobytes(), k
    got = refsoft.io.read_npz(tmp_path / "a.npz")
    for k, a in arrays.items():
        assert (got[k].dtype, got[k].shape) == (a.dtype, a.shape) and got[k].tobytes() == a.tobytes(), k


@pytest.mark.parametrize("channels", [3, 0])
def test_png_of_a_flat_picture_decodes_to_it(tmp_path, channels):
    """A flat frame's PNG (the encoder's IDAT in a zlib stream with its Adler-32): Pillow (every
    chunk's CRC) and imageio decode the image; zlib checks the stream's Adler-32; a noisy image
    is zlib's own stream; the same bytes on a rerun."""
    import imageio.v3 as iio
    from PIL import Image

    from refsoft.io import write_png_rows

    rng = np.random.default_rng(channels)
    img = _flat(rng, 50, 70, channels)
    write_png_rows(tmp_path / "f.png", img, 1)
    write_png_rows(tmp_path / "g.png", img, 1)
    assert (tmp_path / "f.png").read_bytes() == (tmp_path / "g.png").read_bytes()
    with Image.open(tmp_path / "f.png") as im:
        im.load()
        assert np.array_equal(np.asarray(im), img)
    assert np.array_equal(iio.imread(tmp_path / "f.png"), img)
    raw = (tmp_path / "f.png").read_bytes()
    idat = raw[raw.index(b"IDAT") + 4:raw.index(b"IEND") - 8]
    rows = zlib.decompress(idat)  # the header and the Adler-32 checked
    assert rows == np.concatenate([np.zeros((50, 1), np.uint8), img.reshape(50, -1)], axis=1).tobytes()
    noisy = rng.integers(0, 256, img.shape, dtype=np.uint8)
    write_png_rows(tmp_path / "n.png", noisy, 1)
    raw = (tmp_path / "n.png").read_bytes()
    idat = raw[raw.index(b"IDAT") + 4:raw.index(b"IEND") - 8]
    assert idat == zlib.compress(np.concatenate([np.zeros((50, 1), np.uint8), noisy.reshape(50, -1)], axis=1), 1)

"""Last frame's reflection pixels as search starts (refsoft.search.reflect.coherent_starts) against
a plain loop: rows inside the G-buffer kept, rows with an entry outside it (a changed size, or
(-1, -1): none) made (-1, -1); None for no pixels or another vertex count."""

import numpy as np

from refsoft.search.reflect import coherent_starts


def _plain(prev, shape):
    out = np.array(prev, copy=True)
    for i, (r, c) in enumerate(prev):
        if not (0 <= r < shape[0] and 0 <= c < shape[1]):
            out[i] = -1
    return out


def test_coherent_starts_keep_the_pixels_inside_and_restart_the_others():
    rng = np.random.default_rng(4)
    prev = rng.integers(-3, 60, (500, 2)).astype(np.int32)
    prev[::7] = -1
    prev[3] = (39, 10)  # the last row: kept
    prev[4] = (40, 10)  # one past it: restarted
    prev[5] = (10, 49)
    prev[6] = (10, 50)
    got = coherent_starts(prev, 500, (40, 50))
    want = _plain(prev, (40, 50))
    assert got.dtype == prev.dtype and got.tobytes() == want.tobytes()
    assert (got[3] == (39, 10)).all() and (got[4] == -1).all() and (got[5] == (10, 49)).all() and (got[6] == -1).all()
    assert 0 < np.sum(got[:, 0] == -1) < 500  # some kept, some restarted
    assert coherent_starts(None, 500, (40, 50)) is None and coherent_starts(prev, 499, (40, 50)) is None

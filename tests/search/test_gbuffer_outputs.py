"""The G-buffer arrays of the output contract (``method.gbuffer_outputs``): world positions
rounded once to float32 inside the mask and zero outside, against NumPy's float64 sum and cast."""

import numpy as np
import pytest

from refsoft import keys
from refsoft._parallel import one_thread
from refsoft.raster import GBuffer
from refsoft.search.method import gbuffer_outputs


def _gbuffer(dtype, rng, empty=False):
    h, w = 23, 31
    mask = np.zeros((h, w), bool)
    if not empty:
        mask[4:19, 6:27] = rng.random((15, 21)) < 0.7
    position = (rng.normal(0, 50, (h, w, 3)) * mask[..., None]).astype(dtype)
    normal = rng.normal(0, 1, (h, w, 3)).astype(dtype)
    origin = np.array([1e3 / 3, -7.25, 12345.678])
    return GBuffer(position, normal, mask, (0, 0, np.zeros((0, 0), np.float32)), (0, 0, np.zeros((0, 0), np.int32)),
                   np.eye(4), origin)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("threads", [1, 2])
def test_world_positions_are_numpys_sum_rounded_once(dtype, threads):
    rng = np.random.default_rng(4)
    gb = _gbuffer(dtype, rng)
    with one_thread(threads == 1):
        got = gbuffer_outputs(gb, 2)[keys.GBUFFER_POSITION(2)]
    want = np.where(gb.mask[..., None], gb.position.astype(np.float64) + gb.origin, 0.0).astype(np.float32)
    assert got.dtype == np.float32 and got.shape == gb.position.shape
    assert got.tobytes() == want.tobytes()
    assert np.count_nonzero(got.any(axis=2)) == np.count_nonzero(gb.mask)


def test_an_empty_mask_gives_zeros():
    gb = _gbuffer(np.float32, np.random.default_rng(1), empty=True)
    got = gbuffer_outputs(gb, 1)[keys.GBUFFER_POSITION(1)]
    assert got.dtype == np.float32 and not got.any()

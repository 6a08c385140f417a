"""refsoft.linalg: the products, inverses and norms the oracle's inputs are computed with, in a
fixed order (bit for bit against plain Python sums) and right (against NumPy's BLAS and LAPACK, to a
tolerance: their bits are the machine's)."""

import numpy as np
import pytest

from refsoft import linalg


def _python_matmul(a, b):
    return np.array([[sum_left(float(a[i, k]) * float(b[k, j]) for k in range(a.shape[1])) for j in range(b.shape[1])]
                     for i in range(a.shape[0])])


def sum_left(values):
    values = list(values)
    total = values[0]
    for v in values[1:]:
        total = total + v
    return total


def test_products_sum_left_to_right_bit_for_bit():
    rng = np.random.default_rng(1)
    for m, k, n in ((4, 4, 4), (3, 3, 3), (5, 3, 1), (2, 4, 3)):
        a, b = rng.normal(size=(m, k)), rng.normal(size=(k, n)) * 1e3
        assert np.array_equal(linalg.matmul(a, b), _python_matmul(a, b))
        np.testing.assert_allclose(linalg.matmul(a, b), a @ b, rtol=1e-12, atol=1e-9)
    p, mat = rng.normal(size=(50, 3)), rng.normal(size=(4, 4))
    want = np.array([[sum_left([p[i, 0] * mat[r, 0], p[i, 1] * mat[r, 1], p[i, 2] * mat[r, 2], mat[r, 3]])
                      for r in range(4)] for i in range(50)])
    assert np.array_equal(linalg.homogeneous(p, mat), want)
    assert np.array_equal(linalg.dot3(p, p[::-1]), [sum_left([x[0] * y[0], x[1] * y[1], x[2] * y[2]])
                                                     for x, y in zip(p, p[::-1])])


def test_inverses_agree_with_lapack():
    rng = np.random.default_rng(2)
    for _ in range(20):
        m = rng.normal(size=(4, 4)) + 3 * np.eye(4)
        np.testing.assert_allclose(linalg.inv(m), np.linalg.inv(m), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(linalg.matmul(linalg.inv(m), m), np.eye(4), atol=1e-12)
        r = rng.normal(size=(3, 3)) + 2 * np.eye(3)
        np.testing.assert_allclose(linalg.inv3(r), np.linalg.inv(r), rtol=1e-10, atol=1e-12)
        aff = np.eye(4)
        aff[:3, :3], aff[:3, 3] = r, rng.normal(size=3)
        np.testing.assert_allclose(linalg.inv_affine(aff), np.linalg.inv(aff), rtol=1e-10, atol=1e-12)
    with pytest.raises(ValueError, match="singular"):
        linalg.inv(np.ones((4, 4)))
    with pytest.raises(ValueError, match="singular"):
        linalg.inv3(np.zeros((3, 3)))


def test_a_perspective_matrix_inverts():
    from refsoft.scene.camera import Camera

    cam = Camera(eye=(1.0, 2.0, 5.0), target=(0.0, 0.3, 0.0), fov_y=50.0, width=64, height=48)
    vp = cam.view_proj()
    np.testing.assert_allclose(linalg.matmul(linalg.inv(vp), vp), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(vp, cam.projection_matrix() @ cam.view_matrix(), rtol=1e-13, atol=1e-13)

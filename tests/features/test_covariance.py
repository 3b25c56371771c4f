"""Covariance (Eq. 5.4) and batched eigenvalue kernels against the numpy reference."""

import numpy as np
import pytest

from pointatlas._core import NonFiniteError, readonly_view
from pointatlas.features import symmetric_eigenvalues, weighted_covariances
from pointatlas.features._kernels import covariance_kernel

from . import reference as ref


def _random_psd(rng, n, rank=3, scale=1.0):
    x = rng.normal(size=(n, 3, rank)) * scale
    return x @ np.swapaxes(x, 1, 2)


@pytest.mark.parametrize("rank", [1, 2, 3])
def test_eigenvalues_match_eigvalsh(rank):
    rng = np.random.default_rng(rank)
    m = _random_psd(rng, 500, rank=rank)
    got = symmetric_eigenvalues(m)
    want = np.linalg.eigvalsh(m)[:, ::-1]
    scale = want[:, :1]
    np.testing.assert_allclose(got / scale, want / scale, atol=1e-13)
    assert (np.diff(got, axis=1) <= 0).all()


def test_eigenvalues_special_matrices():
    m = np.array([np.zeros((3, 3)), np.eye(3) * 2, np.diag([1e-300, 1.0, 1e300])])
    got = symmetric_eigenvalues(m)
    assert got[0].tolist() == [0.0, 0.0, 0.0]
    assert got[1].tolist() == [2.0, 2.0, 2.0]
    assert got[2].tolist() == [1e300, 1.0, 1e-300]
    nan = symmetric_eigenvalues(np.full((1, 3, 3), np.nan))
    assert np.isnan(nan).all()
    # small eigenvalue of a nearly planar covariance stays relatively accurate
    r = np.linalg.qr(np.random.default_rng(0).normal(size=(3, 3)))[0]
    m = r @ np.diag([1.0, 0.5, 1e-12]) @ r.T
    assert symmetric_eigenvalues(m[None])[0, 2] == pytest.approx(1e-12, rel=1e-3)


def test_eigenvalues_validation():
    with pytest.raises(ValueError, match=r"shape \(N, 3, 3\)"):
        symmetric_eigenvalues(np.zeros((2, 3)))


def _check_against_reference(points, idx, weights):
    cov, reason = weighted_covariances(points, idx, weights)
    w = np.ones(idx.shape) if weights is None else weights
    for i in range(points.shape[0]):
        pts = points[idx[i]]
        want_reason = ref.reason(pts, w[i])
        assert reason[i] == want_reason, i
        if want_reason == 1:
            assert np.isnan(cov[i]).all()
            continue
        want = ref.covariance(pts, w[i])
        np.testing.assert_allclose(cov[i], want, atol=1e-12 * max(1.0, np.abs(want).max()))


def test_covariance_random_with_and_without_weights():
    rng = np.random.default_rng(5)
    pts = rng.normal(size=(60, 3))
    idx = np.column_stack([np.arange(60), rng.integers(0, 60, size=(60, 9))])
    _check_against_reference(pts, idx, None)
    _check_against_reference(pts, idx, rng.random(idx.shape))


def test_covariance_collinear_coplanar_duplicate_nan():
    t = np.linspace(0, 1, 8)
    line = np.column_stack([t, 2 * t, -t])
    plane = np.column_stack([t, np.sin(7 * t), np.zeros(8)])
    dup = np.tile([[1.0, 2.0, 3.0]], (8, 1))
    two = np.vstack([np.tile([[0.0, 0, 0]], (4, 1)), np.tile([[1.0, 1, 1]], (4, 1))])
    nan = line.copy()
    nan[3] = np.nan
    idx = np.tile(np.arange(8), (8, 1))
    for pts in (line, plane, dup, two):
        _check_against_reference(pts, idx, None)
    # collinear: rank one; coplanar: smallest eigenvalue 0; duplicates: code 3
    ev = symmetric_eigenvalues(weighted_covariances(line, idx)[0])
    assert np.allclose(ev[:, 1:], 0, atol=1e-15)
    ev = symmetric_eigenvalues(weighted_covariances(plane, idx)[0])
    assert np.allclose(ev[:, 2], 0, atol=1e-15)
    assert (weighted_covariances(dup, idx)[1] == 3).all()
    assert (weighted_covariances(two, idx)[1] == 3).all()
    with pytest.raises(NonFiniteError, match=r"^points contains 3 non-finite values .* at row 3$"):
        weighted_covariances(nan, idx)
    # the kernel itself (fed by tiles and searches) flags a non-finite neighbour: code 1
    out, reason = np.empty((8, 3, 3)), np.empty(8, dtype=np.uint8)
    # read-only points, as `weighted_covariances` passes them (one compiled signature)
    covariance_kernel(readonly_view(nan), idx, np.empty((0, 0)), False, out, reason)
    assert (reason == 1).all() and np.isnan(out).all()
    assert all(ref.reason(nan[row], np.ones(8)) == 1 for row in idx)
    zero_w = np.zeros(idx.shape)
    assert (weighted_covariances(plane, idx, zero_w)[1] == 2).all()


def test_unweighted_barycentre_as_printed():
    # one point with positive weight still has a non-zero covariance about the
    # unweighted barycentre (Eq. 5.4), but is flagged: fewer than 3 distinct points
    pts = np.array([[0.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0]])
    w = np.array([[1.0, 0, 0]] * 3)
    cov, reason = weighted_covariances(pts, [[0, 1, 2]] * 3, w)
    bary = pts.mean(axis=0)
    np.testing.assert_allclose(cov[0], np.outer(-bary, -bary))
    assert reason[0] == 3


def test_covariance_validation():
    with pytest.raises(ValueError, match="weights must have the shape"):
        weighted_covariances(np.zeros((3, 3)), [[0, 1, 2]] * 3, np.ones((3, 2)))
    with pytest.raises(ValueError, match="weights must be >= 0"):
        weighted_covariances(np.zeros((3, 3)), [[0, 1, 2]] * 3, -np.ones((3, 3)))
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\)"):
        weighted_covariances(np.zeros((3, 2)), [[0, 1, 2]] * 3)


def test_a_b_pi_weights_give_the_equal_weight_covariance():
    from pointatlas.features import normal_weights

    rng = np.random.default_rng(8)
    pts = rng.normal(size=(50, 3))
    nrm = rng.normal(size=(50, 3))  # arbitrary, even opposite normals
    idx = np.column_stack([np.arange(50), rng.integers(0, 50, size=(50, 7))])
    w = normal_weights(nrm, idx, np.pi, np.pi)
    assert (w == 1.0).all()
    np.testing.assert_array_equal(
        weighted_covariances(pts, idx, w)[0], weighted_covariances(pts, idx)[0]
    )

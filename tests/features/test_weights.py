"""Cosine sigmoid (Def. 15) and normal angles."""

import math

import numpy as np
import pytest

from pointatlas.features import cosine_sigmoid, normal_angles, normal_weights

from . import reference as ref


def test_sigmoid_matches_reference_on_grid():
    xs = np.linspace(0, math.pi, 181)
    for a in (0.0, math.pi / 6, math.pi / 2, math.pi):
        for b in (a, a + (math.pi - a) / 2, math.pi):
            got = cosine_sigmoid(xs, a, b)
            want = np.array([ref.sigmoid(x, a, b) for x in xs])
            np.testing.assert_allclose(got, want, atol=1e-15)


def test_sigmoid_shape_properties():
    xs = np.linspace(0, math.pi, 1001)
    w = cosine_sigmoid(xs, 0.3, 2.0)
    assert np.all(np.diff(w) <= 1e-15)  # monotonic falling
    assert w[0] == 1.0 and w[-1] == 0.0
    mid = cosine_sigmoid(np.array([1.15]), 0.3, 2.0)[0]
    assert mid == pytest.approx(0.5)  # symmetric ramp: half weight at the midpoint


def test_sharp_cutoff_rule_and_tolerance():
    # a = b: weight 1 iff angle <= a; identical normals keep weight 1 at a = b = 0
    assert cosine_sigmoid(np.array([0.0, 5e-8, 2e-7]), 0.0, 0.0).tolist() == [1.0, 1.0, 0.0]
    assert cosine_sigmoid(np.array([0.5, 0.5000001]), 0.5, 0.5).tolist() == [1.0, 0.0]
    assert (cosine_sigmoid(np.linspace(0, math.pi, 50), math.pi, math.pi) == 1.0).all()


@pytest.mark.parametrize(("a", "b"), [(-0.1, 1.0), (1.0, 0.5), (0.0, 4.0), (float("nan"), 1.0)])
def test_sigmoid_rejects_bad_thresholds(a, b):
    with pytest.raises(ValueError, match=r"^[ab] must be a finite angle in \[(0|1), pi\] radians"):
        cosine_sigmoid(np.zeros(3), a, b)


def test_normal_angles_accurate_near_zero_and_pi():
    n = np.array([[0, 0, 1.0], [0, math.sin(1e-6), math.cos(1e-6)], [0, 0, -1.0], [1, 0, 0]])
    ang = normal_angles(n, [[0, 1, 2, 3]] * 4)
    assert ang[0, 0] == 0.0
    assert ang[0, 1] == pytest.approx(1e-6, rel=1e-9)
    assert ang[0, 2] == pytest.approx(math.pi, rel=1e-15)
    assert ang[0, 3] == pytest.approx(math.pi / 2, rel=1e-15)
    rng = np.random.default_rng(3)
    m = rng.normal(size=(30, 3))
    m /= np.linalg.norm(m, axis=1)[:, None]
    idx = rng.integers(0, 30, size=(30, 5))
    got = normal_angles(m, idx)
    want = np.array([[ref.angle(m[i], m[j]) for j in row] for i, row in enumerate(idx)])
    np.testing.assert_allclose(got, want, atol=1e-12)


def test_normal_weights_and_bad_normals_are_nan():
    n = np.array([[0, 0, 1.0], [0, 1.0, 0], [np.nan, 0, 0], [0, 0, 0]])
    w = normal_weights(n, [[0, 1, 2, 3]] * 4, 0.0, math.pi)
    assert w[0, 0] == 1.0 and w[0, 1] == pytest.approx(0.5)
    assert np.isnan(w[0, 2]) and np.isnan(w[0, 3]) and np.isnan(w[2]).all()


def test_indices_validated():
    with pytest.raises(ValueError, match="neighbors must have shape"):
        normal_angles(np.eye(3), [[0, 1]])
    with pytest.raises(ValueError, match="must index points"):
        normal_angles(np.eye(3), [[0, 5]] * 3)


def test_polynomial_ramp_matches_cosine_to_round_off():
    from pointatlas.features._kernels.math_helpers import cosine_sigmoid_scalar, sigmoid_ramp

    u = np.linspace(0.0, 1.0, 100001)
    got = np.array([sigmoid_ramp(v) for v in u])
    np.testing.assert_allclose(got, 0.5 * np.cos(np.pi * u) + 0.5, rtol=0, atol=4e-16)
    assert (got >= 0).all() and sigmoid_ramp(0.0) == pytest.approx(1.0, abs=1e-16)
    # the scalar sigmoid: exact 1 at and below a, exact 0 at and beyond b, a = b sharp
    assert cosine_sigmoid_scalar(0.3, 0.3, 1.0) == 1.0
    assert cosine_sigmoid_scalar(1.0, 0.3, 1.0) == 0.0
    assert cosine_sigmoid_scalar(0.5, 0.5, 0.5) == 1.0
    assert cosine_sigmoid_scalar(0.6, 0.5, 0.5) == 0.0


def test_branch_free_atan2_within_two_ulp_of_libm():
    from numba import njit

    from pointatlas.features._kernels.math_helpers import atan2_nonneg

    f = njit(lambda y, x: atan2_nonneg(y, x))
    rng = np.random.default_rng(5)
    for scale in (1e-300, 1e-12, 1e-3, 1.0, 1e8):
        y = rng.random(2000) * scale
        x = rng.random(2000)
        for a, b in ((y, x), (x, y)):
            got = np.array([f(u, v) for u, v in zip(a, b, strict=True)])
            want = np.array([math.atan2(u, v) for u, v in zip(a, b, strict=True)])
            ulp = np.abs(got - want) / np.spacing(np.maximum(want, 1e-300))
            assert ulp.max() <= 2.0
    assert f(0.0, 1.0) == 0.0 and f(1.0, 0.0) == math.pi / 2 and f(2.0, 2.0) == math.pi / 4
    assert math.isnan(f(math.nan, 1.0)) and math.isnan(f(1.0, math.nan))


def test_unit_normals_as_numpy_and_bad_rows_nan():
    from pointatlas.features._weights import _unit_normals_or_nan

    rng = np.random.default_rng(4)
    nrm = rng.normal(size=(500, 3)).astype(np.float32) * 3.0
    nrm[10] = 0.0
    nrm[11] = [np.nan, 0.0, 1.0]
    nrm[12] = [np.inf, 0.0, 0.0]
    nrm[13] = [1e-13, 0.0, 0.0]
    got = _unit_normals_or_nan(nrm, 500)
    x = nrm.astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        want = x / np.linalg.norm(x, axis=1)[:, None]
    good = np.ones(500, bool)
    good[10:14] = False
    np.testing.assert_array_equal(got[good], want[good])
    assert np.isnan(got[~good]).all()
    # a squared length that overflows is flagged, not turned into a zero vector
    assert np.isnan(_unit_normals_or_nan([[1e200, 0.0, 0.0]], 1)).all()
    with pytest.raises(ValueError, match="one row per point"):
        _unit_normals_or_nan(nrm, 499)

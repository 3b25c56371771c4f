"""flipped_fraction and angle_error."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from pointatlas.normals import angle_error, flipped_fraction

from ..strategies import seeds


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@settings(deadline=None, max_examples=30)
@given(seed=seeds())
def test_angle_error_matches_arccos_reference(seed):
    rng = np.random.default_rng(seed)
    a, b = _unit(rng, 50), _unit(rng, 50)
    ref = np.arccos(np.clip(np.sum(a * b, axis=1), -1, 1))
    err = angle_error(3.0 * a, b)  # lengths do not matter
    assert err.shape == (50,) and err.dtype == np.float64
    assert np.allclose(err, ref, atol=1e-7)
    un = angle_error(a, b, unoriented=True)
    assert np.allclose(un, np.minimum(ref, np.pi - ref), atol=1e-7)
    assert np.allclose(angle_error(b, a), err)  # symmetric
    assert np.allclose(angle_error(-a, b), np.pi - err, atol=1e-12)


def test_angle_error_accurate_for_tiny_and_opposite():
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1e-9, 0.0, 1.0]])
    r = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    err = angle_error(n, r)
    assert err[0] == 0.0
    assert err[1] == np.pi
    assert abs(err[2] - 1e-9) < 1e-20
    assert angle_error(n, r, unoriented=True)[1] == 0.0


def test_flipped_fraction():
    rng = np.random.default_rng(0)
    a = _unit(rng, 400)
    sign = np.where(rng.random(400) < 0.25, -1.0, 1.0)
    assert flipped_fraction(a * sign[:, None], a) == np.mean(sign < 0)
    assert flipped_fraction(a, a) == 0.0
    assert flipped_fraction(-a, a) == 1.0
    # perpendicular pairs are not flipped
    assert flipped_fraction([[1.0, 0, 0]], [[0.0, 1, 0]]) == 0.0
    assert flipped_fraction(np.zeros((0, 3)), np.zeros((0, 3))) == 0.0


def test_errors():
    with pytest.raises(ValueError, match="one row per point"):
        angle_error(np.ones((3, 3)), np.ones((2, 3)))
    with pytest.raises(ValueError, match="zero-length"):
        flipped_fraction([[0.0, 0, 0]], [[0.0, 0, 1]])
    with pytest.raises(ValueError, match="non-finite"):
        angle_error([[np.nan, 0, 1]], [[0.0, 0, 1]])

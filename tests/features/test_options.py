"""Numeric options of the features room: k in [1, N] (the point itself counts),
angles and angle grids finite in [0, pi] radians, b >= a, flatness even >= 0."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointatlas.features import (
    angle_pairs,
    cosine_sigmoid,
    covariance_features,
    eigen_features,
    normal_weights,
    optimal_k_features,
    optimal_neighborhood,
)

N = 40
NAN, INF = float("nan"), float("inf")
RNG = np.random.default_rng(5)
PTS = RNG.random((N, 3)) * [1.0, 1.0, 0.1]
NRM = np.tile([0.0, 0.0, 1.0], (N, 1)) + RNG.normal(scale=0.2, size=(N, 3))

K_RANGE = r"must be an integer in \[1, 40\] \(the number of points\); got "
K_BAD = [
    (0, ValueError, r"^k " + K_RANGE + "0$"),
    (-4, ValueError, r"^k " + K_RANGE + "-4$"),
    (N + 1, ValueError, r"^k " + K_RANGE + "41$"),
    (100000, ValueError, r"^k " + K_RANGE + "100000$"),
    (True, TypeError, r"^k must be an integer; got bool True$"),
    (5.5, TypeError, r"^k must be an integer; got float 5\.5$"),
    (14.0, TypeError, r"^k must be an integer; got float 14\.0$"),
    (NAN, TypeError, r"^k must be an integer; got float nan$"),
    (INF, TypeError, r"^k must be an integer; got float inf$"),
]


@pytest.mark.parametrize(("value", "error", "match"), K_BAD)
def test_covariance_features_k(value, error, match):
    with pytest.raises(error, match=match):
        covariance_features(PTS, value)


@pytest.mark.parametrize("k", [1, 3, N, np.int64(9)])
def test_covariance_features_k_boundaries(k):
    res = covariance_features(PTS, k)
    assert (res.k == int(k)).all()


_A = r"^a must be a finite angle in \[0, pi\] radians; got "
_B = r"^b must be a finite angle in \[{}, pi\] radians \(b >= a\); got "
AB_BAD = [
    ({"a": NAN, "b": math.pi}, ValueError, _A + "nan$"),
    ({"a": -0.1, "b": 1.0}, ValueError, _A + r"-0\.1$"),
    ({"a": 4.0, "b": 4.0}, ValueError, _A + r"4\.0$"),
    ({"a": INF, "b": INF}, ValueError, _A + "inf$"),
    ({"a": True, "b": 1.0}, TypeError, r"^a must be a real number; got bool True$"),
    ({"a": "0", "b": 1.0}, TypeError, r"^a must be a real number; got str '0'$"),
    ({"a": 0.5, "b": NAN}, ValueError, _B.format(r"0\.5") + "nan$"),
    ({"a": 1.0, "b": 0.5}, ValueError, _B.format("1") + r"0\.5$"),
    ({"a": 0.0, "b": 3.5}, ValueError, r"^b must be .*; got 3\.5$"),
    ({"a": 0.0, "b": None}, TypeError, r"^b must be a real number; got NoneType None$"),
]


@pytest.mark.parametrize(("kwargs", "error", "match"), AB_BAD)
@pytest.mark.parametrize("func", ["covariance_features", "cosine_sigmoid", "normal_weights"])
def test_sigmoid_thresholds(func, kwargs, error, match):
    idx = np.repeat(np.arange(N)[:, None], 3, axis=1)
    calls = {
        "covariance_features": lambda: covariance_features(PTS, 8, normals=NRM, **kwargs),
        "cosine_sigmoid": lambda: cosine_sigmoid(np.zeros(3), kwargs["a"], kwargs["b"]),
        "normal_weights": lambda: normal_weights(NRM, idx, kwargs["a"], kwargs["b"]),
    }
    with pytest.raises(error, match=match):
        calls[func]()


@pytest.mark.parametrize(("a", "b"), [(0.0, 0.0), (0.0, math.pi), (math.pi, math.pi), (1, 2)])
def test_sigmoid_threshold_boundaries(a, b):
    res = covariance_features(PTS, 8, normals=NRM, a=a, b=b)
    assert res.a[0] == a and res.b[0] == b


FLAT_BAD = [
    ((7, 8), ValueError, r"flatness exponents m1, m2 must be even and >= 0 .*got \(7, 8\)$"),
    ((-2, 8), ValueError, r"^flatness\[0\] must be an integer >= 0; got -2$"),
    ((8, 2.5), TypeError, r"^flatness\[1\] must be an integer; got float 2\.5$"),
    ((8.0, 8), TypeError, r"^flatness\[0\] must be an integer; got float 8\.0$"),
    ((True, 8), TypeError, r"^flatness\[0\] must be an integer; got bool True$"),
    ((NAN, 8), TypeError, r"^flatness\[0\] must be an integer; got float nan$"),
    ((INF, 8), TypeError, r"^flatness\[0\] must be an integer; got float inf$"),
    ((8,), TypeError, r"^flatness must be a pair of even integers"),
    (8, TypeError, r"^flatness must be a pair of even integers"),
]


@pytest.mark.parametrize(("flatness", "error", "match"), FLAT_BAD)
def test_flatness(flatness, error, match):
    with pytest.raises(error, match=match):
        covariance_features(PTS, 8, flatness=flatness)
    with pytest.raises(error, match=match):
        eigen_features([[1.0, 0.5, 0.1]], flatness=flatness)


@pytest.mark.parametrize("flatness", [(0, 0), (2, 8), (np.int64(4), 6)])
def test_flatness_boundaries(flatness):
    res = covariance_features(PTS, 8, flatness=flatness)
    assert res.flatness_exponents == tuple(int(v) for v in flatness)


_GRID = r"must hold finite angles in \[0, pi\] radians; got "
GRID_BAD = [
    ([0.0, NAN], ValueError, _GRID + "nan$"),
    ([NAN], ValueError, _GRID + "nan$"),
    ([0.0, INF], ValueError, _GRID + "inf$"),
    ([-0.5, 0.0], ValueError, _GRID + r"-0\.5$"),
    ([0.0, 4.0, 5.0], ValueError, _GRID + r"4\.0, 5\.0$"),
    ([], ValueError, r"must hold at least 1 value\(s\); got 0$"),
    ([[0.0, 1.0], [2.0, 3.0]], ValueError, r"must be a flat sequence of numbers; got shape"),
    ([True, False], TypeError, r"must hold real numbers"),
    (["0", "30"], TypeError, r"must hold real numbers"),
    (None, TypeError, r"must be a sequence of numbers; got None$"),
]


@pytest.mark.parametrize(("grid", "error", "match"), GRID_BAD)
@pytest.mark.parametrize("which", ["a_grid", "b_grid"])
def test_angle_grids(which, grid, error, match):
    with pytest.raises(error, match="^" + which + " " + match):
        optimal_neighborhood(PTS, NRM, **{which: grid})
    with pytest.raises(error, match="^" + which + " " + match):
        angle_pairs(**{which: grid})


@pytest.mark.parametrize(
    ("a_grid", "b_grid", "n_pairs"),
    [
        ([0.0], [0.0], 1),
        ([math.pi], [math.pi], 1),
        ([math.pi + 5e-13], [math.pi], 1),  # round-off above pi counts as pi
        ([0, 1, 1, 0], [3], 2),  # ints, repeats: sorted and de-duplicated
        (np.deg2rad([0, 90, 180]), np.deg2rad([180]), 3),
    ],
)
def test_angle_grid_boundaries(a_grid, b_grid, n_pairs):
    assert angle_pairs(a_grid, b_grid).shape == (n_pairs, 2)


def test_angle_grids_without_pair():
    with pytest.raises(ValueError, match=r"no \(a, b\) pair with a <= b"):
        angle_pairs([2.0], [1.0])


KR = r"must be an integer in \[1, 40\] \(the number of points\); got "
KRANGE_BAD = [
    ((0, 10), ValueError, r"^k_range\[0\] " + KR + "0$"),
    ((6, N + 1), ValueError, r"^k_range\[1\] " + KR + "41$"),
    ((6, 100000), ValueError, r"^k_range\[1\] " + KR + "100000$"),
    ((10, 6), ValueError, r"^k_range must have k_min <= k_max; got \(10, 6\)$"),
    ((6.0, 10), TypeError, r"^k_range\[0\] must be an integer; got float 6\.0$"),
    ((6, NAN), TypeError, r"^k_range\[1\] must be an integer; got float nan$"),
    ((True, 10), TypeError, r"^k_range\[0\] must be an integer; got bool True$"),
    (10, TypeError, r"^k_range must be a pair \(k_min, k_max\)"),
]


@pytest.mark.parametrize(("k_range", "error", "match"), KRANGE_BAD)
def test_k_range(k_range, error, match):
    with pytest.raises(error, match=match):
        optimal_neighborhood(PTS, NRM, k_range=k_range)
    with pytest.raises(error, match=match):
        optimal_k_features(PTS, k_range=k_range)


@pytest.mark.parametrize("k_range", [(1, 1), (N, N), (1, N), (np.int32(6), np.int64(8))])
def test_k_range_boundaries(k_range):
    res = optimal_k_features(PTS, k_range=k_range, criterion="e_dim")
    ok = res.k >= 0
    assert ((res.k[ok] >= k_range[0]) & (res.k[ok] <= k_range[1])).all()
    res = optimal_neighborhood(PTS, NRM, k_range=k_range, a_grid=[0.0, math.pi])
    assert res.k.shape == (N,)

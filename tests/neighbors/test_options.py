"""Numeric options of the neighbors room: k counts the point itself, 1 <= k <= N;
radius finite and > 0; mean_spacing's k excludes the point, 1 <= k <= N - 1."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.neighbors import (
    NeighborIndex,
    knn_components,
    knn_graph,
    mean_spacing,
    query_knn,
    query_radius,
)

N = 30
NAN, INF = float("nan"), float("inf")
PTS = np.random.default_rng(3).random((N, 3))

K_BAD = [
    (0, ValueError, r"^k must be an integer in \[1, 30\] \(the number of points\); got 0$"),
    (-1, ValueError, r"^k must be an integer in \[1, 30\] \(the number of points\); got -1$"),
    (N + 1, ValueError, r"^k must be an integer in \[1, 30\] \(the number of points\); got 31$"),
    (100000, ValueError, r"^k must be an integer in \[1, 30\].*; got 100000$"),
    (True, TypeError, r"^k must be an integer; got bool True$"),
    (np.bool_(False), TypeError, r"^k must be an integer; got bool False$"),
    (2.5, TypeError, r"^k must be an integer; got float 2\.5$"),
    (4.0, TypeError, r"^k must be an integer; got float 4\.0$"),
    (NAN, TypeError, r"^k must be an integer; got float nan$"),
    (INF, TypeError, r"^k must be an integer; got float inf$"),
    ("3", TypeError, r"^k must be an integer; got str '3'$"),
]


@pytest.mark.parametrize(("value", "error", "match"), K_BAD)
@pytest.mark.parametrize("func", [query_knn, knn_graph, knn_components])
def test_k(func, value, error, match):
    with pytest.raises(error, match=match):
        func(PTS, value)


@pytest.mark.parametrize("k", [1, N, np.int64(5), np.array(5)])
def test_k_boundaries(k):
    idx, dist = query_knn(PTS, k)
    assert idx.shape == (N, int(k)) and dist.shape == (N, int(k))
    assert knn_graph(PTS, k).shape == (N, N)


def test_knn_graph_with_indices_checks_only_the_type_of_k():
    idx, _ = query_knn(PTS, 4)
    assert knn_graph(PTS, 100, neighbors=idx).shape == (N, N)
    with pytest.raises(TypeError, match=r"^k must be an integer; got float"):
        knn_graph(PTS, 4.0, neighbors=idx)


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (0.0, ValueError, r"^radius must be a finite number > 0; got 0\.0$"),
        (-1.0, ValueError, r"^radius must be a finite number > 0; got -1\.0$"),
        (NAN, ValueError, r"^radius must be a finite number > 0; got nan$"),
        (INF, ValueError, r"^radius must be a finite number > 0; got inf$"),
        (True, TypeError, r"^radius must be a real number; got bool True$"),
        ("0.5", TypeError, r"^radius must be a real number; got str '0\.5'$"),
        (None, TypeError, r"^radius must be a real number; got NoneType None$"),
    ],
)
@pytest.mark.parametrize("backend", ["auto", "kdtree"])
def test_radius(value, error, match, backend):
    with pytest.raises(error, match=match):
        query_radius(PTS, value, backend=backend)
    with pytest.raises(error, match=match):
        NeighborIndex(PTS, backend=backend).radius(value)


@pytest.mark.parametrize("radius", [1e-300, 1, np.float32(0.25), 1e300])
def test_radius_boundaries(radius):
    assert query_radius(PTS, radius).counts.shape == (N,)


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (0, ValueError, r"^k must be an integer in \[1, 29\] \(the number of other points\)"),
        (N, ValueError, r"^k must be an integer in \[1, 29\].*; got 30$"),
        (True, TypeError, r"^k must be an integer; got bool True$"),
        (2.0, TypeError, r"^k must be an integer; got float 2\.0$"),
        (NAN, TypeError, r"^k must be an integer; got float nan$"),
    ],
)
def test_mean_spacing_k(value, error, match):
    with pytest.raises(error, match=match):
        mean_spacing(PTS, value)


def test_mean_spacing_boundaries_and_distances():
    assert mean_spacing(PTS, 1) > 0 and mean_spacing(PTS, N - 1) > 0
    _, dist = query_knn(PTS, 5)
    assert mean_spacing(PTS, 4, distances=dist) == pytest.approx(dist[:, 1:].mean())
    with pytest.raises(ValueError, match=r"columns of distances minus 1\); got 5$"):
        mean_spacing(PTS, 5, distances=dist)

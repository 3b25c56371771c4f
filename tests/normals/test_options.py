"""Numeric options of the normals room: k counts the point itself, minimum <= k <= N."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.normals import estimate_normals, orient_normals, pca_normals

from .shapes import sphere

N = 50
NAN, INF = float("nan"), float("inf")


@pytest.fixture(scope="module")
def cloud():
    pts, nrm = sphere(N)
    return np.asarray(pts), np.asarray(nrm)


def _k_cases(lo: int):
    rng = rf"^k must be an integer in \[{lo}, {N}\] \(the number of points\); got "
    return [
        (lo - 1, ValueError, rng + f"{lo - 1}$"),
        (0, ValueError, rng + "0$"),
        (-2, ValueError, rng + "-2$"),
        (N + 1, ValueError, rng + f"{N + 1}$"),
        (100000, ValueError, rng + "100000$"),
        (True, TypeError, r"^k must be an integer; got bool True$"),
        (5.5, TypeError, r"^k must be an integer; got float 5\.5$"),
        (10.0, TypeError, r"^k must be an integer; got float 10\.0$"),
        (NAN, TypeError, r"^k must be an integer; got float nan$"),
        (INF, TypeError, r"^k must be an integer; got float inf$"),
    ]


@pytest.mark.parametrize(("value", "error", "match"), _k_cases(3))
@pytest.mark.parametrize("func", [estimate_normals, pca_normals])
def test_estimate_k(cloud, func, value, error, match):
    with pytest.raises(error, match=match):
        func(cloud[0], value)


@pytest.mark.parametrize("k", [3, N, np.int32(7)])
def test_estimate_k_boundaries(cloud, k):
    assert estimate_normals(cloud[0], k).shape == (N, 3)


def test_estimate_k_too_large_with_table(cloud):
    # the k <= N rule holds with a precomputed table too
    table = np.zeros((N, N + 5), dtype=np.int64)
    with pytest.raises(ValueError, match=r"k must be an integer in \[3, 50\]"):
        estimate_normals(cloud[0], N + 1, neighbors=table)


def test_estimate_too_few_points_message():
    with pytest.raises(ValueError, match=r"in \[3, 2\] \(the number of points\), which is empty"):
        estimate_normals(np.zeros((2, 3)), 3)


@pytest.mark.parametrize(("value", "error", "match"), _k_cases(2))
def test_orient_k(cloud, value, error, match):
    with pytest.raises(error, match=match):
        orient_normals(*cloud, k=value)


@pytest.mark.parametrize(
    ("value", "error", "match"),
    [
        (NAN, ValueError, r"^edge_penalty must be a finite number >= 0; got nan$"),
        (INF, ValueError, r"^edge_penalty must be a finite number >= 0; got inf$"),
        (-1e-3, ValueError, r"^edge_penalty must be a finite number >= 0; got -0\.001$"),
        (True, TypeError, r"^edge_penalty must be a real number; got bool True$"),
        ("1", TypeError, r"^edge_penalty must be a real number; got str '1'$"),
    ],
)
def test_orient_edge_penalty(cloud, value, error, match):
    with pytest.raises(error, match=match):
        orient_normals(*cloud, edge_penalty=value)


@pytest.mark.parametrize(("k", "edge_penalty"), [(2, 0.0), (N, 1.0), (np.int64(10), 1e6)])
def test_orient_boundaries(cloud, k, edge_penalty):
    out = orient_normals(*cloud, k=k, edge_penalty=edge_penalty)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", out, cloud[1])), 1.0, atol=1e-12)


def test_orient_viewpoint_ignores_k(cloud):
    out = orient_normals(*cloud, k=10**6, method="viewpoint", viewpoint=[0, 0, 0])
    assert out.shape == (N, 3)

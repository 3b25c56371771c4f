"""Numeric options of the segment room: finite, integral where counted, in range.

k counts the point itself: 1 <= k <= N (only k >= 1 when a neighbour table is given).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointatlas.neighbors import query_knn
from pointatlas.segment import (
    area_weights,
    estimate_eta,
    region_adjacency,
    region_growing,
    surface_curvature,
    vsa_segment,
)

N = 40
NAN, INF = float("nan"), float("inf")


@pytest.fixture(scope="module")
def cloud():
    """Two perpendicular 20-point grids (a floor and a wall) with exact normals."""
    floor = [[x, y, 0.0] for x in range(5) for y in range(4)]
    wall = [[x, 4.0, z] for x in range(5) for z in range(1, 5)]
    pts = np.array(floor + wall, dtype=np.float64)
    nrm = np.array([[0.0, 0.0, 1.0]] * 20 + [[0.0, 1.0, 0.0]] * 20)
    return pts, nrm


def _k_cases(lo: int):
    """(value, error, match) for a k with valid range [lo, N]."""
    rng = rf"^k must be an integer in \[{lo}, {N}\] \(the number of points\); got "
    return [
        (lo - 1, ValueError, rng + f"{lo - 1}$"),
        (-1, ValueError, rng + "-1$"),
        (N + 1, ValueError, rng + f"{N + 1}$"),
        (100000, ValueError, rng + "100000$"),
        (True, TypeError, r"^k must be an integer; got bool True$"),
        (2.5, TypeError, r"^k must be an integer; got float 2\.5$"),
        (8.0, TypeError, r"^k must be an integer; got float 8\.0$"),
        (NAN, TypeError, r"^k must be an integer; got float nan$"),
        (INF, TypeError, r"^k must be an integer; got float inf$"),
    ]


# ---------------------------------------------------------------- vsa_segment

_ANGLE = r"^max_angle must be a finite angle in \[0, pi\] radians; got "
# k < 1 and seeds < 1 are refused by VSAOptions, which does not know N
_BELOW_1 = [
    ({"k": 0}, ValueError, r"^k must be an integer >= 1; got 0$"),
    ({"k": -1}, ValueError, r"^k must be an integer >= 1; got -1$"),
    ({"seeds": 0}, ValueError, r"^seeds must be an integer >= 1; got 0$"),
]
VSA_BAD = [({"k": v}, e, m) for v, e, m in _k_cases(1) if not (isinstance(v, int) and v < 1)]
VSA_BAD += _BELOW_1 + [
    ({"eta": NAN}, ValueError, r"^eta must be a finite number >= 0; got nan$"),
    ({"eta": INF}, ValueError, r"^eta must be a finite number >= 0; got inf$"),
    ({"eta": -1.0}, ValueError, r"^eta must be a finite number >= 0; got -1\.0$"),
    ({"eta": True}, TypeError, r"^eta must be a real number; got bool True$"),
    ({"eta": "1"}, TypeError, r"^eta must be a real number; got str '1'$"),
    ({"max_angle": NAN}, ValueError, _ANGLE + "nan$"),
    ({"max_angle": -0.1}, ValueError, _ANGLE + r"-0\.1$"),
    ({"max_angle": 4.0}, ValueError, _ANGLE + r"4\.0$"),
    ({"max_angle": INF}, ValueError, _ANGLE + "inf$"),
    ({"max_iter": -1}, ValueError, r"^max_iter must be an integer >= 0; got -1$"),
    ({"max_iter": 10.0}, TypeError, r"^max_iter must be an integer; got float 10\.0$"),
    ({"max_iter": False}, TypeError, r"^max_iter must be an integer; got bool False$"),
    ({"seeds": N + 1}, ValueError, r"^seeds must be an integer in \[1, 40\].*; got 41$"),
]


@pytest.mark.parametrize(("kwargs", "error", "match"), VSA_BAD)
def test_vsa_segment_rejects(cloud, kwargs, error, match):
    pts, nrm = cloud
    with pytest.raises(error, match=match):
        vsa_segment(pts, nrm, **kwargs)


def test_vsa_segment_k_beyond_n_on_2000_points_raises():
    # `segment --k 100000` on 2,000 points used to run with k silently clamped
    rng = np.random.default_rng(0)
    pts = rng.random((2000, 3))
    nrm = np.tile([0.0, 0.0, 1.0], (2000, 1))
    with pytest.raises(
        ValueError,
        match=r"^k must be an integer in \[1, 2000\] \(the number of points\); got 100000$",
    ):
        vsa_segment(pts, nrm, k=100000)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"k": 1},
        {"k": N},
        {"k": np.int64(6)},
        {"k": 6, "eta": 0.0},
        {"k": 6, "max_angle": 0.0},
        {"k": 6, "max_angle": math.pi},
        {"k": 6, "max_iter": 0},
        {"k": 6, "seeds": 1, "rng": 0},
        {"k": 6, "seeds": N, "rng": 0},
    ],
)
def test_vsa_segment_accepts_boundaries(cloud, kwargs):
    pts, nrm = cloud
    res = vsa_segment(pts, nrm, **kwargs)
    assert res.labels.shape == (N,) and (res.labels >= 0).all()


def test_vsa_segment_k_with_given_neighbors_needs_only_k_at_least_1(cloud):
    pts, nrm = cloud
    table = query_knn(pts, 6)[0]
    res = vsa_segment(pts, nrm, k=1000, neighbors=table, eta=0.5)
    assert res.n_regions == 2
    with pytest.raises(ValueError, match=r"^k must be an integer >= 1; got 0$"):
        vsa_segment(pts, nrm, k=0, neighbors=table)


# ---------------------------------------------------------------- region_growing

_SMOOTH = r"^smoothness_angle must be a finite angle in \[0, pi\] radians; got "
RG_BAD = [({"k": v}, e, m) for v, e, m in _k_cases(1)] + [
    ({"smoothness_angle": NAN}, ValueError, _SMOOTH + "nan$"),
    ({"smoothness_angle": -1e-9}, ValueError, _SMOOTH + "-1e-09$"),
    ({"smoothness_angle": 3.5}, ValueError, _SMOOTH + r"3\.5$"),
    ({"smoothness_angle": True}, TypeError, r"^smoothness_angle must be a real number"),
    ({"curvature_threshold": NAN}, ValueError, r"^curvature_threshold must be a finite number"),
    ({"curvature_threshold": -INF}, ValueError, r"^curvature_threshold .*; got -inf$"),
    ({"min_cluster_size": 0}, ValueError, r"^min_cluster_size must be an integer >= 1; got 0$"),
    ({"min_cluster_size": -5}, ValueError, r"^min_cluster_size must be an integer >= 1"),
    ({"min_cluster_size": 2.5}, TypeError, r"^min_cluster_size must be an integer; got float"),
    ({"min_cluster_size": NAN}, TypeError, r"^min_cluster_size must be an integer; got float"),
    ({"min_cluster_size": True}, TypeError, r"^min_cluster_size must be an integer; got bool"),
    (
        {"min_cluster_size": 5, "max_cluster_size": 4},
        ValueError,
        r"^max_cluster_size must be an integer >= 5 \(>= min_cluster_size\); got 4$",
    ),
    ({"max_cluster_size": 3.0}, TypeError, r"^max_cluster_size must be an integer; got float"),
]


@pytest.mark.parametrize(("kwargs", "error", "match"), RG_BAD)
def test_region_growing_rejects(cloud, kwargs, error, match):
    pts, nrm = cloud
    with pytest.raises(error, match=match):
        region_growing(pts, nrm, **kwargs)


@pytest.mark.parametrize("min_cluster_size", [N + 1, 100000])
def test_region_growing_min_cluster_size_above_n_leaves_all_unassigned(cloud, min_cluster_size):
    # used to leak numpy's "Cannot cast ufunc 'divide' output" error
    pts, nrm = cloud
    res = region_growing(pts, nrm, k=6, min_cluster_size=min_cluster_size)
    assert res.n_regions == 0 and res.assigned_fraction == 0.0
    assert (res.labels == -1).all() and math.isnan(res.mse)
    assert res.proxy_normals.shape == (0, 3) and res.proxy_normals.dtype == np.float64
    assert res.centroids.shape == (0, 3) and res.centroids.dtype == np.float64
    assert res.region_l21.dtype == np.float64 and res.region_counts.dtype == np.int64


@pytest.mark.parametrize(
    "kwargs",
    [
        {"k": 1},
        {"k": N},
        {"k": 6, "smoothness_angle": 0.0},
        {"k": 6, "smoothness_angle": math.pi},
        {"k": 6, "curvature_threshold": -1.0},
        {"k": 6, "min_cluster_size": N},
        {"k": 6, "min_cluster_size": 20, "max_cluster_size": 20},
    ],
)
def test_region_growing_accepts_boundaries(cloud, kwargs):
    pts, nrm = cloud
    res = region_growing(pts, nrm, **kwargs)
    assert res.labels.shape == (N,)


def test_region_growing_rejects_out_of_range_neighbor_table(cloud):
    # indices >= N would be read out of bounds by the kernel
    pts, nrm = cloud
    table = query_knn(pts, 6)[0]
    table[3, 2] = N
    with pytest.raises(ValueError, match=r"^neighbors must index points < 40; got range 0\.\.40$"):
        region_growing(pts, nrm, neighbors=table)
    table[3, 2] = -1
    with pytest.raises(
        ValueError, match=r"^neighbors must index points 0\.\.39; got range -1\.\.39$"
    ):
        surface_curvature(pts, neighbors=table)


# ---------------------------------------------------------------- k of the helpers


@pytest.mark.parametrize(("value", "error", "match"), _k_cases(1))
@pytest.mark.parametrize("func", ["area_weights", "surface_curvature", "region_adjacency"])
def test_k_of_graph_helpers(cloud, func, value, error, match):
    pts, _ = cloud
    calls = {
        "area_weights": lambda: area_weights(pts, k=value),
        "surface_curvature": lambda: surface_curvature(pts, k=value),
        "region_adjacency": lambda: region_adjacency(pts, np.zeros(N, dtype=int), k=value),
    }
    with pytest.raises(error, match=match):
        calls[func]()


def test_k_of_graph_helpers_boundaries(cloud):
    pts, _ = cloud
    assert area_weights(pts, k=1).tolist() == [0.0] * N
    assert surface_curvature(pts, k=N).shape == (N,)
    assert region_adjacency(pts, np.arange(N) // 20, k=N).tolist() == [[0, 1]]


# ---------------------------------------------------------------- estimate_eta


@pytest.mark.parametrize(
    ("args", "kwargs", "error", "match"),
    [
        ((NAN, 10), {}, ValueError, r"^mean_curvature must be a finite number >= 0; got nan$"),
        ((INF, 10), {}, ValueError, r"^mean_curvature must be a finite number >= 0; got inf$"),
        ((-1.0, 10), {}, ValueError, r"^mean_curvature must be a finite number >= 0"),
        ((True, 10), {}, TypeError, r"^mean_curvature must be a real number; got bool"),
        ((1.0, 0), {}, ValueError, r"^n_points must be an integer >= 1; got 0$"),
        ((1.0, 10.0), {}, TypeError, r"^n_points must be an integer; got float 10\.0$"),
        ((1.0, True), {}, TypeError, r"^n_points must be an integer; got bool True$"),
        ((1.0, 10), {"curvature_split": NAN}, ValueError, r"^curvature_split .*1\]; got nan$"),
        ((1.0, 10), {"curvature_split": 1.5}, ValueError, r"^curvature_split .*; got 1\.5$"),
        ((1.0, 10), {"curvature_split": -0.1}, ValueError, r"^curvature_split .*; got -0\.1$"),
    ],
)
def test_estimate_eta_rejects(args, kwargs, error, match):
    with pytest.raises(error, match=match):
        estimate_eta(*args, **kwargs)


def test_estimate_eta_boundaries():
    assert estimate_eta(0.0, 1) == 0.0
    assert estimate_eta(2.0, 50, curvature_split=0.0) > 0.0
    assert estimate_eta(2.0, 50, curvature_split=1.0) > 0.0

"""query_knn / NeighborIndex.knn against the brute-force reference."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas._core import PointAtlasError
from pointatlas.neighbors import NeighborIndex, query_knn
from pointatlas.neighbors._grid import group_queries, knn_grid_for

from ..strategies import random_clouds, seeds
from .reference import knn_reference

BACKENDS = ["auto", "grid", "kdtree"]


def _cloud(name: str) -> np.ndarray:
    rng = np.random.default_rng(7)
    if name == "random":
        return rng.random((400, 3))
    if name == "grid":
        # integer lattice: massive exact ties (6 at distance 1, 12 at sqrt 2, ...)
        g = np.arange(7.0)
        return np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    if name == "duplicates":
        # 12 sites with 30 exact copies each (more copies than k), shuffled
        sites = rng.random((12, 3))
        return np.repeat(sites, 30, axis=0)[rng.permutation(360)]
    if name == "plane":
        # a 2-manifold: most cells of a 3-D grid are empty
        return np.c_[rng.random((300, 2)), np.zeros(300)]
    if name == "line":
        # extreme anisotropy: 1e6 long, 1e-3 thick
        return np.c_[rng.random(200) * 1e6, rng.random((200, 2)) * 1e-3]
    if name == "clusters":
        # a dense cluster, a sparse halo and far outliers
        return np.concatenate(
            [rng.normal(scale=1e-3, size=(250, 3)), rng.random((100, 3)), [[50, 0, 0], [0, 80, 1]]]
        )
    raise KeyError(name)


CLOUDS = ["random", "grid", "duplicates", "plane", "line", "clusters"]


@cache
def _reference(name: str, k: int):
    return knn_reference(_cloud(name), k)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", CLOUDS)
@pytest.mark.parametrize("k", [1, 2, 7, 20])
def test_knn_matches_reference(name, k, backend):
    pts = _cloud(name)
    ref_idx, ref_dist = _reference(name, k)
    idx, dist = query_knn(pts, k, backend=backend)
    assert idx.dtype == np.int64 and idx.shape == (len(pts), k)
    assert dist.dtype == np.float64 and dist.shape == (len(pts), k)
    np.testing.assert_array_equal(idx, ref_idx)
    np.testing.assert_array_equal(dist, ref_dist)


@pytest.mark.parametrize("backend", BACKENDS)
def test_k_equals_n(backend):
    pts = _cloud("random")[:60]
    ref_idx, ref_dist = knn_reference(pts, 60)
    idx, dist = query_knn(pts, 60, backend=backend)
    np.testing.assert_array_equal(idx, ref_idx)
    np.testing.assert_array_equal(dist, ref_dist)
    # every row is a permutation of all points
    np.testing.assert_array_equal(np.sort(idx, axis=1), np.broadcast_to(np.arange(60), (60, 60)))


@pytest.mark.parametrize("backend", BACKENDS)
def test_self_first_even_with_duplicates(backend):
    pts = np.zeros((25, 3))
    idx, dist = query_knn(pts, 5, backend=backend)
    assert (idx[:, 0] == np.arange(25)).all()
    assert (dist == 0).all()
    # the others are the smallest indices except itself
    assert idx[0, 1:].tolist() == [1, 2, 3, 4]
    assert idx[3, 1:].tolist() == [0, 1, 2, 4]
    assert idx[24, 1:].tolist() == [0, 1, 2, 3]


def test_grid_ties_smaller_index_wins():
    pts = _cloud("grid")
    idx, dist = query_knn(pts, 7)
    centre = 3 * 49 + 3 * 7 + 3  # (3, 3, 3): six neighbours at distance 1
    expected = sorted(centre + d for d in (-49, -7, -1, 1, 7, 49))
    assert idx[centre].tolist() == [centre, *expected]
    assert dist[centre].tolist() == [0.0] + [1.0] * 6
    # corner (0,0,0): 3 at distance 1, then the 3 at sqrt(2) by index: (0,1,1), (1,0,1), (1,1,0)
    assert idx[0].tolist() == [0, 1, 7, 49, 8, 50, 56]


@pytest.mark.parametrize("backend", BACKENDS)
def test_too_few_points(backend):
    with pytest.raises(PointAtlasError, match=r"k must be an integer in \[1, 3\] \(the number"):
        query_knn(np.zeros((3, 3)), 4, backend=backend)


def test_single_point():
    idx, dist = query_knn([[1.0, 2.0, 3.0]], 1)
    assert idx.tolist() == [[0]] and dist.tolist() == [[0.0]]
    with pytest.raises(PointAtlasError, match=r"k must be an integer in \[1, 1\]"):
        query_knn([[1.0, 2.0, 3.0]], 2)


def test_nan_raises_value_error():
    pts = np.random.default_rng(0).random((20, 3))
    pts[4, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        query_knn(pts, 3)


@pytest.mark.parametrize(
    ("k", "exc", "match"),
    [
        (0, ValueError, r"k must be an integer in \[1, 5\]"),
        (2.5, TypeError, "k must be an integer"),
        (True, TypeError, "k must be an integer"),
    ],
)
def test_bad_k(k, exc, match):
    with pytest.raises(exc, match=match):
        query_knn(np.zeros((5, 3)), k)


def test_bad_backend():
    with pytest.raises(ValueError, match="backend must be one of"):
        query_knn(np.zeros((5, 3)), 2, backend="octree")


def test_bad_shape():
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        query_knn(np.zeros((5, 2)), 2)


def test_input_not_modified():
    pts = np.random.default_rng(3).random((50, 3)) + 10.0
    before = pts.copy()
    query_knn(pts, 5)
    np.testing.assert_array_equal(pts, before)


def test_auto_hands_far_outliers_to_kdtree(monkeypatch):
    pts = _cloud("clusters")
    calls = []
    original = NeighborIndex._knn_kdtree

    def spy(self, rows, k):
        calls.append(rows.copy())
        return original(self, rows, k)

    monkeypatch.setattr(NeighborIndex, "_knn_kdtree", spy)
    idx, dist = query_knn(pts, 12)
    ref_idx, ref_dist = _reference("clusters", 12)
    np.testing.assert_array_equal(idx, ref_idx)
    np.testing.assert_array_equal(dist, ref_dist)
    assert len(calls) == 1
    assert {350, 351} <= set(calls[0].tolist())  # the far outliers went to the tree
    assert calls[0].size < len(pts) // 2  # the bulk stayed on the grid


@pytest.mark.parametrize("n_brute", [0, 64])
def test_far_path_scan_and_tree_agree(monkeypatch, n_brute):
    # the queries the grid leaves go to a scan of all points (a few) or the k-d tree
    import pointatlas.neighbors._knn as knn_module

    monkeypatch.setattr(knn_module, "_BRUTE_ROWS", n_brute)
    rng = np.random.default_rng(11)
    pts = np.concatenate([rng.random((2000, 3)), (rng.random((40, 3)) - 0.5) * 1e4])
    pts = np.concatenate([pts, pts[-5:]])  # far duplicates: ties at the k-th place
    ref_idx, ref_dist = knn_reference(pts, 9)
    for backend in ("auto", "grid"):
        idx, dist = query_knn(pts, 9, backend=backend)
        np.testing.assert_array_equal(idx, ref_idx)
        np.testing.assert_array_equal(dist, ref_dist)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", CLOUDS)
def test_rows_are_the_full_query_rows(name, backend):
    pts = _cloud(name)
    index = NeighborIndex(pts, backend=backend)
    rng = np.random.default_rng(len(pts))
    for k in (1, 5, 20):
        full_idx, full_dist = index.knn(k)
        for rows in (
            rng.permutation(len(pts))[: len(pts) // 3],
            rng.integers(0, len(pts), 50),
            np.arange(len(pts)),
            np.array([len(pts) - 1, 0, 0]),
        ):
            idx, dist = index.knn(k, rows=rows)
            assert idx.shape == (len(rows), k) and dist.shape == (len(rows), k)
            assert idx.dtype == np.int64 and dist.dtype == np.float64
            np.testing.assert_array_equal(idx, full_idx[rows])
            np.testing.assert_array_equal(dist, full_dist[rows])


def test_rows_on_a_lidar_like_scan():
    # ground with mm-quantised coordinates (ties), walls and sparse vegetation
    rng = np.random.default_rng(2)
    ground = np.c_[rng.random((6000, 2)) * 40.0, rng.normal(0, 0.02, 6000)]
    wall = np.c_[rng.random(1500) * 40.0, np.full(1500, 20.0), rng.random(1500) * 8.0]
    veg = np.c_[rng.random((300, 2)) * 40.0, 0.5 + rng.random(300) * 9.5]
    pts = np.round(np.concatenate([ground, wall, veg]) * 1000.0) / 1000.0
    ref_idx, ref_dist = knn_reference(pts, 20)
    index = NeighborIndex(pts)
    idx, dist = index.knn(20)
    np.testing.assert_array_equal(idx, ref_idx)
    np.testing.assert_array_equal(dist, ref_dist)
    rows = np.flatnonzero(pts[:, 0] < 13.0)[::-1]
    idx, dist = index.knn(20, rows=rows)
    np.testing.assert_array_equal(idx, ref_idx[rows])
    np.testing.assert_array_equal(dist, ref_dist[rows])


def _group_queries_reference(grid, queries):
    """The former numpy grouping: a stable argsort of the queries' cell-order positions."""
    pos_of = np.empty(grid.ids.size, dtype=np.int64)
    pos_of[grid.ids] = np.arange(grid.ids.size)
    qp = pos_of[queries]
    qout = np.argsort(qp, kind="stable")
    qpos = qp[qout]
    cell = np.searchsorted(grid.cstart, qpos, side="right") - 1
    first = np.flatnonzero(np.r_[True, cell[1:] != cell[:-1]]) if cell.size else cell
    return cell[first], np.append(first, cell.size), qpos, qout


@pytest.mark.parametrize("name", CLOUDS)
def test_group_queries_is_a_stable_sort_by_cell(name):
    pts = _cloud(name)
    grid = knn_grid_for(NeighborIndex(pts).points_, 7)
    rng = np.random.default_rng(3)
    n = len(pts)
    for queries in (
        np.arange(n),
        rng.permutation(n)[: n // 2],
        rng.integers(0, n, 3 * n),
        np.array([n - 1, 0, 0, n - 1]),
        np.empty(0, dtype=np.int64),
    ):
        got = group_queries(grid, queries)
        for a, b in zip(got, _group_queries_reference(grid, queries), strict=True):
            assert a.dtype == np.int64
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    ("rows", "exc", "match"),
    [
        ([0.5, 1.0], TypeError, "rows must be an array of integer indices"),
        ([True, False], TypeError, "rows must be an array of integer indices"),
        ([[0, 1]], ValueError, "rows must be one-dimensional"),
        ([0, 5], ValueError, r"rows must be indices in \[0, 5\); got 1 outside, e.g. 5"),
        ([-1], ValueError, r"rows must be indices in \[0, 5\)"),
    ],
)
def test_bad_rows(rows, exc, match):
    with pytest.raises(exc, match=match):
        NeighborIndex(np.random.default_rng(0).random((5, 3))).knn(2, rows=rows)


def test_empty_rows():
    idx, dist = NeighborIndex(np.random.default_rng(0).random((30, 3))).knn(4, rows=[])
    assert idx.shape == (0, 4) and dist.shape == (0, 4) and idx.dtype == np.int64


def test_index_reused_for_several_k():
    pts = _cloud("random")
    index = NeighborIndex(pts)
    assert index.n_points == len(pts)
    idx5, _ = index.knn(5)
    idx9, _ = index.knn(9)
    np.testing.assert_array_equal(idx9[:, :5], idx5)


@settings(max_examples=15, deadline=None)
@given(random_clouds(min_points=20, max_points=150), seeds(), st.integers(2, 15))
def test_permutation_equivariance(pts, seed, k):
    perm = np.random.default_rng(seed).permutation(len(pts))
    idx, dist = query_knn(pts, k)
    idx_p, dist_p = query_knn(pts[perm], k)
    # row r of the permuted query is the original point perm[r]
    assert (perm[idx_p[:, 0]] == perm).all()
    for r in range(len(pts)):
        assert set(perm[idx_p[r]].tolist()) == set(idx[perm[r]].tolist())
    np.testing.assert_array_equal(dist_p, dist[perm])


@settings(max_examples=15, deadline=None)
@given(random_clouds(min_points=20, max_points=150), st.integers(2, 15))
def test_translation_invariance(pts, k):
    idx, dist = query_knn(pts, k)
    idx_s, dist_s = query_knn(pts + np.array([1e6, -2e6, 5e5]), k)
    np.testing.assert_array_equal(idx_s, idx)
    np.testing.assert_allclose(dist_s, dist, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 500), st.integers(0, 2**32 - 1))
def test_bounds_kernel_matches_numpy(n, seed):
    from pointatlas.neighbors._kernels import bounds

    pts = np.random.default_rng(seed).normal(size=(n, 3)) * 10.0 ** (seed % 7 - 3)
    lo, hi = bounds(pts)
    np.testing.assert_array_equal(lo, pts.min(axis=0))
    np.testing.assert_array_equal(hi, pts.max(axis=0))


@pytest.mark.parametrize("backend", ["grid", "kdtree"])
def test_index_over_a_part_with_the_whole_centre_gives_the_whole_distances(backend):
    # a part of a cloud, indexed with the centre of the whole cloud: wherever its rows
    # are the whole set's rows, the distances are equal bit for bit (centred on its own
    # box, most of them differ in the last bits)
    rng = np.random.default_rng(5)
    pts = rng.random((3000, 3)) * [40.0, 30.0, 5.0] - [3.0, 7.0, 1.0]
    whole = NeighborIndex(pts, backend=backend)
    part = np.flatnonzero(pts[:, 0] < 17.0)
    own = NeighborIndex(pts[part], backend=backend, center=whole.center_)
    np.testing.assert_array_equal(own.center_, whole.center_)
    np.testing.assert_array_equal(own.points_, pts[part] - whole.center_)
    t_whole, d_whole = whole.knn(8)
    t_part, d_part = own.knn(8)
    same = (part[t_part] == t_whole[part]).all(axis=1)
    assert same.mean() > 0.9
    np.testing.assert_array_equal(d_part[same], d_whole[part][same])
    _, d_own_centre = NeighborIndex(pts[part], backend=backend).knn(8)
    assert (d_own_centre[same] != d_whole[part][same]).any(axis=1).mean() > 0.3
    with pytest.raises(ValueError, match="center must be 3 finite numbers"):
        NeighborIndex(pts, center=[0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="center must be 3 finite numbers"):
        NeighborIndex(pts, center=[0.0, 0.0])


def _blob_with_far_points(n=3000, seed=0):
    """A dense blob (extent 1e-9) and five points 1e3 away: no int64 grid resolves it."""
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3)) * 1e-9
    pts[:5] = rng.random((5, 3)) * 1e3
    return pts


def test_auto_takes_the_tree_where_the_grid_cannot_refine():
    from pointatlas.neighbors._grid import grid_too_coarse, knn_grid_for, knn_target

    pts = _blob_with_far_points()
    centred = pts - 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    assert grid_too_coarse(knn_grid_for(centred, 20), 32.0 * knn_target(20))
    auto = query_knn(pts, 20)
    tree = query_knn(pts, 20, backend="kdtree")
    grid = query_knn(pts, 20, backend="grid")
    for a, b in zip(auto, tree, strict=True):
        assert np.array_equal(a, b)
    for a, b in zip(auto, grid, strict=True):
        assert np.array_equal(a, b)


def test_exact_duplicates_stay_on_the_grid():
    from pointatlas.neighbors._grid import grid_too_coarse, knn_grid_for, knn_target

    rng = np.random.default_rng(1)
    pts = rng.random((3000, 3))
    pts[:1500] = 0.5  # half the points at one position: the grid's case, not the tree's
    centred = pts - 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    assert not grid_too_coarse(knn_grid_for(centred, 20), 32.0 * knn_target(20))
    auto = query_knn(pts, 20)
    tree = query_knn(pts, 20, backend="kdtree")
    for a, b in zip(auto, tree, strict=True):
        assert np.array_equal(a, b)


def test_kdtree_holds_each_position_once():
    # 30,000 copies of one point: one tree entry, so every query takes k candidates
    # of it (the copies' selection was quadratic in their number); same rows as the
    # grid and the reference's order (ties by index)
    rng = np.random.default_rng(3)
    pts = np.concatenate([np.zeros((30_000, 3)), rng.random((500, 3)), np.zeros((7, 3))])
    index = NeighborIndex(pts, backend="kdtree")
    tree, gptr, gmem = index._tree_entries()
    assert tree.n == gptr.size - 1 == 501
    assert np.array_equal(np.sort(gmem), np.arange(pts.shape[0]))
    for k in (2, 20):
        got = index.knn(k)
        grid = query_knn(pts, k, backend="grid")
        for a, b in zip(got, grid, strict=True):
            assert np.array_equal(a, b)
    rows = np.array([30_500, 0, 29_999, 30_506])
    got_idx, _ = index.knn(20, rows=rows)
    assert got_idx[1].tolist() == list(range(20))  # a copy's neighbours: the first copies
    assert got_idx[2].tolist() == [29_999, *range(19)]
    assert np.array_equal(got_idx, grid[0][rows])

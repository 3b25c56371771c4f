"""The grid k-NN of the robust path (`_grid_knn.GridKnn`): the k-d tree's answer,
distances bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pointatlas.simplify._grid_knn import GridKnn
from pointatlas.synth import sample_mesh
from tests.jit_off import JIT_OFF, run_module_without_jit

from .cad_shapes import cube_with_square_hole, l_bracket


def _lattice_band(p, step, width=3):
    """The grid nodes within ``width`` steps of the points' cells (as the field's band)."""
    origin = p.min(axis=0) - (width + 2) * step
    cells = np.unique(np.floor((p - origin) / step).astype(np.int64), axis=0)
    offsets = np.stack(np.meshgrid(*[np.arange(-width, width + 1)] * 3, indexing="ij"), -1).reshape(
        -1, 3
    )
    nodes = np.unique((cells[:, None, :] + offsets[None, :, :]).reshape(-1, 3), axis=0)
    return origin + nodes * step


@pytest.mark.parametrize("shape", [cube_with_square_hole, l_bracket])
@pytest.mark.parametrize("k", [1, 8, 16])
def test_matches_the_kdtree_on_band_nodes_of_sampled_shapes(shape, k):
    v, t = shape()
    p = np.asarray(sample_mesh(v, t, 3000, rng=0).points)
    step = 1.5 * float(np.median(cKDTree(p).query(p, k=2)[0][:, 1]))
    x = _lattice_band(p, step)
    d0, j0 = cKDTree(p).query(x, k=k)
    d, j = GridKnn(p, 2.0 * step).query(x, k)
    assert d.shape == j.shape == (x.shape[0], k) and j.dtype == np.int64
    assert np.array_equal(d, d0.reshape(d.shape)) and np.array_equal(j, j0.reshape(j.shape))


def _assert_as_kdtree(p, x, cells, ks):
    for cell in cells:
        for k in ks:
            d0, j0 = cKDTree(p).query(x, k=k)
            d, j = GridKnn(p, cell).query(x, k)
            assert np.array_equal(d, d0.reshape(d.shape))
            assert np.array_equal(j, j0.reshape(j.shape))


@pytest.mark.parametrize("cell", [1e-4, 0.05, 0.3, 5.0])
def test_matches_the_kdtree_anywhere_and_at_any_cell_size(cell):
    # queries inside the cells, far outside on every side, and on the points; cells
    # from far too small (capped) to one cell for all
    rng = np.random.default_rng(4)
    p = rng.normal(size=(80, 3)) * [1.0, 0.5, 0.1]
    x = np.vstack([rng.normal(size=(40, 3)) * 3.0, p[:10], [[40.0, -40.0, 3.0]]])
    _assert_as_kdtree(p, x, [cell], (1, 6, 80))


def test_few_points_match_the_kdtree():
    # the kernel's branches on a small input (also run with the JIT off): rows inside,
    # outside and on the points, rings to the grid's end, k up to every point
    rng = np.random.default_rng(5)
    p = rng.normal(size=(30, 3))
    x = np.vstack([rng.normal(size=(12, 3)) * 2.0, p[:3], [[9.0, -9.0, 1.0]]])
    _assert_as_kdtree(p, x, (0.4, 5.0), (1, 4, 30))


def test_a_far_outlier_goes_to_the_tree():
    # 500 points in a unit box and one a million units away: cells of 0.1 would be
    # 10^21; grown to fit they would hold every point, so the tree answers
    rng = np.random.default_rng(7)
    p = np.vstack([rng.random((500, 3)), [[1e6, 0.0, 0.0]]])
    grid = GridKnn(p, 0.1)
    assert grid.tree is not None and GridKnn(p[:500], 0.1).tree is None
    _assert_as_kdtree(p, rng.random((30, 3)), (0.1,), (1, 8))


def test_far_from_the_origin():
    # map coordinates (5e6 units away, a spacing of 1e-4): the cells' bounds are
    # rounded to the coordinates' last place, which the search's margin covers
    rng = np.random.default_rng(6)
    p = 5e6 + rng.random((400, 3)) * [2e-3, 2e-3, 1e-5]
    x = np.vstack([p[:50] + rng.normal(size=(50, 3)) * 1e-4, p[50:60]])
    _assert_as_kdtree(p, x, (1e-4, 3e-4), (1, 8))


def test_repeated_points_come_by_index_at_the_tree_distances():
    # exact duplicates: the k-d tree's order among them is not defined; here the
    # smaller index first, at the same distances
    rng = np.random.default_rng(1)
    p = rng.random((40, 3))
    p = np.vstack([p, p[::-1], p[::3]])
    x = rng.random((60, 3))
    d0, _ = cKDTree(p).query(x, k=8)
    d, j = GridKnn(p, 0.1).query(x, 8)
    assert np.array_equal(d, d0)
    e = x[:, None, :] - p[j]
    assert np.array_equal(d, np.sqrt(((0.0 + e[..., 0] ** 2) + e[..., 1] ** 2) + e[..., 2] ** 2))
    tie = d[:, 1:] == d[:, :-1]
    assert tie.any() and (j[:, 1:][tie] > j[:, :-1][tie]).all()


def test_one_point_and_no_extent():
    p = np.zeros((3, 3))
    d, j = GridKnn(p, 0.0).query(np.array([[1.0, 0, 0], [0, 0, 0]]), 3)
    assert j.tolist() == [[0, 1, 2], [0, 1, 2]] and d[0].tolist() == [1.0] * 3


@pytest.mark.parametrize("cell", [0.01, 0.03, 0.2])
def test_farther_than_is_never_wrong_and_tells_the_far_queries(cell):
    # a thin sheet and queries all over a box twice its size (many far from it)
    rng = np.random.default_rng(3)
    p = rng.random((4000, 3)) * [1.0, 1.0, 0.01]
    x = rng.random((50000, 3)) * 2.0 - 0.5
    d0 = cKDTree(p).query(x)[0]
    g = GridKnn(p, cell)
    for dist in (0.0, 0.05, 0.1, 0.4):
        far = g.farther_than(x, dist)
        assert not (d0[far] <= dist).any()  # never a row within dist
        # a row D cells (Chebyshev) from every point's cell is within (D + 1)
        # cell diagonals of a point: those farther than this are all told
        surely = d0 > np.sqrt(3.0) * (dist + 2.0 * g.h + g.margin)
        assert surely.any() and far[surely].all()


def test_farther_than_says_nothing_where_the_tree_answers():
    p = np.vstack([np.random.default_rng(5).random((200, 3)), [[1e6, 0, 0]]])
    g = GridKnn(p, 0.05)
    assert g.tree is not None and not g.farther_than(p + 10.0, 0.0).any()


def test_nearest_of_some_rows():
    rng = np.random.default_rng(4)
    p, x = rng.random((500, 3)), rng.random((300, 3)) * 3.0 - 1.0
    g = GridKnn(p, 0.1)
    d0, j0 = cKDTree(p).query(x)
    rows = rng.random(300) < 0.4
    for asked in (rows, np.flatnonzero(rows)):
        d, j = g.nearest_of(x, asked)
        assert np.array_equal(d[rows], d0[rows]) and np.array_equal(j[rows], j0[rows])
        assert np.isinf(d[~rows]).all() and (j[~rows] == 0).all()


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="few_points or repeated or no_extent")

"""knn_graph, knn_components and mean_spacing."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse

from pointatlas.neighbors import knn_components, knn_graph, mean_spacing, query_knn

from .reference import components_reference, graph_reference, squared_distances


def _cloud():
    rng = np.random.default_rng(5)
    return rng.random((300, 3))


@pytest.mark.parametrize("symmetric", [True, False])
@pytest.mark.parametrize("k", [2, 6, 15])
def test_graph_matches_reference(symmetric, k):
    pts = _cloud()
    idx, _ = query_knn(pts, k)
    g = knn_graph(pts, k, symmetric=symmetric)
    assert isinstance(g, sparse.csr_array) and g.shape == (300, 300)
    assert g.indices.dtype.kind == "i" and g.data.dtype == np.float64
    adj = np.zeros((300, 300), dtype=bool)
    rows = np.repeat(np.arange(300), np.diff(g.indptr))
    adj[rows, g.indices] = True
    np.testing.assert_array_equal(adj, graph_reference(idx, symmetric))
    # columns sorted and unique in every row; no self loops
    for i in range(300):
        cols = g.indices[g.indptr[i] : g.indptr[i + 1]]
        assert (np.diff(cols) > 0).all() and i not in cols
    np.testing.assert_allclose(g.data, np.sqrt(squared_distances(pts)[rows, g.indices]))


def test_symmetric_structure():
    g = knn_graph(_cloud(), 8)
    s = sparse.csr_array((np.ones_like(g.data), g.indices, g.indptr), shape=g.shape)
    assert (s != s.T).nnz == 0
    np.testing.assert_array_equal(g.toarray(), g.toarray().T)


def test_duplicates_stored_as_explicit_zeros():
    pts = np.array([[0.0, 0, 0], [0, 0, 0], [1, 0, 0], [5, 0, 0]])
    g = knn_graph(pts, 2)
    # 2's nearest other is 0 (tie with 1, smaller index), so 0 ~ 1 and 0 ~ 2
    assert g.indices[g.indptr[0] : g.indptr[1]].tolist() == [1, 2]
    assert g.data[g.indptr[0]] == 0.0  # explicit zero kept in the structure
    assert g.nnz == 6


def test_graph_precomputed_neighbors():
    pts = _cloud()
    idx, _ = query_knn(pts, 6)
    a = knn_graph(pts, 6)
    b = knn_graph(pts, 6, neighbors=idx)
    np.testing.assert_array_equal(a.indptr, b.indptr)
    np.testing.assert_array_equal(a.indices, b.indices)
    with pytest.raises(ValueError, match="neighbors must have shape"):
        knn_graph(pts, 6, neighbors=idx[:10])
    with pytest.raises(ValueError, match=r"neighbors must index points 0\.\.299; got range"):
        knn_graph(pts, 6, neighbors=idx + 1000)


def test_components_of_disconnected_clusters():
    rng = np.random.default_rng(2)
    centres = np.array([[0.0, 0, 0], [100, 0, 0], [0, 100, 0]])
    labels_true = rng.permutation(np.repeat([0, 1, 2], 60))
    pts = centres[labels_true] + rng.random((180, 3))
    n, labels = knn_components(pts, 6)
    assert n == 3
    assert labels.dtype == np.int64 and labels.shape == (180,)
    # numbered by first occurrence and equal to the true partition
    first = [labels_true[0]]
    for t in labels_true:
        if t not in first:
            first.append(t)
    np.testing.assert_array_equal(labels, np.argsort(first)[labels_true])
    idx, _ = query_knn(pts, 6)
    np.testing.assert_array_equal(labels, components_reference(graph_reference(idx, True)))


def test_components_chain():
    pts = np.c_[np.r_[np.arange(10.0), np.arange(10.0) + 100], np.zeros((20, 2))]
    n, labels = knn_components(pts, 2)
    assert n == 2 and labels.tolist() == [0] * 10 + [1] * 10


def test_mean_spacing_on_a_line():
    # points 0, 1, ..., 9 on a line: interior points have both neighbours at 1,
    # the ends have 1 and 2, so l = (8 * 1 + 2 * 1.5) / 10 = 1.1
    pts = np.c_[np.arange(10.0), np.zeros((10, 2))]
    assert mean_spacing(pts, k=2) == pytest.approx(1.1, abs=1e-15)
    assert mean_spacing(pts, k=1) == pytest.approx(1.0, abs=1e-15)


def test_mean_spacing_cubic_lattice_and_precomputed():
    g = np.arange(5.0) * 0.5
    pts = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    _, dist = query_knn(pts, 13)
    assert mean_spacing(pts, distances=dist) == mean_spacing(pts)
    d2 = squared_distances(pts)
    np.fill_diagonal(d2, np.inf)
    expected = np.mean(np.sort(np.sqrt(d2), axis=1)[:, :12])
    assert mean_spacing(pts) == pytest.approx(expected, rel=1e-14)

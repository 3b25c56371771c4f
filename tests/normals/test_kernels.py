"""numba kernels against the plain-numpy references in reference.py."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from scipy import sparse

from pointatlas.neighbors import query_knn
from pointatlas.normals import orient_normals
from pointatlas.normals._kernels import (
    component_tops_kernel,
    pca_normals_kernel,
    propagate_signs_kernel,
    riemannian_graph_kernel,
    sym3_eigen,
)
from tests.jit_off import run_without_jit

from . import reference
from .shapes import random_flips, sphere, torus


def _eigen(a):
    v = np.empty((3, 3))
    w = np.empty(3)
    sym3_eigen(np.array(a, dtype=np.float64), v, w)
    return w, v


def _random_sym(rng, eigvals):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return (q * eigvals) @ q.T


@pytest.mark.parametrize(
    "eigvals",
    [
        (3.0, 2.0, 1.0),
        (1.0, 1e-3, 1e-9),  # thin strip, very flat
        (1.0, 1.0, 1e-6),  # isotropic disc
        (1.0, 1e-8 * (1 + 1e-6), 1e-8),  # needle: lambda_2 ~ lambda_3
        (1.0, 1.0, 1.0),
        (1e-250, 5e-251, 1e-252),  # tiny scale, no underflow
        (1e250, 5e249, 1e248),  # huge scale, no overflow
        (0.0, 0.0, 0.0),
    ],
)
def test_sym3_eigen_matches_eigh(eigvals):
    rng = np.random.default_rng(7)
    for _ in range(20):
        a = _random_sym(rng, np.array(eigvals))
        w, v = _eigen(a)
        w_ref, v_ref = np.linalg.eigh(a)
        scale = max(abs(eigvals[0]), 1e-300)
        assert np.all(np.diff(w) <= 0)
        assert np.allclose(w, w_ref[::-1], rtol=0, atol=1e-13 * scale)
        assert np.allclose(v.T @ v, np.eye(3), atol=1e-13)
        # residual of every eigenpair
        assert np.abs(a @ v - v * w).max() <= 1e-13 * scale
        gap = (eigvals[1] - eigvals[2]) / scale
        if gap > 1e-6:
            # smallest eigenvector is determined: agrees with eigh up to sign
            assert 1.0 - abs(v[:, 2] @ v_ref[:, 0]) < 1e-12 / gap**2 + 1e-15
        elif eigvals[0] > eigvals[1] * (1 + 1e-3):
            # cluster {lambda_2, lambda_3}: v_3 stays orthogonal to the largest axis
            assert abs(v[:, 2] @ v_ref[:, 2]) < 1e-12


def _run_pca_kernel(points, indices, k):
    n = indices.shape[0]
    normals = np.empty((n, 3))
    eig = np.empty((n, 3))
    deg = np.empty(n, dtype=bool)
    pca_normals_kernel(points, indices, k, reference.DEGENERATE_RATIO, normals, eig, deg)
    return normals, eig, deg


def _compare_pca(points, indices, k):
    normals, eig, deg = _run_pca_kernel(points, indices, k)
    n_ref, eig_ref, deg_ref = reference.pca_normals_reference(points, indices, k)
    scale = max(eig_ref[:, 0].max(initial=0.0), 1e-300)
    assert np.allclose(eig, eig_ref, rtol=0, atol=1e-12 * scale)
    assert np.array_equal(deg, deg_ref)
    ok = ~deg
    gap = (eig_ref[:, 1] - eig_ref[:, 2]) / np.maximum(eig_ref[:, 0], 1e-300)
    sep = ok & (gap > 1e-4)
    assert (1.0 - np.abs(np.sum(normals[sep] * n_ref[sep], axis=1)) < 1e-9).all()
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)


def test_pca_kernel_random_clouds():
    rng = np.random.default_rng(3)
    pts = rng.random((300, 3)) * [1.0, 1.0, 0.1]
    idx, _ = query_knn(pts, 12)
    _compare_pca(pts, idx, 12)
    _compare_pca(pts, idx, 5)  # first k columns of a wider array


def test_pca_kernel_edge_cases():
    # empty
    normals, eig, deg = _run_pca_kernel(np.zeros((0, 3)), np.zeros((0, 3), np.int64), 3)
    assert normals.shape == (0, 3)
    # one point, k = 1: zero covariance -> fallback (0, 0, 1), flagged
    normals, eig, deg = _run_pca_kernel(np.ones((1, 3)), np.zeros((1, 1), np.int64), 1)
    assert normals.tolist() == [[0.0, 0.0, 1.0]] and deg.tolist() == [True]
    # duplicates, collinear and a plane mixed
    rng = np.random.default_rng(4)
    plane = np.column_stack([rng.random((40, 2)), np.zeros(40)])
    line = np.column_stack([np.linspace(5, 6, 20), np.full(20, 5.0), np.full(20, 5.0)])
    dup = np.tile([[-5.0, -5.0, -5.0]], (10, 1))
    pts = np.vstack([plane, line, dup])
    idx, _ = query_knn(pts, 6)
    _compare_pca(pts, idx, 6)
    normals, _, deg = _run_pca_kernel(pts, idx, 6)
    assert deg[40:].all() and not deg[:40].any()
    assert np.array_equal(normals[60:], np.tile([0.0, 0.0, 1.0], (10, 1)))


def test_riemannian_graph_matches_reference():
    pts, exact = sphere(200)
    nrm = random_flips(exact, 1)
    dup = np.vstack([pts, pts[:5]])
    nrm = np.vstack([nrm, nrm[:5]])
    idx, _ = query_knn(dup, 8)
    for penalty in (0.0, 1.0, 2.5):
        indptr, cols, w = riemannian_graph_kernel(dup, nrm, idx, 8, 1e-9, penalty)
        ref = reference.riemannian_graph_reference(dup, nrm, idx, 8, 1e-9, penalty)
        rows = np.repeat(np.arange(dup.shape[0]), np.diff(indptr))
        ours = {(min(a, b), max(a, b)): x for a, b, x in zip(rows, cols, w, strict=True)}
        assert len(ours) == len(w) == len(ref)  # every undirected edge exactly once
        assert ours.keys() == ref.keys()
        keys = list(ref)
        assert np.allclose([ours[e] for e in keys], [ref[e] for e in keys], rtol=1e-12)
        assert (w > 0).all()


def test_component_tops_match_reference():
    rng = np.random.default_rng(6)
    z = rng.integers(0, 5, 300).astype(float)  # many ties
    labels = rng.integers(0, 7, 300)
    labels[labels == 3] = 4  # label 3 absent
    roots = component_tops_kernel(z, labels, 7)
    for c in range(7):
        members = np.flatnonzero(labels == c)
        expected = members[np.argmax(z[members])] if members.size else -1
        assert roots[c] == expected


def test_propagate_signs_matches_reference():
    rng = np.random.default_rng(5)
    n = 120
    nrm = rng.normal(size=(n, 3))
    # a random forest of three trees: node j > root attaches to an earlier node
    comp = np.repeat([0, 1, 2], 40)
    parent = np.array([rng.integers(40 * (j // 40), j) if j % 40 else -1 for j in range(n)])
    child = np.flatnonzero(parent >= 0)
    tree = sparse.csr_array((np.ones(child.size), (parent[child], child)), shape=(n, n))
    sym = (tree + tree.T).tocsr()
    roots = np.array([0, 40, 80])
    root_signs = np.array([1.0, -1.0, 1.0])
    signs, order = propagate_signs_kernel(
        sym.indptr.astype(np.int64), sym.indices.astype(np.int64), nrm, roots, root_signs
    )
    ref = reference.propagate_signs_reference(tree, nrm, roots, root_signs)
    assert np.array_equal(signs, ref)
    assert sorted(order.tolist()) == list(range(n))
    assert np.array_equal(np.unique(comp[order[:40]]), [0])


def test_orient_matches_reference():
    for pts, exact in (sphere(300), torus(30, 12, rng=0)):
        nrm = random_flips(exact + 0.05 * np.random.default_rng(1).normal(size=exact.shape), 2)
        idx, _ = query_knn(pts, 10)
        for penalty in (0.0, 1.0):
            ours = orient_normals(pts, nrm, k=10, neighbors=idx, method="mst", edge_penalty=penalty)
            ref = reference.orient_mst_reference(pts, nrm, idx, 10, 1e-9, penalty)
            assert np.allclose(ours, ref, atol=1e-15)


_JIT_OFF_SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from pointatlas.neighbors import query_knn
    from pointatlas.normals import estimate_normals, orient_normals
    from tests.normals import reference
    from tests.normals.shapes import random_flips, sphere

    pts, exact = sphere(60)
    idx, _ = query_knn(pts, 8)
    est = estimate_normals(pts, 8, neighbors=idx)
    ref, _, _ = reference.pca_normals_reference(pts, idx, 8)
    assert (1 - np.abs(np.sum(est * ref, axis=1)) < 1e-9).all()
    line = np.column_stack([np.arange(6.0), np.zeros(6), np.zeros(6)])
    assert np.isfinite(estimate_normals(np.vstack([line, np.zeros((4, 3))]), 3)).all()
    ours = orient_normals(pts, random_flips(est, 0), k=8, neighbors=idx, method="mst")
    assert np.allclose(ours, reference.orient_mst_reference(pts, ours, idx, 8, 1e-9, 1.0))
    assert (np.sum(ours * exact, axis=1) > 0).all()
    print("ok")
    """
)


def test_kernels_without_jit():
    assert run_without_jit(_JIT_OFF_SCRIPT).strip() == "ok"


def test_kruskal_forest_keeps_scipys_edges():
    """Kruskal in stable weight order keeps exactly scipy's minimum spanning
    forest, also with tied weights (a regular grid, two components)."""
    from scipy.sparse import csgraph

    from pointatlas._core._sort import stable_argsort
    from pointatlas.normals._kernels import kruskal_forest_kernel

    g = np.arange(12.0)
    grid = np.array([[x, y, 0.0] for x in g for y in g])
    pts = np.vstack([grid, grid + [100.0, 0, 0]])
    nrm = np.tile([0.0, 0.0, 1.0], (pts.shape[0], 1))
    nrm[::7] = [0.0, 0.6, 0.8]
    n = pts.shape[0]
    idx, _ = query_knn(pts, 9)
    indptr, cols, w = riemannian_graph_kernel(pts, nrm, idx, 9, 1e-9, 1.0)
    assert np.unique(w).size < w.size  # ties present
    order = stable_argsort(w)
    np.testing.assert_array_equal(order, np.argsort(w, kind="stable"))
    tree_ptr, tree_adj, labels, n_comp = kruskal_forest_kernel(indptr, cols, order)
    ours = sparse.csr_array((np.ones(tree_adj.size), tree_adj, tree_ptr), shape=(n, n))
    ref = csgraph.minimum_spanning_tree(sparse.csr_array((w, cols, indptr), shape=(n, n)))
    ref = ((ref + ref.T) != 0).astype(np.float64)
    assert (ours != ref).nnz == 0
    assert n_comp == 2 and labels[0] == 0 and labels[-1] == 1
    ref_comp = csgraph.connected_components(ref, directed=False)[1]
    np.testing.assert_array_equal(labels, ref_comp)


def test_kruskal_core_id_width_does_not_matter():
    """The 32-bit union-find (used below 2**31 nodes) keeps the same edges and
    labels as the 64-bit one."""
    from pointatlas._core._sort import stable_argsort
    from pointatlas.normals._kernels import _kruskal_core

    rng = np.random.default_rng(3)
    pts = np.round(rng.random((400, 3)) * 8)  # clumps: several components
    pts += rng.random((400, 3)) * 1e-3
    nrm = np.tile([0.0, 0.0, 1.0], (400, 1))
    idx, _ = query_knn(pts, 7)
    indptr, cols, w = riemannian_graph_kernel(pts, nrm, idx, 7, 1e-9, 1.0)
    order = stable_argsort(w)
    narrow = _kruskal_core(indptr, cols, order, np.arange(400).astype(np.int32))
    wide = _kruskal_core(indptr, cols, order, np.arange(400))
    assert narrow[2] == wide[2] and narrow[4] == wide[4]
    np.testing.assert_array_equal(narrow[0][: narrow[2]], wide[0][: wide[2]])
    np.testing.assert_array_equal(narrow[1][: narrow[2]], wide[1][: wide[2]])
    np.testing.assert_array_equal(narrow[3], wide[3])

"""numba kernels against the plain-numpy references in reference.py."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse

from pointatlas._core import readonly_view
from pointatlas.neighbors import query_knn
from pointatlas.normals import estimate_normals, orient_normals
from pointatlas.normals._kernels import component_tops_kernel, pca_normals_kernel, sym3_eigen
from pointatlas.normals._kernels.eig3 import sym3_eigen_scalars
from pointatlas.normals._kernels.forest import _forest_edges, _forest_labels
from pointatlas.normals._orient import _riemannian_graph, _spanning_forest
from tests.jit_off import JIT_OFF, run_module_without_jit

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


@pytest.mark.parametrize(
    "eigvals",
    [
        (3.0, 2.0, 1.0),
        (1.0, 1e-3, 1e-9),
        (1.0, 1.0, 1e-6),
        (1.0, 1e-8 * (1 + 1e-6), 1e-8),
        (1.0, 1.0, 1.0),
        (1e-250, 5e-251, 1e-252),
        (1e250, 5e249, 1e248),
        (0.0, 0.0, 0.0),
    ],
)
def test_sym3_eigen_scalars_is_sym3_eigen_bit_for_bit(eigvals):
    """The register version used by the PCA kernel: the same eigenvalues and the
    vectors of the largest and smallest one, bit for bit, also on diagonal and
    nearly diagonal input (rotations skipped or zeroed)."""
    rng = np.random.default_rng(11)
    mats = [_random_sym(rng, np.array(eigvals)) for _ in range(40)]
    mats += [np.diag(eigvals), np.diag(eigvals[::-1]), np.diag(eigvals) + 1e-17 * np.ones((3, 3))]
    for a in mats:
        a = 0.5 * (a + a.T)
        w, v = _eigen(a)
        got = sym3_eigen_scalars(a[0, 0], a[0, 1], a[0, 2], a[1, 1], a[1, 2], a[2, 2])
        want = (*w, *v[:, 0], *v[:, 2])
        assert np.array_equal(np.array(got).view(np.uint64), np.array(want).view(np.uint64))


def _run_pca_kernel(points, indices, k):
    n = indices.shape[0]
    normals = np.empty((n, 3))
    eig = np.empty((n, 3))
    deg = np.empty(n, dtype=bool)
    # read-only inputs, as `pca_normals` passes them (one compiled signature)
    pts, idx = readonly_view(points), readonly_view(indices)
    pca_normals_kernel(pts, idx, k, reference.DEGENERATE_RATIO, normals, eig, deg)
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
        indptr, cols, w, opposed = _riemannian_graph(dup, nrm, idx, 8, 1e-9, penalty)
        ref = reference.riemannian_graph_reference(dup, nrm, idx, 8, 1e-9, penalty)
        rows = np.repeat(np.arange(dup.shape[0]), np.diff(indptr))
        ours = {(min(a, b), max(a, b)): x for a, b, x in zip(rows, cols, w, strict=True)}
        assert len(ours) == len(w) == len(ref)  # every undirected edge exactly once
        assert ours.keys() == ref.keys()
        keys = list(ref)
        assert np.allclose([ours[e] for e in keys], [ref[e] for e in keys], rtol=1e-12)
        assert (w > 0).all()
        dots = np.sum(nrm[rows] * nrm[cols], axis=1)
        np.testing.assert_array_equal(opposed, (dots < 0).astype(np.uint8))


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


def test_forest_parity_matches_breadth_first_signs():
    """Signs from the forest kernel's path parities equal breadth-first propagation
    (scipy's traversal, one Python step per node) from any root."""
    rng = np.random.default_rng(5)
    n = 120
    nrm = rng.normal(size=(n, 3))
    # a random forest of three trees: node j > root attaches to an earlier node
    parent = np.array([rng.integers(40 * (j // 40), j) if j % 40 else -1 for j in range(n)])
    child = np.flatnonzero(parent >= 0)
    tree = sparse.csr_array((np.ones(child.size), (parent[child], child)), shape=(n, n))
    weights = rng.random(child.size) + 0.1
    graph = sparse.csr_array((weights, (parent[child], child)), shape=(n, n))
    rows = np.repeat(np.arange(n), np.diff(graph.indptr))
    dots = np.sum(nrm[rows] * nrm[graph.indices], axis=1)
    kept_a, _, labels, n_comp, parity = _spanning_forest(
        graph.indptr.astype(np.int64),
        graph.indices.astype(np.int64),
        graph.data,
        (dots < 0).astype(np.uint8),
    )
    assert kept_a.size == n - 3 and n_comp == 3
    np.testing.assert_array_equal(labels, np.repeat([0, 1, 2], 40))
    for roots in ([0, 40, 80], [17, 55, 119]):
        root_signs = np.array([1.0, -1.0, 1.0])
        ref = reference.propagate_signs_reference(tree, nrm, roots, root_signs)
        ours = root_signs[labels] * np.where(parity == parity[roots][labels], 1.0, -1.0)
        np.testing.assert_array_equal(ours, ref)


def test_orient_matches_reference():
    for pts, exact in (sphere(300), torus(30, 12, rng=0)):
        nrm = random_flips(exact + 0.05 * np.random.default_rng(1).normal(size=exact.shape), 2)
        idx, _ = query_knn(pts, 10)
        for penalty in (0.0, 1.0):
            ours = orient_normals(pts, nrm, k=10, neighbors=idx, method="mst", edge_penalty=penalty)
            ref = reference.orient_mst_reference(pts, nrm, idx, 10, 1e-9, penalty)
            assert np.allclose(ours, ref, atol=1e-15)


def test_estimate_and_orient_tiny_reference():
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


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="tiny_reference")


def _forest_edge_set(kept_a, kept_b):
    return {(min(a, b), max(a, b)) for a, b in zip(kept_a.tolist(), kept_b.tolist(), strict=True)}


def test_spanning_forest_keeps_scipys_edges():
    """Kruskal in stable weight order keeps exactly scipy's minimum spanning
    forest, also with tied weights (a regular grid, two components)."""
    from scipy.sparse import csgraph

    g = np.arange(12.0)
    grid = np.array([[x, y, 0.0] for x in g for y in g])
    pts = np.vstack([grid, grid + [100.0, 0, 0]])
    nrm = np.tile([0.0, 0.0, 1.0], (pts.shape[0], 1))
    nrm[::7] = [0.0, 0.6, 0.8]
    n = pts.shape[0]
    idx, _ = query_knn(pts, 9)
    indptr, cols, w, opposed = _riemannian_graph(pts, nrm, idx, 9, 1e-9, 1.0)
    assert np.unique(w).size < w.size  # ties present
    kept_a, kept_b, labels, n_comp, parity = _spanning_forest(indptr, cols, w, opposed)
    ours = sparse.csr_array((np.ones(kept_a.size), (kept_a, kept_b)), shape=(n, n))
    ours = ((ours + ours.T) != 0).astype(np.float64)
    ref = csgraph.minimum_spanning_tree(sparse.csr_array((w, cols, indptr), shape=(n, n)))
    ref = ((ref + ref.T) != 0).astype(np.float64)
    assert (ours != ref).nnz == 0
    assert n_comp == 2 and labels[0] == 0 and labels[-1] == 1
    ref_comp = csgraph.connected_components(ref, directed=False)[1]
    np.testing.assert_array_equal(labels, ref_comp)
    assert not parity.any()  # no opposed normals


def _random_graph(rng, n, m, values):
    """CSR graph with each undirected edge once (sorted columns), weights drawn from
    ``values`` (many ties), the nodes split into a few clumps."""
    clump = rng.integers(0, 4, n)
    pairs = set()
    while len(pairs) < m:
        a, b = rng.integers(0, n, 2)
        if a != b and clump[a] == clump[b] and (b, a) not in pairs:
            pairs.add((int(a), int(b)))
    pairs = sorted(pairs)
    a, b = np.array(pairs).T
    indptr = np.searchsorted(a, np.arange(n + 1)).astype(np.int64)
    w = rng.choice(values, len(pairs))
    opposed = rng.integers(0, 2, len(pairs)).astype(np.uint8)
    return indptr, b.astype(np.int64), w, opposed


def _kruskal_reference(indptr, cols, weights, n):
    """Kept edges of Kruskal over Python's stable sort of the weights."""
    rows = np.repeat(np.arange(n), np.diff(indptr))
    comp = list(range(n))

    def find(x):
        while comp[x] != x:
            x = comp[x]
        return x

    kept = []
    for e in sorted(range(len(weights)), key=lambda e: weights[e]):
        ra, rb = find(rows[e]), find(cols[e])
        if ra != rb:
            comp[ra] = rb
            kept.append((int(rows[e]), int(cols[e])))
    return kept


@pytest.mark.parametrize("seed", range(4))
def test_filter_kruskal_and_id_width_keep_kruskals_edges(seed):
    """Filter-Kruskal (forced small stages), 32- and 64-bit ids and packed or
    positional payloads keep Kruskal's edges in Kruskal's order, on graphs with
    many tied weights (also -0.0 against +0.0 and negative weights), and the
    parities flip exactly across the opposed tree edges."""
    from scipy.sparse import csgraph

    rng = np.random.default_rng(seed)
    n = 300
    for values in ([1.0, 2.0, 3.0, 4.0], [-0.0, 0.0, -1.5, 2.0, 1e-300], np.arange(1.0, 9.0)):
        indptr, cols, w, opposed = _random_graph(rng, n, 900, np.array(values))
        expected = _kruskal_reference(indptr, cols, w, n)
        results = []
        for wide, share, minimum in ((False, 0.2, 100_000), (False, 0.3, 16), (True, 0.1, 8)):
            link = 2 * np.arange(n) if wide else (2 * np.arange(n)).astype(np.int32)
            work = np.empty((6, cols.size), np.uint64)
            kept_a, kept_b, n_kept = _forest_edges(
                indptr, cols, w, opposed, link, wide, share, minimum, work
            )
            got = list(zip(kept_a[:n_kept].tolist(), kept_b[:n_kept].tolist(), strict=True))
            assert got == expected
            labels, n_comp, parity = _forest_labels(link)
            results.append((labels, n_comp, parity))
        for labels, n_comp, parity in results:
            assert n_comp == results[0][1]
            np.testing.assert_array_equal(labels, results[0][0])
            np.testing.assert_array_equal(parity, results[0][2])
        rows = np.repeat(np.arange(n), np.diff(indptr))
        flips = {(int(a), int(b)): int(o) for a, b, o in zip(rows, cols, opposed, strict=True)}
        parity = results[0][2]
        for a, b in expected:
            assert parity[a] ^ parity[b] == flips[(a, b)]
        graph = sparse.csr_array((np.ones(cols.size), cols, indptr), shape=(n, n))
        n_ref, ref_labels = csgraph.connected_components(graph, directed=False)
        assert results[0][1] == n_ref
        np.testing.assert_array_equal(results[0][0], ref_labels)
        if min(values) > 0:  # scipy reads weight 0 as no edge
            ref = csgraph.minimum_spanning_tree(sparse.csr_array((w, cols, indptr), shape=(n, n)))
            ref = sparse.coo_array(ref)
            assert _forest_edge_set(*np.array(expected).T) == _forest_edge_set(ref.row, ref.col)


def test_spatial_order_is_a_permutation():
    """The graph kernel's visiting order: a permutation for any input (empty, one
    point, coincident points, a flat or shuffled cloud), nearby points close in it."""
    from pointatlas._core._sort import morton_bits, morton_order

    rng = np.random.default_rng(2)
    flat = np.column_stack([rng.random((500, 2)), np.zeros(500)])
    for pts in (np.zeros((0, 3)), np.ones((1, 3)), np.ones((7, 3)), flat, rng.random((2000, 3))):
        order = morton_order(pts, morton_bits(pts.shape[0]))
        np.testing.assert_array_equal(np.sort(order), np.arange(pts.shape[0]))
    pts = rng.random((4000, 3))
    order = morton_order(pts, morton_bits(pts.shape[0]))
    steps = np.linalg.norm(np.diff(pts[order], axis=0), axis=1)
    assert np.median(steps) < 0.2 * np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1))


def test_offsets_kernel_matches_numpy():
    from pointatlas.normals._kernels import offsets_kernel

    rng = np.random.default_rng(8)
    pts = rng.normal(size=(500, 3)) * 1e3
    targets = rng.integers(0, 500, 500)
    np.testing.assert_array_equal(offsets_kernel(pts, targets), pts[targets] - pts)
    assert offsets_kernel(np.zeros((0, 3)), np.zeros(0, np.int64)).shape == (0, 3)

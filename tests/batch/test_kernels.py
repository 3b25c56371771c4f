"""Numba kernels of tiled processing against plain numpy / scipy references."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import sparse
from scipy.sparse import csgraph

from pointatlas.batch._kernels import smooth_pieces_kernel
from pointatlas.batch._tiles_tasks import SMOOTH_COS, _piece_tops, _smooth_pieces
from pointatlas.neighbors import query_knn
from pointatlas.normals import estimate_normals, orient_normals
from tests.jit_off import JIT_OFF, run_module_without_jit

from .test_tiles import scan


def _reference(table, normals):
    """Weak components over smooth edges (scipy) and summed dots of the other edges."""
    n, k = table.shape
    rows = np.repeat(np.arange(n), k)
    cols = table.reshape(-1)
    dots = np.einsum("ij,ij->i", normals[rows], normals[cols])
    smooth = np.abs(dots) >= SMOOTH_COS
    graph = sparse.csr_array((np.ones(int(smooth.sum())), (rows[smooth], cols[smooth])), (n, n))
    _, labels = csgraph.connected_components(graph, directed=True, connection="weak")
    a, b = labels[rows[~smooth]], labels[cols[~smooth]]
    cross = a != b
    pairs = np.column_stack([np.minimum(a, b), np.maximum(a, b)])[cross]
    uniq, inv = np.unique(pairs, axis=0, return_inverse=True)
    sums = np.bincount(inv.ravel(), weights=dots[~smooth][cross], minlength=uniq.shape[0])
    return labels, uniq, sums


def test_smooth_pieces_equal_scipy_components_and_links():
    pts = scan(8_000, seed=3)
    table = query_knn(pts, 10)[0]
    normals = orient_normals(
        pts, estimate_normals(pts, 10, neighbors=table), k=10, method="mst", neighbors=table
    )
    labels, uniq, sums = _reference(table, normals)
    assert labels.max() > 2 and uniq.shape[0] > 2  # ground, roof, walls, tank: several pieces
    got_labels, links = _smooth_pieces(table, normals)
    assert np.array_equal(got_labels, labels)  # same numbering: by smallest point
    assert np.array_equal(links[:, :2].astype(np.int64), uniq)
    np.testing.assert_allclose(links[:, 2], sums, rtol=0, atol=1e-9)


def test_smooth_pieces_of_one_plane_and_of_opposed_normals_tiny_reference():
    # a flat grid: one piece, no links; flipping half the normals keeps one piece
    # (|n_i . n_j| is what counts) and a perpendicular normal makes its own piece
    g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0)), -1).reshape(-1, 2)
    pts = np.column_stack([g, np.zeros(100)])
    table = query_knn(pts, 5)[0]
    normals = np.tile([0.0, 0.0, 1.0], (100, 1))
    normals[::2] *= -1
    labels, a, b, dots = smooth_pieces_kernel(table, normals, SMOOTH_COS)
    assert labels.tolist() == [0] * 100 and a.size == 0
    normals[55] = [1.0, 0.0, 0.0]
    labels, a, b, dots = smooth_pieces_kernel(table, normals, SMOOTH_COS)
    assert labels.max() == 1 and labels[55] == 1 and np.count_nonzero(labels) == 1
    assert np.all(a == 0) and np.all(b == 1) and np.all(dots == 0.0)
    others = table[np.arange(100) != 55]
    assert a.size == 4 + int(np.count_nonzero(others == 55))  # its 4 edges out, the edges in


def test_piece_tops_tiny_reference():
    """Per piece the owned point with the largest z, ties to the smallest global index
    (a lexsort reference), with many ties and pieces without owned points."""
    rng = np.random.default_rng(3)
    n = 3000
    comp = rng.integers(0, 400, n)
    z = rng.integers(0, 5, n).astype(np.float64)  # many equal heights
    gidx = rng.permutation(10 * n)[:n].astype(np.int64)
    owned = rng.random(n) < 0.7
    nz = rng.normal(size=n)
    comps, rows = _piece_tops(comp, owned, z, gidx, nz)
    want = {}
    order = np.flatnonzero(owned)
    order = order[np.lexsort((gidx[order], -z[order]))]
    for i in order:
        want.setdefault(int(comp[i]), (z[i], float(gidx[i]), nz[i]))
    assert comps.tolist() == sorted(want)
    assert np.array_equal(rows, np.array([want[c] for c in sorted(want)]))


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="tiny_reference")

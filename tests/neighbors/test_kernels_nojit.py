"""Small kernel-vs-reference checks, run JIT-compiled with the suite and once more with
NUMBA_DISABLE_JIT=1 (CONTRIBUTING.md, Tests: coverage of the kernel bodies; inputs are tiny)."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.neighbors import knn_components, knn_graph, query_knn, query_radius
from tests.jit_off import JIT_OFF, run_module_without_jit
from tests.neighbors.reference import (
    components_reference,
    graph_reference,
    knn_reference,
    radius_reference,
)


def _clouds():
    rng = np.random.default_rng(0)
    g = np.arange(3.0)
    return {
        "random": rng.random((40, 3)),
        "grid": np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3),
        "duplicates": np.repeat(rng.random((5, 3)), 6, axis=0)[rng.permutation(30)],
        "outliers": np.concatenate([rng.random((30, 3)) * 0.1, [[40.0, 0, 0], [0, 60, 0]]]),
        "one": np.array([[1.0, 2.0, 3.0]]),
    }


CLOUDS = list(_clouds())


@pytest.mark.parametrize("name", CLOUDS)
def test_knn_tiny_reference(name):
    pts = _clouds()[name]
    n = len(pts)
    for k in sorted({1, min(2, n), min(4, n), min(9, n)}):
        ref_idx, ref_dist = knn_reference(pts, k)
        for backend in ("auto", "grid", "kdtree"):
            idx, dist = query_knn(pts, k, backend=backend)
            np.testing.assert_array_equal(idx, ref_idx, err_msg=f"{k} {backend}")
            np.testing.assert_array_equal(dist, ref_dist, err_msg=f"{k} {backend}")


@pytest.mark.parametrize("name", CLOUDS)
def test_radius_tiny_reference(name):
    pts = _clouds()[name]
    for radius in (0.05, 1.0):
        ref = radius_reference(pts, radius)
        for backend in ("auto", "kdtree"):
            nb = query_radius(pts, radius, backend=backend)
            for i, (row, d) in enumerate(ref):
                np.testing.assert_array_equal(nb.row(i), row)
                np.testing.assert_array_equal(nb.distances[nb.indptr[i] : nb.indptr[i + 1]], d)


@pytest.mark.parametrize("name", [c for c in CLOUDS if c != "one"])
def test_graph_tiny_reference(name):
    pts = _clouds()[name]
    n = len(pts)
    idx, _ = query_knn(pts, 4)
    for symmetric in (True, False):
        gr = knn_graph(pts, 4, symmetric=symmetric)
        adj = np.zeros((n, n), dtype=bool)
        adj[np.repeat(np.arange(n), np.diff(gr.indptr)), gr.indices] = True
        np.testing.assert_array_equal(adj, graph_reference(idx, symmetric))
    _, labels = knn_components(pts, 4)
    np.testing.assert_array_equal(labels, components_reference(graph_reference(idx, True)))


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="tiny_reference")

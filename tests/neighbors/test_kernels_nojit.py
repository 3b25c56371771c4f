"""Kernel-vs-reference checks once more with NUMBA_DISABLE_JIT=1 (STYLE section 7).

The kernels then run as plain Python, so coverage sees their bodies; inputs are
tiny. The script runs in a subprocess because the JIT switch is read at import.
"""

from __future__ import annotations

from tests.jit_off import run_without_jit

SCRIPT = r"""
import numpy as np
import numba
assert numba.config.DISABLE_JIT
from pointatlas.neighbors import knn_components, knn_graph, query_knn, query_radius
from tests.neighbors.reference import (

    components_reference, graph_reference, knn_reference, radius_reference,
)

rng = np.random.default_rng(0)
g = np.arange(3.0)
clouds = {
    "random": rng.random((40, 3)),
    "grid": np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3),
    "duplicates": np.repeat(rng.random((5, 3)), 6, axis=0)[rng.permutation(30)],
    "outliers": np.concatenate([rng.random((30, 3)) * 0.1, [[40.0, 0, 0], [0, 60, 0]]]),
    "one": np.array([[1.0, 2.0, 3.0]]),
}
for name, pts in clouds.items():
    n = len(pts)
    for k in sorted({1, min(2, n), min(4, n), min(9, n)}):
        ref = knn_reference(pts, k)
        for backend in ("auto", "grid", "kdtree"):
            idx, dist = query_knn(pts, k, backend=backend)
            assert (idx == ref[0]).all(), (name, k, backend)
            assert (dist == ref[1]).all(), (name, k, backend)
    for radius in (0.05, 1.0):
        ref = radius_reference(pts, radius)
        for backend in ("auto", "kdtree"):
            nb = query_radius(pts, radius, backend=backend)
            for i, (row, d) in enumerate(ref):
                assert (nb.row(i) == row).all(), (name, radius, backend)
                assert (nb.distances[nb.indptr[i]:nb.indptr[i + 1]] == d).all()
    if n >= 4:
        idx, _ = query_knn(pts, 4)
        for symmetric in (True, False):
            gr = knn_graph(pts, 4, symmetric=symmetric)
            adj = np.zeros((n, n), dtype=bool)
            adj[np.repeat(np.arange(n), np.diff(gr.indptr)), gr.indices] = True
            assert (adj == graph_reference(idx, symmetric)).all()
        _, labels = knn_components(pts, 4)
        assert (labels == components_reference(graph_reference(idx, True))).all()
print("ok")
"""


def test_kernels_without_jit():
    assert run_without_jit(SCRIPT).strip().endswith("ok")

"""The numba kernels shared by segment, neighbors and batch (`pointatlas._core.kernels`)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import sparse
from scipy.sparse import csgraph

from pointatlas._core.kernels import bounds, find_root, union_min


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 200), st.integers(0, 2**32 - 1))
def test_bounds_are_numpys_min_and_max(n, seed):
    pts = np.random.default_rng(seed).normal(size=(n, 3)) * 1e3
    lo, hi = bounds(pts)
    assert np.array_equal(lo, pts.min(axis=0))
    assert np.array_equal(hi, pts.max(axis=0))


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 60), st.integers(0, 120), st.integers(0, 2**32 - 1))
def test_union_min_gives_scipys_components_rooted_at_their_smallest_node(n, m, seed):
    rng = np.random.default_rng(seed)
    i, j = rng.integers(0, n, size=(2, m))
    parent = np.arange(n, dtype=np.int64)
    for a, b in zip(i.tolist(), j.tolist(), strict=True):
        union_min(parent, a, b)
    roots = np.array([find_root(parent, a) for a in range(n)])
    _, comp = csgraph.connected_components(
        sparse.coo_array((np.ones(m), (i, j)), shape=(n, n)), directed=False
    )
    smallest = np.full(comp.max() + 1, n)
    np.minimum.at(smallest, comp, np.arange(n))
    assert np.array_equal(roots, smallest[comp])
    # after find_root every node points at its root (path compression)
    assert np.array_equal(parent, roots)

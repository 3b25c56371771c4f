"""Spatial renumbering and neighbour-table permutation (`pointatlas._core._sort`)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas._core._sort import (
    morton_bits,
    morton_order,
    permute_table,
    sorted_key_runs,
    spatial_renumbering,
)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 300), st.integers(0, 2**32 - 1))
def test_renumbering_is_a_permutation_and_its_inverse(n, seed):
    pts = np.random.default_rng(seed).normal(size=(n, 3))
    order, inv = spatial_renumbering(pts)
    assert np.array_equal(np.sort(order), np.arange(n))
    assert np.array_equal(order[inv], np.arange(n))
    assert np.array_equal(inv[order], np.arange(n))


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 3000), st.integers(0, 2**32 - 1))
def test_renumbering_is_the_morton_kernels_order(n, seed):
    # numpy's renumbering and the kernel give the same order bit for bit: random,
    # on a grid (many points share a cell and a coordinate), flat (zero extent on
    # an axis), duplicates, and with non-finite points (they go last)
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-3, 4)
    if n and seed % 4 == 1:
        pts = np.round(pts * 3) / 3
    if n and seed % 4 == 2:
        pts[:, 2] = 1.5
        pts[rng.integers(0, n, size=n // 3)] = pts[0]
    if n and seed % 4 == 3:
        bad = rng.random((n, 3)) < 0.05
        pts[bad] = rng.choice([np.nan, np.inf, -np.inf], size=int(bad.sum()))
    order, inv = spatial_renumbering(pts)
    assert np.array_equal(order, morton_order(pts, morton_bits(n)))
    assert np.array_equal(inv[order], np.arange(n))


def test_renumbering_groups_neighbours():
    # a line sampled in random order: after renumbering, consecutive points lie
    # in the same or the next grid cell (8 along the line), so they are far
    # closer than in the input order
    rng = np.random.default_rng(0)
    t = rng.permutation(4096).astype(np.float64)
    pts = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
    order, _ = spatial_renumbering(pts)
    jumps = np.abs(np.diff(t[order]))
    assert jumps.max() < 2 * 4096 / 8
    assert jumps.mean() < 0.25 * np.abs(np.diff(t)).mean()


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 200), st.integers(1, 6), st.integers(0, 2**32 - 1))
def test_permute_table_matches_numpy(n, c, seed):
    rng = np.random.default_rng(seed)
    table = rng.integers(-1, n, size=(n, c))
    order = rng.permutation(n)
    inv = np.empty(n, dtype=np.int64)
    inv[order] = np.arange(n)
    got = permute_table(table, order, inv)
    rows = table[order]
    want = np.where(rows >= 0, inv[np.maximum(rows, 0)], rows)
    assert np.array_equal(got, want)
    # renumbering back restores the table
    assert np.array_equal(permute_table(got, inv, order), table)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 300), st.sampled_from([3, 1000, 2**40, 2**62]), st.integers(0, 2**32 - 1))
def test_sorted_key_runs_matches_numpy(n, high, seed):
    # keys with repeats (small ranges) and keys spanning the high bytes: the stable
    # order, the sorted keys and the run starts are numpy's argsort and unique
    keys = np.random.default_rng(seed).integers(0, high, size=n, dtype=np.int64)
    srt, order, first = sorted_key_runs(keys.copy())
    want = np.argsort(keys, kind="stable")
    assert np.array_equal(order, want)
    assert np.array_equal(srt, keys[want])
    _, starts = np.unique(keys[want], return_index=True)
    assert np.array_equal(np.flatnonzero(first), starts)

"""Merging VSA regions whose union stays flat (`_mesh_path._merge_flat`)."""

from __future__ import annotations

import numpy as np

from pointatlas.simplify._mesh_path import _merge_flat
from pointatlas.simplify._triangles import _face_graph, _surface


def _roof(n: int = 6, ridge_deg: float = 30.0):
    """Two planes meeting at a ridge (x = n), each an n x n grid of squares split in
    two triangles; the second plane rises at ``ridge_deg``."""
    xs = np.arange(2 * n + 1, dtype=np.float64)
    ys = np.arange(n + 1, dtype=np.float64)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    z = np.where(gx > n, (gx - n) * np.tan(np.radians(ridge_deg)), 0.0)
    v = np.stack([gx, gy, z], axis=-1).reshape(-1, 3)
    idx = np.arange(v.shape[0]).reshape(gx.shape)
    tri = []
    for i in range(2 * n):
        for j in range(n):
            a, b, c, d = idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]
            tri += [[a, b, c], [a, c, d]]
    tri = np.asarray(tri, dtype=np.int64)
    centre = v[tri].mean(axis=1)
    return v, tri, centre


def test_coplanar_regions_merge_and_regions_across_the_ridge_do_not():
    v, tri, centre = _roof()
    s = _surface(v, tri)
    # four regions: each plane cut in two along y (numbered so that the first
    # triangles' regions are not 0, 1, ...)
    labels = 2 * (centre[:, 0] > 6).astype(np.int64) + (centre[:, 1] > 3)
    labels = 3 - labels
    merged = _merge_flat(s, _face_graph(s), labels, np.radians(1.0))
    assert np.unique(merged).tolist() == [0, 1]
    # one region per plane, numbered in the order of their first triangles
    np.testing.assert_array_equal(merged, (centre[:, 0] > 6).astype(np.int64))


def test_nothing_merges_when_every_union_turns_more_than_the_angle():
    v, tri, centre = _roof()
    s = _surface(v, tri)
    labels = 1 - (centre[:, 0] > 6).astype(np.int64)  # one region per plane
    merged = _merge_flat(s, _face_graph(s), labels, np.radians(1.0))
    # renumbered by first triangle, otherwise the same regions
    np.testing.assert_array_equal(merged, 1 - labels)
    # at 20 degrees the two planes (30 degrees apart: the union's mean deviation
    # is 15) do merge
    merged = _merge_flat(s, _face_graph(s), labels, np.radians(20.0))
    assert (merged == 0).all()

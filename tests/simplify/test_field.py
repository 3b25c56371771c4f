"""The robust path's field at the band nodes: the numba kernel against the numpy
reference (tests/simplify/reference.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pointatlas.simplify._kernels import band_field
from pointatlas.simplify._reconstruct import _band_values
from pointatlas.simplify._voxel_grid import point_spacing
from pointatlas.synth import sample_mesh
from tests.jit_off import JIT_OFF, run_module_without_jit

from .cad_shapes import cube_with_square_hole, cylinder
from .reference import band_field_reference


def _sheet():
    """A wavy open sheet (a grid of triangles)."""
    u = np.linspace(0.0, 4.0, 21)
    x, y = np.meshgrid(u, u, indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), 0.3 * np.sin(x.ravel()) * np.cos(y.ravel())], 1)
    i = np.arange(20)[:, None] * 21 + np.arange(20)[None, :]
    i = i.ravel()
    t = np.concatenate([np.stack([i, i + 21, i + 1], 1), np.stack([i + 1, i + 21, i + 22], 1)])
    return v, t


def _nodes_near(p, step, n, seed=0):
    """``n`` nodes within 4 steps of the points (as the band holds them)."""
    rng = np.random.default_rng(seed)
    return p[rng.integers(0, p.shape[0], n)] + rng.uniform(-4 * step, 4 * step, (n, 3))


def _both(p, normals, x, step, spacing, k=8):
    tree = cKDTree(p)
    d, j = tree.query(x, k=k)
    d, j = d.reshape(x.shape[0], k), j.reshape(x.shape[0], k)
    return _band_values(p, normals, tree, x, step, spacing), band_field_reference(
        x, p, normals, d, j, step, spacing
    )


def _split_nodes(p, normals, x, step, spacing):
    """How many nodes see neighbours' planes on both sides (the vote's branch)."""
    d, j = cKDTree(p).query(x, k=min(8, p.shape[0]))
    d, j = d.reshape(x.shape[0], -1), j.reshape(x.shape[0], -1)
    near = d <= d[:, :1] + spacing
    s = np.einsum("nkd,nkd->nk", normals[j], x[:, None, :] - p[j])
    side = np.sign(s) * (np.abs(s) > 1e-9 * step) * near
    return int(((side > 0).any(axis=1) & (side < 0).any(axis=1)).sum())


@pytest.mark.parametrize("shape", [cube_with_square_hole, cylinder, _sheet])
def test_band_field_matches_reference_on_sampled_shapes(shape):
    v, t = shape()
    s = sample_mesh(v, t, 4000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    spacing = point_spacing(p, cKDTree(p))
    step = 1.5 * spacing
    x = _nodes_near(p, step, 20000)
    fast, slow = _both(p, n, x, step, spacing)
    # the same sums in the same order: equal here, and within rounding anywhere
    assert np.abs(fast - slow).max() <= 1e-12 * step
    if shape is not _sheet:  # edges: some nodes take the vote's branch
        assert _split_nodes(p, n, x, step, spacing) > 0


def test_band_field_tiny_reference_edge_cases():
    # fewer points than FIELD_K (k = 5), a node exactly on two points' plane (they
    # abstain), a repeated point with the opposite normal (the sides disagree), and a
    # node on a point
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [0.5, 0.5, 1.0]])
    n = np.array([[0, 0, 1], [0, 0, 1], [0, 0, 1], [0, 0, -1], [0, 1, 0]], dtype=float)
    x = np.array([[0.5, 0, 0], [0.2, 0.9, 0.3], [0.4, 0.6, -0.2], [0, 0, 0], [3, 3, 3]])
    for step, spacing in ((0.5, 0.4), (2.0, 5.0), (0.1, 0.0)):
        fast, slow = _both(p, n, x, step, spacing, k=5)
        assert np.abs(fast - slow).max() <= 1e-12 * step
    assert _split_nodes(p, n, x, 0.5, 0.4) > 0
    # one point: its tangent-plane distance
    one = _band_values(p[:1], n[:1], cKDTree(p[:1]), x, 0.5, 0.4)
    assert np.array_equal(one, x[:, 2])


def test_band_field_tiny_reference_more_neighbors_than_eight():
    # k = 20: the blocked pairwise sum (numpy's order from 8 elements on)
    rng = np.random.default_rng(3)
    p = rng.normal(size=(60, 3))
    n = p / np.linalg.norm(p, axis=1, keepdims=True)
    x = rng.normal(size=(40, 3)) * 1.3
    d, j = cKDTree(p).query(x, k=20)
    gauss = np.exp(-((d / 0.7) ** 2))
    fast = band_field(x, d, gauss, j.astype(np.int64), p, n, 0.7, 0.5)
    slow = band_field_reference(x, p, n, d, j, 0.7, 0.5)
    assert np.abs(fast - slow).max() <= 1e-12


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    out = run_module_without_jit(__file__, select="tiny_reference")
    assert "2 passed" in out, out[-500:]


def test_band_field_takes_the_side_of_a_convex_or_concave_turn_over_the_vote():
    """A node beyond a convex edge (solid x < 0, z < 0): four points of the top face
    say inside, one of the side face outside; the edge is convex (each point lies
    below the other's plane), so the node is outside, at the nearest point's distance
    (the vote alone said inside: a bulge past the edge). Normals flipped (the
    complement, a concave edge): inside."""
    top = [[-0.1, 0.0, 0.0], [-0.1, 0.1, 0.0], [-0.1, -0.1, 0.0], [-0.2, 0.0, 0.0]]
    p = np.array([*top, [0.0, 0.0, -0.4]])
    n = np.array([[0, 0, 1.0]] * 4 + [[1.0, 0, 0]])
    x = np.array([[0.3, 0.0, -0.1]])
    nearest = float(np.linalg.norm(x[0] - p[0]))
    for sign in (1.0, -1.0):
        fast, slow = _both(p, sign * n, x, 0.5, 5.0, k=5)
        assert fast[0] == slow[0] == pytest.approx(sign * nearest, abs=1e-15)

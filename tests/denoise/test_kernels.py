"""Kernels vs the plain-numpy references of tests/denoise/reference.py."""

import math

import numpy as np
import pytest

from pointatlas._core import readonly_view
from pointatlas.denoise._flatness import flatness_step
from pointatlas.denoise._kernels import (
    adaptive_k_kernel,
    voting_filter_kernel,
)
from pointatlas.denoise._sharpen import quadric_update_kernel
from pointatlas.neighbors import point_mesh_distance, query_knn
from tests.denoise import reference as ref


def _noisy_normals(rng, n, spread=0.3):
    nrm = rng.normal(size=(n, 3)) * spread + [0, 0, 1.0]
    return nrm / np.linalg.norm(nrm, axis=1)[:, None]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_point_to_mesh_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    verts = rng.normal(size=(12, 3))
    faces = rng.integers(0, 12, size=(15, 3))
    faces[0] = [0, 0, 1]  # a degenerate (zero-area) triangle
    pts = rng.normal(size=(40, 3)) * 1.5
    pts[0] = verts[3]  # on a vertex
    got = point_mesh_distance(pts, verts, faces)
    want = ref.point_to_mesh(pts, verts, faces)
    np.testing.assert_allclose(got, want, atol=1e-12)


def test_point_to_mesh_empty_and_on_surface():
    verts = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert point_mesh_distance(np.empty((0, 3)), verts, [[0, 1, 2]]).shape == (0,)
    d = point_mesh_distance([[0.25, 0.25, 0.0], [2.0, 0.0, 0.0]], verts, [[0, 1, 2]])
    np.testing.assert_allclose(d, [0.0, 1.0], atol=1e-15)


def test_point_to_mesh_bad_faces():
    with pytest.raises(ValueError, match="triangles must index vertices 0..2; got 0..3"):
        point_mesh_distance([[0, 0, 0]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]])


def _table(seed, n=30, k=12, duplicates=False):
    rng = np.random.default_rng(seed)
    pts = rng.normal(size=(n, 3)) * [1.0, 0.8, 0.1]
    if duplicates:
        pts[5] = pts[4]
    nrm = _noisy_normals(rng, n)
    nrm[3] *= -1  # a flipped normal: its cut-off weights vanish
    idx = query_knn(pts, k)[0]
    return pts, nrm, idx


@pytest.mark.parametrize("seed,duplicates", [(0, False), (1, True), (2, False)])
def test_adaptive_k_matches_reference(seed, duplicates):
    pts, nrm, idx = _table(seed, duplicates=duplicates)
    pts = readonly_view(pts)  # as the filter passes them: the kernel's one signature
    n = len(pts)
    k_lo = np.full(n, 3, dtype=np.int64)
    k_hi = np.full(n, 12, dtype=np.int64)
    k_lo[0], k_hi[0] = 1, 1  # every choice degenerate
    cos_a = math.cos(0.5)
    bk = np.empty(n, dtype=np.int64)
    be = np.empty(n)
    adaptive_k_kernel(pts, nrm, idx, k_lo, k_hi, cos_a, bk, be, np.full(n, -1, np.int64))
    wk, we = ref.adaptive_k(pts, nrm, idx, k_lo, k_hi, cos_a)
    assert bk[0] == -1 and math.isinf(be[0])
    assert bk[3] == -1  # flipped normal
    np.testing.assert_allclose(be[np.isfinite(we)], we[np.isfinite(we)], atol=1e-7)
    assert (np.isinf(be) == np.isinf(we)).all()
    fin = np.isfinite(we)
    close = np.zeros(len(we), dtype=bool)
    close[fin] = np.abs(be[fin] - we[fin]) < 1e-9
    assert (bk[close] == wk[close]).all() and (bk[~fin] == -1).all()


@pytest.mark.parametrize("seed", [0, 1])
def test_adaptive_k_cache_gives_the_fresh_result(seed):
    """Kept choices (unchanged weight pattern) equal a fresh search, bit for bit."""
    pts, nrm, idx = _table(seed, n=40)
    pts = readonly_view(pts)  # as the filter passes them: the kernel's one signature
    n = len(pts)
    k_lo = np.full(n, 3, dtype=np.int64)
    k_hi = np.full(n, 12, dtype=np.int64)
    cos_a = math.cos(0.5)
    masks = np.full(n, -1, np.int64)
    bk, be = np.empty(n, np.int64), np.empty(n)
    adaptive_k_kernel(pts, nrm, idx, k_lo, k_hi, cos_a, bk, be, masks)
    assert (masks >= 0).all()
    rng = np.random.default_rng(seed + 5)
    for _ in range(3):  # small changes: most patterns stay, some flip
        nrm = nrm + rng.normal(scale=0.05, size=nrm.shape) * (rng.random((n, 1)) < 0.3)
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
        adaptive_k_kernel(pts, nrm, idx, k_lo, k_hi, cos_a, bk, be, masks)
        fk, fe = np.empty(n, np.int64), np.empty(n)
        adaptive_k_kernel(pts, nrm, idx, k_lo, k_hi, cos_a, fk, fe, np.full(n, -1, np.int64))
        assert np.array_equal(bk, fk) and np.array_equal(be, fe)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_voting_filter_matches_reference(seed):
    pts, nrm, idx = _table(seed)
    n = len(pts)
    k_of = np.random.default_rng(seed).integers(1, 13, size=n).astype(np.int64)
    use_cut = np.arange(n) % 3 != 0
    out = np.empty_like(nrm)
    voting_filter_kernel(nrm, idx, k_of, use_cut, 0.9, 0.3, out)
    want = ref.voting_filter(nrm, idx, k_of, use_cut, 0.9, 0.3)
    np.testing.assert_allclose(out, want, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0)


@pytest.mark.parametrize("tau", [0.05, 0.3, 0.9])
def test_voting_filter_near_degenerate_tensors(tau):
    """Tensors of two or three nearly equal eigenvalues and of well-separated ones
    match the reference (the shared `eigh3_accurate` eigenvectors)."""
    rng = np.random.default_rng(7)
    n = 24
    base = np.eye(3)[rng.integers(0, 3, size=n)]
    # groups of points whose neighbours hold 1, 2 or 3 orthogonal normals
    nrm = base + rng.normal(scale=1e-9, size=(n, 3)) * (np.arange(n) % 2)[:, None]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    idx = np.array([np.roll(np.arange(n), -i)[:6] for i in range(n)], dtype=np.int64)
    k_of = np.full(n, 6, np.int64)
    use_cut = np.zeros(n, bool)
    out = np.empty_like(nrm)
    voting_filter_kernel(nrm, idx, k_of, use_cut, 0.9, tau, out)
    want = ref.voting_filter(nrm, idx, k_of, use_cut, 0.9, tau)
    np.testing.assert_allclose(out, want, atol=1e-9)


def test_voting_filter_single_point_keeps_normal():
    nrm = np.array([[0.0, 0.6, 0.8]])
    out = np.empty_like(nrm)
    voting_filter_kernel(
        nrm, np.zeros((1, 1), np.int64), np.ones(1, np.int64), np.ones(1, bool), 0.9, 0.3, out
    )
    np.testing.assert_allclose(out, nrm)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_quadric_update_matches_reference(seed):
    pts, nrm, idx = _table(seed)
    # half the points get normals of a second plane: edges and corners appear
    nrm[:10] = _noisy_normals(np.random.default_rng(seed + 10), 10, 0.1)[:, [2, 0, 1]]
    k_of = np.full(len(pts), 10, dtype=np.int64)
    k_of[::3] = 1  # a lone point: face class, nothing to fit
    out = np.empty_like(pts)
    klass = np.empty(len(pts), dtype=np.int64)
    for sharpen in (True, False):
        quadric_update_kernel(pts, nrm, idx, k_of, 0.9, 0.1, 0.05, sharpen, out, klass)
        want, wclass = ref.quadric_update(pts, nrm, idx, k_of, 0.9, 0.1, 0.05, sharpen)
        assert (klass == wclass).all()
        assert {1, 2} <= set(klass.tolist())
        np.testing.assert_allclose(out, want, atol=1e-9)
        assert (np.linalg.norm(out - pts, axis=1) <= 0.05 + 1e-12).all()
    # without sharpening every move is along the point's own normal
    move = out - pts
    assert np.allclose(np.cross(move, nrm), 0.0, atol=1e-12)


def test_flatness_step_matches_reference():
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(60, 3)) * [1.0, 1.0, 0.05]
    got, energy, v3, valid = flatness_step(pts, 10, 0.5, 0.1)
    want = ref.flatness_step(pts, 10, 0.5, 0.1)
    assert valid.all()
    np.testing.assert_allclose(got, want, atol=1e-9)

"""estimate_normals / pca_normals: exact shapes, invariants, degenerate cases, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas._core import PointAtlasError
from pointatlas.neighbors import query_knn
from pointatlas.normals import PCANormalsResult, angle_error, estimate_normals, pca_normals

from ..strategies import rigid_motions, seeds
from .shapes import cylinder, sphere


def _rotation(seed):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def test_plane_exact():
    rng = np.random.default_rng(0)
    rot = _rotation(1)
    pts = np.column_stack([rng.random((500, 2)), np.zeros(500)]) @ rot.T + [5.0, -3.0, 2.0]
    normals = estimate_normals(pts, 12)
    assert normals.shape == (500, 3)
    assert normals.dtype == np.float64
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0)
    assert angle_error(normals, np.tile(rot[:, 2], (500, 1)), unoriented=True).max() < 1e-9


def test_plane_far_from_origin_keeps_precision():
    # UTM-like offsets: coordinates relative to each point keep the digits
    rng = np.random.default_rng(2)
    pts = np.column_stack([rng.random((300, 2)), np.zeros(300)]) * 0.01 + [5e5, 4e6, 300.0]
    normals = estimate_normals(pts, 10)
    assert np.abs(np.abs(normals[:, 2]) - 1.0).max() < 1e-7


def test_sphere_close_to_exact():
    pts, exact = sphere(3000, radius=2.0, center=(1.0, 2.0, 3.0))
    err = angle_error(estimate_normals(pts, 20), exact, unoriented=True)
    assert err.mean() < 0.01
    assert err.max() < 0.03


def test_cylinder_close_to_exact():
    pts, exact = cylinder(60, 20)
    err = angle_error(estimate_normals(pts, 12), exact, unoriented=True)
    assert err.mean() < 0.02
    assert err.max() < 0.1


def test_precomputed_neighbors_give_same_result():
    pts, _ = sphere(400)
    idx, dist = query_knn(pts, 25)
    direct = estimate_normals(pts, 15)
    assert np.array_equal(estimate_normals(pts, 15, neighbors=idx), direct)
    assert np.array_equal(estimate_normals(pts, 15, neighbors=(idx, dist)), direct)
    assert np.array_equal(estimate_normals(pts, 15, neighbors=idx.astype(np.int32)), direct)


def test_pca_result_fields():
    pts, _ = sphere(200)
    res = pca_normals(pts, 10)
    assert isinstance(res, PCANormalsResult)
    assert res.normals.shape == (200, 3) and res.eigenvalues.shape == (200, 3)
    assert res.is_degenerate.dtype == np.bool_ and res.n_degenerate == 0
    assert (np.diff(res.eigenvalues, axis=1) <= 0).all()
    assert (res.eigenvalues >= 0).all()
    assert not res.normals.flags.writeable
    # normal is orthogonal to the two larger principal directions: n^T C n = lambda_3
    idx, _ = query_knn(pts, 10)
    nb = pts[idx]
    d = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", d, d) / 10
    quad = np.einsum("ni,nij,nj->n", res.normals, cov, res.normals)
    assert np.allclose(quad, res.eigenvalues[:, 2], atol=1e-15)


def test_coincident_points_fallback_and_flag():
    pts = np.vstack([np.zeros((5, 3)), np.eye(3) * 10])
    res = pca_normals(pts, 4)
    assert res.is_degenerate[:5].all()
    assert np.array_equal(res.normals[:5], np.tile([0.0, 0.0, 1.0], (5, 1)))
    nan = estimate_normals(pts, 4, degenerate="nan")
    assert np.isnan(nan[:5]).all()


def test_collinear_points_orthogonal_to_line():
    t = np.linspace(0, 1, 30)[:, None]
    direction = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    pts = t * direction + [3.0, 1.0, 0.0]
    res = pca_normals(pts, 5)
    assert res.is_degenerate.all()
    assert np.abs(res.normals @ direction).max() < 1e-12
    assert np.allclose(np.linalg.norm(res.normals, axis=1), 1.0)
    assert np.isfinite(estimate_normals(pts, 5)).all()


def test_duplicate_points_do_not_crash():
    pts, exact = sphere(300)
    dup = np.vstack([pts, pts[:50], pts[:50]])
    normals = estimate_normals(dup, 10)
    assert np.isfinite(normals).all()
    assert angle_error(normals[:300], exact, unoriented=True).max() < 0.2


def test_inputs_not_modified():
    pts, _ = sphere(100)
    pts.flags.writeable = False
    idx, _ = query_knn(pts, 10)
    idx.flags.writeable = False
    before = pts.copy(), idx.copy()
    estimate_normals(pts, 10, neighbors=idx)
    assert np.array_equal(pts, before[0]) and np.array_equal(idx, before[1])


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"k": 2}, ValueError, r"k must be an integer in \[3, 100\]"),
        ({"k": 3.0}, TypeError, "k must be an integer"),
        ({"k": 500}, PointAtlasError, r"\(the number of points\); got 500"),
        ({"k": 5, "degenerate": "zero"}, ValueError, "degenerate must be"),
        ({"k": 5, "neighbors": np.zeros((100, 3), dtype=np.int64)}, ValueError, "m >= 5"),
        ({"k": 5, "neighbors": np.zeros((99, 5), dtype=np.int64)}, ValueError, "shape"),
        ({"k": 5, "neighbors": np.full((100, 5), 100)}, ValueError, r"range 100\.\.100"),
        ({"k": 5, "neighbors": np.zeros((100, 5))}, TypeError, "integer index array"),
    ],
)
def test_bad_input(kwargs, error, match):
    pts, _ = sphere(100)
    with pytest.raises(error, match=match):
        estimate_normals(pts, **kwargs)


def test_bad_points():
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        estimate_normals(np.zeros((10, 2)))
    bad = np.zeros((30, 3))
    bad[3] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        estimate_normals(bad, 5)


def _surface(seed, n):
    """A smooth random surface patch z = f(x, y) (well-separated eigenvalues)."""
    rng = np.random.default_rng(seed)
    xy = rng.random((n, 2))
    c = rng.normal(size=4) * 0.3
    z = c[0] * xy[:, 0] ** 2 + c[1] * xy[:, 0] * xy[:, 1] + c[2] * xy[:, 1] ** 2 + c[3] * xy[:, 0]
    return np.column_stack([xy, z])


@settings(deadline=None, max_examples=25)
@given(seed=seeds(), motion=rigid_motions(), n=st.integers(min_value=30, max_value=150))
def test_rigid_motion_equivariance_up_to_sign(seed, motion, n):
    rot, shift = motion
    pts = _surface(seed, n)
    moved = pts @ rot.T + shift
    a = estimate_normals(pts, 8) @ rot.T
    b = estimate_normals(moved, 8)
    assert angle_error(a, b, unoriented=True).max() < 1e-6


@settings(deadline=None, max_examples=15)
@given(seed=seeds(), n=st.integers(min_value=30, max_value=150))
def test_permutation_equivariance(seed, n):
    pts = _surface(seed, n)
    perm = np.random.default_rng(seed).permutation(n)
    a = estimate_normals(pts, 8)[perm]
    b = estimate_normals(pts[perm], 8)
    assert angle_error(a, b, unoriented=True).max() < 1e-9

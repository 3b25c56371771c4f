"""Small kernel-vs-reference checks, run JIT-compiled with the suite and once more with
NUMBA_DISABLE_JIT=1 (CONTRIBUTING.md, Tests: coverage of the kernel bodies)."""

import math

import numpy as np
import pytest

from pointatlas.features import (
    angle_pairs,
    covariance_features,
    optimal_neighborhood,
    symmetric_eigenvalues,
    weighted_covariances,
)
from pointatlas.neighbors import query_knn
from tests.features import reference as ref
from tests.jit_off import JIT_OFF, run_module_without_jit


def _cloud():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(16, 3)) * [1.0, 0.7, 0.1]
    pts[5] = pts[4]
    nrm = rng.normal(size=(16, 3)) * 0.3 + [0, 0, 1.0]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    return pts, nrm, query_knn(pts, 8)[0]


def test_covariances_and_eigenvalues_tiny_reference():
    pts, _, idx = _cloud()
    cov, reason = weighted_covariances(pts, idx)
    assert (reason == 0).all()
    for i in range(16):
        assert np.allclose(cov[i], ref.covariance(pts[idx[i]], np.ones(8)), atol=1e-12)
    ev = symmetric_eigenvalues(cov)
    assert np.allclose(ev, np.linalg.eigvalsh(cov)[:, ::-1], atol=1e-12)


def test_fixed_k_features_tiny_reference():
    pts, nrm, idx = _cloud()
    res = covariance_features(pts, 8, normals=nrm, a=0.2, b=1.0, neighbors=idx)
    for i in range(16):
        code, _, f = ref.point_features(pts, nrm, idx[i], 8, 0.2, 1.0)
        assert res.reason[i] == code
        if code == 0:
            assert abs(res.e_dim[i] - f["e_dim"]) < 1e-9


def test_search_tiny_reference():
    pts, nrm, idx = _cloud()
    grid = [0.0, math.pi / 3, math.pi]
    opt = optimal_neighborhood(pts, nrm, a_grid=grid, b_grid=grid, k_range=(4, 8), neighbors=idx)
    best, _, _ = ref.brute_force_search(pts, nrm, idx, angle_pairs(grid, grid), 4, 8)
    assert np.allclose(opt.e_dim, best, atol=1e-7)


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="tiny_reference")

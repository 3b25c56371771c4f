"""The polish after a high-noise run (`polish_kernel`, `_polish`; docs/decisions/denoise.md,
"Polish")."""

import numpy as np
import pytest

import pointatlas.denoise._voting as voting
from pointatlas.denoise import add_noise, normal_voting_denoise
from pointatlas.denoise._kernels import polish_kernel
from pointatlas.neighbors import query_knn
from pointatlas.synth import plane_patch, sphere
from tests.jit_off import JIT_OFF, run_module_without_jit


def _reference(points, idx, k_normal, k_mean, lam):
    """`polish_kernel` in plain numpy: each row re-sorted by the current distances,
    mean of the k_mean nearest, least eigenvector of the k_normal nearest."""
    out = points.copy()
    for i, row in enumerate(idx):
        near = row[np.argsort(((points[row] - points[i]) ** 2).sum(axis=1), kind="stable")]
        nb = points[near[:k_normal]]
        normal = np.linalg.eigh(np.cov(nb.T, bias=True))[1][:, 0]
        out[i] += lam * ((points[near[:k_mean]].mean(axis=0) - points[i]) @ normal) * normal
    return out


def test_polish_tiny_reference():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(40, 3)) * [1.0, 0.8, 0.2]
    idx = query_knn(pts + rng.normal(size=pts.shape) * 0.3, 16)[0]  # rows of other positions
    out = np.empty_like(pts)
    polish_kernel(pts, idx, 10, 6, 0.85, out)
    np.testing.assert_allclose(out, _reference(pts, idx, 10, 6, 0.85), atol=1e-12)
    assert not np.allclose(out, pts)


def _sphere_error(points):
    return float(np.abs(np.linalg.norm(points, axis=1) - 1.0).mean())


@pytest.fixture
def no_polish(monkeypatch):
    monkeypatch.setattr(voting, "POLISH_MOVE", np.inf)


def test_low_noise_run_is_not_polished(no_polish):
    m = plane_patch(24, 24)
    noisy = add_noise(m.points, m.normals, 0.3, rng=0)
    without = normal_voting_denoise(noisy, None)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(voting, "POLISH_MOVE", 0.28)
        polished = normal_voting_denoise(noisy, None)
    assert without.n_iter == 1
    np.testing.assert_array_equal(polished.points, without.points)


def test_polish_brings_a_very_noisy_sphere_closer(no_polish):
    m = sphere(3000)
    rng = np.random.default_rng(1)
    ell = float(
        np.mean(
            np.linalg.norm(m.points[query_knn(m.points, 7)[0][:, 1:]] - m.points[:, None], axis=2)
        )
    )
    noisy = m.points + rng.normal(size=m.points.shape) * 1.2 * ell
    without = normal_voting_denoise(noisy, None, adaptive=False)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(voting, "POLISH_MOVE", 0.0)  # any run of two or more rounds
        polished = normal_voting_denoise(noisy, None, adaptive=False)
    assert without.n_iter >= 2 and polished.n_iter == without.n_iter
    assert _sphere_error(polished.points) < _sphere_error(without.points)


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    out = run_module_without_jit(__file__, select="tiny_reference")
    assert "1 passed" in out, out[-500:]

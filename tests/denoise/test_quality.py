"""No default denoiser ends farther from the true surface than its input (issue 28 item 5).

The thin plates and the box have analytic distances to the true surface;
benchmarks/bench_denoise_quality.py measures the same on the shared noisy models.
"""

import numpy as np
import pytest

from pointatlas.denoise import add_noise, denoise
from pointatlas.synth import cube


def _plate(thickness, noise=0.3, n_side=2000, rng=0):
    """Two noisy 1 x 1 squares ``thickness`` noise sigmas apart, sigma = noise l."""
    gen = np.random.default_rng(rng)
    side = np.repeat([1.0, -1.0], n_side)
    sigma = noise / np.sqrt(n_side)
    h = thickness * sigma
    z = side * h / 2 + gen.normal(0.0, sigma, 2 * n_side)
    return np.c_[gen.uniform(0.0, 1.0, (2 * n_side, 2)), z], side, h, sigma


def _plate_rms(points, h):
    z = points[:, 2]
    return np.sqrt(np.mean(np.minimum(np.abs(z - h / 2), np.abs(z + h / 2)) ** 2))


@pytest.mark.parametrize("thickness", [1.6, 2.5])
@pytest.mark.parametrize("method", ["normal-voting", "normal-voting-adaptive", "flatness"])
def test_thin_plate_sides_stay_apart(method, thickness):
    # estimated normals face one way across the plate: without the sides told
    # apart the planes pulled both onto the mid-plane (2.5 sigma: 1.2-1.4x the
    # input's distance; 1.6 sigma: each side's mean offset 0.1 sigma of 0.8)
    pts, side, h, sigma = _plate(thickness)
    out = denoise(pts, None, method=method).points
    assert _plate_rms(out, h) < 0.8 * _plate_rms(pts, h)
    for s in (1.0, -1.0):  # each side on its own side, most of the way
        assert (out[side == s, 2] * s).mean() > 0.5 * (h / 2)


def _box_rms(points, half=0.5):
    """RMS distance to the surface of the cube [-half, half]^3."""
    a = np.abs(points) - half
    outside = np.sqrt((np.maximum(a, 0.0) ** 2).sum(axis=1))
    inside = np.minimum(a.max(axis=1), 0.0)
    return np.sqrt(np.mean((outside + inside) ** 2))


@pytest.mark.parametrize("pct", [1, 3])
def test_flatness_defaults_bring_a_noisy_box_closer(pct):
    # Eq. 6.3 at eta = 1 for 60 iterations is a curvature flow: it moved the cube's
    # points 4-15 noise sigmas and ended 3.7-11x farther than the input
    m = cube(16)
    radius = np.sqrt(3) / 2
    noisy = add_noise(m.points, m.normals, pct / 100, kind="isotropic", spacing=radius, rng=pct)
    r = denoise(noisy, None, method="flatness")
    assert _box_rms(r.points) < 0.9 * _box_rms(noisy)
    assert 0 < r.n_iter < 60  # stopped by the displacement rule


def test_flatness_explicit_iterations_run_them_all():
    m = cube(8)
    noisy = add_noise(m.points, m.normals, 0.3, k=6, rng=0)
    from pointatlas.denoise import flatness_denoise

    assert flatness_denoise(noisy, n_iter=5).n_iter == 5
    with pytest.raises(ValueError, match="noise must be a finite number >= 0"):
        flatness_denoise(noisy, noise=-1.0)

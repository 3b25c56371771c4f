"""Noise along normals and isotropic noise in units of the mean spacing l."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.neighbors import mean_spacing
from pointatlas.synth import add_gaussian_noise, add_normal_noise, fibonacci_sphere, plane_patch


@pytest.fixture(scope="module")
def sphere_points():
    mesh = fibonacci_sphere(20000, triangulate=False)
    return np.array(mesh.points), np.array(mesh.normals)


def test_normal_noise_std_matches_amplitude(sphere_points):
    pts, nrm = sphere_points
    ell = mean_spacing(pts, 12)
    noisy = add_normal_noise(pts, nrm, 0.25, rng=5)
    offset = noisy - pts
    along = np.einsum("ij,ij->i", offset, nrm)
    # all displacement is along the normal
    np.testing.assert_allclose(offset, along[:, None] * nrm, atol=1e-15)
    # std of N(0, s^2) from 20,000 draws has relative standard error 0.5 %
    assert along.std() == pytest.approx(0.25 * ell, rel=0.03)
    assert abs(along.mean()) < 4 * 0.25 * ell / np.sqrt(len(pts))


def test_normal_noise_k_and_spacing(sphere_points):
    pts, nrm = sphere_points
    ell6 = mean_spacing(pts, 6)
    a = add_normal_noise(pts, nrm, 0.3, k=6, rng=1)
    b = add_normal_noise(pts, nrm, 0.3, spacing=ell6, rng=1)
    np.testing.assert_array_equal(a, b)
    c = add_normal_noise(pts, nrm, 0.3, spacing=2 * ell6, rng=1)
    np.testing.assert_allclose(c - pts, 2 * (a - pts), rtol=1e-12, atol=1e-15)


def test_gaussian_noise_std(sphere_points):
    pts, _ = sphere_points
    ell = mean_spacing(pts, 12)
    offset = add_gaussian_noise(pts, 0.5, rng=2) - pts
    np.testing.assert_allclose(offset.std(axis=0), 0.5 * ell, rtol=0.03)


def test_determinism_and_inputs_untouched():
    mesh = plane_patch(10, 10)
    pts, nrm = np.array(mesh.points), np.array(mesh.normals)
    a = add_normal_noise(pts, nrm, 0.5, rng=11)
    b = add_normal_noise(pts, nrm, 0.5, rng=np.random.default_rng(11))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, add_normal_noise(pts, nrm, 0.5, rng=12))
    np.testing.assert_array_equal(pts, mesh.points)
    np.testing.assert_array_equal(add_normal_noise(pts, nrm, 0.0, rng=1), pts)
    g1 = add_gaussian_noise(pts, 0.5, rng=11)
    np.testing.assert_array_equal(g1, add_gaussian_noise(pts, 0.5, rng=11))
    np.testing.assert_array_equal(a[:, :2], pts[:, :2])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"amplitude": -0.1}, "amplitude must be"),
        ({"amplitude": np.inf}, "amplitude must be"),
        ({"amplitude": 0.1, "k": 0}, "k must be a positive integer"),
        ({"amplitude": 0.1, "k": 50}, "at least k \\+ 1 = 51"),
        ({"amplitude": 0.1, "spacing": -1.0}, "spacing must be"),
    ],
)
def test_bad_arguments(kwargs, match):
    mesh = plane_patch(4, 4)
    with pytest.raises(ValueError, match=match):
        add_normal_noise(mesh.points, mesh.normals, **kwargs)


def test_normals_shape_checked():
    mesh = plane_patch(4, 4)
    with pytest.raises(ValueError, match="normals must have one row per point"):
        add_normal_noise(mesh.points, mesh.normals[:3], 0.1)

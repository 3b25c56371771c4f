"""Noise models and the measures of the denoising literature."""

import numpy as np
import pytest

from pointatlas.denoise import (
    add_impulsive_noise,
    add_noise,
    chamfer_distance,
    denoise_measures,
    normal_mse,
    unit_sphere_transform,
)
from pointatlas.neighbors import mean_spacing, point_mesh_distance
from pointatlas.synth import cube, plane_patch
from tests.denoise import reference as ref


def test_normal_mse_eq_5_10():
    n = np.array([[0, 0, 1.0], [0, 0, 1.0], [1.0, 0, 0]])
    assert normal_mse(n, n) == 0.0
    assert normal_mse(-n, n) == pytest.approx(4.0)
    with pytest.raises(ValueError, match="normals must have one row per point"):
        normal_mse(n[:2], n)


def test_chamfer_scale_invariant_and_symmetric():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(50, 3))
    b = a + rng.normal(size=(50, 3)) * 0.01
    c = chamfer_distance(a, b)
    assert c > 0
    assert chamfer_distance(10 * a + 3, 10 * b + 3) == pytest.approx(c)
    center, radius = unit_sphere_transform(b)
    assert np.allclose(center, b.mean(axis=0)) and radius > 0
    raw = chamfer_distance(a, b, normalize=False)
    assert raw == pytest.approx(c * radius**2)


def test_point_to_mesh_on_cube_surface_and_offsets():
    m = cube(3)
    d = point_mesh_distance(m.points, m.points, m.faces)
    assert np.abs(d).max() < 1e-15
    q = np.array([[0.0, 0.0, 0.7], [0.6, 0.6, 0.0], [0.1, 0.0, 0.0]])
    np.testing.assert_allclose(
        point_mesh_distance(q, m.points, m.faces),
        ref.point_to_mesh(q, m.points, m.faces),
        atol=1e-12,
    )
    np.testing.assert_allclose(
        point_mesh_distance(q, m.points, m.faces), [0.2, np.sqrt(0.02), 0.4], atol=1e-12
    )


def test_denoise_measures_noise_levels():
    m = cube(8)
    noisy = add_noise(m.points, m.normals, 0.6, k=6, rng=0)
    r = denoise_measures(
        noisy, m.points, normals=m.normals, clean_normals=m.normals, clean_faces=m.faces
    )
    assert r.matched == "index" and r.normal_mse == 0.0
    assert r.drift_share == 0.0  # noise along the normals is not tangential
    assert 0 < r.p2m_mean <= r.distance_mean + 1e-12 and r.p2m_max <= r.distance_max + 1e-12
    assert r.spacing == pytest.approx(mean_spacing(m.points, 6))
    # noise std 0.6 l: the mean |displacement| is about 0.6 l sqrt(2/pi)
    assert 0.3 < r.distance_mean / r.spacing < 0.7
    d = r.as_dict()
    assert set(d) >= {"chamfer", "p2m_mean", "normal_mse", "drift_share"}
    sub = denoise_measures(noisy[::2], m.points)
    assert sub.matched == "nearest" and np.isnan(sub.p2m_mean) and np.isnan(sub.drift_share)


def test_tangential_drift_share():
    m = plane_patch(10, 10)
    ell = mean_spacing(m.points, 6)
    moved = np.array(m.points)
    moved[:25, 0] += 2 * ell
    r = denoise_measures(moved, m.points, clean_normals=m.normals)
    assert r.drift_share == pytest.approx(0.25)


def test_noise_models_deterministic_and_shaped():
    m = cube(6)
    for kind in ("normal", "impulsive", "isotropic"):
        a = add_noise(m.points, m.normals, 0.3, kind=kind, rng=5)
        b = add_noise(m.points, m.normals, 0.3, kind=kind, rng=5)
        assert np.array_equal(a, b) and a.shape == m.points.shape
    imp = add_impulsive_noise(m.points, m.normals, 2.0, fraction=0.2, rng=1)
    moved = np.linalg.norm(imp - m.points, axis=1) > 0
    assert moved.sum() == round(0.2 * m.n_vertices)
    with pytest.raises(ValueError, match=r"fraction must be a finite number in \[0, 1\]"):
        add_impulsive_noise(m.points, m.normals, 1.0, fraction=1.5)
    with pytest.raises(ValueError, match="kind must be one of normal, impulsive, isotropic"):
        add_noise(m.points, m.normals, 0.3, kind="salt")

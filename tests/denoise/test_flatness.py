"""Flatness denoising (thesis Eq. 6.3) and its schedules."""

import numpy as np
import pytest

from pointatlas.denoise import add_noise, flatness_denoise, flatness_schedule
from pointatlas.synth import dodecahedron, plane_patch


def test_plane_flatter_and_shapes():
    m = plane_patch(20, 20)
    noisy = add_noise(m.points, m.normals, 0.4, k=12, rng=0)
    r = flatness_denoise(noisy, k=14, eta=1.0, n_iter=20, normals=m.normals)
    assert np.sqrt(np.mean(r.points[:, 2] ** 2)) < 0.5 * np.sqrt(np.mean(noisy[:, 2] ** 2))
    assert r.points.shape == (400, 3) and r.energy.shape == (400,) and r.k.dtype == np.int64
    assert (r.normals[:, 2] > 0).all()  # oriented like the input normals
    assert not r.points.flags.writeable
    assert r.method == "flatness" and r.n_iter == 20


def test_eta_one_moves_only_along_v3_on_a_plane():
    m = plane_patch(12, 12)
    noisy = add_noise(m.points, m.normals, 0.3, k=12, rng=1)
    r = flatness_denoise(noisy, k=10, eta=1.0, n_iter=1)
    # the plane term moves along the PCA normal, which is close to z here
    move = r.points - noisy
    assert np.abs(move[:, :2]).max() < 0.5 * np.abs(move[:, 2]).max()


def test_schedules():
    ks, etas = flatness_schedule(5, 8, 0.5, schedule="decreasing", k_start=32)
    assert ks[0] == 32 and ks[-1] == 8 and (np.diff(ks) <= 0).all()
    assert etas[0] == 1.0 and etas[-1] == 0.5
    ks, etas = flatness_schedule(3, 14, 1.0)
    assert ks.tolist() == [14, 14, 14] and etas.tolist() == [1.0, 1.0, 1.0]
    with pytest.raises(ValueError, match="schedule must be one of constant, decreasing"):
        flatness_schedule(3, 14, 1.0, schedule="linear")


def test_decreasing_schedule_runs_and_is_deterministic():
    m = dodecahedron(4)
    noisy = add_noise(m.points, m.normals, 0.25, k=12, rng=2)
    a = flatness_denoise(noisy, k=8, eta=0.5, n_iter=6, schedule="decreasing")
    b = flatness_denoise(noisy, k=8, eta=0.5, n_iter=6, schedule="decreasing")
    assert np.array_equal(a.points, b.points)
    assert a.k.max() == 8


def test_validation():
    pts = plane_patch(6, 6).points
    with pytest.raises(ValueError, match=r"eta must be a finite number in \[0, 1\]; got 2.0"):
        flatness_denoise(pts, k=8, eta=2.0)
    with pytest.raises(ValueError, match=r"k must be an integer in \[3, 35\]"):
        flatness_denoise(pts, k=40)
    with pytest.raises(ValueError, match="eps must be a finite number > 0"):
        flatness_denoise(pts, k=8, eps=0.0)

"""Normal voting filtering (thesis 5.4, [YRS+18] reconstructed) and the point update."""

import math

import numpy as np
import pytest

from pointatlas.denoise import (
    THESIS_FILTER_PARAMETERS,
    add_noise,
    default_neighborhoods,
    denoise,
    filter_normals,
    normal_mse,
    normal_voting_denoise,
)
from pointatlas.normals import angle_error
from pointatlas.synth import cube, plane_patch, vertex_normals


@pytest.fixture(scope="module")
def noisy_cube():
    """cube(12) with 0.3 l noise along the normals (l: 6-NN), noisy-mesh vertex normals."""
    m = cube(12)
    noisy = add_noise(m.points, m.normals, 0.3, k=6, rng=3)
    return m, noisy, vertex_normals(noisy, m.faces)


def _near_edge_face_points(m, ell, width=2.0):
    a = np.sort(np.abs(m.points), axis=1)
    return ~m.is_sharp & (0.5 - a[:, 1] <= width * ell + 1e-9)


def test_clean_cube_normals_unchanged():
    m = cube(8)
    for adaptive in (False, True):
        r = filter_normals(m.points, m.normals, rho=0.95, tau=0.3, n_iter=10, adaptive=adaptive)
        np.testing.assert_allclose(r.normals, m.normals, atol=1e-12)
        assert r.normals.shape == (m.n_vertices, 3) and r.normals.dtype == np.float64
        assert r.k.dtype == np.int64 and not r.normals.flags.writeable


def test_adaptive_lowers_the_normal_mse_on_the_cube_at_0_3_l():
    """Table 5.3's claim, read over noise draws (thesis 5.4: MSE(K) < MSE([YRS+18])).

    The thesis compares one noise draw per model. Per draw the claim can fail: on
    cube(18) with seed 0 the adaptive MSE is 0.4 % above the fixed one, because a
    few edge points choose a k whose votes snap their normal to a face while the
    ground truth there is the area-weighted blend (docs/decisions/denoise.md). So
    the test takes the first six seeds, fixed in advance: the adaptive variant must
    lower the mean MSE and win most draws.
    """
    m = cube(12)
    p, rho, tau = THESIS_FILTER_PARAMETERS["cube"]
    fixed_mse, adaptive_mse = [], []
    for seed in range(6):
        noisy = add_noise(m.points, m.normals, 0.3, k=6, rng=seed)
        nn = vertex_normals(noisy, m.faces)
        fixed = filter_normals(noisy, nn, rho=rho, tau=tau, n_iter=p)
        adaptive = filter_normals(noisy, nn, rho=rho, tau=tau, n_iter=p, adaptive=True)
        fixed_mse.append(normal_mse(fixed.normals, m.normals))
        adaptive_mse.append(normal_mse(adaptive.normals, m.normals))
        assert fixed_mse[-1] < normal_mse(nn, m.normals)  # the filter helps at all
        # the chosen k lies in the thesis' range around the default k
        ok = ~adaptive.is_fallback
        assert (np.abs(adaptive.k[ok] - adaptive.default_k[ok]) <= 10).all()
    fixed_mse, adaptive_mse = np.array(fixed_mse), np.array(adaptive_mse)
    assert adaptive_mse.mean() < fixed_mse.mean()
    assert (adaptive_mse < fixed_mse).sum() > len(fixed_mse) / 2


def test_range_fits_the_cached_weight_patterns():
    from pointatlas._core.tolerances import DENOISE_K_MAX, DENOISE_K_WIDTH
    from pointatlas.denoise._kernels import MASK_BITS

    assert DENOISE_K_MAX + DENOISE_K_WIDTH <= MASK_BITS


@pytest.mark.parametrize("kw", [{}, {"n_filter_iter": 30}, {"adaptive": False}])
def test_sharp_edges_survive_filter_and_update(noisy_cube, kw):
    m, noisy, nn = noisy_cube
    r = normal_voting_denoise(noisy, nn, rho=0.95, tau=0.3, **kw)
    near = _near_edge_face_points(m, 1 / 12)
    ang = np.degrees(angle_error(r.normals, m.normals))[near]
    # normals on both sides of every edge stay within 5 degrees of their face's
    assert np.percentile(ang, 95) < 5.0 and (ang < 5.0).mean() > 0.9
    # edge points are classified as edges or corners, face centres as faces
    centre = np.abs(np.sort(np.abs(m.points), axis=1)[:, 1]) < 0.2
    assert (r.feature_class[centre] == 1).mean() > 0.95
    assert (r.feature_class[m.is_sharp] >= 2).mean() > 0.5
    # the update moves points towards the surface
    dist_before = np.abs(np.abs(noisy).max(axis=1) - 0.5).mean()
    dist_after = np.abs(np.abs(r.points).max(axis=1) - 0.5).mean()
    assert dist_after < 0.6 * dist_before


def test_estimated_normals_are_refitted_to_their_faces():
    """PCA normals blend across edges and the filter keeps some of it; the returned
    normals of a run that estimated them are refitted to each point's face."""
    m = cube(12)
    noisy = add_noise(m.points, m.normals, 0.15, k=6, rng=5)
    est = normal_voting_denoise(noisy, None, adaptive=False)
    assert est.n_iter >= 1  # default with estimated normals: 1 filter step per round
    given = normal_voting_denoise(noisy, est_input(noisy), adaptive=False, n_filter_iter=1)
    np.testing.assert_allclose(est.points, given.points, rtol=0, atol=1e-9)  # moves nothing
    near = _near_edge_face_points(m, 1 / 12)
    ok_est = (np.degrees(angle_error(est.normals, m.normals))[near] < 5.0).mean()
    ok_given = (np.degrees(angle_error(given.normals, m.normals))[near] < 5.0).mean()
    assert ok_est > ok_given + 0.15 and ok_est > 0.95  # measured 0.98 vs 0.76
    # given normals refitted on request (the CLI does so when it estimated them)
    asked = normal_voting_denoise(noisy, est_input(noisy), adaptive=False, refit_normals=True)
    np.testing.assert_allclose(asked.normals, est.normals, rtol=0, atol=1e-9)


def est_input(points):
    """The normals `normal_voting_denoise` estimates (PCA k = 20, MST orientation)."""
    from pointatlas.neighbors import query_knn
    from pointatlas.normals import estimate_normals, orient_normals

    table = query_knn(points, 48)[0]
    return orient_normals(points, estimate_normals(points, 20, neighbors=table), neighbors=table)


@pytest.mark.parametrize("method", ["normal-voting", "normal-voting-adaptive", "flatness"])
def test_noisy_plane_gets_flatter(method):
    m = plane_patch(24, 24)
    noisy = add_noise(m.points, m.normals, 0.5, k=6, rng=7)
    r = denoise(noisy, m.normals, method=method)
    inner = np.abs(m.points[:, :2]).max(axis=1) < 0.4  # away from the open border
    rms_before = math.sqrt(np.mean(noisy[inner, 2] ** 2))
    rms_after = math.sqrt(np.mean(r.points[inner, 2] ** 2))
    assert rms_after < 0.5 * rms_before
    assert r.points.shape == (m.n_vertices, 3) and r.displacement.shape == (m.n_vertices,)


def test_denoise_without_normals_estimates_them():
    """Normal voting without normals: PCA normals (k = 20), MST-oriented outwards."""
    m = cube(8)
    noisy = add_noise(m.points, m.normals, 0.3, k=6, rng=1)
    r = denoise(noisy, None, method="normal-voting")
    assert r.method == "normal-voting" and np.isfinite(r.normals).all()
    assert ((r.normals * m.normals).sum(axis=1) > 0.5).mean() > 0.95  # outward
    dist = np.abs(np.abs(r.points).max(axis=1) - 0.5).mean()
    assert dist < 0.6 * np.abs(np.abs(noisy).max(axis=1) - 0.5).mean()
    assert denoise(noisy).method == "normal-voting"  # auto


def test_same_seed_same_output():
    m = cube(6)
    outs = []
    for _ in range(2):
        noisy = add_noise(m.points, m.normals, 0.6, k=6, rng=11)
        r = normal_voting_denoise(noisy, vertex_normals(noisy, m.faces), n_iter=2)
        outs.append((noisy, r.points, r.normals, r.k))
    for a, b in zip(outs[0], outs[1], strict=True):
        assert np.array_equal(a, b)


def test_default_neighbourhoods_sizes():
    pts = plane_patch(20, 20).points
    idx, k, ell = default_neighborhoods(pts, extra=10)
    assert idx.shape[1] == int(k.max()) + 10 and (idx[:, 0] == np.arange(len(pts))).all()
    assert 12 <= np.median(k) <= 24 and ell > 0  # 21 lattice points within 2.28 h


def test_validation_messages():
    m = cube(4)
    with pytest.raises(ValueError, match=r"rho must be a finite number in \[-1, 1\]"):
        filter_normals(m.points, m.normals, rho=2.0)
    with pytest.raises(ValueError, match="normals must have one row per point"):
        filter_normals(m.points, m.normals[:5])
    with pytest.raises(TypeError, match="n_iter must be an integer"):
        filter_normals(m.points, m.normals, n_iter=1.5)
    with pytest.raises(ValueError, match="points must hold at least 8"):
        normal_voting_denoise(m.points[:5], m.normals[:5])
    with pytest.raises(ValueError, match="method must be one of"):
        denoise(m.points, m.normals, method="median")


def test_fewer_than_ten_points_without_normals():
    """The orientation graph is capped at the point count (8 points, no normals)."""
    pts = np.random.default_rng(0).normal(size=(8, 3)) * [1.0, 1.0, 0.05]
    for adaptive in (False, True):
        r = normal_voting_denoise(pts, None, adaptive=adaptive)
        assert r.points.shape == (8, 3) and np.isfinite(r.points).all()
        np.testing.assert_allclose(np.linalg.norm(r.normals, axis=1), 1.0)


@pytest.mark.parametrize(
    ("call", "name", "why"),
    [
        (lambda m: filter_normals(m.points, m.normals, n_iter=10**12), "n_iter", "filter step"),
        (lambda m: normal_voting_denoise(m.points, m.normals, n_iter=10**12), "n_iter", "round"),
        (
            lambda m: normal_voting_denoise(m.points, m.normals, n_filter_iter=10**12),
            "n_filter_iter",
            "filter step",
        ),
    ],
)
def test_iteration_counts_are_capped_before_any_work(call, name, why):
    """10^12 iterations are refused in one line at once (not run for ages)."""
    msg = rf"^{name} must be an integer in \[0, 100000\] \(each {why} is a pass over every point\)"
    with pytest.raises(ValueError, match=msg):
        call(cube(4))

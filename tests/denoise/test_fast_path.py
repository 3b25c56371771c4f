"""The normal voting pipeline: one neighbour table, the symmetric plane update, the
automatic stops, and the one-thread rule (docs/decisions/denoise.md)."""

import numpy as np
import pytest

from pointatlas.denoise import _filter, _threads, _voting, add_noise, normal_voting_denoise
from pointatlas.denoise._kernels import (
    feature_class_kernel,
    plane_lists_kernel,
    plane_update_kernel,
)
from pointatlas.neighbors import query_knn
from pointatlas.synth import cube
from tests.denoise import reference as ref


def _blob(rng, n):
    """A noisy wavy sheet with a fold: uneven density, outliers, two normal families."""
    uv = rng.uniform(-1, 1, size=(n, 2))
    z = 0.2 * np.sin(3 * uv[:, 0]) + np.where(uv[:, 1] > 0.3, uv[:, 1] - 0.3, 0.0)
    pts = np.column_stack([uv, z]) + rng.normal(scale=0.01, size=(n, 3))
    pts[: n // 50] += rng.normal(scale=0.2, size=(n // 50, 3))  # a few far points
    return pts


def _plane_lists(nrm, idx, k_of, cos_rho):
    lists = np.empty_like(idx)
    counts = np.empty(len(idx), np.int64)
    plane_lists_kernel(nrm, idx, k_of, cos_rho, lists, counts)
    return lists, counts


@pytest.mark.parametrize("extra", [0, 10])
def test_neighbourhoods_match_brute_force(extra):
    rng = np.random.default_rng(3)
    for n in (60, 700):
        pts = _blob(rng, n)
        table, idx, k, ell = _filter._neighbourhoods(pts, 2.0, extra)
        want_k, want_ell = ref.neighbourhoods(pts, 2.0)
        assert np.array_equal(k, want_k) and ell == pytest.approx(want_ell, rel=1e-12)
        assert np.array_equal(table, query_knn(pts, min(48 + extra, n))[0])
        assert np.array_equal(idx, table[:, : int(k.max()) + extra])


@pytest.mark.parametrize("seed", [0, 1])
def test_plane_update_matches_reference(seed):
    rng = np.random.default_rng(seed)
    pts = _blob(rng, 300)
    nrm = rng.normal(size=(300, 3)) * 0.2 + [0, 0, 1.0]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    idx = query_knn(pts, 16)[0]
    k_of = rng.integers(1, 17, size=300).astype(np.int64)
    out = np.empty_like(pts)
    plane_update_kernel(
        pts, nrm, *_plane_lists(nrm, idx, k_of, 0.95), 0.02, 1.0 / 0.05**2, 1.0, out, np.empty(300)
    )
    want = ref.plane_update(pts, nrm, idx, k_of, 0.95, 0.02, 0.05)
    np.testing.assert_allclose(out, want, atol=1e-12)
    leaning = np.empty_like(pts)  # later rounds: (2 - beta) n_i + beta n_j
    plane_update_kernel(
        pts,
        nrm,
        *_plane_lists(nrm, idx, k_of, 0.95),
        0.02,
        1.0 / 0.05**2,
        0.75,
        leaning,
        np.empty(300),
    )
    want = ref.plane_update(pts, nrm, idx, k_of, 0.95, 0.02, 0.05, beta=0.75)
    np.testing.assert_allclose(leaning, want, atol=1e-12)
    assert not np.allclose(leaning, out, atol=1e-6)
    step = np.linalg.norm(out - pts, axis=1)
    assert step.max() <= 0.02 + 1e-15 and (step > 0).any()
    assert np.allclose(np.cross(out - pts, nrm), 0.0, atol=1e-12)  # along the own normal


@pytest.mark.parametrize("shape", ["sphere", "cylinder"])
def test_points_on_spheres_and_cylinders_stay(shape):
    """(n_i + n_j) . (p_j - p_i) = 0 on a sphere and a cylinder: no inflation; the
    one-sided planes of the old update push the convex surface out."""
    rng = np.random.default_rng(5)
    v = rng.normal(size=(2000, 3))
    if shape == "cylinder":
        v[:, 2] = 0.0
    nrm = v / np.linalg.norm(v, axis=1)[:, None]
    pts = 2.0 * nrm
    if shape == "cylinder":
        pts[:, 2] = rng.uniform(-1, 1, size=2000)
    idx = query_knn(pts, 20)[0]
    k_of = np.full(2000, 20, np.int64)
    out = np.empty_like(pts)
    plane_update_kernel(
        pts, nrm, *_plane_lists(nrm, idx, k_of, 0.9), 1.0, 1.0 / 0.1**2, 1.0, out, np.empty(2000)
    )
    np.testing.assert_allclose(out, pts, atol=1e-13)
    from pointatlas.denoise._sharpen import quadric_update_kernel

    quadric_update_kernel(pts, nrm, idx, k_of, 0.9, 0.3, 1.0, False, out, np.empty(2000, np.int64))
    assert ((out - pts) * nrm).sum(axis=1).mean() > 1e-4  # outwards


def test_feature_classes_match_the_quadric_kernel():
    from pointatlas.denoise._sharpen import quadric_update_kernel

    m = cube(8)
    idx = query_knn(m.points, 12)[0]
    k_of = np.full(m.n_vertices, 12, np.int64)
    klass = np.empty(m.n_vertices, np.int64)
    want = np.empty(m.n_vertices, np.int64)
    # writeable copies, as the denoising loop passes its working arrays (one signature)
    pts, nrm = m.points.copy(), m.normals.copy()
    feature_class_kernel(nrm, idx, k_of, 0.3, klass)
    quadric_update_kernel(pts, nrm, idx, k_of, 0.9, 0.3, 0.1, False, np.empty_like(pts), want)
    assert np.array_equal(klass, want) and set(klass.tolist()) == {1, 2, 3}


def test_clean_cube_stays_in_place():
    """Exact normals of a clean cube (area-weighted at edges and corners): nothing
    moves, one round, and the automatic stop ends the updates at once."""
    m = cube(8)
    for adaptive in (False, True):
        r = normal_voting_denoise(m.points, m.normals, rho=0.95, adaptive=adaptive)
        np.testing.assert_allclose(r.points, m.points, atol=1e-12)
        assert r.n_iter == 1 and r.displacement.max() < 1e-12


def test_automatic_rounds_equal_explicit_ones():
    """n_iter=None stops where an explicit count gives the same result."""
    m = cube(12)
    for noise in (0.3, 1.2):
        noisy = add_noise(m.points, m.normals, noise, k=6, rng=2)
        auto = normal_voting_denoise(noisy, None, adaptive=False)
        again = normal_voting_denoise(noisy, None, adaptive=False, n_iter=auto.n_iter)
        assert np.array_equal(auto.points, again.points)
        assert 1 <= auto.n_iter <= _voting.MAX_ROUNDS
    assert auto.n_iter >= 2  # the high noise takes another round


def test_one_thread_and_parallel_give_the_same_bits(monkeypatch):
    """Small inputs on a busy machine run every kernel in one thread; same output."""
    import numba

    from pointatlas.denoise import flatness_denoise

    rng = np.random.default_rng(7)
    pts = _blob(rng, 900)
    threads = numba.get_num_threads()
    seen = []
    orig = _filter.voting_filter_kernel

    def spy(*args):
        seen.append(numba.get_num_threads())
        return orig(*args)

    monkeypatch.setattr(_filter, "voting_filter_kernel", spy)
    out = {}
    for busy in (True, False):
        monkeypatch.setattr(_threads, "machine_busy", lambda busy=busy: busy)
        out[busy] = (
            normal_voting_denoise(pts, None, n_iter=2, n_filter_iter=3),
            flatness_denoise(pts, k=10, n_iter=3),
        )
        assert numba.get_num_threads() == threads  # restored
    # 2 rounds of 3 steps each (estimated normals: the last ones refitted, not filtered)
    assert seen == [1] * 6 + [threads] * 6
    (one, flat_one), (par, flat_par) = out[True], out[False]
    assert np.array_equal(one.points, par.points) and np.array_equal(one.normals, par.normals)
    assert np.array_equal(flat_one.points, flat_par.points)
    monkeypatch.setattr(_threads, "machine_busy", lambda: True)
    with _threads.threads_for(_threads.PARALLEL_MIN_POINTS):  # large inputs: untouched
        assert numba.get_num_threads() == threads
    assert isinstance(_threads.machine_busy(), bool)


def test_estimated_normals_from_the_first_table():
    """Without normals: PCA + orientation as on a fresh normal_k-NN table (also when
    normal_k exceeds the table's width and needs its own query)."""
    from pointatlas.normals import estimate_normals, orient_normals

    pts = _blob(np.random.default_rng(4), 400)
    for normal_k in (20, 60):
        knn = query_knn(pts, normal_k)
        want = orient_normals(pts, estimate_normals(pts, normal_k, neighbors=knn), neighbors=knn)
        r = normal_voting_denoise(pts, None, n_iter=0, normal_k=normal_k)
        assert np.array_equal(r.normals, want)
        # a round on them moves the points as on the normals given (up to their
        # rescaling to unit length); only estimated normals are refitted at the end
        r = normal_voting_denoise(pts, None, n_iter=1, n_filter_iter=0, normal_k=normal_k)
        given = normal_voting_denoise(pts, want, n_iter=1, n_filter_iter=0, normal_k=normal_k)
        np.testing.assert_allclose(r.points, given.points, rtol=0, atol=1e-12)
        np.testing.assert_allclose(given.normals, want, rtol=0, atol=1e-9)


def test_default_filter_steps_follow_the_returned_normals(monkeypatch):
    """n_filter_iter None: 1 step per round when the returned normals are refitted
    (estimated), 5 per round and 5 more when they are filtered (given)."""
    from pointatlas.denoise import default_filter_iter, denoise_halo

    assert (default_filter_iter(True), default_filter_iter(False)) == (1, 5)
    pts = _blob(np.random.default_rng(3), 500)
    calls = []
    orig = _filter.voting_filter_kernel

    def spy(*args):
        calls.append(1)
        return orig(*args)

    monkeypatch.setattr(_filter, "voting_filter_kernel", spy)
    est = normal_voting_denoise(pts, None, n_iter=2, n_update=1, adaptive=False)
    assert len(calls) == 2
    calls.clear()
    given = normal_voting_denoise(pts, est.normals, n_iter=2, n_update=1, adaptive=False)
    assert len(calls) == 2 * 5 + 5
    calls.clear()
    normal_voting_denoise(pts, est.normals, n_iter=2, n_update=1, refit_normals=True)
    assert len(calls) == 2
    assert given.n_iter == est.n_iter == 2
    # the halo counts the same steps (and the lonely-normal pass of each round)
    assert denoise_halo(n_iter=2, n_update=1).rings == 2 * (5 + 1) + 1 + 2 + 5 + 1
    assert denoise_halo(n_iter=2, n_update=1, estimate=True).rings == 2 * (1 + 1) + 1 + 2 + 1 + 1


def test_lonely_points_take_their_neighbours_normals(monkeypatch):
    """Points far off a plane with sideways normals have no plane within the cut-off;
    the lonely pass gives them the plane's normal and the update pulls them back
    (docs/decisions/denoise.md, "Lonely points"); without it they stay off."""
    from pointatlas.synth import add_normal_noise, plane_patch

    m = plane_patch(20, 20)
    pts = add_normal_noise(m.points, m.normals, 0.2, rng=1)
    nrm = m.normals.copy()
    far = np.random.default_rng(0).choice(len(pts), 12, replace=False)
    pts[far, 2] += 0.8 * np.linalg.norm(pts[1] - pts[0])
    nrm[far] = [np.sin(np.radians(80)), 0.0, np.cos(np.radians(80))]
    r = normal_voting_denoise(pts, nrm, n_iter=1, adaptive=False)
    rest = np.delete(np.abs(r.points[:, 2]), far)
    assert np.abs(r.points[far, 2]).max() <= 1.1 * rest.max()
    assert (r.normals[far, 2] > 0.999).all()
    monkeypatch.setattr(_voting, "LONELY_PASSES", 0)
    off = normal_voting_denoise(pts, nrm, n_iter=1, adaptive=False)
    assert np.abs(off.points[far, 2]).mean() > 4 * np.abs(r.points[far, 2]).mean()
    assert (off.normals[far, 2] < 0.2).all()

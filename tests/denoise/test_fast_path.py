"""The fast normal voting pipeline gives the previous implementation's output bit for bit.

Speed work (docs/decisions/denoise.md, "Speed"): one table serves normal
estimation, orientation and the first filter run; later tables are queried only
as wide as the last need (checked); small inputs on a busy machine run every
kernel in one thread.
``tests/denoise/reference.py`` keeps the previous pipeline.
"""

import numpy as np
import pytest

from pointatlas.denoise import _voting, add_noise, normal_voting_denoise
from pointatlas.neighbors import query_knn
from pointatlas.synth import cube, vertex_normals
from tests.denoise import reference as ref


def _blob(rng, n):
    """A noisy wavy sheet with a fold: uneven density, outliers, two normal families."""
    uv = rng.uniform(-1, 1, size=(n, 2))
    z = 0.2 * np.sin(3 * uv[:, 0]) + np.where(uv[:, 1] > 0.3, uv[:, 1] - 0.3, 0.0)
    pts = np.column_stack([uv, z]) + rng.normal(scale=0.01, size=(n, 3))
    pts[: n // 50] += rng.normal(scale=0.2, size=(n // 50, 3))  # a few far points
    return pts


def _same(result, previous):
    p, n, k, klass = previous
    assert np.array_equal(result.points, p)
    assert np.array_equal(result.normals, n)
    assert np.array_equal(result.k, k)
    assert np.array_equal(result.feature_class, klass.astype(np.int8))


@pytest.mark.parametrize("adaptive", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_equals_previous_without_normals(adaptive, seed):
    rng = np.random.default_rng(seed)
    pts = _blob(rng, int(rng.integers(300, 1500)))
    kw = dict(adaptive=adaptive, n_iter=3, n_filter_iter=4)
    _same(normal_voting_denoise(pts, None, **kw), ref.previous_normal_voting_denoise(pts, **kw))


@pytest.mark.parametrize("adaptive", [False, True])
def test_equals_previous_with_normals_and_sharpen(adaptive):
    m = cube(10)
    noisy = add_noise(m.points, m.normals, 0.5, k=6, rng=5)
    nn = vertex_normals(noisy, m.faces)
    kw = dict(adaptive=adaptive, n_iter=3, n_filter_iter=5, sharpen=True, rho=0.95)
    _same(
        normal_voting_denoise(noisy, nn, **kw), ref.previous_normal_voting_denoise(noisy, nn, **kw)
    )


def test_one_thread_and_parallel_give_the_same_bits(monkeypatch):
    """Small inputs on a busy machine run every kernel in one thread; same output."""
    import numba

    from pointatlas.denoise import _kernels, flatness_denoise

    rng = np.random.default_rng(7)
    pts = _blob(rng, 900)
    threads = numba.get_num_threads()
    seen = []
    orig = _voting.voting_filter_kernel

    def spy(*args):
        seen.append(numba.get_num_threads())
        return orig(*args)

    monkeypatch.setattr(_voting, "voting_filter_kernel", spy)
    out = {}
    for busy in (True, False):
        monkeypatch.setattr(_kernels, "machine_busy", lambda busy=busy: busy)
        out[busy] = (
            normal_voting_denoise(pts, None, n_iter=2, n_filter_iter=3),
            flatness_denoise(pts, k=10, n_iter=3),
        )
        assert numba.get_num_threads() == threads  # restored
    assert seen == [1] * 6 + [threads] * 6
    (one, flat_one), (par, flat_par) = out[True], out[False]
    assert np.array_equal(one.points, par.points) and np.array_equal(one.normals, par.normals)
    assert np.array_equal(flat_one.points, flat_par.points)
    monkeypatch.setattr(_kernels, "machine_busy", lambda: True)
    with _kernels.threads_for(_kernels.PARALLEL_MIN_POINTS):  # large inputs: untouched
        assert numba.get_num_threads() == threads
    assert isinstance(_kernels.machine_busy(), bool)


@pytest.mark.parametrize("extra", [0, 10])
def test_narrow_table_equals_the_full_one(extra):
    rng = np.random.default_rng(3)
    for n in (60, 700):
        pts = _blob(rng, n)
        idx, k, ell = ref.previous_neighbourhoods(pts, 2.0, extra)
        for width in (7, 12, 20, int(k.max()) + extra, int(k.max()) + extra + 4, 80):
            table, got_idx, got_k, got_ell = _voting._neighbourhoods(pts, 2.0, extra, width)
            assert np.array_equal(got_idx, idx) and np.array_equal(got_k, k) and got_ell == ell
            assert np.array_equal(table, query_knn(pts, table.shape[1])[0])


def test_estimated_normals_from_the_first_table():
    """Without normals: PCA + orientation as on a fresh normal_k-NN table (also when
    normal_k exceeds the first table's width and needs its own query)."""
    from pointatlas.normals import estimate_normals, orient_normals

    pts = _blob(np.random.default_rng(4), 400)
    for normal_k in (20, 60):
        knn = query_knn(pts, normal_k)
        want = orient_normals(pts, estimate_normals(pts, normal_k, neighbors=knn), neighbors=knn)
        for n_iter in (0, 1):
            r = normal_voting_denoise(pts, None, n_iter=n_iter, n_filter_iter=0, normal_k=normal_k)
            assert np.array_equal(r.normals, want)

"""Optimal neighbourhood search (Eq. 5.9) against a brute-force loop over all choices."""

import math

import numpy as np
import pytest

from pointatlas.features import (
    angle_pairs,
    covariance_features,
    optimal_k_features,
    optimal_neighborhood,
)
from pointatlas.neighbors import query_knn
from pointatlas.synth import cube

from . import reference as ref


def _noisy_surface(seed, n=40):
    rng = np.random.default_rng(seed)
    uv = rng.random((n, 2)) * 2 - 1
    z = 0.3 * np.sin(2 * uv[:, 0]) + 0.2 * np.abs(uv[:, 1]) + rng.normal(scale=0.02, size=n)
    pts = np.column_stack([uv, z])
    nrm = np.column_stack([-0.6 * np.cos(2 * uv[:, 0]), -0.2 * np.sign(uv[:, 1]), np.ones(n)])
    nrm += rng.normal(scale=0.3, size=(n, 3))
    return pts, nrm / np.linalg.norm(nrm, axis=1)[:, None]


def _check_against_brute_force(pts, nrm, pairs, kmin, kmax, res_k, res_pair, res_e):
    idx = query_knn(pts, kmax)[0]
    best, bk, bp = ref.brute_force_search(pts, nrm, idx, pairs, kmin, kmax)
    for i in range(pts.shape[0]):
        if bk[i] < 0:
            assert res_k[i] == -1 and math.isinf(res_e[i])
            continue
        assert res_e[i] == pytest.approx(best[i], abs=1e-7)
        # same triple unless another choice is within round-off of the minimum
        code, lam, f = ref.point_features(pts, nrm, idx[i], res_k[i], *pairs[res_pair[i]])
        assert code == 0 and f["e_dim"] == pytest.approx(best[i], abs=1e-7)
        if (res_k[i], res_pair[i]) != (bk[i], bp[i]):
            assert abs(f["e_dim"] - best[i]) < 1e-7


def test_search_agrees_with_brute_force_over_all_420_choices():
    pts, nrm = _noisy_surface(0, n=21)
    pairs = angle_pairs()
    res = optimal_neighborhood(pts, nrm)
    pair_index = {tuple(p): j for j, p in enumerate(pairs.tolist())}
    res_pair = np.array(
        [
            pair_index.get((a, b), -1) if k > 0 else -1
            for a, b, k in zip(res.a, res.b, res.k, strict=True)
        ]
    )
    assert len(pairs) == 28
    _check_against_brute_force(pts, nrm, pairs, 6, 20, res.k, res_pair, res.e_dim)
    assert (res.reason == 0).all()
    # the reported features are those of the chosen triple, recomputed
    for i in range(0, 21, 5):
        one = covariance_features(pts, int(res.k[i]), normals=nrm, a=res.a[i], b=res.b[i])
        assert one.e_dim[i] == pytest.approx(res.e_dim[i], abs=1e-12)


def test_search_small_grid_exact_ties_and_degenerate():
    # a flat grid: every choice with >= 3 weighted points is planar-ish; exact
    # duplicate weight vectors must resolve to smallest k, then a, then b
    g = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0), [0.0]), -1).reshape(-1, 3)
    nrm = np.tile([0.0, 0.0, 1.0], (36, 1))
    res = optimal_neighborhood(g, nrm, k_range=(6, 9))
    full = optimal_neighborhood(g, nrm, a_grid=[0.0], b_grid=[0.0], k_range=(6, 9))
    np.testing.assert_array_equal(res.k, full.k)
    assert (res.a == 0).all() and (res.b == 0).all()  # identical weights: smallest a, b win
    # flipped normals with a sharp cut-off at 0: only the point itself -> all degenerate
    alt = nrm.copy()
    alt[::2] *= -1
    rng = np.random.default_rng(1)
    pts = rng.random((36, 3))
    only_zero = optimal_neighborhood(pts, alt, a_grid=[0.0], b_grid=[0.0], k_range=(2, 3))
    idx = query_knn(pts, 3)[0]
    opposite = (alt[idx[:, 1:], 2] != alt[:, None, 2]).all(axis=1)
    assert np.isinf(only_zero.e_dim[opposite]).all()
    assert (only_zero.k[opposite] == -1).all() and (only_zero.reason[opposite] == 3).all()
    assert np.isnan(only_zero.planarity[opposite]).all()


def test_weinmann_optimal_k_matches_brute_force():
    pts, _ = _noisy_surface(2, n=60)
    for criterion in ("eigenentropy", "e_dim"):
        res = optimal_k_features(pts, k_range=(5, 25), criterion=criterion)
        idx = query_knn(pts, 25)[0]
        best, bk, _ = ref.brute_force_search(
            pts, None, idx, [(math.pi, math.pi)], 5, 25, criterion=criterion
        )
        np.testing.assert_array_equal(res.k, bk)
        np.testing.assert_allclose(getattr(res, criterion), best, atol=1e-7)
        assert (res.a == math.pi).all()


def test_cube_optimal_weights_sharpen_edges():
    m = cube(8)
    eq = optimal_k_features(m.points, k_range=(6, 20), criterion="e_dim")
    opt = optimal_neighborhood(m.points, m.normals)
    assert (opt.reason == 0).all()
    assert opt.e_dim.mean() < eq.e_dim.mean()  # Table 5.1's direction


def test_search_validation():
    pts, nrm = _noisy_surface(4, n=30)
    with pytest.raises(ValueError, match="k_min <= k_max"):
        optimal_neighborhood(pts, nrm, k_range=(10, 6))
    with pytest.raises(
        ValueError, match=r"a_grid must hold finite angles in \[0, pi\] radians; got 4.0"
    ):
        optimal_neighborhood(pts, nrm, a_grid=[0.0, 4.0])
    with pytest.raises(ValueError, match="no \\(a, b\\) pair"):
        optimal_neighborhood(pts, nrm, a_grid=[2.0], b_grid=[1.0])
    with pytest.raises(ValueError, match="criterion must be one of"):
        optimal_k_features(pts, criterion="entropy")
    with pytest.raises(ValueError, match="normals must have one row per point"):
        optimal_neighborhood(pts, nrm[:5])


def _smooth_patch(seed, n=36):
    # a gently curved patch with exact normals: the a = 0 pairs get cosine weights
    # within a fraction of a percent of each other, which the search's perturbation
    # bounds (Loewner factor and Weyl) must prune without changing the answer
    rng = np.random.default_rng(seed)
    uv = rng.random((n, 2)) * 2 - 1
    z = 0.15 * uv[:, 0] ** 2 - 0.1 * uv[:, 1] ** 2 + 0.05 * uv[:, 0] * uv[:, 1]
    nrm = np.column_stack([-0.3 * uv[:, 0] - 0.05 * uv[:, 1], 0.2 * uv[:, 1] - 0.05 * uv[:, 0]])
    nrm = np.column_stack([nrm, np.ones(n)])
    return np.column_stack([uv, z]), nrm / np.linalg.norm(nrm, axis=1)[:, None]


def test_search_with_pruning_agrees_with_brute_force_on_smooth_patch():
    pts, nrm = _smooth_patch(5)
    pairs = angle_pairs()
    res = optimal_neighborhood(pts, nrm, k_range=(6, 14))
    pair_index = {tuple(p): j for j, p in enumerate(pairs.tolist())}
    res_pair = np.array([pair_index[(a, b)] for a, b in zip(res.a, res.b, strict=True)])
    idx = query_knn(pts, 14)[0]
    best, bk, bp = ref.brute_force_search(pts, nrm, idx, pairs, 6, 14)
    np.testing.assert_allclose(res.e_dim, best, atol=1e-9)
    np.testing.assert_array_equal(res.k, bk)
    np.testing.assert_array_equal(res_pair, bp)


@pytest.mark.parametrize("kind", ["random", "collinear", "coplanar", "disc", "duplicate"])
def test_fast_closed_form_eigenvalues_match_eigvalsh(kind):
    from pointatlas.normals._kernels.eig3 import eig3_fast

    rng = np.random.default_rng(7)
    y = rng.normal(size=(200, 12, 3))
    if kind == "collinear":
        y = y[:, :, :1] * np.array([1.0, 2.0, 3.0]) + 1e-9 * y
    elif kind == "coplanar":
        y[:, :, 2] *= 1e-6
    elif kind == "disc":
        t = rng.random((200, 12)) * 2 * np.pi
        y = np.stack([np.cos(t), np.sin(t), 1e-4 * rng.normal(size=(200, 12))], -1)
    elif kind == "duplicate":
        y[:, 1:5] = y[:, :1]
    y = y @ np.linalg.qr(rng.normal(size=(200, 3, 3)))[0]
    z = y - y.mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", z, z)
    want = np.linalg.eigvalsh(cov)[:, ::-1]
    got = np.array([eig3_fast(c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2]) for c in cov])
    # relative to lambda_1; near double roots (collinear: lambda_2 = lambda_3) the
    # closed form is good to ~1e-8 lambda_1, elsewhere to ~1e-13
    tol = 1e-7 if kind == "collinear" else 1e-12
    np.testing.assert_array_less(np.abs(got - want) / want[:, :1], tol)
    assert (got[:, 0] >= got[:, 1]).all() and (got[:, 1] >= got[:, 2]).all()


def test_branch_free_eigenvalues_equal_closed_form_bit_for_bit():
    # the search ranks choices by E_dim of eig3_fast's eigenvalues; its vectorised
    # copy must give the very same numbers (also for C = 0 and C = c I)
    from pointatlas.normals._kernels.eig3 import eig3_fast, eig3_lanes

    rng = np.random.default_rng(11)
    y = rng.normal(size=(300, 8, 3))
    y[:50, :, 2] *= 1e-7
    y[50:80] = y[50:80, :, :1] * np.array([1.0, -2.0, 0.5])
    z = y - y.mean(axis=1, keepdims=True)
    cov = list(np.einsum("nki,nkj->nij", z, z)) + [np.zeros((3, 3)), 2.5 * np.eye(3)]
    for c in cov:
        args = (c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2])
        assert eig3_lanes(*args) == eig3_fast(*args)


def test_chord_bound_is_below_minus_t_log_t():
    from pointatlas.features._kernels.math_helpers import chord_bound

    t = np.concatenate([np.linspace(0.0, 1.0, 20001), np.geomspace(1e-300, 1e-2, 2000)])
    t = np.concatenate([t, [np.nextafter(1.0, 2.0), 1.0 + 4e-16]])
    f = -t * np.log(np.where(t > 0, t, 1.0))
    lb = np.array([chord_bound(x) for x in t])
    assert (lb <= f + 1e-15).all()
    assert (f - lb).max() < 1e-3  # tight enough to rule out most choices


def _degenerate_covariances(rng, n):
    """Covariances with planar, linear, isotropic and double-root spectra (and lambda_3 = 0)."""
    lam = rng.random((6, n, 3))
    lam[1, :, 2] *= 10.0 ** rng.uniform(-17, -1, n)
    lam[2, :, 1] = lam[2, :, 0] * (1 - 10.0 ** rng.uniform(-16, -1, n))
    lam[2, :, 2] *= 10.0 ** rng.uniform(-16, 0, n)
    lam[3, :, 1] = lam[3, :, 0] * 10.0 ** rng.uniform(-16, -1, n)
    lam[3, :, 2] = lam[3, :, 1] * (1 - 10.0 ** rng.uniform(-16, -1, n))
    lam[4, :, 1:] = lam[4, :, :1] * (1 - 10.0 ** rng.uniform(-16, -4, (n, 2)))
    lam[5, :, 2] = 0.0
    lam = lam.reshape(-1, 3)
    rot = np.linalg.qr(rng.normal(size=(lam.shape[0], 3, 3)))[0]
    return np.einsum("nij,nj,nkj->nik", rot, lam, rot)


def test_edim_table_is_below_the_searched_e_dim():
    # the search skips a choice when its table entry exceeds a value it found; the
    # entry must lie below the E_dim the search would compute (eig3_fast's
    # eigenvalues, the kernel's ratios), also at double roots and lambda_3 = 0
    from pointatlas.features._kernels import EDIM_TABLE_SHAPE, edim_table
    from pointatlas.normals._kernels.eig3 import eig3_fast, lanes_stage1

    table = edim_table()
    n_rho, n_v = EDIM_TABLE_SHAPE
    gaps = []
    for c in _degenerate_covariances(np.random.default_rng(21), 4000):
        args = (c[0, 0], c[0, 1], c[0, 2], c[1, 1], c[1, 2], c[2, 2])
        q, p, p2, r = lanes_stage1(*args)
        l1, l2, l3 = eig3_fast(*args)
        rho = p / q
        v1 = math.sqrt(1.0 + r)
        if not (rho >= 0.0 and rho < 1.0 and p2 > 0.0):
            continue  # the kernel gives such choices no bound
        ts = ((l1 - l2) * (1.0 / l1), (l2 - l3) * (1.0 / l1), l3 * (1.0 / l1))
        e = -sum(t * math.log(t) for t in ts if t > 0.0)
        entry = table[int(rho * n_rho), min(int(v1 * (n_v / math.sqrt(2.0))), n_v - 1)]
        gaps.append(e - entry)
    gaps = np.array(gaps)
    assert gaps.size > 20000
    assert gaps.min() >= 0.0
    assert np.median(gaps) < 0.01  # tight enough to rule out most choices


def test_table_pruning_leaves_the_search_unchanged(monkeypatch):
    # the same search without the table (every choice through the whole closed
    # form and the chord bounds) gives the same result bit for bit
    from pointatlas.features import _optimal

    pts, nrm = _noisy_surface(12, n=2000)
    nrm[::13] *= -1
    pts[100:110] = pts[100]
    with_table = optimal_neighborhood(pts, nrm)
    # the read-only empty table of the fixed-choice search: the kernel's signature
    # stays the one the warm-up compiled (a writeable one compiles for a minute)
    monkeypatch.setattr(_optimal, "_edim_bounds", _optimal._no_table)
    without = optimal_neighborhood(pts, nrm)
    for name in ("k", "a", "b", "reason", "e_dim", "eigenvalues", "eigenvector_3"):
        np.testing.assert_array_equal(getattr(with_table, name), getattr(without, name))


def test_reported_row_equals_fused_kernel_at_the_chosen_triple_bit_for_bit():
    # the search takes the winner's covariance from its running moments; it must be
    # the covariance `fused_kernel` builds at that (a, b, k), so every reported
    # value equals a fixed-choice pass there bit for bit (also next to duplicate
    # points, a collinear strand, flipped and NaN normals)
    from pointatlas.features._features import _choice_features, _neighbourhoods
    from pointatlas.features._kernels import angles_kernel
    from pointatlas.features._weights import _unit_normals_or_nan

    pts, nrm = _noisy_surface(8, n=300)
    pts[10:20] = pts[10]
    t = np.linspace(0.0, 1.0, 30)
    pts[40:70] = np.column_stack([t, 2 * t, -t]) + 3.0
    nrm[::9] *= -1
    nrm[5] = np.nan
    idx = _neighbourhoods(pts, 20, None)
    res = optimal_neighborhood(pts, nrm, neighbors=idx)
    ok = res.reason == 0
    assert ok.sum() > 200 and (res.reason == 1).any()
    unit = _unit_normals_or_nan(nrm, len(pts))
    ang = np.empty(idx.shape)
    angles_kernel(unit, idx, np.arange(len(pts)), ang)
    fixed = _choice_features(
        pts,
        idx,
        np.where(ok, res.k, 20),
        ang,
        np.where(ok, res.a, 0.0),
        np.where(ok, res.b, math.pi),
        res.flatness_exponents,
    )
    for name in ("eigenvalues", "eigenvector_1", "eigenvector_3", "e_dim", "flatness"):
        np.testing.assert_array_equal(getattr(res, name)[ok], getattr(fixed, name)[ok])
    np.testing.assert_array_equal(fixed.reason[ok], 0)

"""Kernel-vs-reference checks once more with NUMBA_DISABLE_JIT=1 (coverage of kernel bodies)."""

import textwrap

from tests.jit_off import run_without_jit

_SCRIPT = textwrap.dedent(
    """
    import math
    import numpy as np
    from pointatlas.features import (
        angle_pairs, covariance_features, optimal_neighbourhood, symmetric_eigenvalues,
        weighted_covariances,
    )
    from pointatlas.neighbors import query_knn
    from tests.features import reference as ref

    rng = np.random.default_rng(0)
    pts = rng.normal(size=(16, 3)) * [1.0, 0.7, 0.1]
    pts[5] = pts[4]
    nrm = rng.normal(size=(16, 3)) * 0.3 + [0, 0, 1.0]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    idx = query_knn(pts, 8)[0]
    cov, reason = weighted_covariances(pts, idx)
    for i in range(16):
        assert np.allclose(cov[i], ref.covariance(pts[idx[i]], np.ones(8)), atol=1e-12)
    ev = symmetric_eigenvalues(cov)
    assert np.allclose(ev, np.linalg.eigvalsh(cov)[:, ::-1], atol=1e-12)
    res = covariance_features(pts, 8, normals=nrm, a=0.2, b=1.0, neighbors=idx)
    for i in range(16):
        code, lam, f = ref.point_features(pts, nrm, idx[i], 8, 0.2, 1.0)
        assert res.reason[i] == code
        if code == 0:
            assert abs(res.e_dim[i] - f["e_dim"]) < 1e-9
    pairs = angle_pairs([0.0, math.pi / 3, math.pi], [0.0, math.pi / 3, math.pi])
    opt = optimal_neighbourhood(pts, nrm, a_grid=[0.0, math.pi / 3, math.pi],
                                b_grid=[0.0, math.pi / 3, math.pi], k_range=(4, 8), neighbors=idx)
    best, bk, bp = ref.brute_force_search(pts, nrm, idx, pairs, 4, 8)
    assert np.allclose(opt.e_dim, best, atol=1e-7)
    print("ok")
    """
)


def test_kernels_without_jit():
    assert run_without_jit(_SCRIPT).strip() == "ok"

"""Kernel-vs-reference checks once more with NUMBA_DISABLE_JIT=1 (coverage of kernel bodies)."""

import textwrap

from tests.jit_off import run_without_jit

_SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from pointatlas.denoise._kernels import (
        adaptive_k_kernel, plane_update_kernel, quadric_update_kernel, voting_filter_kernel,
    )
    from pointatlas.neighbors import point_mesh_distance, query_knn
    from tests.denoise import reference as ref

    rng = np.random.default_rng(0)
    verts = rng.normal(size=(8, 3))
    faces = rng.integers(0, 8, size=(6, 3))
    faces[0] = [1, 1, 2]
    pts = rng.normal(size=(10, 3))
    assert np.allclose(point_mesh_distance(pts, verts, faces),
                       ref.point_to_mesh(pts, verts, faces), atol=1e-12)
    pts = rng.normal(size=(14, 3)) * [1.0, 0.8, 0.1]
    nrm = rng.normal(size=(14, 3)) * 0.3 + [0, 0, 1.0]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    nrm[:5] = nrm[:5][:, [2, 0, 1]]
    idx = query_knn(pts, 8)[0]
    lo = np.full(14, 3, np.int64); hi = np.full(14, 8, np.int64)
    bk = np.empty(14, np.int64); be = np.empty(14)
    adaptive_k_kernel(pts, nrm, idx, lo, hi, 0.8, bk, be, np.full(14, -1, np.int64))
    wk, we = ref.adaptive_k(pts, nrm, idx, lo, hi, 0.8)
    fin = np.isfinite(we)
    assert np.allclose(be[fin], we[fin], atol=1e-7) and (bk[~fin] == -1).all()
    k_of = np.full(14, 8, np.int64)
    out = np.empty_like(nrm)
    voting_filter_kernel(nrm, idx, k_of, np.ones(14, bool), 0.9, 0.3, out)
    assert np.allclose(out, ref.voting_filter(nrm, idx, k_of, np.ones(14, bool), 0.9, 0.3))
    newp = np.empty_like(pts); klass = np.empty(14, np.int64)
    quadric_update_kernel(pts, nrm, idx, k_of, 0.9, 0.1, 0.05, True, newp, klass)
    want, wclass = ref.quadric_update(pts, nrm, idx, k_of, 0.9, 0.1, 0.05)
    assert np.allclose(newp, want, atol=1e-9) and (klass == wclass).all()
    plane_update_kernel(pts, nrm, idx, k_of, 0.9, 0.05, 4.0, newp)
    assert np.allclose(newp, ref.plane_update(pts, nrm, idx, k_of, 0.9, 0.05, 0.5), atol=1e-12)
    print("ok")
    """
)


def test_kernels_without_jit():
    assert run_without_jit(_SCRIPT).strip().endswith("ok")

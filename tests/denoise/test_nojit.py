"""Small kernel-vs-reference checks, run JIT-compiled with the suite and once more with
NUMBA_DISABLE_JIT=1 (coverage of the kernel bodies, `tests.jit_off`)."""

import numpy as np
import pytest

from pointatlas._core import readonly_view
from pointatlas.denoise._flatness import flatness_move_kernel
from pointatlas.denoise._kernels import (
    adaptive_k_kernel,
    face_normals_kernel,
    lonely_normals_kernel,
    plane_lists_kernel,
    plane_update_kernel,
    table_distances_kernel,
    voting_filter_kernel,
)
from pointatlas.denoise._sharpen import quadric_update_kernel
from pointatlas.neighbors import point_mesh_distance, query_knn
from tests.denoise import reference as ref
from tests.jit_off import JIT_OFF, run_module_without_jit


def _cloud():
    """14 points near a plane, noisy normals (5 of them turned to another axis), 8-NN."""
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(14, 3)) * [1.0, 0.8, 0.1]
    nrm = rng.normal(size=(14, 3)) * 0.3 + [0, 0, 1.0]
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    nrm[:5] = nrm[:5][:, [2, 0, 1]]
    return pts, nrm, query_knn(pts, 8)[0]


def test_point_to_mesh_tiny_reference():
    rng = np.random.default_rng(0)
    verts = rng.normal(size=(8, 3))
    faces = rng.integers(0, 8, size=(6, 3))
    faces[0] = [1, 1, 2]
    pts = rng.normal(size=(10, 3))
    got = point_mesh_distance(pts, verts, faces)
    np.testing.assert_allclose(got, ref.point_to_mesh(pts, verts, faces), atol=1e-12)


def test_adaptive_k_tiny_reference():
    pts, nrm, idx = _cloud()
    lo = np.full(14, 3, np.int64)
    hi = np.full(14, 8, np.int64)
    bk = np.empty(14, np.int64)
    be = np.empty(14)
    # read-only points, as `_filter._filter_steps` passes them (one kernel signature)
    adaptive_k_kernel(readonly_view(pts), nrm, idx, lo, hi, 0.8, bk, be, np.full(14, -1, np.int64))
    wk, we = ref.adaptive_k(pts, nrm, idx, lo, hi, 0.8)
    fin = np.isfinite(we)
    np.testing.assert_allclose(be[fin], we[fin], atol=1e-7)
    assert (bk[~fin] == -1).all()


def test_voting_filter_tiny_reference():
    pts, nrm, idx = _cloud()
    k_of = np.full(14, 8, np.int64)
    out = np.empty_like(nrm)
    voting_filter_kernel(nrm, idx, k_of, np.ones(14, bool), 0.9, 0.3, out)
    want = ref.voting_filter(nrm, idx, k_of, np.ones(14, bool), 0.9, 0.3)
    np.testing.assert_allclose(out, want, atol=1e-9)


def test_point_updates_tiny_reference():
    pts, nrm, idx = _cloud()
    k_of = np.full(14, 8, np.int64)
    newp = np.empty_like(pts)
    klass = np.empty(14, np.int64)
    quadric_update_kernel(pts, nrm, idx, k_of, 0.9, 0.1, 0.05, True, newp, klass)
    want, wclass = ref.quadric_update(pts, nrm, idx, k_of, 0.9, 0.1, 0.05)
    np.testing.assert_allclose(newp, want, atol=1e-9)
    assert (klass == wclass).all()
    lists, counts = ref.plane_lists(nrm, idx, k_of, 0.9)
    moved2 = np.empty(14)
    plane_update_kernel(pts, nrm, lists, counts, 0.05, 4.0, 1.0, newp, moved2)
    want = ref.plane_update(pts, nrm, idx, k_of, 0.9, 0.05, 0.5)
    np.testing.assert_allclose(newp, want, atol=1e-12)
    np.testing.assert_allclose(moved2, ((newp - pts) ** 2).sum(axis=1), rtol=1e-15)


def test_lonely_normals_tiny_reference():
    pts, nrm, idx = _cloud()  # five normals turned to another axis: lonely at min_count 4
    k_of = np.full(14, 8, np.int64)
    counts = ref.plane_lists(nrm, idx, k_of, 0.8)[1]
    out = np.empty_like(nrm)
    # read-only points, as `_voting._planes` gets them (one kernel signature)
    lonely_normals_kernel(readonly_view(pts), nrm, idx, k_of, counts, 0.8, 4, 1.0 / 0.7**2, out)
    want = ref.lonely_normals(pts, nrm, idx, k_of, 0.8, 4, 0.7)
    np.testing.assert_allclose(out, want, atol=1e-12)
    lonely = counts < 4
    assert 0 < lonely.sum() < 14 and np.array_equal(out[~lonely], nrm[~lonely])
    assert not np.allclose(out[lonely], nrm[lonely])


def test_plane_lists_tiny_reference():
    pts, nrm, idx = _cloud()
    k_of = np.arange(14, dtype=np.int64) % 8 + 1
    lists = np.full(idx.shape, -2, dtype=np.int64)
    counts = np.empty(14, np.int64)
    plane_lists_kernel(nrm, idx, k_of, 0.9, lists, counts)
    want, wcounts = ref.plane_lists(nrm, idx, k_of, 0.9)
    assert np.array_equal(counts, wcounts) and 0 < counts.sum() < k_of.sum()
    for i in range(14):
        assert np.array_equal(lists[i, : counts[i]], want[i, : wcounts[i]])


def test_face_normals_tiny_reference():
    pts, nrm, idx = _cloud()
    k_of = np.full(14, 8, np.int64)
    k_of[0] = 2  # too few neighbours: the normal stays
    out = np.empty_like(nrm)
    face_normals_kernel(pts, nrm, *ref.plane_lists(nrm, idx, k_of, 0.8), out)
    want = ref.face_normals(pts, nrm, idx, k_of, 0.8)
    np.testing.assert_allclose(out, want, atol=1e-9)
    assert np.array_equal(out[0], nrm[0]) and not np.allclose(out, nrm)


def test_table_distances_tiny_reference():
    pts, _, idx = _cloud()
    out = np.empty(idx.shape)
    table_distances_kernel(pts, idx, out)
    want = np.linalg.norm(pts[idx] - pts[:, None, :], axis=2)
    np.testing.assert_allclose(out, want, rtol=1e-15, atol=0)
    assert (out[:, 0] == 0).all()


def test_flatness_move_tiny_reference():
    pts, _, idx = _cloud()
    rng = np.random.default_rng(1)
    v1 = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    v1s, v3s = np.tile(v1[:, 0], (14, 1)), np.tile(v1[:, 2], (14, 1))
    energy = rng.random(14)
    valid = np.arange(14) != 3
    out = np.empty_like(pts)
    moved = np.empty(14, bool)
    flatness_move_kernel(pts, idx, v1s, v3s, energy, valid, 0.5, 0.1, out, moved)
    rel = pts - pts[idx].mean(axis=1)
    d = (rel * v3s).sum(axis=1)[:, None]
    to_line = (rel * v1s).sum(axis=1)[:, None] * v1s - rel
    step = 0.1 * (0.5 * (2 - energy)[:, None] * (-d * v3s) + 0.5 * energy[:, None] * to_line)
    step[3] = 0.0
    np.testing.assert_allclose(out, pts + step, atol=1e-12)
    assert moved.tolist() == valid.tolist()


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    out = run_module_without_jit(__file__, select="tiny_reference")
    assert "9 passed" in out, out[-500:]

"""Input checks of simplify: point count, k, memory, points without a usable normal
(issue 15 of the hardening list)."""

import tracemalloc

import numpy as np
import pytest

from pointatlas._core import PointAtlasError
from pointatlas.simplify import simplify_points, simplify_segmentation
from pointatlas.synth import cube

from .reference import row_majority_reference

ROBUST = {"max_angle": np.radians(20)}  # see test_cli.ROBUST


def _sphere_points(n, seed=0):
    p = np.random.default_rng(seed).normal(size=(n, 3))
    return p, p / np.linalg.norm(p, axis=1, keepdims=True)


def test_five_points_name_the_point_count_not_an_internal_k():
    pts, nrm = _sphere_points(5)
    with pytest.raises(PointAtlasError, match=r"simplify needs at least k = 8 points; got 5"):
        simplify_points(pts, nrm)
    with pytest.raises(PointAtlasError, match=r"at least k = 8 points; got 5"):
        simplify_segmentation(pts, nrm, [0, 1, 2, 0, 1])
    with pytest.raises(PointAtlasError, match=r"simplify needs at least 4 points .*; got 3"):
        simplify_points(pts[:3], nrm[:3], k=2)


def test_k_is_bounded_by_the_point_count_before_any_work():
    m = cube(4)
    n = m.n_vertices
    with pytest.raises(PointAtlasError, match=r"k must be <= the number of points\)"):
        simplify_points(m.vertices, m.normals, k=n + 1)
    with pytest.raises(PointAtlasError, match=rf"at least k = {n + 1} points; got {n}"):
        simplify_segmentation(m.vertices, m.normals, m.labels, k=n + 1)
    with pytest.raises(PointAtlasError, match="k must be an integer >= 1; got 0"):
        simplify_points(m.vertices, m.normals, k=0)
    with pytest.raises(TypeError, match="k must be an integer"):
        simplify_points(m.vertices, m.normals, k=8.0)


def test_memory_beyond_what_is_available_is_refused_up_front(monkeypatch):
    import pointatlas.simplify._checks as checks

    m = cube(8, size=2.0)
    monkeypatch.setattr(checks, "available_memory", lambda: 1_000_000)
    with pytest.raises(PointAtlasError, match=r"k = 300 on 386 points needs about .* GiB"):
        simplify_points(m.vertices, m.normals, k=300)
    with pytest.raises(
        PointAtlasError, match=r"needs about .* GiB of memory; 0.0 GiB are available"
    ):
        simplify_segmentation(m.vertices, m.normals, m.labels, k=300)
    monkeypatch.setattr(checks, "available_memory", lambda: None)  # unknown: no check
    assert simplify_segmentation(m.vertices, m.normals, m.labels).n_faces == 6


def test_the_memory_check_counts_the_neighbour_table_s_width(monkeypatch):
    """The points path's one k-NN table is wider than VSA's k (the discs' neighbours):
    the estimate counts its columns, the message still names the k given."""
    import pointatlas.simplify._checks as checks

    wide = checks.memory_estimate(10**6, 10)
    monkeypatch.setattr(checks, "available_memory", lambda: wide - 1)
    checks.check_memory(10**6, 8)  # k = 8 alone fits
    with pytest.raises(PointAtlasError, match=r"k = 8 on 1000000 points needs about"):
        checks.check_memory(10**6, 8, columns=10)
    checks.check_memory(10**6, 8, columns=6)  # never below k


def test_available_memory_is_read_from_the_system():
    from pointatlas.simplify._checks import available_memory

    have = available_memory()
    assert have is None or have > 0


def test_label_smoothing_memory_grows_with_n_k_not_n_k_squared():
    # simplify --k 2001 on a 2,048-point model used to compare all pairs of every
    # k-NN row (N k^2 bytes, 8 GB) and run out of memory
    from pointatlas.simplify._repair import smooth_labels

    rng = np.random.default_rng(0)
    n, k = 400, 400
    idx = np.concatenate(
        [np.arange(n)[:, None], rng.integers(0, n, size=(n, k - 1))], axis=1
    ).astype(np.int64)
    lab = rng.integers(0, 5, size=n).astype(np.int64)
    tracemalloc.start()
    smooth_labels(lab, idx, 1)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 64 * n * k  # all pairs: n k^2 = 64 MB of booleans alone


def test_row_majority_matches_the_all_pairs_reference():
    from pointatlas.simplify._repair import _row_majority

    rng = np.random.default_rng(1)
    for _ in range(300):
        n, k, n_labels = rng.integers(1, 15), rng.integers(1, 10), rng.integers(1, 5)
        nb = rng.integers(0, n_labels, size=(n, k)).astype(np.int64)
        np.testing.assert_array_equal(_row_majority(nb), row_majority_reference(nb))
    one = np.array([[3, 1, 1, 3, 2]])  # own label 3 ties with 1: own wins
    assert _row_majority(one).tolist() == [3]
    two = np.array([[0, 2, 1, 1, 2]])  # 1 and 2 tie, 2 is seen first
    assert _row_majority(two).tolist() == [2]


def _cube_with_bad_normals():
    m = cube(8, size=2.0)
    nrm = m.normals.copy()
    bad = np.array([5, 77, 200])
    nrm[5] = 0.0
    nrm[77] = [np.nan, 0.0, 1.0]
    nrm[200] = [np.inf, 0.0, 0.0]
    return m, nrm, bad


def test_points_without_a_usable_normal_are_dropped_and_counted():
    m, nrm, bad = _cube_with_bad_normals()
    kept = np.setdiff1d(np.arange(m.n_vertices), bad)
    r = simplify_points(m.vertices, nrm, **ROBUST)
    assert r.n_dropped == 3 and r.mesh.n_dropped == 3
    np.testing.assert_array_equal(r.point_index, kept)
    np.testing.assert_array_equal(r.mesh.point_index, kept)
    assert r.point_index.dtype == np.int64 and not r.point_index.flags.writeable
    assert r.segmentation.labels.shape == (kept.size,)
    assert r.mesh.labels.shape == r.mesh.distances.shape == (kept.size,)
    assert (r.mesh.n_vertices, r.mesh.n_faces) == (8, 6) and r.mesh.is_closed
    assert r.mesh.summary()["n_dropped_points"] == 3
    s = simplify_segmentation(m.vertices, nrm, m.labels)
    assert s.n_dropped == 3 and s.point_index.tolist() == kept.tolist()
    assert (s.n_vertices, s.n_faces) == (8, 6) and s.is_closed
    full = simplify_segmentation(m.vertices, m.normals, m.labels)
    assert full.n_dropped == 0 and full.point_index.tolist() == list(range(m.n_vertices))
    assert full.summary()["n_dropped_points"] == 0


def test_dropping_follows_given_weights_and_ignores_given_indices():
    from pointatlas.neighbors import query_knn

    m, nrm, _ = _cube_with_bad_normals()
    w = np.ones(m.n_vertices)
    r = simplify_points(m.vertices, nrm, weights=w, **ROBUST)
    assert r.n_dropped == 3 and r.mesh.n_faces == 6
    with pytest.raises(ValueError, match=r"weights must have shape \(386,\)"):
        simplify_points(m.vertices, nrm, weights=w[:10], **ROBUST)
    idx, _ = query_knn(m.vertices, 8)  # rows of all 386 points: recomputed for 383
    s = simplify_segmentation(m.vertices, nrm, m.labels, neighbors=idx)
    assert s.n_dropped == 3 and s.n_faces == 6


def test_no_usable_normal_or_an_emptied_region_gives_a_clear_message():
    m = cube(8, size=2.0)
    with pytest.raises(PointAtlasError, match="no point has a usable normal"):
        simplify_points(m.vertices, np.zeros_like(m.normals))
    nrm = m.normals.copy()
    nrm[m.labels == 2] = np.nan
    with pytest.raises(PointAtlasError, match=r"regions \[2\] keep no point with a usable normal"):
        simplify_segmentation(m.vertices, nrm, m.labels)
    with pytest.raises(ValueError, match=r"normals must have shape \(N, 3\)"):
        simplify_points(m.vertices, m.normals[:, :2])

"""`point_mesh_distance` against a brute-force plain-numpy reference (every point
against every triangle), on random meshes, degenerate triangles, points on the
surface and far away; `MeshDistanceIndex` (hints, `all_within`) against it."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.neighbors import MeshDistanceIndex, point_mesh_distance
from pointatlas.synth import torus
from tests.jit_off import JIT_OFF, run_module_without_jit


def _segment_d2(p, a, b):
    """(N, T) squared distances from points p (N, 3) to segments ab (T, 3)."""
    ab = b - a
    ll = (ab * ab).sum(axis=1)
    ap = p[:, None, :] - a[None, :, :]
    safe = np.where(ll > 0, ll, 1.0)
    t = np.where(ll > 0, (ap * ab).sum(axis=2) / safe, 0.0).clip(0.0, 1.0)
    q = ap - t[:, :, None] * ab
    return (q * q).sum(axis=2)


def reference(points, vertices, triangles):
    """Brute force: the smaller of the in-plane foot distance (when the foot lies in
    the triangle) and the three edge distances, minimised over all triangles."""
    p = np.asarray(points, dtype=np.float64)
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    d2 = np.minimum(np.minimum(_segment_d2(p, a, b), _segment_d2(p, b, c)), _segment_d2(p, c, a))
    n = np.cross(b - a, c - a)
    nn = (n * n).sum(axis=1)
    flat = nn <= 1e-24 * ((b - a) ** 2).sum(axis=1) * ((c - a) ** 2).sum(axis=1)
    unit = n / np.sqrt(np.where(flat, 1.0, nn))[:, None]
    ap = p[:, None, :] - a[None]
    h = (ap * unit).sum(axis=2)
    foot = p[:, None, :] - h[:, :, None] * unit
    inside = np.broadcast_to(~flat, h.shape).copy()
    for x, y in ((a, b), (b, c), (c, a)):
        side = (np.cross(y - x, foot - x) * unit).sum(axis=2)
        inside &= side >= 0
    d2 = np.where(inside, np.minimum(d2, h * h), d2)
    return np.sqrt(d2.min(axis=1))


def _check(points, vertices, triangles, rtol=1e-12, atol=1e-13):
    got = point_mesh_distance(points, vertices, triangles)
    want = reference(points, vertices, triangles)
    np.testing.assert_allclose(got, want, rtol=rtol, atol=atol)
    return got


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_random_soup_matches_reference(seed):
    rng = np.random.default_rng(seed)
    verts = rng.normal(size=(60, 3))
    tris = rng.integers(0, 60, size=(200, 3))
    pts = np.concatenate([rng.normal(scale=1.5, size=(150, 3)), rng.normal(size=(20, 3)) * 1e3])
    _check(pts, verts, tris)


def test_degenerate_triangles_match_reference():
    rng = np.random.default_rng(4)
    verts = rng.normal(size=(8, 3))
    verts[7] = verts[0] + 0.5 * (verts[1] - verts[0])  # collinear with 0 and 1
    tris = np.array(
        [[0, 1, 7], [2, 2, 2], [3, 3, 4], [0, 1, 2], [5, 6, 5], [1, 7, 0]], dtype=np.int64
    )
    mid = (verts[3] + verts[4])[None] / 2
    pts = np.concatenate([rng.normal(scale=2.0, size=(80, 3)), verts, mid])
    got = _check(pts, verts, tris)
    assert np.all(got[80:-1] <= 1e-15)  # every vertex is on the mesh
    assert got[-1] <= 1e-15  # on the zero-area triangle's edge
    # a mesh of zero-area triangles only: the distance to its segments and points
    only = np.array([[0, 1, 7], [2, 2, 2], [3, 3, 4]])
    _check(pts, verts, only)


def test_points_on_vertices_edges_and_faces_are_at_zero():
    m = torus(n_major=24, n_minor=12)
    v, f = m.points, m.faces
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    on = np.concatenate([v, (a + b) / 2, (0.2 * a + 0.3 * b + 0.5 * c)])
    d = point_mesh_distance(on, v, f)
    assert d.max() < 1e-15
    rng = np.random.default_rng(5)
    pts = np.concatenate(
        [
            on[rng.choice(len(on), 200, replace=False)] + rng.normal(scale=0.05, size=(200, 3)),
            rng.normal(size=(100, 3)) * 5.0,
            rng.normal(size=(10, 3)) * 1e6,
        ]
    )
    _check(pts, v, f, atol=1e-14)


def test_larger_mesh_matches_reference():
    m = torus(n_major=60, n_minor=30)  # 3,600 triangles: a hierarchy several levels deep
    rng = np.random.default_rng(6)
    pts = rng.uniform(-1.6, 1.6, size=(400, 3)) * [1.0, 1.0, 0.4]
    _check(pts, m.points, m.faces)


def test_far_from_the_origin_and_identical_triangles():
    rng = np.random.default_rng(7)
    verts = rng.normal(size=(30, 3))
    tris = rng.integers(0, 30, size=(50, 3))
    pts = rng.normal(scale=2.0, size=(60, 3))
    near = point_mesh_distance(pts, verts, tris)
    shift = np.array([1e7, -3e7, 2e7])
    far = point_mesh_distance(pts + shift, verts + shift, tris)
    np.testing.assert_allclose(far, near, rtol=1e-8, atol=1e-8)
    # one triangle repeated many times (every centroid equal)
    same = np.tile([[0, 1, 2]], (100, 1))
    _check(pts, verts, same)


def test_small_inputs_and_errors():
    tri = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    assert point_mesh_distance(np.empty((0, 3)), tri, [[0, 1, 2]]).shape == (0,)
    d = point_mesh_distance([[0.25, 0.25, 0.0], [2.0, 0.0, 0.0], [0.2, 0.2, 1.0]], tri, [[0, 1, 2]])
    np.testing.assert_allclose(d, [0.0, 1.0, 1.0], atol=1e-15)
    with pytest.raises(ValueError, match=r"triangles must index vertices 0..2; got 0..3"):
        point_mesh_distance([[0, 0, 0]], tri, [[0, 1, 3]])
    with pytest.raises(ValueError, match=r"triangles must have shape \(T, 3\) with T >= 1"):
        point_mesh_distance([[0, 0, 0]], tri, np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(ValueError, match="triangles must hold integers; got dtype float64"):
        point_mesh_distance([[0, 0, 0]], tri, [[0.0, 1.0, 2.0]])
    with pytest.raises(ValueError, match="vertices"):
        point_mesh_distance([[0, 0, 0]], [[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(ValueError, match="points"):
        point_mesh_distance([[0, 0]], tri, [[0, 1, 2]])


def _torus_points(seed, n=300):
    m = torus(n_major=30, n_minor=14)
    rng = np.random.default_rng(seed)
    v, f = m.points, m.faces
    pts = v[rng.integers(0, len(v), n)] + rng.normal(scale=0.08, size=(n, 3))
    return pts, v, f, rng


@pytest.mark.parametrize("seed", [0, 1])
def test_index_hints_give_the_same_distances(seed):
    pts, v, f, rng = _torus_points(seed)
    plain = point_mesh_distance(pts, v, f)
    index = MeshDistanceIndex(v, f)
    np.testing.assert_allclose(plain, reference(pts, v, f), rtol=1e-12, atol=1e-13)
    np.testing.assert_array_equal(index.distance(pts), plain)
    # a random triangle, a near one, or none per point: the same values bit for bit
    hint = rng.integers(-1, len(f), len(pts))
    np.testing.assert_array_equal(index.distance(pts, hint=hint), plain)
    near = np.argmin(np.linalg.norm(pts[:, None] - v[f].mean(axis=1)[None], axis=2), axis=1)
    np.testing.assert_array_equal(index.distance(pts, hint=near), plain)
    # within: every value up to it stays up to it, every larger one is exact
    w = float(np.median(plain))
    got = index.distance(pts, within=w, hint=near)
    assert np.all(got[plain <= w] <= w)
    np.testing.assert_array_equal(got[plain > w], plain[plain > w])
    with pytest.raises(ValueError, match="hint must hold one triangle"):
        index.distance(pts, hint=np.full(len(pts), len(f)))
    with pytest.raises(ValueError, match="hint must hold one triangle"):
        index.distance(pts, hint=[0])


@pytest.mark.parametrize("seed", [2, 3])
def test_index_all_within_decides_as_the_distances(seed):
    pts, v, f, rng = _torus_points(seed)
    index = MeshDistanceIndex(v, f)
    top = float(point_mesh_distance(pts, v, f).max())
    below = float(np.nextafter(top, 0.0))
    for bound in (0.0, 0.01, below, top, 2 * top):
        want = bool(point_mesh_distance(pts, v, f, within=bound).max() <= bound)
        assert index.all_within(pts, bound) is want
        assert index.all_within(pts, bound, hint=rng.integers(-1, len(f), len(pts))) is want
    assert index.all_within(pts, top) and not index.all_within(pts, below)
    assert index.all_within(np.empty((0, 3)), 0.0)
    with pytest.raises(ValueError, match="bound"):
        index.all_within(pts, -1.0)


def test_index_measures_in_any_given_order_with_the_same_values():
    pts, v, f, rng = _torus_points(4)
    index = MeshDistanceIndex(v, f)
    plain = point_mesh_distance(pts, v, f)
    hint = rng.integers(-1, len(f), len(pts))
    morton = MeshDistanceIndex.point_order(pts)
    assert np.array_equal(np.sort(morton), np.arange(len(pts)))
    for order in (morton, rng.permutation(len(pts)), np.arange(len(pts))[::-1]):
        np.testing.assert_array_equal(index.distance(pts, hint=hint, order=order), plain)
        top = float(plain.max())
        assert index.all_within(pts, top, hint=hint, order=order)
        assert not index.all_within(pts, float(np.nextafter(top, 0.0)), hint=hint, order=order)
    with pytest.raises(ValueError, match="order must be a permutation of the 300 points"):
        index.distance(pts, hint=hint, order=np.zeros(len(pts), dtype=np.int64))
    with pytest.raises(ValueError, match="order must be a permutation"):
        index.all_within(pts, 1.0, hint=hint, order=morton[:-1])


@pytest.mark.parametrize("n", [1, 8, 9, 1000])
def test_hierarchy_boxes_are_their_triangles_boxes(n):
    """`build_bvh`: the leaves hold every triangle once, at most the leaf size each;
    an inner node splits its triangles at the middle position, the left half's
    centroids at most the right half's along the widest span of its centroids; every
    node's box is exactly the box of its triangles (plain numpy)."""
    from pointatlas.neighbors._kernels.mesh_distance import build_bvh

    corners = np.random.default_rng(n).random((n, 9))
    boxes, first, count, order = build_bvh(corners, 4)
    assert np.array_equal(np.sort(order), np.arange(n))
    cen = corners.reshape(n, 3, 3).mean(axis=1)
    span = {0: (0, n)}  # node -> its triangles' positions in ``order``
    for node in range(first.shape[0]):
        s, e = span[node]
        tri = corners[order[s:e]].reshape(-1, 3, 3)
        box = np.stack([tri.min(axis=(0, 1)), tri.max(axis=(0, 1))], axis=1).reshape(-1)
        assert np.array_equal(boxes[node], box)
        if count[node] > 0:
            assert first[node] == s and count[node] == e - s <= 4
            continue
        mid = (s + e) // 2
        c = cen[order[s:e]]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        assert cen[order[s:mid], axis].max() <= cen[order[mid:e], axis].min()
        span[first[node]], span[first[node] + 1] = (s, mid), (mid, e)
    assert sum(count) == n


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="soup or degenerate or small_inputs or index")

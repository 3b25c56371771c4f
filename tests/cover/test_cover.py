"""Ball covers (Props 4-5), Algorithm 2 and the scale search (thesis 2.2)."""

import math

import numpy as np
import pytest

from pointatlas.complex import curve_report, surface_report
from pointatlas.cover import (
    BallCover,
    _kernels,
    ball_cover,
    cover_radii,
    random_rotations,
    search_cover_scale,
)
from pointatlas.synth import fibonacci_sphere
from tests.jit_off import JIT_OFF, run_module_without_jit

from .reference import cubic_membership_reference, tiling_membership_reference


def _counts(points, scale, **kw):
    cov = ball_cover(points, scale, **kw)
    return cov.cloud_complex.n_memberships


@pytest.mark.parametrize("seed", [0, 1])
def test_prop4_every_sample_of_space_in_one_to_three_balls(seed):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-3.0, 7.0, size=(200_000, 3))
    cnt = _counts(pts, 0.7)
    assert cnt.min() >= 1 and cnt.max() <= 3  # four only on a null set
    assert {1, 2, 3} <= set(np.unique(cnt).tolist())


def test_prop4_four_balls_meet_only_at_isolated_points():
    s = 0.5
    # the cube centre: the four big balls touch there; a corner (big ball) fixes the box
    pts = np.array([[0.0, 0.0, 0.0], [4.0, 4.0, 4.0], [0.5, 0.5, 0.5], [1.5, 0.5, 0.5]]) * s
    cnt = _counts(pts, s)
    assert cnt[2] == 4 and cnt[3] == 4
    rng = np.random.default_rng(5)
    near = pts[2] + rng.normal(scale=1e-3 * s, size=(20_000, 3))
    near = np.concatenate([pts[:2], near])
    assert _counts(near, s)[2:].max() <= 3


@pytest.mark.parametrize(
    ("layout", "radius", "max_count_random"),
    [
        ("two-radius", None, 2),
        ("two-radius", 0.8, 2),
        ("two-radius", 0.99, 2),
        ("tiling", None, 2),
        ("tiling", math.sqrt(3) / 2, 3),
    ],
)
def test_prop5_every_sample_of_the_plane_in_one_to_three_balls(layout, radius, max_count_random):
    rng = np.random.default_rng(3)
    pts = rng.uniform(-2.0, 9.0, size=(200_000, 2))
    cnt = _counts(pts, 1.0, dim=2, layout=layout, radius=radius)
    assert cnt.min() >= 1 and cnt.max() == max_count_random


def test_prop5_three_balls_meet_in_single_points():
    # tiling with r = e / sqrt(3): the barycentre of a tile is in three balls
    pts = np.array([[0.0, 0.0], [10.0, 10.0], [0.5, math.sqrt(3) / 6]])
    assert _counts(pts, 1.0, dim=2, layout="tiling")[2] == 3
    # two-radius with r = 0.8: the big balls at A = (0, 0) and C = (1, 1) and the small
    # ball at B = (1, 0) meet in the single point mid(A, C) + t (1, -1) / sqrt(2),
    # t = sqrt(r^2 - 1/2) (its distance to B is 1/sqrt(2) - t = r~)
    t = math.sqrt(0.8**2 - 0.5)
    p = np.array([0.5 + t / math.sqrt(2), 0.5 - t / math.sqrt(2)])
    box = np.array([[0.0, 0.0], [6.0, 6.0]])
    assert _counts(np.vstack([box, p]), 1.0, dim=2, radius=0.8)[2] == 3
    rng = np.random.default_rng(0)
    near = p + rng.normal(scale=1e-4, size=(5000, 2))
    assert _counts(np.vstack([box, near]), 1.0, dim=2, radius=0.8)[2:].max() == 2


def test_cubic_kernel_matches_reference():
    rng = np.random.default_rng(11)
    y = rng.uniform(0.0, 4.0, size=(400, 3))
    y[:5] = np.floor(y[:5])  # lattice points exactly
    y[5] = [0.5, 0.5, 0.5]
    for dim, (re, ro) in ((3, cover_radii(3)), (2, cover_radii(2, "two-radius", 0.9))):
        yy = y.copy()
        if dim == 2:
            yy[:, 2] = 0.0
        shape = np.array([6, 6, 6 if dim == 3 else 1], dtype=np.int64)
        codes, counts = _kernels.cubic_membership(yy, dim, re * re, ro * ro, shape)
        ref = cubic_membership_reference(yy, dim, re, ro)
        for p in range(y.shape[0]):
            got = codes[p, : counts[p]]
            assert (codes[p, counts[p] :] == -1).all()
            want = [(i * shape[1] + j) * shape[2] + k for i, j, k in ref[p]]
            assert got.tolist() == want


def test_tiling_kernel_matches_reference():
    rng = np.random.default_rng(12)
    y = np.zeros((400, 3))
    y[:, :2] = rng.uniform(0.0, 5.0, size=(400, 2))
    y[0, :2] = [0.5, math.sqrt(3) / 6]
    for r in (1 / math.sqrt(3), 0.7, math.sqrt(3) / 2):
        offset = np.array([-4, 0], dtype=np.int64)
        shape = np.array([12, 9], dtype=np.int64)
        codes, counts = _kernels.tiling_membership(y, r * r, shape, offset)
        ref = tiling_membership_reference(y, r)
        for p in range(y.shape[0]):
            want = [(i - offset[0]) * shape[1] + (j - offset[1]) for i, j in ref[p]]
            assert codes[p, : counts[p]].tolist() == want


@pytest.mark.skipif(JIT_OFF, reason="already running with the JIT off")
def test_kernels_without_jit():
    run_module_without_jit(__file__, select="kernel_matches_reference")


def test_algorithm2_clouds_are_the_non_empty_balls():
    pts = fibonacci_sphere(3000).vertices * 2.0
    cov = ball_cover(pts, 0.5)
    assert isinstance(cov, BallCover)
    K = cov.cloud_complex
    assert K.uncovered_points.size == 0 and K.empty_clouds.size == 0
    assert cov.centers.shape == (cov.n_clouds, 3) and cov.ball_radius.shape == (cov.n_clouds,)
    # every cloud is exactly the points within its ball
    for c in range(0, cov.n_clouds, 7):
        d = np.linalg.norm(pts - cov.centers[c], axis=1)
        inside = np.flatnonzero(d <= cov.ball_radius[c] * (1 + 1e-12))
        assert K.cloud(c).tolist() == inside.tolist()
    # centres on the scaled lattice anchored at the bounding-box corner
    lat = (cov.centers - pts.min(axis=0)) / 0.5
    np.testing.assert_allclose(lat, np.round(lat), atol=1e-9)
    assert set(np.round(cov.ball_radius / 0.5, 6)) <= {
        round(math.sqrt(3) / 2, 6),
        round(math.sqrt(3) / 6, 6),
    }


def test_sphere_gives_closed_genus0_cloud_surface_for_some_scale():
    pts = fibonacci_sphere(10_000).vertices
    res = search_cover_scale(pts, np.arange(0.3, 1.01, 0.1))
    assert res.accepted.size >= 1
    for i in res.accepted:
        rep = res.reports[i]
        assert rep.is_cloud_surface and rep.is_closed and rep.genus == 0
        assert rep.euler_characteristic == 2 and rep.is_orientable
    assert len(res.rows()) == res.scales.size


def test_search_with_rotations_is_seeded_and_reproducible():
    pts = fibonacci_sphere(2000).vertices
    a = search_cover_scale(pts, [0.5, 0.7], n_rotations=2, rng=7)
    b = search_cover_scale(pts, [0.5, 0.7], n_rotations=2, rng=7)
    c = search_cover_scale(pts, [0.5, 0.7], n_rotations=2, rng=8)
    assert np.array_equal(a.rotations, b.rotations) and not np.array_equal(a.rotations, c.rotations)
    assert a.rows() == b.rows()
    assert a.rotation_index.tolist() == [0, 1, 2, 0, 1, 2]
    R = random_rotations(3, rng=1)
    for q in R:
        np.testing.assert_allclose(q @ q.T, np.eye(3), atol=1e-12)
        assert abs(np.linalg.det(q) - 1) < 1e-12


def test_rotation_changes_the_cover_but_not_the_coverage():
    pts = fibonacci_sphere(2000).vertices
    R = random_rotations(1, rng=3)[1]
    a = ball_cover(pts, 0.5)
    b = ball_cover(pts, 0.5, rotation=R)
    assert b.cloud_complex.uncovered_points.size == 0
    # the ball centres of the rotated cover sit on the rotated lattice
    lat = (b.centers @ R.T - (pts @ R.T).min(axis=0)) / 0.5
    np.testing.assert_allclose(lat, np.round(lat), atol=1e-9)
    assert a.n_clouds != b.n_clouds or not np.array_equal(a.centers, b.centers)


def test_curve_cover_in_the_plane_is_a_one_manifold():
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    ellipse = np.column_stack([3 * np.cos(t), 1.5 * np.sin(t)])
    res = search_cover_scale(ellipse, [0.3, 0.6, 1.0], dim=2)
    assert res.is_accepted.tolist() == [False, True, True]
    assert not res.reports[0].is_one_manifold and res.reports[0].n_endpoints == 4
    rep = curve_report(ball_cover(ellipse, 0.6, dim=2).cloud_complex)
    assert rep.is_closed and rep.n_components == 1 and rep.euler_characteristic == 0


def test_cloud_points_centre_option():
    pts = fibonacci_sphere(500).vertices
    cov = ball_cover(pts, 0.6, cloud_points="center")
    np.testing.assert_array_equal(cov.cloud_complex.cloud_points, cov.centers)


def test_same_input_same_output():
    pts = np.random.default_rng(4).normal(size=(5000, 3))
    a, b = ball_cover(pts, 0.8), ball_cover(pts.copy(), 0.8)
    assert np.array_equal(a.cloud_complex.point_clouds, b.cloud_complex.point_clouds)
    assert np.array_equal(a.cloud_complex.triangles, b.cloud_complex.triangles)
    ra, rb = surface_report(a.cloud_complex), surface_report(b.cloud_complex)
    assert ra.summary() == rb.summary()


def test_bad_input_messages():
    pts = np.zeros((4, 3))
    with pytest.raises(ValueError, match=r"scale must be a finite number > 0"):
        ball_cover(pts, 0.0)
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\); got \(4, 2\)"):
        ball_cover(np.zeros((4, 2)), 1.0)
    with pytest.raises(ValueError, match="non-finite"):
        ball_cover(np.array([[0, 0, np.nan]]), 1.0)
    with pytest.raises(ValueError, match="radius is fixed for the 3-D cover"):
        ball_cover(pts, 1.0, radius=0.8)
    with pytest.raises(ValueError, match=r"radius must be a finite number in \[0.707"):
        ball_cover(pts, 1.0, dim=2, radius=1.2)
    with pytest.raises(ValueError, match="layout must be one of"):
        ball_cover(pts, 1.0, dim=2, layout="hex")
    with pytest.raises(ValueError, match="orthonormal"):
        ball_cover(pts, 1.0, rotation=2 * np.eye(3))
    with pytest.raises(ValueError, match=r"dim must be an integer in \[2, 3\]"):
        ball_cover(pts, 1.0, dim=4)
    with pytest.raises(ValueError, match="scales must hold finite"):
        search_cover_scale(pts, [1.0, -1.0])
    with pytest.raises(ValueError, match="n_rotations must be"):
        search_cover_scale(pts, [1.0], n_rotations=-1)
    with pytest.raises(ValueError, match=r"more than 1e\+06 balls"):
        ball_cover(np.array([[0, 0, 0], [1, 0, 0.0]]), 1e-7)


def test_offset_shifts_the_lattice_against_the_bounding_box():
    from pointatlas.cover import random_offsets

    pts = fibonacci_sphere(1500).vertices
    off = np.array([0.25, 0.5, 0.75])
    cov = ball_cover(pts, 0.5, offset=off)
    np.testing.assert_array_equal(cov.offset, off)
    lat = (cov.centers - pts.min(axis=0)) / 0.5 + off
    np.testing.assert_allclose(lat, np.round(lat), atol=1e-9)
    assert cov.cloud_complex.uncovered_points.size == 0
    # every cloud is exactly the points within its ball
    for c in range(0, cov.n_clouds, 5):
        d = np.linalg.norm(pts - cov.centers[c], axis=1)
        inside = np.flatnonzero(d <= cov.ball_radius[c]).tolist()
        assert cov.cloud_complex.cloud(c).tolist() == inside
    o = random_offsets(3, dim=2, rng=1)
    assert o.shape == (4, 3) and (o[0] == 0).all() and (o[:, 2] == 0).all()
    assert ((o >= 0) & (o < 1)).all()
    np.testing.assert_array_equal(o, random_offsets(3, dim=2, rng=1))
    with pytest.raises(ValueError, match=r"offset must hold numbers in \[0, 1\)"):
        ball_cover(pts, 0.5, offset=[0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=r"offset must have shape \(3,\); got \(4,\)"):
        ball_cover(pts, 0.5, offset=np.zeros(4))


def test_search_over_offsets_accepts_an_open_plane_and_rebuilds_the_chosen_setting():
    from pointatlas.synth import plane_patch

    pts = plane_patch(65, 65, width=4.0, height=4.0).vertices
    res = search_cover_scale(pts, [0.25], n_offsets=24, rng=0, accept="open")
    assert res.offset_index.tolist() == list(range(25)) and res.rotation_index.max() == 0
    assert not res.is_accepted[0] and res.reports[0].n_faces == 0  # the lattice layer z = 0
    assert res.n_unsupported[0] == pts.shape[0]
    i = res.chosen
    assert i == res.accepted[0] and res.n_unsupported[i] == 0
    rep = surface_report(ball_cover(pts, **res.setting(i)).cloud_complex)
    assert rep.summary() == res.reports[i].summary()
    assert rep.is_cloud_surface and not rep.is_closed and rep.n_boundary_loops == 1
    closed = search_cover_scale(pts, [0.25], n_offsets=24, rng=0)  # accept="closed"
    assert closed.accepted.size == 0 and closed.chosen == i  # fewest unsupported points
    with pytest.raises(ValueError, match="accept must be one of closed, open"):
        search_cover_scale(pts, [0.25], accept="any")


def test_unsupported_points_match_a_plain_reference():
    from pointatlas.complex import cloud_complex
    from pointatlas.complex._clouds import unsupported_mask

    rng = np.random.default_rng(3)
    pts = rng.uniform(0.0, 3.0, size=(3000, 3))
    pts[:, 2] *= 0.2  # a slab: some edges and vertices on no triangle
    K = ball_cover(pts, 0.6).cloud_complex
    tris = {tuple(t) for t in K.triangles.tolist()}
    tri_edges = {e for a, b, c in tris for e in ((a, b), (b, c), (a, c))}
    tri_verts = {v for t in tris for v in t}
    want = []
    for p in range(K.n_points):
        cl = tuple(K.clouds_of(p).tolist())
        ok = (
            len(cl) == 3
            or (len(cl) == 2 and cl in tri_edges)
            or (len(cl) == 1 and cl[0] in tri_verts)
        )
        want.append(not ok)
    assert unsupported_mask(K).tolist() == want
    assert 0 < sum(want) < K.n_points
    # point 2: its vertex (cloud 3) is on no triangle; point 3: in no cloud
    Kt = cloud_complex([[0, 1], [0, 1], [0, 1], [2]], n_points=4)
    assert unsupported_mask(Kt).tolist() == [False, False, True, True]

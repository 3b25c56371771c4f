"""Cloud dynamics (Algorithm 3): routing, the three update schemes, reversibility."""

import numpy as np
import pytest
from hypothesis import given, settings

from pointatlas.complex import cloud_complex, realize_complex, surface_report
from pointatlas.cover import ball_cover
from pointatlas.dynamics import DeformResult, deform_points
from pointatlas.synth import cube, fibonacci_sphere, plane_patch

from ..strategies import rigid_motions, seeds
from .reference import triangle_update_reference


def _sphere_cover():
    pts = fibonacci_sphere(6000).vertices
    cov = ball_cover(pts, 1.0)
    rep = surface_report(cov.cloud_complex)
    assert rep.is_closed and rep.is_cloud_surface
    return pts, cov.cloud_complex


PTS, K = _sphere_cover()
CP0 = np.asarray(K.cloud_points)
FACES = realize_complex(K)[1]


@settings(max_examples=20, deadline=None)
@given(motion=rigid_motions(), seed=seeds())
def test_round_trip_restores_every_point(motion, seed):
    R, t = motion
    rng = np.random.default_rng(seed)
    # an orientation-preserving motion of the cloud points: rigid plus a small jiggle
    cp1 = (CP0 + rng.normal(scale=0.02, size=CP0.shape)) @ R.T + t
    fwd = deform_points(PTS, K, cp1, faces=FACES)
    back = deform_points(fwd.points, K, cp1, faces=FACES, inverse=True)
    assert fwd.unroutable.size == 0
    size = np.linalg.norm(PTS, axis=1).max()
    err = np.linalg.norm(back.points - PTS, axis=1).max() / size
    assert err < 1e-9
    assert not np.allclose(fwd.points, PTS)


def test_rigid_motion_moves_triangle_and_edge_points_rigidly():
    q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    R = q * np.sign(np.linalg.det(q))
    t = np.array([1.0, -2.0, 0.5])
    res = deform_points(PTS, K, CP0 @ R.T + t, faces=FACES)
    rigid = PTS @ R.T + t
    te = res.route >= 2
    assert te.sum() > 100
    np.testing.assert_allclose(res.points[te], rigid[te], rtol=0, atol=1e-12)
    # vertex points: translated and turned so the vertex normal follows; distance kept
    v = np.flatnonzero(res.route == 1)
    c = res.simplex[v, 0]
    d0 = np.linalg.norm(PTS[v] - CP0[c], axis=1)
    d1 = np.linalg.norm(res.points[v] - (CP0 @ R.T + t)[c], axis=1)
    np.testing.assert_allclose(d1, d0, rtol=1e-12, atol=1e-12)


def test_triangle_points_match_eq_2_4_reference():
    rng = np.random.default_rng(2)
    cp1 = CP0 * (1 + 0.3 * rng.random((CP0.shape[0], 1))) + rng.normal(scale=0.05, size=CP0.shape)
    res = deform_points(PTS, K, cp1, faces=FACES)
    tri = np.flatnonzero(res.route == 3)
    assert tri.size > 20
    fs = {tuple(sorted(f)): f for f in FACES.tolist()}
    for i in tri[:200]:
        f = fs[tuple(res.simplex[i])]
        want = triangle_update_reference(PTS[i], CP0[f], cp1[f])
        np.testing.assert_allclose(res.points[i], want, rtol=0, atol=1e-10)


def test_signed_height_keeps_points_below_the_surface_below():
    cp = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    pts = np.array([[0.2, 0.2, -0.1], [0.2, 0.2, 0.1]])
    Kt = cloud_complex([[0, 1], [0, 1], [0, 1]], pts, cloud_points=cp)
    res = deform_points(pts, Kt, cp + [0.0, 0.0, 1.0])
    np.testing.assert_allclose(res.points, pts + [0.0, 0.0, 1.0], atol=1e-15)


def test_unroutable_points_are_reported_never_dropped():
    cp = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5], [6, 5, 5]])
    pts = np.array(
        [
            [0.2, 0.2, 0.0],  # triangle 0, 1, 2
            [9.0, 9.0, 9.0],  # in no cloud
            [5.5, 5.0, 5.0],  # clouds 3, 4: an edge on no triangle
            [6.2, 5.0, 5.0],  # cloud 4 only: a vertex on no triangle
        ]
    )
    Kt = cloud_complex([[0], [0], [0], [2], [2, 3]], pts, cloud_points=cp)
    res = deform_points(pts, Kt, cp * 2)
    assert isinstance(res, DeformResult)
    assert res.route.tolist() == [3, 0, 0, 0]
    assert res.unroutable.tolist() == [1, 2, 3]
    np.testing.assert_array_equal(res.points[1:], pts[1:])
    texts = [res.reasons[r] for r in res.reason[1:]]
    assert texts == [
        "in no cloud",
        "its two clouds span no edge of a triangle",
        "its vertex is on no triangle",
    ]
    assert res.counts()["unroutable"] == 3 and res.points.shape == (4, 3)


def _searched_cover(pts, scale, accept):
    from pointatlas.cover import search_cover_scale

    res = search_cover_scale(pts, [scale], n_offsets=24, rng=0, accept=accept)
    return ball_cover(pts, **res.setting(res.chosen)), res


def test_lifted_planar_grid_fig_2_20_routes_every_point():
    pts = plane_patch(65, 65, width=1.0, height=1.0).vertices  # 4,225 points as in 2.3.2
    cov, res = _searched_cover(pts, 0.25, "open")
    Kp = cov.cloud_complex
    rep = surface_report(Kp)
    assert res.is_accepted[res.chosen] and rep.is_cloud_surface
    assert rep.n_boundary_loops == 1 and rep.genus == 0 and rep.n_components == 1
    verts, faces = realize_complex(Kp, rep)
    inner = np.ones(Kp.n_clouds, dtype=bool)
    inner[rep.boundary_edges.ravel()] = False
    cp1 = verts.copy()
    cp1[inner, 2] += 0.3  # lift every cloud point off the boundary
    fwd = deform_points(pts, Kp, cp1, faces=faces)
    assert fwd.unroutable.size == 0 and (fwd.route > 0).mean() == 1.0
    assert fwd.points[:, 2].max() > 0.1
    back = deform_points(fwd.points, Kp, cp1, faces=faces, inverse=True)
    assert np.abs(back.points - pts).max() < 1e-9


def test_plane_in_a_lattice_layer_routes_every_point_with_an_offset():
    # a sparse plane in the layer z = 0 of the lattice (Algorithm 2 as printed) misses
    # the small regions where three balls meet: no triangles, nothing routable;
    # a lattice offset of 0.4 s in z puts it between two layers, where the slices of the
    # balls form a triangulated square lattice
    pts = plane_patch(65, 65, width=4.0, height=4.0).vertices
    flat = ball_cover(pts, 0.25)
    assert flat.cloud_complex.triangles.shape[0] == 0
    K = flat.cloud_complex
    assert (deform_points(pts, K, K.cloud_points).route > 0).sum() == 0
    cov = ball_cover(pts, 0.25, offset=[0.13, 0.37, 0.4])
    rep = surface_report(cov.cloud_complex)
    assert rep.is_cloud_surface and rep.n_boundary_loops == 1 and rep.genus == 0
    fwd = deform_points(pts, cov.cloud_complex, np.asarray(cov.cloud_complex.cloud_points) * 1.5)
    assert fwd.unroutable.size == 0


def test_cube_points_pushed_onto_the_unit_sphere_fig_2_21():
    pts = cube(16, size=2.0).vertices  # 1,538 points
    cov, res = _searched_cover(pts, 1.0, "closed")
    Kc = cov.cloud_complex
    cp0 = np.asarray(Kc.cloud_points)
    cp1 = cp0 / np.linalg.norm(cp0, axis=1, keepdims=True)
    fwd = deform_points(pts, Kc, cp1)
    assert fwd.unroutable.size == res.n_unsupported[res.chosen] == 3  # routed share 99.8 %
    assert (fwd.route > 0).mean() >= 0.998
    # identity and offset 0 (Algorithm 2 as printed) leave the faces in lattice layers
    assert res.n_unsupported[0] == pts.shape[0] and res.reports[0].n_faces == 0
    back = deform_points(fwd.points, Kc, cp1, inverse=True)
    np.testing.assert_allclose(back.points, pts, rtol=0, atol=1e-9 * 2)


def test_bad_input_messages():
    with pytest.raises(ValueError, match=r"points must have shape \(6000, 3\)"):
        deform_points(PTS[:5], K, CP0)
    with pytest.raises(ValueError, match=r"new_cloud_points must have shape"):
        deform_points(PTS, K, CP0[:3])
    with pytest.raises(ValueError, match="faces must be the triangles of complex"):
        deform_points(PTS, K, CP0, faces=np.roll(FACES, 1, axis=0) + 1)
    with pytest.raises(TypeError, match="CloudComplex"):
        deform_points(PTS, None, CP0)

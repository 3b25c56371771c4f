"""The points path's vertices on the points (`simplify/_snap.py`): a placement onto a
plane the points do not support goes back, a vertex left off the points after the
collapses is fitted back onto their tangent planes, and sampled CAD parts keep
their corners."""

from __future__ import annotations

import numpy as np
import pytest

from pointatlas.simplify._distance import (
    DISC_CANDIDATES,
    OUTLINE_MARGIN,
    OUTLINE_NEIGHBORS,
    PointSurface,
)
from pointatlas.simplify._grid_knn import GridKnn
from pointatlas.simplify._snap import (
    fit_to_points,
    placed_edges_near_points,
    placed_near_points,
    refit_far,
)
from pointatlas.synth import sample_mesh

from .cad_shapes import box, cube_with_square_hole, l_bracket
from .reference import disc_distance_reference, outline_distance_reference


def _floor(n=21):
    """Points on a grid over the unit square at z = 0, normals +z, and their surface."""
    g = np.linspace(0.0, 1.0, n)
    x, y = np.meshgrid(g, g, indexing="ij")
    q = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    normals = np.tile([0.0, 0.0, 1.0], (q.shape[0], 1))
    return q, normals, PointSurface(q, normals)


def _fan(centre):
    """A vertex (row 0) and a ring of four around it, one triangle fan, facing +z."""
    ring = centre + np.array([[0.1, 0, 0], [0, 0.1, 0], [-0.1, 0, 0], [0, -0.1, 0]])
    v = np.vstack([centre, ring])
    t = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])
    return v, t


def test_a_placement_off_the_points_goes_back_and_one_on_them_stays():
    _, _, surface = _floor()
    v0, t = _fan(np.array([0.5, 0.5, 0.0]))
    placed = v0.copy()
    placed[0] = [0.5, 0.5, 0.05]  # onto a wrong plane: 0.05 off the points
    placed[1] = [0.63, 0.5, 0.0]  # along the floor: still on the points
    out = placed_near_points(v0, placed, t, surface, tol=0.01)
    assert out[0].tolist() == [0.5, 0.5, 0.0]  # back where it was
    assert out[1].tolist() == [0.63, 0.5, 0.0]  # kept
    # a move below the tolerance is never measured, whatever it is
    small = v0.copy()
    small[0, 2] = 0.005
    assert placed_near_points(v0, small, t, surface, tol=0.01)[0, 2] == 0.005
    # a vertex that was as far before keeps its placement (it is no worse)
    lifted = v0 + [0.0, 0.0, 0.08]
    moved = lifted.copy()
    moved[0, 2] = 0.05
    assert placed_near_points(lifted, moved, t, surface, tol=0.01)[0, 2] == 0.05


def _step(n=41):
    """A step: the floor z = 0 for x <= 0.5 and a wall x = 0.5 from z = -0.5 up to it
    (normals +z and -x), as points on a grid of spacing 1 / (n - 1)."""
    g = np.linspace(0.0, 1.0, n)
    top = np.array([[x, y, 0.0] for x in g if x <= 0.5 for y in g])
    wall = np.array([[0.5, y, -z] for z in g[1:] if z <= 0.5 for y in g])
    q = np.vstack([top, wall])
    normals = np.vstack(
        [np.tile([0.0, 0.0, 1.0], (len(top), 1)), np.tile([1.0, 0, 0], (len(wall), 1))]
    )
    return q, normals, PointSurface(q, normals)


def test_outline_distance_is_the_disc_distance_inside_and_the_distance_past_the_edge():
    q, normals, surface = _step()
    rng = np.random.default_rng(0)
    inside = np.column_stack(
        [rng.uniform(0.05, 0.45, 50), rng.uniform(0.05, 0.95, 50), rng.uniform(-0.01, 0.01, 50)]
    )
    assert (surface.outline_distance(inside) == surface.distance(inside)).all()
    # the wall's top edge (a convex edge of the sample) is on the surface
    edge = np.column_stack([np.full(9, 0.5), np.linspace(0.1, 0.9, 9), np.zeros(9)])
    assert surface.outline_distance(edge).max() == pytest.approx(0.0, abs=1e-12)
    # the floor extended past the wall by 0.02 (0.8 spacings): within a disc's reach
    # (the 8th neighbour: 0.035), but past the outline by 0.02, measured along the
    # middle of the neighbours' gap (tilted by their uneven ring: up to 0.02)
    lip = np.array([[0.52, 0.5, 0.0], [0.52, 0.5, 0.002]])
    assert surface.distance(lip[:1])[0] == 0.0
    far = surface.outline_distance(lip)
    assert (far >= 0.75 * np.hypot([0.0, 0.002], 0.02)).all()
    assert (far <= np.hypot([0.0, 0.002], 0.02) + 1e-12).all()
    # an open sheet's corner and a position across a gap in the middle of it
    _, _, floor = _floor()
    x = np.array([[1.03, 1.04, 0.0], [0.525, 0.5, 0.0]])
    far = floor.outline_distance(x)
    assert 0.75 * 0.05 <= far[0] <= 0.05 + 1e-12 and far[1] == 0.0


def test_a_face_extended_past_a_wall_goes_back():
    """A vertex of the floor placed onto the floor's plane past the wall of a step is
    within a disc's radius of the floor's points (`distance`: near) but past the
    sample's outline: the placement goes back."""
    _, _, surface = _step()
    v0, t = _fan(np.array([0.45, 0.5, 0.0]))
    placed = v0.copy()
    placed[0] = [0.52, 0.5, 0.0]
    assert surface.distance(placed[:1])[0] == 0.0
    out = placed_near_points(v0, placed, t, surface, tol=0.01)
    assert out[0].tolist() == [0.45, 0.5, 0.0]


def test_a_vertex_left_off_the_points_is_fitted_back_within_the_bound():
    _, _, surface = _floor()
    v, t = _fan(np.array([0.5, 0.5, 0.0]))
    v[0, 2] = 0.05
    near = refit_far(v, t, surface, tol=0.01, bound=1.0)
    assert near[0] == pytest.approx([0.5, 0.5, 0.0], abs=1e-12)
    assert (near[1:] == v[1:]).all()  # the ring lay on the points: not moved
    capped = refit_far(v, t, surface, tol=0.01, bound=0.02)
    assert capped[0] == pytest.approx([0.5, 0.5, 0.03], abs=1e-12)
    # within the tolerance: nothing moves
    v[0, 2] = 0.005
    assert (refit_far(v, t, surface, tol=0.01, bound=1.0) == v).all()


def test_an_edge_placed_across_a_gap_goes_back():
    """`placed_edges_near_points`: a vertex placed onto the points on the far side of
    a slot (both of its edges' ends on the points, their middles over the slot) goes
    back; a move whose edges stay on the points is kept."""
    q, normals, _ = _floor()
    keep = (q[:, 0] <= 0.3) | (q[:, 0] >= 0.7)
    surface = PointSurface(q[keep], normals[keep])
    v0, t = _fan(np.array([0.2, 0.5, 0.0]))
    placed = v0.copy()
    placed[1] = [0.75, 0.5, 0.0]  # (0.3, 0.5) across the slot
    assert surface.distance(placed[1:2])[0] == 0.0
    assert (placed_near_points(v0, placed, t, surface, tol=0.01) == placed).all()
    out = placed_edges_near_points(v0, placed, t, surface, far=0.05)
    assert (out == v0).all()
    placed[1] = [0.28, 0.52, 0.0]  # along the floor
    assert (placed_edges_near_points(v0, placed, t, surface, far=0.05) == placed).all()


def test_a_placement_that_collapses_a_triangle_goes_back():
    """Two ring vertices placed on one spot: the triangle between them has zero area
    and a normal of rounding noise that may still point the former way (100 sparse
    sphere points gave such an output triangle); its vertices go back. The first fit
    of the surface may collapse triangles: its decimation removes them."""
    from pointatlas.simplify._place import _unflip

    v0, t = _fan(np.array([0.5, 0.5, 0.0]))
    placed = v0.copy()
    placed[2] = placed[1] + [0.0, 1e-12, 0.0]  # onto vertex 1 but for rounding
    twice_area = np.cross(placed[1] - placed[0], placed[2] - placed[0])[2]
    assert 0.0 < twice_area < 1e-12  # still the former way (+z), area ~1e-13
    out = _unflip(v0, placed.copy(), t)
    assert (out == v0).all()
    kept = _unflip(v0, placed.copy(), t, collapsed=True)
    assert (kept == placed).all()
    # a placement that shrinks a triangle without collapsing it stays
    shrunk = v0.copy()
    shrunk[2] = [0.55, 0.55, 0.0]
    assert (_unflip(v0, shrunk.copy(), t) == shrunk).all()


def test_fit_to_points_moves_onto_the_corner_of_three_planes():
    """Points on three faces of a cube corner: a vertex near the corner goes to it
    (the three tangent planes meet there), at most the bound."""
    g = np.linspace(0.05, 1.0, 12)
    a, b = (x.ravel() for x in np.meshgrid(g, g, indexing="ij"))
    z = np.zeros(a.size)
    q = np.vstack(
        [np.column_stack([a, b, z]), np.column_stack([a, z, b]), np.column_stack([z, a, b])]
    )
    n = np.repeat(-np.eye(3)[[2, 1, 0]], a.size, axis=0)
    v = np.array([[0.03, 0.02, 0.04], [0.5, 0.5, 0.03]])
    out = fit_to_points(v, np.zeros((0, 3), np.int64), q, n, GridKnn(q, 0.5), bound=1.0, k=48)
    assert out[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    # on one face only: straight onto its plane, not along it
    assert out[1] == pytest.approx([0.5, 0.5, 0.0], abs=1e-12)
    capped = fit_to_points(v, np.zeros((0, 3), np.int64), q, n, GridKnn(q, 0.5), bound=0.01, k=48)
    assert capped[1] == pytest.approx([0.5, 0.5, 0.02], abs=1e-12)


@pytest.mark.parametrize("shape", [box, l_bracket], ids=["box", "l-bracket"])
def test_sampled_cad_corners_come_back_on_the_true_corners(shape):
    """20,000 points with their normals on a box / an L-bracket (the robust path):
    every true corner has an output vertex within 0.2 % of the diagonal (measured:
    0.13 % on the box, 0.11 % on the L-bracket; the grid step is about 1 %), and
    every output vertex lies on the true surface within 0.2 %."""
    from pointatlas.neighbors import point_mesh_distance
    from pointatlas.simplify import simplify_points

    v, t = shape()
    s = sample_mesh(v, t, 20000, rng=0)
    p = np.asarray(s.points)
    r = simplify_points(p, s.normals)
    m = r.mesh
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    assert r.path == "robust" and m.is_closed and m.is_manifold and m.is_oriented
    gap = np.linalg.norm(v[:, None, :] - m.vertices[None, :, :], axis=2).min(axis=1)
    assert gap.max() <= 2e-3 * diag
    assert point_mesh_distance(m.vertices, v, t).max() <= 2e-3 * diag


@pytest.mark.parametrize("shape", [l_bracket])
def test_level_search_on_a_subset_of_the_points_meets_the_bound_on_all(shape, monkeypatch):
    """The points path's level search first on a few of the points (`PointsDecimation.
    steps_within`): a subset of 60 points (its levels fail on all, the search runs
    again on all) and of 1,500 give the plain search's mesh, within the bound."""
    import warnings

    from pointatlas.simplify import SimplifyWarning, simplify_points
    from pointatlas.simplify._snap import PointsDecimation

    v, t = shape()
    s = sample_mesh(v, t, 6000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    meshes = []
    for few in (10**9, 60, 1500):
        monkeypatch.setattr(PointsDecimation, "search_points", few)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimplifyWarning)
            meshes.append(simplify_points(p, n, path="robust").mesh)
    for m in meshes[1:]:
        np.testing.assert_array_equal(m.triangles, meshes[0].triangles)
        np.testing.assert_array_equal(m.vertices, meshes[0].vertices)


def test_level_0_without_the_sequence_is_the_sequence_s_level_0():
    """`PointsDecimation` places and measures level 0 before its collapses begin
    (their tolerances come from it): `no_collapses`' level 0 is `collapse_all`'s."""
    from pointatlas.simplify._decimate import collapse_all, no_collapses

    v, t = l_bracket()
    for a, b in zip(
        no_collapses(v, t).mesh_and_map(0), collapse_all(v, t).mesh_and_map(0), strict=True
    ):
        np.testing.assert_array_equal(a, b)


def test_disc_kernels_agree_with_the_numpy_reference():
    """Both distances on positions on, near and past a sampled L-bracket (its open
    top: the points of a box without one face, so that positions lie past an
    outline), and far from it."""
    v, t = l_bracket()
    s = sample_mesh(v, t, 3000, rng=3)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    keep = q[:, 2] < q[:, 2].max() - 1e-9  # no top face: an outline along its edges
    q, n = q[keep], n[keep]
    surface = PointSurface(q, n)
    rng = np.random.default_rng(4)
    lo, hi = q.min(axis=0), q.max(axis=0)
    x = np.vstack(
        [
            q[::7] + rng.normal(scale=0.02, size=q[::7].shape),
            rng.uniform(lo - 0.3, hi + 0.3, size=(500, 3)),
            q[::11] * [1.0, 1.0, 0.0] + [0.0, 0.0, hi[2] + 0.05],  # over the open top
        ]
    )
    k = max(OUTLINE_NEIGHBORS, DISC_CANDIDATES)
    np.testing.assert_allclose(
        surface.distance(x), disc_distance_reference(surface, x, DISC_CANDIDATES), atol=1e-12
    )
    got = surface.outline_distance(x)
    ref = outline_distance_reference(surface, x, k, DISC_CANDIDATES, OUTLINE_MARGIN)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)
    # the outline cut makes some positions farther than their discs, never nearer
    assert (got >= surface.distance(x)).all() and (got > surface.distance(x) + 1e-3).any()


def test_a_placement_that_takes_points_past_their_floor_is_put_back():
    """`_snap.placed_keeps_points`: a vertex placed 0.2 off a sampled box's face takes
    the points of its triangles past their floor: it goes back; one placed a hair
    off stays, and so does every vertex of a triangle no point went far from."""
    from pointatlas.neighbors import point_mesh_distance
    from pointatlas.simplify._snap import placed_keeps_points

    from .cad_shapes import subdivide

    v, t = subdivide(*subdivide(*box()))
    s = sample_mesh(v, t, 4000, rng=0)
    q = np.array(s.points)  # writeable, as the points path's (one kernel signature)
    top = np.flatnonzero(np.isclose(v[:, 2], v[:, 2].max()))
    inner = top[np.argsort(np.linalg.norm(v[top, :2] - v[top, :2].mean(axis=0), axis=1))]
    far = inner[0]
    ring = np.unique(t[(t == far).any(axis=1)])  # far and the vertices around it
    near = next(i for i in inner[::-1] if i not in ring)
    placed = v.copy()
    placed[far, 2] += 0.2
    placed[near, 2] += 1e-4
    floor = np.full(q.shape[0], 0.01)
    got = placed_keeps_points(v, placed, t, q, floor, 0.0025)
    np.testing.assert_array_equal(got[far], v[far])
    np.testing.assert_array_equal(got[near], placed[near])
    others = np.setdiff1d(np.arange(v.shape[0]), ring)
    np.testing.assert_array_equal(got[others], placed[others])
    assert point_mesh_distance(q, got, t).max() <= 1e-4 + 1e-12


def test_the_triangles_cross_products_are_numpys_bit_for_bit():
    """`_place._cross` (one numba pass) gives ``np.cross`` of the gathered edges
    exactly, on coordinates spread over twelve orders of magnitude, and nothing for
    no triangles."""
    from pointatlas.simplify._place import _cross

    rng = np.random.default_rng(5)
    v = rng.normal(size=(500, 3)) * 10.0 ** rng.uniform(-6, 6, size=(500, 1))
    t = rng.integers(0, 500, size=(2000, 3))
    want = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    assert np.array_equal(_cross(v, t), want)
    assert np.array_equal(_cross(v, t.astype(np.int32)), want)
    assert _cross(v, np.zeros((0, 3), dtype=np.int64)).shape == (0, 3)


#: More triangles than any level of the sampled cube with a square hole but level 0
#: (about 25,000).
LEVEL_0 = 5000


def test_a_level_the_planar_step_takes_past_the_bound_is_measured_without_it(monkeypatch):
    """`PointsDecimation.within`: a level over the bound with its faces made planar
    (`_planar.merged_planar_faces`) is measured again as placed without that step, so the
    step never costs a level: a step that shifts every vertex of a level by 3 % of
    the box gives the mesh of no step at all, bit for bit (level 0 aside: its
    placement sets the search's floors, `_level_search.default_steps`, so shifted it raises
    them to the shift, no farther, and the level found moves by three collapses)."""
    import warnings

    from pointatlas.simplify import SimplifyWarning, _snap, simplify_points

    v, t = cube_with_square_hole()
    s = sample_mesh(v, t, 6000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    meshes = []
    for step in (
        lambda x, t, face, *a, **k: (x, face),
        lambda x, t, face, *a, **k: (x + (t.shape[0] < LEVEL_0) * 0.03 * np.ptp(x, axis=0), face),
    ):
        monkeypatch.setattr(_snap, "merged_planar_faces", step)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimplifyWarning)
            meshes.append(simplify_points(p, n, path="robust").mesh)
    np.testing.assert_array_equal(meshes[1].triangles, meshes[0].triangles)
    np.testing.assert_array_equal(meshes[1].vertices, meshes[0].vertices)


def test_a_level_over_the_bound_is_made_planar_again_with_smaller_moves(monkeypatch):
    """`PointsDecimation.within`: a level the planar step takes over the bound and
    that passes without it is made planar again with the moves at most each share
    of `GENTLE_SHARES` of the bound in turn; the first that passes is kept. A step
    that shifts every vertex by 3 % of the box at a cap of half the bound or more,
    and by a hair at less, gives the mesh of no step shifted by that hair; the
    shares are asked in order, down to the first below half the bound."""
    import warnings

    from pointatlas.simplify import SimplifyWarning, _snap, simplify_points

    v, t = cube_with_square_hole()
    s = sample_mesh(v, t, 6000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    hair = 1e-9
    caps = []

    def shifted(x, t, face, flat, tol, cap, planes=None):
        caps.append(cap)
        if t.shape[0] >= LEVEL_0:  # level 0, whose placement sets the floors, as is
            return x, face
        far = cap >= 0.5 * caps[0]  # caps[0]: the first level's, the whole bound
        return x + (0.03 if far else hair) * np.ptp(x, axis=0), face

    meshes = []
    for step in (lambda x, t, face, *a, **k: (x, face), shifted):
        monkeypatch.setattr(_snap, "merged_planar_faces", step)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SimplifyWarning)
            meshes.append(simplify_points(p, n, path="robust").mesh)
    plain, gentle = meshes
    np.testing.assert_array_equal(gentle.triangles, plain.triangles)
    want = np.asarray(plain.vertices)
    # the hair's shift of the plain level's vertices (the box clip aside)
    np.testing.assert_allclose(gentle.vertices, want + hair * np.ptp(want, axis=0), atol=1e-12)
    shares = [round(c / caps[0], 12) for c in caps]
    order = (1.0, *_snap.GENTLE_SHARES)
    # the shares down to the first at less than half the bound, none past it
    first = next(i for i, share in enumerate(order) if share < 0.5)
    assert set(shares) == set(order[: first + 1])
    # each after the one before (or the same again: the output level placed once more
    # where its crossing moves are put back, `_placed_uncrossed`)
    for prev, share in zip(shares, shares[1:], strict=False):
        if share != 1.0 and share != prev:
            assert prev == order[order.index(share) - 1]


def test_the_planar_step_s_shares_hold_only_for_the_measure_that_chose_them(monkeypatch):
    """`PointsDecimation.within` / `forget_levels`: a level over the bound with the
    step on the points' planes, on its own planes and without it keeps the step (the
    step did not take it over); a level over on the points' planes and within on the
    faces' own planes keeps those; a level placed without the step, or with a shorter
    move, under one measure gets the whole step on the points' planes again once the
    measure changes (`forget_levels`: the looser floors), and keeps it where it then
    passes (the sampled cable holder: 48 -> 25 faces bent)."""
    from pointatlas.simplify import _decimate_mesh, _snap

    level = object.__new__(_snap.PointsDecimation)
    level._planar_share, level._planar_moved = {}, {5: True, 6: True, 7: True}
    level._on_points, level._given_up, level.measure = {}, {}, None  # no faces left out
    level._relabel, level._relabelled = {}, {}  # no triangle given away
    level._over, level._near, level._kept_level = set(), {}, None
    passes = {}  # (level, how) -> within, under the measure of the moment

    def how(self, m):
        share = self._planar_share.get(m, 1.0)
        return "points" if share == 1.0 and self._on_points.get(m, True) else share

    def within(self, m, bound, first=None):
        ok = passes[(m, how(self, m))]
        if ok:
            self._kept_level = (m, ("placed", how(self, m)))
        else:
            self._over.add((m, bound))
        return ok

    monkeypatch.setattr(_decimate_mesh.Decimation, "within", within)
    shares = ("points", 1.0, 0.0, *_snap.GENTLE_SHARES)
    passes.update({(5, s): False for s in shares})
    passes.update({(6, s): s == 1.0 for s in shares})
    passes.update({(7, s): s == 0.0 for s in shares})
    assert not level.within(5, 1.0)
    assert 5 not in level._planar_share  # over either way: the step stays
    assert level.within(6, 1.0)
    assert level._kept_level == (6, ("placed", 1.0)) and not level._on_points[6]
    assert level.within(7, 1.0)
    assert level._planar_share[7] == 0.0 and level._kept_level == (7, ("placed", 0.0))
    # looser floors: every level passes with the whole step on the points' planes
    level.forget_levels()
    passes.update({(m, s): True for m in (5, 6, 7) for s in shares})
    assert level._planar_share == {} and level._on_points == {} and level._kept_level is None
    for m in (5, 6, 7):
        assert level.within(m, 1.0)
        assert level._planar_share.get(m, 1.0) == 1.0
        assert level._kept_level == (m, ("placed", "points"))


def test_a_level_over_the_bound_leaves_out_of_the_step_the_faces_where_it_went_over(
    monkeypatch,
):
    """`PointsDecimation.within`: a level the planar step takes over the bound on the
    points' planes and on its own, and within it without the step, is placed again
    with the step on the points' planes but for the flat faces at the vertices
    nearest to where it went over (`PointDistances.over_at`) that the step moved,
    round by round; the first round that passes is kept with the faces it left out
    (``_given_up``). Where no round passes, the shorter moves follow on the faces'
    own planes as before, and no face is left out."""
    from pointatlas.simplify import _decimate_mesh, _snap

    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 0, 0], [2, 1, 0.0]])
    t = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3], [4, 5, 3]])
    face = np.array([0, 1, 1, 2])  # vertex 3 is on faces 1 and 2, moved by the step

    class Measure:
        def over_at(self, y, out_t, bound):
            return y[[3]] + 1e-3 if (y[3] != x[3]).any() else np.zeros((0, 3))

    def placed(self, m):  # as the level's `_placed`: the placement, kept as the last made
        given = self._given_up.get(m)
        y = x.copy()
        if given is None or not given[1]:
            y[3, 2] += 0.1
        self._stepped = (m, (y, t, face, None, None))
        return self._stepped[1]

    calls = []

    def run(passes_with_face_1_out):
        level = object.__new__(_snap.PointsDecimation)
        level._planar_share, level._planar_moved = {}, {4: True}
        level._on_points, level._given_up = {}, {}
        level._relabel, level._relabelled = {}, {}
        level._over, level._near, level._kept_level = set(), {}, None
        level.planes = (None, None, np.ones(3, dtype=bool))
        level.measure, level._unstepped = Measure(), (4, (x, t, face, None, None))
        calls.clear()

        def within(self, m, bound, first=None):  # places the level, as `Decimation.within`
            self._placed(m)
            share, on = self._planar_share.get(m, 1.0), self._on_points.get(m, True)
            given = self._given_up.get(m)
            calls.append((share, on, None if given is None else given.tolist()))
            out = given is not None and bool(given[1]) and passes_with_face_1_out
            ok = share == 0.0 or (share == 1.0 and on and out)
            if ok:
                self._kept_level = (m, ("placed", share, on))
            else:
                self._over.add((m, bound))
            return ok

        monkeypatch.setattr(_decimate_mesh.Decimation, "within", within)
        monkeypatch.setattr(_snap.PointsDecimation, "_placed", placed)
        assert level.within(4, 1.0)
        return level

    none, one = [False, False, False], [False, True, True]  # the faces at vertex 3
    level = run(True)
    assert calls == [(1.0, True, None), (0.0, True, None), (1.0, False, None)] + [
        (1.0, True, none),
        (1.0, True, one),
    ]
    assert level._given_up[4].tolist() == one and level._on_points[4]
    assert level._planar_share[4] == 1.0 and level._kept_level == (4, ("placed", 1.0, True))
    level = run(False)  # no round passes: the shorter moves, then no step
    gentle = [(share, False, None) for share in _snap.GENTLE_SHARES]
    assert calls[3:] == [(1.0, True, none), (1.0, True, one), *gentle]
    assert 4 not in level._given_up and not level._on_points[4]
    # the placement without the step, as measured second (before the own planes)
    assert level._planar_share[4] == 0.0 and level._kept_level == (4, ("placed", 0.0, True))


def test_a_level_over_with_triangles_given_away_is_measured_as_they_were(monkeypatch):
    """`PointsDecimation.within`: a level the step takes over the bound with triangles
    of flat faces given to the faces they lie on (`off_plane_relabelled`), within it
    without the step, is measured again with them as they were, on the points'
    planes, and kept so where it passes (the triangles never cost a level: a sampled
    knob, normals estimated, had ended at 5,380 triangles for 2,070); where the
    triangles were not given away (nothing changed), that measure is not made again.
    A level over without the step too is measured once more on the faces' own planes
    as they were, and is over where that fails: not measured again, nor placed.
    `forget_levels` gives the triangles away anew."""
    from pointatlas.simplify import _decimate_mesh, _snap

    calls = []

    def within(self, m, bound, first=None):
        share, on = self._planar_share.get(m, 1.0), self._on_points.get(m, True)
        relabel = self._relabel.get(m, True)
        calls.append((m, share, on, relabel))
        # on the points' planes with the triangles as they were; without the step,
        # but for level 10
        ok = (share == 1.0 and on and not relabel) or (share == 0.0 and m != 10)
        if ok:
            self._kept_level = (m, ("placed", share, on, relabel))
        else:
            self._over.add((m, bound))
        return ok

    monkeypatch.setattr(_decimate_mesh.Decimation, "within", within)
    level = object.__new__(_snap.PointsDecimation)
    level._planar_share, level._planar_moved = {}, {8: True, 9: True, 10: True}
    level._on_points, level._given_up, level.measure = {}, {}, None
    level._relabel, level._relabelled = {}, {8: True, 9: False, 10: True}
    level._over, level._near, level._kept_level = set(), {}, None
    assert level.within(8, 1.0)
    assert calls == [(8, 1.0, True, True), (8, 0.0, True, True), (8, 1.0, True, False)]
    assert level._kept_level == (8, ("placed", 1.0, True, False)) and not level._relabel[8]
    calls.clear()
    assert level.within(9, 1.0)  # nothing given away: the own planes, then ...
    assert calls[:3] == [(9, 1.0, True, True), (9, 0.0, True, True), (9, 1.0, False, True)]
    calls.clear()
    assert not level.within(10, 1.0)  # over without the step: the own planes alone
    assert calls == [(10, 1.0, True, True), (10, 0.0, True, True), (10, 1.0, False, False)]
    calls.clear()
    assert not level.within(10, 1.0) and calls == []  # over: not measured again
    level.forget_levels()
    assert level._relabel == {} and level._relabelled == {}

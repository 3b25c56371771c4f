"""The robust path's thin parts: nodes between two sides of a wall or a gap keep their
side through the field's smoothing (`_kernels.thin_sides`, `_reconstruct._thin_keep`),
a sample thin in part takes the finer grid (`_voxel_grid.thin_share`), and a level's
bound rises only where the points' surface itself is far (`PointDistances.floor_at`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pointatlas.simplify._distance import PointSurface
from pointatlas.simplify._kernels import OPPOSITE, thin_sides
from pointatlas.simplify._point_distances import (
    FLOOR_CAP,
    FLOOR_NEIGHBORS,
    WITNESSES,
    PointDistances,
)
from pointatlas.simplify._reconstruct import FIELD_K, _thin_keep
from pointatlas.synth import sample_mesh

from .cad_shapes import box, extrude, subdivide
from .collection_runs import COLLECTION, without_and_with
from .test_points_robust import _euler, _to_and_from_truth

Z_TOP = COLLECTION / "prusamini_mini-z-top.stl"


def _reference(x, d, j, q, normals, step, spacing):
    """`thin_sides` in plain numpy: every pair of speaking neighbours."""
    speak = d <= d[:, :1] + spacing
    s = np.einsum("nkd,nkd->nk", normals[j], x[:, None, :] - q[j])
    tol = 1e-9 * step
    pos = ((s >= -tol) & speak).any(axis=1)
    neg = ((s <= tol) & speak).any(axis=1)
    out = np.zeros(x.shape[0], dtype=np.int8)
    for i in np.flatnonzero(pos != neg):
        for a in range(d.shape[1]):
            need = step * np.abs(normals[j[i, a]]).sum()
            for b in range(a + 1, d.shape[1]):
                pair = speak[i, a] and speak[i, b]
                if (
                    pair
                    and normals[j[i, a]] @ normals[j[i, b]] < OPPOSITE
                    and abs(s[i, a]) + abs(s[i, b]) >= need
                ):
                    out[i] = -1 if neg[i] else 1
    return out


def _flags(q, normals, x, step, spacing):
    d, j = cKDTree(q).query(x, k=FIELD_K)
    return thin_sides(x, d, j.astype(np.int64), q, normals, step, spacing), (d, j)


def _plates(gap=0.3, thick=0.3, n=6000):
    """Two square plates ``thick`` thick, ``gap`` apart (sampled, face normals)."""
    v, t = extrude([[0, 0], [3, 0], [3, 3], [0, 3]], height=thick)
    v2 = v + [0.0, 0.0, thick + gap]
    s = sample_mesh(np.vstack([v, v2]), np.vstack([t, t + v.shape[0]]), n, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def test_thin_sides_in_a_wall_and_in_a_gap():
    q, n = _plates()
    spacing = float(np.median(cKDTree(q).query(q, k=2)[0][:, 1]))
    g = np.linspace(1.0, 2.0, 6)
    gx, gy = np.meshgrid(g, g, indexing="ij")
    mid = lambda z: np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z)])  # noqa: E731
    wall, gap = mid(0.15), mid(0.45)
    flags, _ = _flags(q, n, np.vstack([wall, gap]), 0.1, spacing)
    assert (flags[: len(wall)] == -1).all()  # inside the lower plate
    assert (flags[len(wall) :] == 1).all()  # between the plates
    # a grid coarser than the wall cannot hold it without holes: nothing kept
    coarse, _ = _flags(q, n, np.vstack([wall, gap]), 0.35, spacing)
    assert (coarse == 0).all()


def test_thin_sides_leaves_right_angles_and_open_sides_alone():
    v, t = box()
    s = sample_mesh(v, t, 6000, rng=0)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    spacing = float(np.median(cKDTree(q).query(q, k=2)[0][:, 1]))
    rng = np.random.default_rng(1)
    x = q[rng.integers(0, q.shape[0], 3000)] + rng.normal(0.0, 2 * spacing, (3000, 3))
    flags, _ = _flags(q, n, x, 1.5 * spacing, spacing)
    assert (flags == 0).all()  # no two faces of a box face opposite ways within reach


def test_thin_sides_matches_plain_reference():
    q, n = _plates(gap=0.2, thick=0.2, n=4000)
    spacing = float(np.median(cKDTree(q).query(q, k=2)[0][:, 1]))
    rng = np.random.default_rng(2)
    x = q[rng.integers(0, q.shape[0], 4000)] + rng.uniform(-0.2, 0.2, (4000, 3))
    step = 1.5 * spacing
    flags, (d, j) = _flags(q, n, x, step, spacing)
    ref = _reference(x, d, j, q, n, step, spacing)
    np.testing.assert_array_equal(flags, ref)
    assert (ref == -1).sum() > 50 and (ref == 1).sum() > 50  # both branches seen


def test_thin_keep_grows_along_its_side_only():
    band = np.ones((5, 5, 5), dtype=bool)
    values = np.ones(band.sum())
    values.reshape(5, 5, 5)[:, :, 2] = -1.0  # a one-node wall at z = 2
    thin = np.zeros(band.sum(), dtype=np.int8)
    thin.reshape(5, 5, 5)[2, 2, 2] = -1  # one node of it seen between two sides
    keep = _thin_keep(band, thin, values)
    want = np.zeros((5, 5, 5), dtype=bool)
    want[1:4, 1:4, 2] = True  # its wall neighbours, not the outside beside it
    np.testing.assert_array_equal(keep, want)


def _dented(v, at, depth):
    """``v`` with vertex ``at`` (on a face z = 0 or z = 1) moved ``depth`` into the cube."""
    w = v.copy()
    w[at, 2] += depth if w[at, 2] < 0.5 else -depth
    return w


def _sampled_cube():
    """The unit cube (subdivided), 6,000 points sampled on it with their normals, and
    its vertices at the top's and the bottom's middle."""
    v, t = subdivide(*box())
    v = (v - v.min(axis=0)) / np.ptp(v, axis=0)  # the unit cube
    s = sample_mesh(v, t, 6000, rng=0)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    top = int(np.argmin(np.linalg.norm(v - [0.5, 0.5, 1.0], axis=1)))
    bottom = int(np.argmin(np.linalg.norm(v - [0.5, 0.5, 0.0], axis=1)))
    return v, t, q, n, top, bottom


def test_floor_raises_the_bound_only_where_the_surface_is_far():
    v, t, q, n, top, bottom = _sampled_cube()
    measure = PointDistances(q, PointSurface(q, n))
    bound = 0.01
    far = _dented(v, top, 0.05)  # the points' surface 5 % off at one face's middle
    most = measure.floor_at(far, t, bound, slack=1.0, factor=1.1)
    np.testing.assert_allclose(most, 0.05, rtol=0.02)
    assert measure.within(far, t, bound)  # the surface itself passes
    # a second face nearly as far passes a bound raised everywhere, not here
    worse = _dented(far, bottom, 0.045)
    assert measure.error(worse, t) <= 1.1 * most
    assert not measure.within(worse, t, bound)
    # at the first: what the surface reaches there + the bound, at most 1.1 x the most
    assert measure.within(_dented(v, top, 0.054), t, bound)
    assert not measure.within(_dented(v, top, 0.057), t, bound)


def test_witnesses_of_a_level_over_the_bound_give_every_answer_a_fresh_measure_gives(
    monkeypatch,
):
    """`PointDistances.within` keeps the points a level was over at (at most
    `WITNESSES`, the farthest past their floors) and asks them first: the same answer
    as a measure of every point for each surface of a sequence (over, over nearby,
    within, over elsewhere), measuring every point only where the witnesses do not
    decide; a subset keeps witnesses of its own rows."""
    from pointatlas.simplify import _mesh

    v, t, q, n, top, bottom = _sampled_cube()
    bound = 0.01

    def measure():
        out = PointDistances(q, PointSurface(q, n))
        out.floor_at(v, t, bound)  # the cube is the points' surface
        return out

    kept = measure()
    seq = [
        _dented(v, top, 0.05),
        _dented(v, top, 0.04),
        v,
        _dented(v, bottom, 0.05),
        _dented(v, top, 0.03),
    ]
    answers = [measure().within(w, t, bound) for w in seq]
    assert answers == [False, False, True, False, False]
    sizes = []
    real = _mesh.point_mesh_distance

    def counted(points, *args, **kwargs):
        sizes.append(len(points))
        return real(points, *args, **kwargs)

    monkeypatch.setattr(_mesh, "point_mesh_distance", counted)
    for w, want in zip(seq, answers, strict=True):
        sizes.clear()
        assert kept.within(w, t, bound) == want
        if w is seq[1]:  # decided by the first one's witnesses alone
            assert q.shape[0] not in sizes
        if not want:
            assert 0 < kept._witness.size <= WITNESSES
            over = kept._witness
            assert (real(q[over], w, t) > bound).all()
    few = kept.subset(1000)
    assert few._witness.size == 0 and few.within(seq[0], t, bound) is False


def test_capped_floors_stay_under_the_cap_where_the_surface_is_nearer():
    """`PointDistances.floor_at` with ``cap`` (`FLOOR_CAP` bounds, the level search's):
    where the points' surface is within the cap, a level may reach the cap there, not
    what the surface reaches plus the bound; where the surface itself is farther, as
    far as it is, no farther."""
    v, t, q, n, top, bottom = _sampled_cube()
    bound = 0.01
    # the points' surface 5 bounds off at the top's middle, 1.2 at the bottom's
    surface = _dented(_dented(v, top, 0.05), bottom, 0.012)
    level = _dented(surface, bottom, 0.021 - 0.012)  # the bottom 2.1 bounds off
    plain = PointDistances(q, PointSurface(q, n))
    plain.floor_at(surface, t, bound)
    capped = PointDistances(q, PointSurface(q, n))
    capped.floor_at(surface, t, bound, cap=FLOOR_CAP)
    assert plain.within(level, t, bound)  # 1.2 + 1 bounds
    assert not capped.within(level, t, bound)  # over 1.8
    assert capped.within(_dented(surface, bottom, 0.017 - 0.012), t, bound)
    assert capped.within(surface, t, bound)  # the far top: as far as it is
    assert not capped.within(_dented(surface, top, 0.06 - 0.05), t, bound)
    assert plain.within(_dented(surface, top, 0.054 - 0.05), t, bound)
    over = capped.there_floor > FLOOR_CAP * bound + 1e-12
    assert over.any() and (q[over, 2] > 0.9).all()  # the top's only
    # the collapses' tolerance (`there_floor_of`) is not capped: the bottom's is the
    # surface's distance there plus the bound
    low = capped.there_floor_of(surface, t, bound)
    assert low[q[:, 2] < 0.1].max() > FLOOR_CAP * bound
    assert (low >= np.maximum(bound, capped.there_floor)).all()


def test_a_second_surfaces_floors_only_raise_the_first_ones():
    """`PointDistances.floor_at` with ``raise_only``: the floors of two surfaces (the
    points' surface, and it placed on its planes) let pass what either lets pass:
    each surface's own dent, not a third one."""
    v, t, q, n, top, bottom = _sampled_cube()
    bound = 0.01
    first, second = _dented(v, top, 0.05), _dented(v, bottom, 0.05)
    both = _dented(first, bottom, 0.05)
    alone = PointDistances(q, PointSurface(q, n))
    alone.floor_at(second, t, bound, slack=1.0, factor=1.1)  # the second replaces
    alone.floor_at(first, t, bound, slack=1.0, factor=1.1)
    assert alone.within(first, t, bound) and not alone.within(second, t, bound)
    raised = PointDistances(q, PointSurface(q, n))
    raised.floor_at(first, t, bound, slack=1.0, factor=1.1)
    raised.floor_at(second, t, bound, slack=1.0, factor=1.1, raise_only=True)
    assert raised.within(first, t, bound) and raised.within(second, t, bound)
    assert raised.within(both, t, bound)  # each dent within its own floor
    assert raised.there_floor.shape == (q.shape[0],)
    # near each sample of either, the floor of the nearest sample of both surfaces
    # (found lazily), the higher where both are as near: the eager formula's, every
    # sample's at once (plain numpy and k-d trees)
    layers = raised.back_floor.layers
    assert len(layers) == 2
    x = np.concatenate([layer[0] for layer in layers])
    found = []  # each layer's distance to its nearest sample and that sample's floor
    for samples, back, _, add, cap, low in layers:
        assert low == np.inf  # not capped: floor_at's default
        tree = cKDTree(samples)
        floor = np.minimum(back[tree.query(samples, k=FLOOR_NEIGHBORS)[1]].max(axis=1) + add, cap)
        d, i = tree.query(x)
        found.append((d, floor[i]))
    (d0, f0), (d1, f1) = found
    want = np.where(d0 < d1, f0, np.where(d1 < d0, f1, np.maximum(f0, f1)))
    assert np.array_equal(raised.back_floor.near(x), want)
    assert ((d0 == d1) & (f0 != f1)).any()  # samples both surfaces share: the higher
    # a dent where neither surface was is over the bound
    side = int(np.argmin(np.linalg.norm(v - [0.5, 0.0, 0.5], axis=1)))
    far = v.copy()
    far[side, 1] += 0.05
    assert not raised.within(far, t, bound)


def test_a_plate_two_spacings_thick_keeps_its_volume():
    """A square plate 0.08 thick (about 2 point spacings at 3,000 points): before the
    thin parts kept their side, the smoothing averaged it away and the output was 40
    triangles 40 % of the diagonal off the truth; now it is the plate, closed, within
    2.5 % both ways (its Euler characteristic is still 0 for 2: a hole where the
    wall is thinner than the grid resolves)."""
    import warnings

    from pointatlas.neighbors import point_mesh_distance
    from pointatlas.simplify import SimplifyWarning, mesh_checks, simplify_points

    v, t = extrude([[0, 0], [3, 0], [3, 3], [0, 3]], height=0.08)
    s = sample_mesh(v, t, 3000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SimplifyWarning)
        m = simplify_points(p, n).mesh
    mv, mt = np.asarray(m.vertices), np.asarray(m.triangles)
    assert all(mesh_checks(m.n_vertices, mt))
    out = np.vstack([mv, sample_mesh(mv, mt, 5000, rng=1).points])
    truth = np.vstack([v, sample_mesh(v, t, 5000, rng=1).points])
    far = max(point_mesh_distance(out, v, t).max(), point_mesh_distance(truth, mv, mt).max())
    assert far <= 0.025 * np.linalg.norm(np.ptp(p, axis=0))


def test_a_subset_of_the_points_never_passes_what_all_of_them_fail():
    """`PointDistances.subset`: every s-th point with its floor; whatever it finds over
    the bound is over it on all the points (the level search's first pass), while a
    point it leaves out can fail alone (hence the search's check on all)."""
    v, t = subdivide(*box())
    v = (v - v.min(axis=0)) / np.ptp(v, axis=0)  # the unit cube
    s = sample_mesh(v, t, 6000, rng=0)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    bound = 0.01
    measure = PointDistances(q, PointSurface(q, n))
    assert measure.subset(q.shape[0]) is None
    measure.floor_at(v, t, bound)
    few = measure.subset(1000)
    np.testing.assert_array_equal(few.q, q[::6])
    np.testing.assert_array_equal(few.there_floor, measure.there_floor[::6])
    top = int(np.argmin(np.linalg.norm(v - [0.5, 0.5, 1.0], axis=1)))
    seen = set()
    for depth in np.linspace(0.0, 0.05, 11):
        dented = _dented(v, top, depth)
        on_few, on_all = few.within(dented, t, bound), measure.within(dented, t, bound)
        assert on_few or not on_all
        seen.add((on_few, on_all))
    assert {(True, True), (False, False)} <= seen
    # a point the subset leaves out, 6 % off the cube: all fail, the subset passes
    # (the cube's samples are up to 2.4 % from the points' discs, at its corners,
    # where the discs stop at both edges: a bound of 3 %)
    off = q.copy()
    off[1] += 0.06 * n[1]
    alone = PointDistances(off, PointSurface(off, n))
    assert alone.subset(1000).within(v, t, 0.03) and not alone.within(v, t, 0.03)


def test_a_surface_with_its_radii_from_the_knn_table_is_the_searched_one():
    """`PointSurface` given its disc radii from a `query_knn` table (`disc_radii`)
    holds what it finds itself (the same attributes; radii up to rounding) and
    measures the same distances; a table too narrow is refused."""
    from pointatlas.neighbors import query_knn
    from pointatlas.simplify._distance import disc_radii

    v, t = subdivide(*box())
    s = sample_mesh(v, t, 3000, rng=0)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    tree = cKDTree(q)
    searched = PointSurface(q, n, tree)
    rows, dist = query_knn(q, 10)
    tabled = PointSurface(q, n, tree, disc_radii(dist, q, n, rows))
    assert vars(tabled).keys() == vars(searched).keys()
    np.testing.assert_allclose(tabled.radius, searched.radius, rtol=1e-13, atol=0)
    x = np.random.default_rng(0).uniform(-0.2, 1.2, size=(500, 3)) * np.ptp(v, axis=0)
    np.testing.assert_allclose(tabled.distance(x), searched.distance(x), rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="needs 9 neighbours"):
        disc_radii(dist[:, :8])


@pytest.mark.parametrize("share", [0.5, 1.0])
def test_discs_stop_at_an_edge_so_a_face_extended_past_it_is_measured(share):
    """A face carried past a box's edge by a share of the median disc radius r is
    measured: its far rim at least 0.7 of that from the points' surface, while the
    plain discs (radius the 8th neighbour's distance) forgive all but less than half
    of it; the edge's points still measure nothing off on the box itself (fresh
    samples of it as near as with the plain discs)."""
    v, t = subdivide(*box())
    s = sample_mesh(v, t, 3000, rng=0)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    clipped = PointSurface(q, n)
    plain = PointSurface(q, n, radius=cKDTree(q).query(q, 9)[0][:, 8])
    assert np.all(clipped.radius <= plain.radius)
    r = float(np.median(plain.radius))
    # the box spans [0, 2] x [0, 1] x [0, 0.5]: its top plane carried past x = 2
    past = np.array([[2.0 + share * r, 0.5, 0.5]])
    assert clipped.distance(past)[0] >= 0.7 * share * r
    assert plain.distance(past)[0] <= 0.45 * share * r
    fresh = np.asarray(sample_mesh(v, t, 3000, rng=1).points)
    assert clipped.distance(fresh).max() <= 1.0001 * plain.distance(fresh).max()


def test_discs_do_not_stop_at_blended_normals_on_their_own_plane(monkeypatch):
    """A mesh's vertices with their vertex normals (`synth.cube(6)`: normals blended
    45 degrees at the edges): a face point's disc is not stopped by the edge points on
    its own plane (turned, but not off it), only by points off the plane: no radius
    is shorter than the distance to the nearest of the 8 neighbours off the point's
    plane; stopped at every turned neighbour (`DISC_OFF` so that all count), 96 of
    the 218 discs would be."""
    from pointatlas.simplify import _distance
    from pointatlas.synth import cube

    m = cube(6)
    v, n = np.asarray(m.vertices), np.asarray(m.normals)
    dist, rows = cKDTree(v).query(v, 9)
    radius = _distance.disc_radii(dist, v, n, rows)
    height = np.abs(np.einsum("ij,ikj->ik", n, v[rows[:, 1:]] - v[:, None]))
    first_off = np.where(height > 1e-9, dist[:, 1:], np.inf).min(axis=1)
    assert np.all(radius >= np.minimum(first_off, dist[:, 8]))
    monkeypatch.setattr(_distance, "DISC_OFF", -np.pi / 2)
    every_turn = _distance.disc_radii(dist, v, n, rows)
    assert int((every_turn < radius).sum()) == 96


def test_a_surface_holds_writeable_arrays_whatever_the_callers():
    """`PointSurface` keeps writeable C arrays, as the points path makes them (one
    compiled signature of the disc kernels and the collapses whatever the caller
    hands): a read-only input is copied, never written; a writeable one is used as
    it is (no copy)."""
    v, t = subdivide(*box())
    s = sample_mesh(v, t, 500, rng=0)
    q, n = np.asarray(s.points), np.asarray(s.normals)
    assert not q.flags.writeable and not n.flags.writeable  # the sampler's arrays
    held = PointSurface(q, n)
    assert held.points.flags.writeable and held.normals.flags.writeable
    assert held.points.flags.c_contiguous and not np.shares_memory(held.points, q)
    np.testing.assert_array_equal(held.points, q)
    mine = np.array(q)
    assert np.shares_memory(PointSurface(mine, np.array(n)).points, mine)
    x = np.random.default_rng(1).uniform(-0.2, 1.2, size=(200, 3)) * np.ptp(v, axis=0)
    np.testing.assert_array_equal(held.distance(x), PointSurface(mine, np.array(n)).distance(x))


def test_thin_share_counts_the_points_with_a_side_facing_back_that_near():
    """`_voxel_grid.thin_share`: the share of the points with a point facing the other
    way (normals more than 135 degrees apart) among their 16 nearest within a
    distance, as a plain-numpy reference counts it; a block with a fin 0.05 thick:
    its fin's points count once the distance passes the fin's thickness, a plain
    box's none below its own thickness."""
    from scipy.spatial import cKDTree

    from pointatlas.simplify._voxel_grid import THIN_NEIGHBORS, thin_share

    th = 0.05
    outline = [(0, 0), (1, 0), (1, 0.5), (2, 0.5), (2, 0.5 + th), (1, 0.5 + th), (1, 1), (0, 1)]
    v, t = extrude(outline, height=1.0)
    s = sample_mesh(v, t, 3000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    d = np.linalg.norm(p[:, None] - p[None], axis=2)
    near = np.argsort(d, axis=1, kind="stable")[:, :THIN_NEIGHBORS]
    facing = np.einsum("ij,ikj->ik", n, n[near]) < -0.7
    rows = np.arange(len(p))[:, None]
    across = np.where(facing, d[rows, near], np.inf).min(axis=1)
    tree = cKDTree(p)
    for within in (0.02, 0.06, 0.1, 0.3):
        assert thin_share(p, n, tree, within) == pytest.approx(np.mean(across < within), abs=1e-12)
    fin = (p[:, 0] > 1.0 + 1e-9) & (np.abs(n[:, 1]) > 0.99)  # the fin's two sides
    assert thin_share(p, n, tree, 0.02) == 0.0
    assert thin_share(p, n, tree, 0.1) >= 0.8 * fin.mean()
    bv, bt = box()
    b = sample_mesh(bv, bt, 3000, rng=0)
    bp, bn = np.asarray(b.points), np.asarray(b.normals)
    assert thin_share(bp, bn, cKDTree(bp), 0.4) == 0.0  # the box is 0.5 thick


@pytest.mark.skipif(not Z_TOP.exists(), reason="the collection is not under ../shared")
def test_a_shape_thin_in_part_takes_the_finer_grid(monkeypatch):
    """A sampled printer part of the collection (`prusamini_mini-z-top`: walls about
    1.7 grid steps thick, no point lost by the first surface): with the finer grid
    tried where `THIN_SHARE` of the points lie on walls that thin, its output comes
    within 1 % of the diagonal of the truth both ways (1.36 % on the first grid: the
    walls' tops carried up into the gap above them), closed, with the same Euler
    characteristic."""
    from pointatlas.io import read_mesh
    from pointatlas.simplify import _reconstruct, mesh_checks

    plain, m = without_and_with(monkeypatch, _reconstruct, "THIN_SHARE", 2.0, Z_TOP)
    truth = read_mesh(Z_TOP)
    v, t = np.asarray(truth.vertices), np.asarray(truth.triangles)
    diag = float(np.linalg.norm(np.ptp(np.asarray(m.vertices), axis=0)))
    before, after = (max(_to_and_from_truth(x, v, t)) / diag for x in (plain, m))
    assert after <= 0.01 < before
    assert mesh_checks(m.n_vertices, m.triangles) == (True, True, True)
    tri = np.asarray(m.triangles)
    assert _euler(m.n_vertices, tri) == _euler(plain.n_vertices, np.asarray(plain.triangles))

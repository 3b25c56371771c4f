"""What the points path measures back to the points: the output's edge midpoints
besides its vertices and area samples (`_distance.point_back_samples`)."""

import numpy as np
from scipy.spatial import cKDTree

from pointatlas.simplify._distance import (
    PointSurface,
    back_distances,
    output_samples,
    point_back_samples,
)
from pointatlas.simplify._point_distances import FLOOR_NEIGHBORS, PointDistances


def _valley():
    """Points on a V-shaped valley z = |x - 0.5| over [0, 1]^2 (normals up its
    sides), and an output of the valley's four triangles plus a sliver along y =
    0.5 whose long edge spans the valley at z = 0.5, through the air: its corners
    lie on the valley, its edge's midpoint 0.5 / sqrt(2) from both sides."""
    g = np.linspace(0.0, 1.0, 81)
    x, y = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    q = np.c_[x, y, np.abs(x - 0.5)]
    side = np.where(x < 0.5, 1.0, -1.0)
    normals = np.c_[side, np.zeros_like(x), np.ones_like(x)] / np.sqrt(2.0)
    normals[x == 0.5] = [0.0, 0.0, 1.0]
    v = np.array(
        [
            [0, 0, 0.5],
            [0.5, 0, 0],
            [1, 0, 0.5],
            [0, 1, 0.5],
            [0.5, 1, 0],
            [1, 1, 0.5],
            [0, 0.5, 0.5],
            [1, 0.5, 0.5],
            [1, 0.5 + 1e-4, 0.5],
        ]
    )
    t = np.array([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [6, 7, 8]])
    return q, normals, v, t


def test_edge_midpoints_come_first_once_each():
    """Every edge once (shared edges not twice), then `output_samples` as it is."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    t = np.array([[0, 1, 2], [2, 1, 3]])
    got = point_back_samples(v, t, n=7)
    assert got.shape == (5 + 4 + 7, 3)
    middle = got[:5]
    expected = [[0.5, 0, 0], [0, 0.5, 0], [0.5, 0.5, 0], [1, 0.5, 0], [0.5, 1, 0]]
    np.testing.assert_array_equal(middle[np.lexsort(middle.T[::-1])], sorted(expected))
    np.testing.assert_array_equal(got[5:], output_samples(v, t, n=7))


def test_a_sliver_across_a_valley_is_seen_by_its_edge_midpoint():
    """The area samples land on the valley's faces and the sliver's corners lie on
    the points: without the edge midpoints the sliver looks as near as the faces;
    with them the back distance reaches its edge's 0.354."""
    q, normals, v, t = _valley()
    surface = PointSurface(q, normals)
    far = 0.5 / np.sqrt(2.0)
    assert surface.distance(output_samples(v, t)).max() < 0.05
    back = back_distances(v, t, surface)
    np.testing.assert_allclose(back.max(), far, rtol=0.02)
    measure = PointDistances(q, surface)
    assert not measure.within(v, t, 0.1)
    assert measure.within(v, t[:4], 0.1)  # the valley alone is on the points
    np.testing.assert_allclose(measure.error(v, t), far, rtol=0.02)


def test_the_discs_search_gives_each_samples_nearest_point():
    """`PointSurface.distance(x, nearest=True)`: the same distances, and the nearest
    point of every row as a k-d tree finds it (random points: no two equally near),
    with and without normals."""
    rng = np.random.default_rng(3)
    q = rng.random((500, 3))
    normals = rng.normal(size=(500, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    x = rng.random((300, 3)) * 1.2 - 0.1
    expected = cKDTree(q).query(x)[1]
    for n in (normals, None):
        surface = PointSurface(q, n)
        d, j = surface.distance(x, nearest=True)
        np.testing.assert_array_equal(d, surface.distance(x))
        np.testing.assert_array_equal(j, expected)


def test_back_near_points_is_the_most_of_the_samples_nearest_to_each_neighbour():
    """`PointDistances.back_near_points` against a plain reference: each sample
    (`point_back_samples`) goes to its nearest point (a k-d tree), each point takes
    the most back distance among the samples of its `FLOOR_NEIGHBORS` nearest."""
    q, normals, v, t = _valley()
    surface = PointSurface(q, normals)
    measure = PointDistances(q, surface)
    tree = cKDTree(q)
    samples = point_back_samples(v, t)
    back = surface.distance(samples)
    owner = tree.query(samples)[1]
    most = np.zeros(q.shape[0])
    for i, d in zip(owner, back, strict=True):
        most[i] = max(most[i], d)
    near = tree.query(q, k=FLOOR_NEIGHBORS)[1]
    expected = most[near].max(axis=1)
    got = measure.back_near_points(v, t)
    np.testing.assert_array_equal(got, expected)
    assert got.max() > 0.3  # the sliver's edge reaches its points


def test_distance_over_is_exact_beyond_the_bound_and_within_it_elsewhere():
    """`PointSurface.distance_over`: the rows `distance` puts beyond the bound get
    its values bit for bit, the others at most the bound (normals of any length)."""
    rng = np.random.default_rng(8)
    q = rng.random((800, 3)) * [1.0, 1.0, 0.05]
    x = rng.random((2000, 3)) * [1.2, 1.2, 0.4] - [0.1, 0.1, 0.2]
    for scale in (1.0, 1.7):
        normals = rng.normal(size=(800, 3)) * 0.1 + [0.0, 0.0, 1.0]
        normals *= scale / np.linalg.norm(normals, axis=1)[:, None]
        surface = PointSurface(q, normals)
        exact = surface.distance(x)
        for bound in (0.01, 0.05, 0.1):
            got = surface.distance_over(x, bound)
            over = exact > bound
            assert 0 < over.sum() < x.shape[0]
            np.testing.assert_array_equal(got > bound, over)
            np.testing.assert_array_equal(got[over], exact[over])


def test_over_at_is_where_within_finds_the_surface_over_the_bound():
    """`PointDistances.over_at` against a plain reference: the vertices outside the
    box, the points farther than the bound from the output (exact distances to every
    triangle) and its back samples (`point_back_samples`) farther than the bound from
    the points' discs; here the sliver's edge, whose midpoint is over the bound
    while every point is near the valley; none where `within` passes."""
    from pointatlas.neighbors import point_mesh_distance

    q, normals, v, t = _valley()
    surface = PointSurface(q, normals)
    measure = PointDistances(q, surface)
    for bound, tri in ((0.1, t), (0.1, t[:4]), (0.01, t[:3])):
        there = point_mesh_distance(q, v, tri)
        samples = point_back_samples(v, tri)
        back = surface.distance(samples)
        outside = ((v < measure.lo) | (v > measure.hi)).any(axis=1)
        expected = np.vstack([v[outside], q[there > bound], samples[back > bound]])
        got = measure.over_at(v, tri, bound)
        np.testing.assert_array_equal(got, expected)
        assert (got.shape[0] == 0) == measure.within(v, tri, bound)
    assert measure.over_at(v, t, 0.1).shape[0] > 0

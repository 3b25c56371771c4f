"""Small regions join their best neighbour (`VSAOptions.min_region_size`, issue 28
item 6): a noisy scene, the rule against a plain reference, invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas._core import PointAtlasError
from pointatlas.neighbors import query_knn
from pointatlas.normals import estimate_normals, orient_normals
from pointatlas.segment import VSAOptions, pick_merge_targets, vsa_segment
from pointatlas.segment._kernels import canonical_labels
from pointatlas.segment._small import added_l21, join_picks, small_region_groups
from pointatlas.synth import add_normal_noise, cube, sample_mesh

from . import reference

MAX_ANGLE = math.radians(10.0)


def noisy_cube_cloud():
    """A cube sampled with 1,500 points, moved along the normal by 30 % of the
    spacing, PCA normals: VSA at 10 degrees leaves regions of single points."""
    mesh = cube(2)
    sample = sample_mesh(mesh.vertices, mesh.faces, 1500, rng=1)
    points = add_normal_noise(sample.points, sample.normals, 0.3, rng=2)
    normals = orient_normals(points, estimate_normals(points, k=12), method="mst")
    return points, normals


@pytest.fixture(scope="module")
def noisy_cube():
    return noisy_cube_cloud()


def _same_partition(a, b):
    return np.array_equal(canonical_labels(a)[0], canonical_labels(b)[0])


def test_noisy_scene_keeps_no_region_below_the_minimum(noisy_cube):
    points, normals = noisy_cube
    before = vsa_segment(points, normals, max_angle=MAX_ANGLE)
    assert (before.region_counts < 8).sum() > 50  # the fragmentation of issue 28 item 6
    after = vsa_segment(points, normals, max_angle=MAX_ANGLE, min_region_size=8)
    assert after.region_counts.min() >= 8
    assert after.n_regions < before.n_regions
    assert after.step_names[-1] == "small_regions"
    # labels 0..R-1, numbered by smallest member, and the result describes them
    labels = after.labels
    assert np.array_equal(np.unique(labels), np.arange(after.n_regions))
    assert np.array_equal(canonical_labels(labels)[0], labels)
    assert np.array_equal(np.bincount(labels), after.region_counts)
    nrm = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    s = np.stack([np.bincount(labels, weights=nrm[:, d]) for d in range(3)], 1)
    np.testing.assert_allclose(after.proxy_normals, s / np.linalg.norm(s, axis=1)[:, None])
    # only regions that were below the minimum changed: every region of at least
    # 8 points is inside one final region
    big = before.region_counts[before.labels] >= 8
    pairs = np.unique(np.column_stack([before.labels[big], labels[big]]), axis=0)
    assert np.unique(pairs[:, 0]).size == pairs.shape[0]
    # off and 1 are the same run as the default
    for off in (0, 1):
        same = vsa_segment(points, normals, max_angle=MAX_ANGLE, min_region_size=off)
        assert np.array_equal(same.labels, before.labels)


def test_merge_rule_matches_the_plain_reference(noisy_cube):
    points, normals = noisy_cube
    k = 8
    before = vsa_segment(points, normals, max_angle=MAX_ANGLE, k=k)
    after = vsa_segment(points, normals, max_angle=MAX_ANGLE, k=k, min_region_size=6)
    lists = reference.symmetric_lists(query_knn(points, k)[0], points.shape[0])
    nrm = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    expected = reference.merge_small_reference(
        points, lists, nrm, np.ones(points.shape[0]), before.labels, 6
    )
    assert _same_partition(after.labels, expected)


def test_merge_rule_on_a_hand_made_case():
    """Four regions in a row: A (z up, 10 points), c (2 points 20 degrees from z
    towards x), d (1 point 60 degrees from z), B (x, 10 points); c touches A and
    d, d touches c and B. c fits A best and d fits B best."""

    def tilt(deg):
        t = math.radians(deg)
        return np.array([math.sin(t), 0.0, math.cos(t)])

    ssum = np.array([10 * tilt(0), 2 * tilt(20), tilt(60), 10 * tilt(90)])
    counts = np.array([10, 2, 1, 10])
    pairs = np.array([[0, 1], [1, 2], [2, 3]])
    group, m = small_region_groups(pairs, counts.astype(float), ssum, counts, 3)
    assert m == 2 and group.tolist() == [0, 0, 1, 1]
    # the added energy is the L21 of the union minus its parts', 2 (|Sa|+|Sb|-|Sa+Sb|)
    direct = 2 * (
        np.linalg.norm(ssum[1]) + np.linalg.norm(ssum[0]) - np.linalg.norm(ssum[:2].sum(0))
    )
    assert added_l21(ssum[1:2], ssum[0:1])[0] == pytest.approx(direct, rel=1e-12)
    assert added_l21(ssum[1:2], ssum[0:1])[0] == added_l21(ssum[0:1], ssum[1:2])[0]
    # picks join as connected pieces, cycles too (the surface test is not
    # symmetric, so a -> b -> c -> a can happen); ids by smallest member
    remap, m = join_picks(5, np.array([1, 2, 3]), np.array([2, 3, 1]))
    assert m == 3 and remap.tolist() == [0, 1, 1, 1, 2]
    # nothing is small: nothing changes; a small region without a neighbour stays
    assert small_region_groups(pairs, counts.astype(float), ssum, counts, 1)[1] == 4
    lone = small_region_groups(np.zeros((0, 2), np.int64), counts.astype(float), ssum, counts, 3)
    assert lone[1] == 4


@st.composite
def region_graphs(draw):
    """Random regions on a random adjacency: sums, counts and pairs."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    m = draw(st.integers(1, 40))
    counts = rng.integers(1, 12, size=m)
    ssum = rng.normal(size=(m, 3))
    ssum *= (counts * rng.uniform(0.3, 1.0, size=m) / np.linalg.norm(ssum, axis=1))[:, None]
    e = draw(st.integers(0, 3 * m))
    pairs = rng.integers(0, m, size=(e, 2))
    pairs = np.unique(np.sort(pairs[pairs[:, 0] != pairs[:, 1]], axis=1), axis=0).reshape(-1, 2)
    return pairs, counts.astype(float), ssum, counts, draw(st.integers(0, 12))


@given(region_graphs())
@settings(max_examples=60, deadline=None)
def test_grouping_never_adds_regions_and_leaves_no_small_region_with_a_neighbour(case):
    pairs, wsum, ssum, counts, min_size = case
    group, m = small_region_groups(pairs, wsum, ssum, counts, min_size)
    assert group.shape == counts.shape and m <= counts.size
    assert np.array_equal(np.unique(group), np.arange(m))
    size = np.bincount(group, weights=counts)
    joined = group[pairs]
    joined = joined[joined[:, 0] != joined[:, 1]]
    # a group under the minimum touches no other group
    assert not (size[joined] < min_size).any()


@given(st.integers(0, 2**32 - 1), st.integers(0, 12))
@settings(max_examples=12, deadline=None)
def test_merging_keeps_every_point_labelled(seed, min_size):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(30, 150))
    points = rng.random((n, 3))
    normals = rng.normal(size=(n, 3))
    plain = vsa_segment(points, normals, k=6, max_angle=0.3)
    res = vsa_segment(
        points, normals, options=VSAOptions(k=6, max_angle=0.3, min_region_size=min_size)
    )
    assert res.n_regions <= plain.n_regions
    assert res.labels.shape == (n,) and res.labels.min() == 0
    assert np.array_equal(np.unique(res.labels), np.arange(res.n_regions))
    # every starting region lies inside one final region
    pairs = np.unique(np.column_stack([plain.labels, res.labels]), axis=0)
    assert np.unique(pairs[:, 0]).size == pairs.shape[0]


def test_a_small_region_off_every_neighbouring_surface_stays():
    """Three points hovering 5 spacings above a flat grid (their normals tilted, so
    VSA at a small eta keeps them apart) touch only the grid: they do not lie on its
    surface, so they stay a region of their own, as the local mode's off-surface
    points do."""
    xy = np.stack(np.meshgrid(np.arange(20.0), np.arange(20.0)), -1).reshape(-1, 2)
    ground = np.column_stack([xy, np.zeros(len(xy))])
    above = np.array([[9.5, 9.5, 5.0], [10.5, 9.5, 5.0], [10.0, 10.5, 5.0]])
    points = np.vstack([ground, above])
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    normals[-3:] = [0.0, math.sqrt(0.5), math.sqrt(0.5)]
    res = vsa_segment(points, normals, k=8, eta=0.5, min_region_size=8)
    assert res.n_regions == 2 and res.region_counts.tolist() == [400, 3]
    assert res.adjacency.tolist() == [[0, 1]]  # it has a neighbour, and stays
    # lowered onto the grid, the same three points join it
    points[-3:, 2] = 0.1
    res = vsa_segment(points, normals, k=8, eta=0.5, min_region_size=8)
    assert res.n_regions == 1


def test_min_region_size_is_validated():
    with pytest.raises(ValueError, match="min_region_size"):
        VSAOptions(min_region_size=-1)
    with pytest.raises(TypeError, match="min_region_size"):
        VSAOptions(min_region_size=2.5)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pick_merge_targets_is_the_least_added_l21_of_a_plain_loop(seed):
    rng = np.random.default_rng(seed)
    ssum = rng.normal(size=(30, 3)) * rng.uniform(0.1, 5.0, size=(30, 1))
    ssum[7] = ssum[3]  # two equal targets: the smaller id wins
    a = rng.integers(0, 30, size=200)
    b = rng.integers(0, 30, size=200)
    a, b = np.append(a, [11, 11]), np.append(b, [7, 3])
    src, dst = pick_merge_targets(a, b, ssum)

    def added(x, y):  # 2 (|S_a| + |S_b| - |S_a + S_b|), Eq. 4.4 at the optimal normals
        n = np.linalg.norm
        return 2.0 * (n(ssum[x]) + n(ssum[y]) - n(ssum[x] + ssum[y]))

    assert src.tolist() == sorted(set(a.tolist()))
    for x, y in zip(src.tolist(), dst.tolist(), strict=True):
        options = sorted(set(b[a == x].tolist()))
        costs = [added(x, t) for t in options]
        best = min(costs)
        # the pick is the least, up to the reference's cancellation; ties by id
        near = [t for t, c in zip(options, costs, strict=True) if c <= best + 1e-9]
        assert y == near[0]


def test_pick_merge_targets_refuses_mismatched_arrays():
    with pytest.raises(PointAtlasError, match="one length"):
        pick_merge_targets(np.arange(3), np.arange(2), np.zeros((3, 3)))
    with pytest.raises(PointAtlasError, match=r"\(R, 3\)"):
        pick_merge_targets(np.arange(3), np.arange(3), np.zeros((3, 2)))

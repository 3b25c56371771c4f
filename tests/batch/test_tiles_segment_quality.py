"""Tiled segmentation: strong halo links rejoin a border piece of a curved surface;
in VSA's local mode points off their region's surface (vegetation above the ground)
are placed by the tiles as by the untiled run, and links the two tiles agree on are
strong (docs/decisions/batch.md, "Tiles — segmentation stitched across tiles")."""

from __future__ import annotations

import math

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from pointatlas.batch import TileOptions, tiled_segment  # noqa: E402
from pointatlas.batch._tiles_segment import _agreed, _halo_unions, _Regions  # noqa: E402
from pointatlas.batch._tiles_tasks import region_stats  # noqa: E402

from ..segment.test_vsa_local import veg_ground  # noqa: E402


def bump_scene(seed=3):
    """A 200 x 200 m ground with a 4.5 m hill (slopes under 6 degrees) whose top a
    tile border at x = 100 cuts off as a small piece, and a flat roof 6 m above the
    ground far from the hill. Labels: 0 ground, 1 the piece of the hill top (x in
    [100, 103], |y - 100| < 8), 2 the roof. Exact surface normals."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 200, (60_000, 2))
    r2 = ((xy - 100.0) ** 2).sum(axis=1)
    sigma, h = 30.0, 4.5
    z = h * np.exp(-r2 / (2 * sigma**2))
    grad = -(xy - 100.0) / sigma**2 * z[:, None]
    ground_n = np.column_stack([-grad, np.ones(len(z))])
    piece = (xy[:, 0] >= 100) & (xy[:, 0] < 103) & (np.abs(xy[:, 1] - 100) < 8)
    roof = np.column_stack([rng.uniform(20, 26, (400, 2)), np.full(400, 6.0)])
    pts = np.vstack([np.column_stack([xy, z]), roof])
    normals = np.vstack([ground_n, np.tile([0.0, 0.0, 1.0], (400, 1))])
    labels = np.r_[piece.astype(np.int64), np.full(400, 2)]
    return pts, normals, labels


def regions_of(pts, normals, labels):
    st, first = region_stats(labels, 3, pts, normals, pts.mean(axis=0), np.arange(len(pts)))
    return _Regions(st, first, None, math.cos(math.radians(10)), tau2=0.25**2)


def links(pairs_counts):
    """Halo links: (owner label, neighbour label) rows, each pair repeated."""
    return [np.array([p for p, c in pairs_counts for _ in range(c)], dtype=np.int64)]


def test_scene_the_plane_test_alone_refuses():
    pts, normals, labels = bump_scene()
    regions = regions_of(pts, normals, labels)
    n_piece = int(regions.st[1, 0])
    assert 50 < n_piece < 150
    # the hill top lies ~4 m off the ground's plane: the per-point plane test
    # refuses it as it refuses the roof; the normal tests pass for both
    prox = regions.st[:, 1:4] / np.linalg.norm(regions.st[:, 1:4], axis=1)[:, None]
    min_cos = math.cos(math.radians(10))
    assert prox[0] @ prox[1] > min_cos and prox[0] @ prox[2] > min_cos
    assert not regions.ok(0, 1) and not regions.ok(0, 2)
    assert regions.ok(0, 1, strong=True)


@pytest.mark.parametrize("many", [True, False])
def test_strong_halo_links_rejoin_a_border_piece(many):
    pts, normals, labels = bump_scene()
    regions = regions_of(pts, normals, labels)
    n_piece = int(regions.st[1, 0])
    has = np.ones(3, dtype=bool)
    # the neighbour tile put the piece's points in the ground (many links, both
    # directions); the roof touches the ground through two vegetation points
    count = n_piece // 2 + 1 if many else 3
    _, n_unions = _halo_unions(regions, links([((1, 0), count), ((0, 1), count), ((2, 0), 2)]), has)
    assert bool(regions.find(1) == regions.find(0)) is many
    assert n_unions == int(many)
    assert regions.find(2) != regions.find(0)  # the roof stays apart
    if many:  # the joined ground carries the piece's statistics
        assert regions.st[regions.find(0), 0] == np.sum(labels != 2)


def test_strong_links_still_need_the_normal_and_plane_tests():
    pts, normals, labels = bump_scene()
    regions = regions_of(pts, normals, labels)
    n_roof = int(regions.st[2, 0])
    # a roof strongly linked to the ground is parallel, but its points would raise
    # the union's plane MSE beyond 4 x the ground's: refused; tilted 30 degrees
    # (beyond 2 x max angle), it fails the normal test too
    has = np.ones(3, dtype=bool)
    lifted = pts.copy()
    lifted[labels == 2, 2] = 60.0
    far = regions_of(lifted, normals, labels)
    _halo_unions(far, links([((2, 0), n_roof)]), has)
    assert far.find(2) != far.find(0)
    tilted = normals.copy()
    tilted[labels == 2] = [math.sin(math.radians(30)), 0.0, math.cos(math.radians(30))]
    steep = regions_of(pts, tilted, labels)
    _halo_unions(steep, links([((2, 0), n_roof)]), has)
    assert steep.find(2) != steep.find(0)
    assert not steep.ok(0, 2, strong=True) and regions.ok(0, 2, strong=True)


def hill(n, seed):
    """A 60 x 60 m ground with a 4 m Gaussian hill (sigma 10 m, slopes under 14
    degrees) in its middle, millimetre-quantised, far from the origin; normals: the
    surface's with N(0, 0.02) noise."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(0, 60, (n, 2))
    d = xy - 30.0
    z = 4.0 * np.exp(-(d**2).sum(axis=1) / 200.0)
    nrm = np.column_stack([d / 100.0 * z[:, None], np.ones(n)])
    nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None] + rng.normal(0, 0.02, (n, 3))
    pts = np.column_stack([xy, z + rng.normal(0, 0.005, n)])
    return np.round(pts * 1000) / 1000 + np.array([512_000.0, 4_100_000.0, 80.0]), nrm


@pytest.mark.parametrize(("n", "seed"), [(20_000, 0), (12_000, 1)])
def test_a_hill_cut_by_tile_borders_is_one_region_as_untiled(client, n, seed):
    from pointatlas.segment import vsa_segment

    pts, nrm = hill(n, seed)
    ref = vsa_segment(pts, nrm, k=8)  # one region: mean deviation under 10 degrees
    labels, q, run = tiled_segment(
        pts, nrm, TileOptions(tile_size=15.0, scheduler=client), {"k": 8}
    )
    # 16 tiles, one region each; the pieces near the hill top lie metres off the
    # union's plane (the per-point plane test alone left 3 and 2 regions): their
    # strong halo links join all 16
    assert ref.n_regions == 1 and run.extra["tile_regions"] == 16
    assert run.extra["halo_unions"] == 15
    assert q["n_regions"] == 1 and np.all(labels == 0)
    assert q["energy"] == pytest.approx(ref.energy, rel=1e-9)
    assert q["mse"] == pytest.approx(ref.mse, rel=1e-6)


@pytest.mark.parametrize("tile_size", [30.0, 20.0])
def test_local_tiles_place_far_off_points_as_untiled(client, tile_size):
    """Local mode: each tile moves the points off their region's surface as the
    untiled run does (a local decision on the owned points, the halo gives the
    neighbours), so the stitched ground is exactly the untiled one, with no
    vegetation point, and the measures agree (the plane MSE too: without the
    relabelling the vegetation's membership of the ground decided it)."""
    from pointatlas.segment import vsa_segment

    n = 12_000
    pts, nrm = veg_ground(n=n, n_veg=150, extent=(60.0, 40.0))
    ref = vsa_segment(pts, nrm, k=8, local=True)
    labels, q, run = tiled_segment(
        pts, nrm, TileOptions(tile_size=tile_size, scheduler=client), {"k": 8, "local": True}
    )
    assert run.n_tiles >= 4
    ground = labels == np.argmax(np.bincount(labels))
    assert np.array_equal(ground, ref.labels == np.argmax(np.bincount(ref.labels)))
    assert ground[:n].all() and not ground[n:].any()
    assert q["n_regions"] == ref.n_regions
    assert q["energy"] == pytest.approx(ref.energy, rel=0.01)
    assert q["mse"] == pytest.approx(ref.mse, rel=0.01)


def test_agreed_links_are_the_majority_both_ways():
    """`_agreed`: a pair is agreed when it holds at least half of each region's halo
    links with the other region's tile. Regions 0, 1 in tile 0; 2, 3 in tile 1."""
    tile_of = np.array([0, 0, 1, 1])
    pairs = np.array([[0, 2], [2, 0], [0, 3], [1, 3]])
    counts = np.array([60, 40, 30, 5])
    both = np.array([100, 100, 30, 5])  # (0, 2) both ways; the others one way
    got = _agreed(pairs, both, counts, tile_of)
    # 0 has 130 links with tile 1 (100 with 2), 2 has 100 with tile 0 (all with 0):
    # agreed; (0, 3): 30 of 0's 130; (1, 3): all of 1's 5 links but 5 of 3's 35
    assert got.tolist() == [True, True, False, False]

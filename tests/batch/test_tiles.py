"""Tiled processing (pointatlas.batch tiles): exactness, owner rule, stitching, LAS, CLI."""

from __future__ import annotations

import math

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from pointatlas._core import PointAtlasError  # noqa: E402
from pointatlas.batch import (  # noqa: E402
    ArraySource,
    TileOptions,
    make_grid,
    tiled_denoise,
    tiled_features,
    tiled_normals,
    tiled_segment,
)
from pointatlas.batch._tiles import _Spill, _spill  # noqa: E402
from pointatlas.batch._tiles_grid import exact_tile_knn  # noqa: E402
from pointatlas.neighbors import query_knn  # noqa: E402

OFFSET = np.array([512_000.0, 4_100_000.0, 80.0])  # UTM-like coordinates


def scan(n=24_000, seed=0):
    """A small lidar-like scene: ground, a box building with a flat roof, a tank
    (cylinder); millimetre-quantised (ties), far from the origin, shuffled."""
    rng = np.random.default_rng(seed)
    a, b, c = n // 2, n // 4, n - n // 2 - n // 4
    ground = np.column_stack([rng.uniform(0, 40, a), rng.uniform(0, 30, a), rng.normal(0, 0.01, a)])
    roof = np.column_stack(
        [rng.uniform(5, 15, b), rng.uniform(5, 12, b), 6 + rng.normal(0, 0.01, b)]
    )
    th = rng.uniform(0, 2 * np.pi, c)
    tank = np.column_stack([28 + 3 * np.cos(th), 18 + 3 * np.sin(th), rng.uniform(0, 8, c)])
    pts = np.round(np.vstack([ground, roof, tank]) * 1000) / 1000 + OFFSET
    return pts[rng.permutation(n)]


@pytest.fixture(scope="module")
def points():
    return scan()


@pytest.fixture(scope="module")
def oriented(points):
    from pointatlas.normals import estimate_normals, orient_normals

    return orient_normals(points, estimate_normals(points, 20), method="mst")


def test_owner_rule_covers_every_point_exactly_once(points):
    lo, hi = points.min(axis=0), points.max(axis=0)
    grid = make_grid(lo, hi, 7.0)
    owner = grid.owner(points[:, :2])
    assert owner.min() >= 0 and owner.max() < grid.n_tiles
    # the spill pass: every tile gets its owned points plus a halo, in global order
    spill = _Spill(None)
    owned, sent = _spill(ArraySource(points), grid, dict.fromkeys(range(grid.n_tiles), 1.5), spill)
    assert sum(owned.values()) == points.shape[0]
    seen = np.zeros(points.shape[0], dtype=np.int64)
    for t in range(grid.n_tiles):
        data = spill.load(t)
        if not data:
            continue
        g = data["gidx"]
        assert np.all(np.diff(g) > 0)
        assert sent[t] == g.size
        mine = grid.owner(data["xyz"][:, :2]) == t
        seen[g[mine]] += 1
        # halo points lie within 1.5 of the tile's cell
        x0, x1, y0, y1 = grid.core_box(t)
        xy = data["xyz"][~mine, :2]
        assert np.all((xy[:, 0] >= x0 - 1.5) & (xy[:, 0] <= x1 + 1.5))
        assert np.all((xy[:, 1] >= y0 - 1.5) & (xy[:, 1] <= y1 + 1.5))
    assert np.array_equal(seen, np.ones_like(seen))


def test_exact_tile_knn_equals_global_query(points):
    k = 16
    idx_all, _ = query_knn(points, k)
    grid = make_grid(points.min(axis=0), points.max(axis=0), 10.0)
    owner = grid.owner(points[:, :2])
    for t in (0, 5):
        members = np.flatnonzero(grid.members(points[:, :2], owner, t, 2.0))
        xyz = points[members]
        rows = np.flatnonzero(owner[members] == t)
        bdist = grid.boundary_distance(xyz[:, :2], t, 2.0)
        table, bad, r_k = exact_tile_knn(xyz, rows, k, grid.center, bdist)
        assert bad.size == 0 and np.all(r_k < bdist[rows])
        assert np.array_equal(members[table[rows, :k]], idx_all[members[rows]])


def test_tiled_normals_equal_untiled_bit_for_bit(client, points):
    from pointatlas.normals import estimate_normals, orient_normals

    opts = TileOptions(tile_size=9.0, scheduler=client)
    ref = estimate_normals(points, 20)
    got, run = tiled_normals(points, opts, k=20, orient="none")
    assert run.n_tiles > 4 and run.halo_overhead > 1.0
    assert np.array_equal(got, ref)
    vp = OFFSET + [20.0, 15.0, 100.0]
    got, _ = tiled_normals(points, opts, k=20, orient="viewpoint", viewpoint=vp)
    assert np.array_equal(got, orient_normals(points, ref, method="viewpoint", viewpoint=vp))


def test_tiled_mst_orientation_is_consistent_across_tiles(client, points, oriented):
    got, run = tiled_normals(points, TileOptions(tile_size=9.0, scheduler=client), k=20)
    assert np.array_equal(np.abs(got), np.abs(oriented))  # same axes, bit for bit
    agree = np.einsum("ij,ij->i", got, oriented) > 0
    q = points - OFFSET
    on_tank = np.abs(np.hypot(q[:, 0] - 28, q[:, 1] - 18) - 3) < 0.01
    roof = (q[:, 2] > 5.9) & ~on_tank
    # the roof and the ground far from the tank: the untiled signs exactly; the
    # ground-tank junction (90 degrees) is a guess for any MST, tiled or not
    far = ~on_tank & ~roof & (np.hypot(q[:, 0] - 28, q[:, 1] - 18) > 4.0)
    assert agree[roof].all() and agree[far].all()
    assert agree.mean() > 0.98
    radial = np.column_stack([q[:, 0] - 28, q[:, 1] - 18, np.zeros(len(q))])
    assert np.mean(np.einsum("ij,ij->i", got[on_tank], radial[on_tank]) > 0) > 0.99
    # neighbouring points in different tiles agree as well as those in one tile
    idx, _ = query_knn(points, 8)
    owner = run.grid.owner(points[:, :2])
    cross = owner[idx[:, 1:]] != owner[:, None]
    dots = np.einsum("ij,ikj->ik", got, got[idx[:, 1:]])
    assert np.mean(dots[cross] > 0) >= np.mean(dots[~cross] > 0) - 0.005


@pytest.mark.parametrize(
    "params",
    [
        {"mode": "fixed", "k": 20, "flatness": (8, 8)},
        {"mode": "optimal_k", "k_range": (10, 24), "criterion": "e_dim", "flatness": (8, 8)},
        {
            "mode": "optimal",
            "k_range": (6, 14),
            "a_grid": (0.0, math.pi / 3, math.pi),
            "b_grid": (0.0, math.pi / 3, math.pi),
            "flatness": (8, 8),
        },
    ],
    ids=["fixed", "optimal_k", "optimal_ab"],
)
def test_tiled_features_equal_untiled_bit_for_bit(client, points, oriented, params):
    from pointatlas.batch._tiles_tasks import features_dispatch
    from pointatlas.features import classify_dimension

    pts, nrm = points[:12_000], oriented[:12_000]
    ref = features_dispatch(pts, nrm, params)
    got, _ = tiled_features(pts, nrm, TileOptions(tile_size=12.0, scheduler=client), params)
    for name, values in ref.scalar_fields().items():
        assert np.array_equal(got[name], values, equal_nan=True), name
    assert np.array_equal(got["dimension_class"], classify_dimension(ref))


def test_automatic_halo_grows_and_a_given_halo_too_small_is_refused(client, points, monkeypatch):
    from pointatlas.batch import _tiles
    from pointatlas.features import covariance_features

    params = {"mode": "fixed", "k": 20, "flatness": (8, 8)}
    # a tiny starting halo: the tiles ask for more, and the result is still exact
    monkeypatch.setattr(_tiles, "_auto_halo", lambda *args, **kwargs: (0.05, False))
    got, run = tiled_features(points, None, TileOptions(tile_size=9.0, scheduler=client), params)
    assert run.n_retries > 0
    assert min(run.halos.values()) > 0.05
    ref = covariance_features(points, 20).scalar_fields()
    assert all(np.array_equal(got[k], ref[k], equal_nan=True) for k in ref)
    monkeypatch.undo()
    fixed = TileOptions(tile_size=9.0, halo=0.05, scheduler=client)
    with pytest.raises(PointAtlasError, match=r"--halo 0.05 is too small for k = 20.*--halo \d"):
        tiled_features(points, None, fixed, params)


@pytest.mark.parametrize("local", [False, True])
@pytest.mark.parametrize("tile_size", [20.0, 12.0, 8.0])
def test_tiled_segment_quality_within_one_percent(client, points, oriented, tile_size, local):
    from pointatlas.segment import vsa_segment

    params = {
        "k": 8,
        "split": True,
        "merge": True,
        "switch": "batch",
        "eta": None,
        "max_angle": None,
        "local": local,
    }
    labels, q, run = tiled_segment(
        points, oriented, TileOptions(tile_size=tile_size, scheduler=client), params
    )
    # the default threshold (mean deviation <= 10 degrees); the local mode (the
    # tiles run it too) is compared with an untiled run of the same mode
    ref = vsa_segment(points, oriented, k=8, local=local)
    assert run.n_tiles >= 4 and run.extra["halo_unions"] > 0
    assert labels.min() == 0 and labels.max() == q["n_regions"] - 1
    assert abs(q["n_regions"] - ref.n_regions) <= 0.01 * ref.n_regions
    assert abs(q["energy"] - ref.energy) <= 0.01 * ref.energy
    assert abs(q["mse"] - ref.mse) <= 0.01 * ref.mse
    # the reported measures are those of the labels
    assert np.array_equal(np.bincount(labels), q["region_counts"])
    nrm = oriented / np.linalg.norm(oriented, axis=1)[:, None]
    s = np.stack([np.bincount(labels, weights=nrm[:, d]) for d in range(3)], 1)
    energy = float(np.sum(2.0 * (np.bincount(labels) - np.linalg.norm(s, axis=1))))
    assert energy == pytest.approx(q["energy"], rel=1e-9)


def test_tiled_segment_eta_regions_stay_under_eta(client, points, oriented):
    from pointatlas.segment import VSAOptions

    params = {
        "k": 8,
        "split": True,
        "merge": True,
        "switch": "batch",
        "eta": 25.0,
        "max_angle": None,
    }
    tiles = TileOptions(tile_size=12.0, scheduler=client)
    labels, q, _ = tiled_segment(points, oriented, tiles, params)
    assert np.all(q["region_l21"] < 25.0)
    assert np.array_equal(np.bincount(labels), q["region_counts"])
    # one VSAOptions is forwarded as is: the same run as its fields given as a dict
    labels_o, q_o, _ = tiled_segment(points, oriented, tiles, VSAOptions(k=8, eta=25.0))
    assert np.array_equal(labels_o, labels) and q_o["energy"] == q["energy"]
    refused = [
        ({"seeds": 50}, "--seeds must be 'all'"),
        ({"weights": "area"}, "--weights must be uniform"),
        ({"classic": True, "eta": None}, "--classic needs every point"),
    ]
    for bad, message in refused:
        with pytest.raises(PointAtlasError, match=message):
            tiled_segment(points, oriented, tiles, VSAOptions(k=8, eta=25.0).replace(**bad))


def test_tiled_segment_joins_small_regions_across_tiles(client, points, oriented):
    """``min_region_size`` (issue 28 item 6) holds for the stitched regions too:
    none below it touches another region, also where a tile border cut one."""
    from pointatlas.segment import VSAOptions, region_adjacency

    tiles = TileOptions(tile_size=8.0, scheduler=client)
    opts = VSAOptions(k=8, max_angle=math.radians(10.0))
    before, _, _ = tiled_segment(points, oriented, tiles, opts)
    labels, q, run = tiled_segment(points, oriented, tiles, opts.replace(min_region_size=8))
    assert (np.bincount(before) < 8).sum() > 0
    counts = np.bincount(labels)
    assert np.array_equal(counts, q["region_counts"]) and counts.size <= before.max() + 1
    small = np.flatnonzero(counts < 8)
    assert not np.isin(region_adjacency(points, labels, k=8), small).any()
    # the tiles joined their own; the stitch joined those cut by tile borders
    assert run.extra["small_regions_joined"] > 0


def test_tiled_flatness_denoising_matches_untiled(client, points):
    from pointatlas.denoise import flatness_denoise

    pts = points[:10_000]
    params = {
        "method": "flatness",
        "k": 14,
        "eta": 1.0,
        "eps": 0.1,
        "n_iter": 3,
        "schedule": "constant",
        "k_start": None,
    }
    out, run = tiled_denoise(pts, None, TileOptions(tile_size=15.0, scheduler=client), params)
    ref = flatness_denoise(pts, k=14, n_iter=3)
    assert run.n_tiles > 1
    np.testing.assert_allclose(out["points"], ref.points, rtol=0, atol=1e-9)
    assert np.mean(np.all(out["points"] == ref.points, axis=1)) > 0.999
    with pytest.raises(PointAtlasError, match="smaller than the reach of 3 denoising"):
        tiled_denoise(pts, None, TileOptions(tile_size=15.0, halo=0.01, scheduler=client), params)


@pytest.mark.parametrize("method", ["normal-voting", "normal-voting-adaptive"])
def test_tiled_normal_voting_with_fixed_counts_equals_untiled_bit_for_bit(client, method):
    from pointatlas.denoise import denoise_halo, normal_voting_denoise
    from pointatlas.normals import estimate_normals, orient_normals

    # nine scenes side by side (120 x 90): tiles of 30, halo of several 48-neighbour rings
    pts = np.vstack([scan(5_000, seed=s) + [40.0 * (s % 3), 30.0 * (s // 3), 0] for s in range(9)])
    nrm = orient_normals(pts, estimate_normals(pts, 16), k=10, method="mst")
    params = {
        "method": method,
        "rho": 0.9,
        "tau": 0.3,
        "n_iter": 1,
        "filter_iter": 1,
        "max_step": 0.5,
        "n_update": 1,
    }
    assert denoise_halo(method, n_iter=1, n_filter_iter=1, n_update=1).exact
    out, run = tiled_denoise(pts, nrm, TileOptions(tile_size=30.0, scheduler=client), params)
    ref = normal_voting_denoise(
        pts, nrm, n_iter=1, n_filter_iter=1, n_update=1, adaptive=method.endswith("adaptive")
    )
    assert run.n_tiles >= 8 and max(run.tile_points.values()) < 0.8 * len(pts)  # real tiles
    assert np.array_equal(out["points"], ref.points)
    assert np.array_equal(out["normals"], ref.normals)
    assert np.array_equal(out["feature_class"], ref.feature_class)
    assert np.array_equal(out["denoise_k"], ref.k)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"tile_size": 0}, "--tile-size must be > 0"),
        ({"tile_size": -3.0}, "--tile-size must be > 0"),
        ({"tile_size": float("nan")}, "--tile-size must be a finite number"),
        ({"tile_size": 5.0, "halo": -1.0}, "--halo must be a finite number >= 0"),
        ({"tile_size": 5.0, "workers": 0}, "--workers must be an integer >= 1"),
        ({"tile_size": 5.0, "max_memory": "lots"}, "--max-memory must be a size"),
    ],
)
def test_bad_tile_options_are_one_line_errors(kwargs, message):
    with pytest.raises(PointAtlasError, match=message) as info:
        TileOptions(**kwargs)
    assert "\n" not in str(info.value)


def test_unreachable_scheduler_is_a_one_line_error(points, monkeypatch):
    from pointatlas.batch import _tiles

    monkeypatch.setattr(_tiles, "CONNECT_TIMEOUT_S", 1)
    opts = TileOptions(tile_size=9.0, scheduler="tcp://127.0.0.1:9")
    with pytest.raises(PointAtlasError, match=r"--scheduler tcp://127.0.0.1:9: cannot connect"):
        tiled_normals(points, opts, k=20, orient="none")


def test_outward_orientation_is_refused_by_tiles(points):
    with pytest.raises(PointAtlasError, match="--orient outward needs the whole surface"):
        tiled_normals(points, TileOptions(tile_size=9.0), orient="outward")


def test_stitching_refuses_a_small_offset_plane_joining_a_huge_one():
    from pointatlas.batch._tiles_segment import _Regions
    from pointatlas.batch._tiles_tasks import region_stats

    rng = np.random.default_rng(5)
    # rough ground (plane MSE 0.25 m^2, like the benchmark scan's curved ground) cut
    # in two halves, and a small flat roof 6 m above it
    xy = rng.uniform(0, 200, (40_000, 2))
    ground = np.column_stack([xy, 0.01 * xy[:, 0] + rng.normal(0, 0.5, 40_000)])
    roof = np.column_stack([rng.uniform(50, 55, (300, 2)), 6.5 + rng.normal(0, 0.02, 300)])
    pts = np.vstack([ground, roof])
    labels = np.r_[(ground[:, 0] > 100).astype(np.int64), np.full(300, 2)]
    normals = np.tile([-0.01, 0.0, 1.0], (pts.shape[0], 1))
    st, first = region_stats(labels, 3, pts, normals, np.zeros(3), np.arange(pts.shape[0]))
    regions = _Regions(st, first, None, math.cos(math.radians(10)), tau2=0.01)
    assert regions.ok(0, 1)  # the two halves of the ground: one surface
    union = st[0] + st[2]
    # the roof is parallel (the normal tests pass) and the ground's MSE stays within
    # 4 x its own (300 x 36 / 40,000 = 0.27 m^2 more), but its points lie 6 m off
    assert regions.plane_mse(union) < 4.0 * regions.plane_mse(st[0])
    assert not regions.ok(0, 2) and not regions.ok(1, 2)
    regions.union(0, 1)
    assert not regions.ok(regions.find(0), 2)

"""The spill pass (`_spill`): every tile's owned + halo points, in global index order,
equal to testing every point of the neighbour tiles (the plain reference below), with
halos of any width, per-tile halos and points on cell borders; and the LAS source's
coordinates and extremes bit for bit laspy's (docs/decisions/batch.md, "Tiles — LAS/LAZ
streamed by chunks")."""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import pytest

from pointatlas.batch._tiles import ArraySource, _Spill, _spill
from pointatlas.batch._tiles_grid import make_grid

laspy = pytest.importorskip("laspy")


def _reference(source, grid, halos):
    """Every point of a tile's neighbour tiles tested with `TileGrid.members`."""
    pieces, owned = defaultdict(list), defaultdict(int)
    rings = {t: max(1, math.ceil(h / grid.size)) if h > 0 else 0 for t, h in halos.items()}
    for start, xyz, _ in source.chunks():
        owner = grid.owner(xyz[:, :2])
        for t, h in halos.items():
            near = np.isin(owner, grid.neighbors(t, rings[t]))
            cand = np.flatnonzero(near)
            sel = cand[grid.members(xyz[cand, :2], owner[cand], t, h)]
            if sel.size:
                pieces[t].append((start + sel, xyz[sel]))
                owned[t] += int(np.count_nonzero(owner[sel] == t))
    return pieces, owned


@pytest.mark.parametrize(
    ("size", "halo", "per_tile"),
    [
        (10.0, 1.5, False),
        (10.0, 0.0, False),
        (7.0, 16.0, False),
        (10.0, 2.0, True),
        (0.5, 0.001, False),
    ],
)
def test_spill_equals_testing_every_neighbour_point(size, halo, per_tile):
    rng = np.random.default_rng(4)
    n = 30_000
    xy = np.round(rng.uniform(0, 40, (n, 2)), 1)  # many points exactly on cell borders
    xyz = np.column_stack([xy + [512_000.0, 4_100_000.0], rng.normal(0, 1, n)])
    xyz[:50, :2] = [512_040.0, 4_100_040.0]  # on the upper bound: the last, closed cells
    src = ArraySource(xyz)
    src.chunks = lambda: ((s, xyz[s : s + 7_000], None) for s in range(0, n, 7_000))
    lo, hi = src.bounds()
    grid = make_grid(lo, hi, size)
    halos = {t: halo * (1 + (t % 3) if per_tile else 1) for t in range(grid.n_tiles)}
    spill = _Spill(None)
    owned, sent = _spill(src, grid, halos, spill)
    ref, ref_owned = _reference(src, grid, halos)
    assert set(spill.pieces) == set(ref)
    for t, parts in ref.items():
        got = spill.load(t)
        assert np.array_equal(got["gidx"], np.concatenate([g for g, _ in parts]))
        assert np.array_equal(got["xyz"], np.concatenate([p for _, p in parts]))
        assert np.all(np.diff(got["gidx"]) > 0)
        assert owned[t] == ref_owned[t] and sent[t] == got["gidx"].size
    assert sum(owned.values()) == n


def test_las_coordinates_and_extremes_are_laspys(tmp_path):
    from pointatlas.batch._tiles_las import LasSource

    rng = np.random.default_rng(2)
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.001, 0.01, 0.003])
    header.offsets = np.array([512_000.0, 4_100_000.0, -7.5])
    las = laspy.LasData(header)
    las.x = rng.uniform(512_000, 512_100, 5000)
    las.y = rng.uniform(4_100_000, 4_100_100, 5000)
    las.z = rng.normal(0, 30, 5000)
    path = tmp_path / "c.laz"
    las.write(path)
    src = LasSource(path, chunk_points=1200)
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for _, rec in src.records(full=True):
        ref = np.column_stack([np.asarray(rec[c], dtype=np.float64) for c in "xyz"])
        assert np.array_equal(LasSource.xyz_of(rec), ref)
        assert np.array_equal(LasSource.xyz_of(rec[1::3]), ref[1::3])
        c_lo, c_hi = LasSource.extremes_of(rec)
        assert np.array_equal(c_lo, ref.min(axis=0)) and np.array_equal(c_hi, ref.max(axis=0))
        lo, hi = np.minimum(lo, c_lo), np.maximum(hi, c_hi)
    assert src.bounds() == (tuple(lo.tolist()), tuple(hi.tolist()))
    flipped = laspy.ScaleAwarePointRecord(rec.array, rec.point_format, -rec.scales, rec.offsets)
    ref = np.column_stack([np.asarray(flipped[c], dtype=np.float64) for c in "xyz"])
    c_lo, c_hi = LasSource.extremes_of(flipped)  # a negative scale: extremes swap
    assert np.array_equal(c_lo, ref.min(axis=0)) and np.array_equal(c_hi, ref.max(axis=0))

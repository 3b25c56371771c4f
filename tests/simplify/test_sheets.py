"""Whole sheets turned by the winding number far from the points and near them
(`simplify/_sheets.py`, steps of `outward_normals`): the per-sheet winding number
against plain numpy, a tube whose inner wall faces into the wall (which the dipole
test reads as closed) turned back, pockets and through-holes turned inward as a whole
(walls and floor: no patch of them disagrees with its neighbours) turned back, right
normals left as they are, the probes far from every point, determinism."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from pointatlas.neighbors import query_knn
from pointatlas.simplify import outward_normals
from pointatlas.simplify._reconstruct import CLOSED_DIPOLE
from pointatlas.simplify._sheets import (
    FAR_SPACINGS,
    NEAR_SOURCES,
    NEAR_STRIDE,
    far_probes,
    far_sheet_flips,
    near_probes,
    near_sheet_flips,
    sheet_winding,
)
from pointatlas.simplify._winding import dipole_share, point_areas, table_areas
from pointatlas.synth import sample_mesh

from .cad_shapes import box, circle, extrude, pocketed_block, square


def sheet_winding_reference(x, p, dip, row, rows):
    """`sheet_winding` in plain numpy: per row, the winding number of its points."""
    out = np.zeros((rows, x.shape[0]))
    for r in range(rows):
        e = p[row == r][None, :, :] - x[:, None, :]
        dist = np.linalg.norm(e, axis=2)
        out[r] = (np.einsum("ijk,jk->ij", e, dip[row == r]) / dist**3).sum(axis=1)
    return out / (4.0 * np.pi)


def _tube():
    """A tube 6 long, radii 1 and 0.9, 8,000 points: its wall about 2.2 spacings."""
    v, t = extrude(circle((0, 0), 1.0, 96), [circle((0, 0), 0.9, 96)], height=6.0)
    s = sample_mesh(v, t, 8000, rng=0)
    return np.asarray(s.points), np.asarray(s.normals)


def _table(p):
    idx, dist = query_knn(p, 10)
    dist = np.asarray(dist)
    return np.asarray(idx), dist, table_areas(dist, 8)


def test_sheet_winding_matches_plain_numpy():
    """Exact where every group is near (one cube holding all the points), and within
    a thousandth where far groups act as one dipole (a closed sphere's winding number
    is about 1 inside, 0 outside)."""
    rng = np.random.default_rng(0)
    p = rng.normal(size=(300, 3))
    dip = rng.normal(size=(300, 3)) * 0.01
    row = rng.integers(0, 4, 300)
    x = rng.normal(size=(50, 3))  # within every group's reach
    want = sheet_winding_reference(x, p, dip, row, 4)
    np.testing.assert_allclose(sheet_winding(x, p, dip, row, 4, 100.0), want, rtol=1e-10)
    u = rng.normal(size=(6000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    dip = u * point_areas(u)[:, None]
    row = (u[:, 2] > 0.0).astype(np.int64)  # two hemispheres
    x = np.vstack([rng.normal(size=(40, 3)) * 0.2, rng.normal(size=(40, 3)) * 3.0])
    x = x[np.abs(np.linalg.norm(x, axis=1) - 1.0) > 0.2]  # far from the points
    want = sheet_winding_reference(x, u, dip, row, 2)
    got = sheet_winding(x, u, dip, row, 2, 0.1)
    np.testing.assert_allclose(got, want, atol=1e-3)
    inside = np.linalg.norm(x, axis=1) < 1.0
    assert np.allclose(got.sum(axis=0), inside.astype(float), atol=0.05)


def test_a_tubes_inner_wall_turned_into_the_wall_is_turned_back():
    p, truth = _tube()
    inner = (np.hypot(p[:, 0], p[:, 1]) < 0.95) & (np.abs(truth[:, 2]) < 0.5)
    n = truth.copy()
    n[inner] *= -1.0  # facing into the wall, as propagation across it leaves it
    areas = point_areas(p)
    # the walls' normals cancel: the dipole test reads closed, the sheets step runs
    assert dipole_share(p, n, areas) <= CLOSED_DIPOLE
    idx, dist, table = _table(p)
    flip = far_sheet_flips(p, n, idx, dist, table)
    turned = np.where(flip[:, None], -n, n)
    assert int((np.einsum("ij,ij->i", turned, truth) < 0.0).sum()) == 0
    assert int((np.einsum("ij,ij->i", outward_normals(p, n), truth) < 0.0).sum()) == 0


def test_right_normals_are_left_as_they_are():
    v, t = box()
    s = sample_mesh(v, t, 4000, rng=0)
    for p, truth in (_tube(), (np.asarray(s.points), np.asarray(s.normals))):
        idx, dist, table = _table(p)
        assert not far_sheet_flips(p, truth, idx, dist, table).any()
        np.testing.assert_array_equal(outward_normals(p, truth), truth)


def test_all_turned_where_every_normal_points_in():
    p, truth = _tube()
    idx, dist, table = _table(p)
    assert far_sheet_flips(p, -truth, idx, dist, table).all()


def test_probes_are_far_from_every_point_and_seeded():
    p, _ = _tube()
    spacing = float(np.median(query_knn(p, 2)[1][:, 1]))
    x = far_probes(p, spacing)
    assert x.shape[0] > 100
    near = cKDTree(p).query(x, 1)[0]
    assert near.min() >= FAR_SPACINGS * spacing
    np.testing.assert_array_equal(x, far_probes(p, spacing))


def _inside(p, x, y, w, z0=-np.inf, z1=np.inf):
    """Which points ``p`` lie in the box [x, x + w] x [y, y + w] x [z0, z1]."""
    eps = 1e-9
    lo, hi = np.array([x, y, z0]) - eps, np.array([x + w, y + w, z1]) + eps
    return ((p >= lo) & (p <= hi)).all(axis=1)


def _pockets():
    """A block 4 x 4 x 1 with two pockets 0.5 wide and deep (each about 18 point
    spacings across), 12,000 points with their true normals, and which points lie
    on the pockets' walls and floors."""
    v, t = pocketed_block([(0.6, 0.6, 0.5), (2.9, 2.9, 0.5)])
    s = sample_mesh(v, t, 12000, rng=0)
    p, truth = np.asarray(s.points), np.asarray(s.normals)
    pocket = _inside(p, 0.6, 0.6, 0.5, 0.5, 1.0) | _inside(p, 2.9, 2.9, 0.5, 0.5, 1.0)
    return p, truth, pocket & (p[:, 2] < 1.0 - 1e-9)


def _holes():
    """A plate 4 x 4 x 0.5 with four square through-holes 0.4 wide, 12,000 points
    with their true normals, and which points lie on two of the holes' walls."""
    holes = [square(x, y, 0.4) for x, y in ((0.6, 0.6), (3.0, 0.6), (0.6, 3.0), (3.0, 3.0))]
    v, t = extrude(square(0, 0, 4), holes, height=0.5)
    s = sample_mesh(v, t, 12000, rng=0)
    p, truth = np.asarray(s.points), np.asarray(s.normals)
    walls = _inside(p, 0.6, 0.6, 0.4) | _inside(p, 3.0, 3.0, 0.4)
    return p, truth, walls & (np.abs(truth[:, 2]) < 0.5)


def test_pockets_and_holes_turned_inward_as_a_whole_are_turned_back():
    """Each wall and floor is a sheet of 40-150 points (below the far step's
    `SHEET_SHARE`) bounded by edges, and the pocket agrees with itself across them
    (no patch disagrees): the far step and the patches' step leave all of them
    (measured: 583 of 583 and 455 of 455 before the near step). A pocket's walls
    turned alone leave its hollow read halfway: they are turned together."""
    for p, truth, wrong in (_pockets(), _holes()):
        n = truth.copy()
        n[wrong] *= -1.0
        assert wrong.sum() > 400
        idx, dist, table = _table(p)
        assert not far_sheet_flips(p, n, idx, dist, table).any()
        flip = near_sheet_flips(p, n, idx, dist, table)
        assert int((flip & ~wrong).sum()) <= 2
        assert int((wrong & ~flip).sum()) <= 2
        inward = np.einsum("ij,ij->i", outward_normals(p, n), truth) < 0.0
        assert int(inward.sum()) <= 2
        # right normals stay right
        assert not near_sheet_flips(p, truth, idx, dist, table).any()
        np.testing.assert_array_equal(outward_normals(p, truth), truth)


def test_near_probes_are_far_from_every_point_and_on_both_sides():
    p, truth, _ = _pockets()
    spacing = float(np.median(query_knn(p, 2)[1][:, 1]))
    rows = np.arange(p.shape[0])
    x = near_probes(p, truth, rows, spacing)
    assert x.shape[0] > 1000
    assert cKDTree(p).query(x, 1)[0].min() >= FAR_SPACINGS * spacing
    # inside the block and outside it (the block is [0, 4]^2 x [0, 1])
    inside = ((x > 0.0) & (x < [4.0, 4.0, 1.0])).all(axis=1)
    assert 0 < int(inside.sum()) < x.shape[0]
    # every 4th point gives probes, or fewer where there are many (at most about
    # NEAR_SOURCES of them, four probes each)
    assert x.shape[0] <= 4 * len(range(0, rows.size, NEAR_STRIDE))
    many = np.tile(rows, 4)
    assert near_probes(p, truth, many, spacing).shape[0] <= 4 * NEAR_SOURCES

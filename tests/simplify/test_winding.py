"""The points' winding number (robust path's inside/outside away from the points)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from pointatlas.neighbors import query_knn
from pointatlas.simplify._reconstruct import CLOSED_DIPOLE
from pointatlas.simplify._winding import (
    DIPOLE_AREA_CAP,
    dipole_share,
    dipoles,
    far_sides,
    point_areas,
    table_areas,
    winding_numbers,
)
from pointatlas.synth import sample_mesh

from .cad_shapes import cube_with_square_hole
from .reference import (
    far_sides_reference,
    upsample_reference,
    winding_cells_reference,
    winding_reference,
)


def _sphere(n, seed=0):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return p, p.copy()


def test_clustered_sum_agrees_with_the_point_by_point_sum():
    p, n = _sphere(3000)
    rng = np.random.default_rng(1)
    x = rng.uniform(-2.0, 2.0, size=(400, 3))
    x = x[np.abs(np.linalg.norm(x, axis=1) - 1.0) > 0.1]  # away from the points
    fast = winding_numbers(x, p, n, cell=0.25)
    slow = winding_reference(x, p, n, point_areas(p))
    # the far cells' dipoles are first order: a few hundredths, far below the 1/4
    # margin the field uses
    assert np.abs(fast - slow).max() < 0.05
    # one cell per point: every far cell is one point's own dipole, exactly
    assert np.allclose(winding_numbers(x, p, n, cell=1e-6), slow, atol=1e-12)


def test_cells_sum_is_the_plain_loops_bit_for_bit():
    """The kernel (every cell's far term first, then the sum in the cells' order)
    gives the bits of a plain loop over the cells, near cells point by point."""
    p, n = _sphere(600, seed=2)
    rng = np.random.default_rng(4)
    x = rng.uniform(-1.5, 1.5, size=(60, 3))
    x[:3] = p[:3]  # on points: their own term left out
    sources = dipoles(p, n, cell=0.3)
    assert (np.diff(sources.starts) > 1).any() and sources.centres.shape[0] > 20
    got = sources.at(x)
    np.testing.assert_array_equal(got, winding_cells_reference(x, sources))
    assert np.abs(got).max() > 0.5  # inside rows as well as outside
    # a node on a lone point, its cell's centre: no far term of its own (0 / 0)
    q = np.array([[0.0, 0, 0], [5, 0, 0], [0, 5, 0], [0, 0, 5]])
    alone = dipoles(q, q / np.maximum(np.linalg.norm(q, axis=1), 1.0)[:, None], cell=1.0)
    np.testing.assert_array_equal(alone.at(q), winding_cells_reference(q, alone))
    assert np.isfinite(alone.at(q)).all()


def test_one_inside_zero_outside_a_sampled_solid_with_a_hole():
    v, t = cube_with_square_hole()
    s = sample_mesh(v, t, 20000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    lo, hi = p.min(axis=0), p.max(axis=0)
    rng = np.random.default_rng(2)
    x = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), size=(3000, 3))
    d, _ = cKDTree(p).query(x)
    x = x[d > 0.05 * np.linalg.norm(hi - lo)]
    w = winding_numbers(x, p, n, cell=0.1 * np.linalg.norm(hi - lo))
    inside = _inside(v, t, x)
    assert inside.any() and (~inside).any()
    assert np.abs(w[inside] - 1.0).max() < 0.15
    assert np.abs(w[~inside]).max() < 0.15


def _inside(v, t, x):
    """Inside the closed mesh: an odd number of crossings of a ray along +x (a plain
    test on its triangles; the ray is nudged off edges by an irrational direction)."""
    v, t = np.asarray(v, float), np.asarray(t)
    d = np.array([1.0, np.sqrt(2.0) * 1e-3, np.sqrt(3.0) * 1e-3])
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    e1, e2 = b - a, c - a
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    count = np.zeros(x.shape[0], dtype=np.int64)
    for i in range(x.shape[0]):
        s = x[i] - a
        u = np.einsum("ij,ij->i", s, h) / det
        qv = np.cross(s, e1)
        vv = (qv @ d) / det
        tt = np.einsum("ij,ij->i", e2, qv) / det
        count[i] = int(((u >= 0) & (vv >= 0) & (u + vv <= 1) & (tt > 0)).sum())
    return count % 2 == 1


def test_voxel_surface_of_a_sampled_solid_has_no_sheet_away_from_the_points(monkeypatch):
    # at one point spacing per grid step, a sampled solid's inside used to leak out
    # through the sampling's gaps (a surface a band's width inside, cut away after)
    from pointatlas.simplify import _voxel_grid
    from pointatlas.simplify._distance import PointSurface
    from pointatlas.simplify._reconstruct import reconstruct_surface

    monkeypatch.setattr(_voxel_grid, "SPACING_STEPS", 1.0)
    v, t = cube_with_square_hole()
    s = sample_mesh(v, t, 20000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    rec = reconstruct_surface(p, n)
    assert rec.n_trimmed == 0
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    back = PointSurface(p, n).distance(rec.vertices)
    # rounded edges and corners are off by a few steps; a leaked sheet by the band's
    # width (at least 4.5 spacings)
    assert back.max() < 3.5 * rec.step < 0.02 * diag


def test_areas_from_the_knn_table_are_the_searched_ones():
    """`table_areas` of a `query_knn` table (the point first) is `point_areas` up to
    the last bit of the distances (computed apart), repeated points and a set of
    fewer than k + 1 points included; a table too narrow is refused."""
    p, _ = _sphere(2000)
    p = np.vstack([p, p[:50]])  # repeated points: the k-th distance counts them
    _, dist = query_knn(p, 10)
    np.testing.assert_allclose(table_areas(dist), point_areas(p), rtol=1e-13, atol=0)
    _, few = query_knn(p[:4], 4)
    np.testing.assert_allclose(table_areas(few), point_areas(p[:4]), rtol=1e-13, atol=0)
    with pytest.raises(ValueError, match="needs 9 neighbours"):
        table_areas(dist[:, :5])


def test_dipole_share_a_few_strays_do_not_open_a_closed_sample():
    """A sphere's discs sum to nothing (the share near 0), a hemisphere's to half its
    area; 12 stray points far off with normals all one way (each disc hundreds of the
    sphere's) would make it open, but no disc counts for more than `DIPOLE_AREA_CAP`
    times the median; without a disc over the cap the share is the plain sum's."""
    p, n = _sphere(4000)
    area = point_areas(p)
    plain = float(np.linalg.norm(area @ n)) / float(area.sum())
    assert dipole_share(p, n) == plain < 0.01
    cap = p[:, 2] > 0.0
    assert 0.45 < dipole_share(p[cap], n[cap]) < 0.55
    rng = np.random.default_rng(1)
    strays = np.array([3.0, 0.0, 0.0]) + rng.normal(0.0, 1.0, (12, 3))
    q = np.vstack([p, strays])
    m = np.vstack([n, np.tile([1.0, 0.0, 0.0], (12, 1))])
    a = point_areas(q)
    assert (a > DIPOLE_AREA_CAP * np.median(a)).sum() >= 10
    assert float(np.linalg.norm(a @ m)) / float(a.sum()) > CLOSED_DIPOLE  # uncapped
    assert dipole_share(q, m) < CLOSED_DIPOLE
    assert dipole_share(q, m, a) == dipole_share(q, m)  # the areas given or found


@pytest.mark.parametrize("stride", [2, 3, 5])
def test_upsampled_lattice_agrees_with_map_coordinates(stride):
    # grids whose sides are not multiples of the stride: past the last lattice
    # node the value is the nearest one's
    shape = (17, 11, 23)
    rng = np.random.default_rng(stride)
    w = rng.normal(size=[len(range(0, n, stride)) for n in shape])
    nodes = np.argwhere(np.ones(shape, dtype=bool))
    ref = ndimage.map_coordinates(w, (nodes / stride).T, order=1, mode="nearest")
    got = upsample_reference(w, stride, shape)
    assert got.shape == shape
    np.testing.assert_allclose(got.reshape(-1), ref, rtol=0, atol=1e-12)
    # the lattice nodes keep their values exactly
    lattice = got[::stride, ::stride, ::stride]
    np.testing.assert_array_equal(lattice, w)


@pytest.mark.parametrize("stride", [2, 3])
def test_far_sides_kernel_agrees_with_the_reference_bit_for_bit(stride):
    shape = (13, 9, 16)
    rng = np.random.default_rng(10 + stride)
    w = rng.uniform(-0.2, 1.2, size=[len(range(0, n, stride)) for n in shape])
    f = rng.normal(size=shape)
    far_from = rng.uniform(0.0, 2.0, size=shape)
    got = far_sides(f, w, far_from, 0.7, stride, 0.1)
    ref = far_sides_reference(f, w, far_from, 0.7, stride, 0.1)
    np.testing.assert_array_equal(got, ref)
    # near nodes keep the field; every clear far node took its size, with a sign
    near = far_from <= 0.7
    np.testing.assert_array_equal(got[near], f[near])
    assert (np.abs(got[~near]) >= np.minimum(np.abs(f[~near]), far_from[~near])).all()
    assert (got != f).any() and (got[~near] < 0).any() and (got[~near] > 0).any()


def _box_field(step):
    """A sampled box's points and normals, and its signed distance on a grid of
    ``step`` (grid origin, field)."""
    from .cad_shapes import box

    v, t = box()  # [0, 2] x [0, 1] x [0, 0.5]
    s = sample_mesh(v, t, 20000, rng=0)
    origin = np.array([-0.5, -0.5, -0.5])
    nodes = np.argwhere(np.ones((61, 41, 31), dtype=bool))
    x = origin + nodes * step
    half, centre = np.array([1.0, 0.5, 0.25]), np.array([1.0, 0.5, 0.25])
    d = np.abs(x - centre) - half
    sdf = np.linalg.norm(np.maximum(d, 0.0), axis=1) + np.minimum(d.max(axis=1), 0.0)
    return np.asarray(s.points), np.asarray(s.normals), origin, sdf.reshape(61, 41, 31)


def test_level_sides_turns_a_blob_far_from_the_points_and_nothing_near_them():
    """A blob of inside nodes 5 steps over a sampled box's top (as the tangent planes
    of a face extended past a knife edge leave one) goes, round by round from its
    level inwards; inside nodes a step over the top (near the points: the field is
    theirs there) and every other node stay as they were."""
    from pointatlas.simplify._winding import LEVEL_FAR_STEPS, LEVEL_ROUNDS, level_sides

    step = 0.05
    p, n, origin, f = _box_field(step)
    x = origin + np.argwhere(np.ones(f.shape, dtype=bool)).reshape(f.shape + (3,)) * step
    blob = np.linalg.norm(x - np.array([1.0, 0.5, 0.75]), axis=-1) <= 2.01 * step
    near = (np.abs(x[..., 2] - 0.55) < 0.5 * step) & (np.abs(x[..., 0] - 0.5) < 1.5 * step)
    near &= np.abs(x[..., 1] - 0.5) < 1.5 * step
    assert blob.sum() == 33 and near.sum() == 9
    tree = cKDTree(p)
    nearest = tree.query(x.reshape(-1, 3))[0].reshape(f.shape)
    assert nearest[blob].min() > (LEVEL_FAR_STEPS + 1) * step
    assert nearest[near].max() < LEVEL_FAR_STEPS * step
    sources = dipoles(p, n, 8 * step)
    bad = f.copy()
    bad[blob | near] = -step
    # the blob is 2 steps deep along the axes: its centre is reached in the third round
    assert LEVEL_ROUNDS >= 3
    got = level_sides(bad.copy(), nearest, sources, origin, step, 0.1)
    assert (got[blob] > 0.0).all()
    np.testing.assert_array_equal(got[blob], nearest[blob])  # the distance, outside
    np.testing.assert_array_equal(got[~blob], bad[~blob])
    # with one round only the blob's outer nodes turn
    import pointatlas.simplify._winding as winding

    try:
        winding.LEVEL_ROUNDS = 1
        once = level_sides(bad.copy(), nearest, sources, origin, step, 0.1)
    finally:
        winding.LEVEL_ROUNDS = LEVEL_ROUNDS
    assert 0 < (once[blob] > 0.0).sum() < blob.sum()


COLLECTION = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "collection"


@pytest.mark.skipif(not COLLECTION.exists(), reason="the collection is not under ../shared")
def test_no_voxel_surface_past_a_chamfered_knife_edge():
    """Past a chamfered flange's knife edge the nearest points' tangent planes say
    inside, nearer the points than the winding number's lattice reaches: the voxel
    surface of `voron0_b_idler_lower` held 12 vertices more than 3.5 grid steps from
    every point where the winding number is clearly outside (2.29 % of the diagonal
    from the truth); the winding number at the level's nodes turns them."""
    from pointatlas.io import read_mesh
    from pointatlas.simplify._reconstruct import WINDING_CLEAR, reconstruct_surface

    mesh = read_mesh(COLLECTION / "voron0_b_idler_lower_x1.stl")
    v, t = np.asarray(mesh.vertices), np.asarray(mesh.triangles, dtype=np.int64)
    s = sample_mesh(v, t, 20000, rng=0)
    p, n = np.asarray(s.points), np.asarray(s.normals)
    rec = reconstruct_surface(p, n)
    far = rec.vertices[cKDTree(p).query(rec.vertices)[0] > 3.5 * rec.step]
    w = winding_numbers(far, p, n, 8 * rec.step)
    assert not ((w < WINDING_CLEAR) | (w > 1.0 - WINDING_CLEAR)).any()

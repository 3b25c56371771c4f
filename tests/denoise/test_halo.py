"""`denoise_halo`: a tile holding the halo's rings gives its owned points the untiled
result, bit for bit (normal voting with fixed counts, the untiled l and table)."""

import numpy as np
import pytest

from pointatlas.denoise import DenoiseHalo, denoise_halo, normal_voting_denoise
from pointatlas.neighbors import query_knn
from pointatlas.synth import add_normal_noise, plane_patch


def _wavy(n=70, seed=0, lonely=False):
    """A noisy wavy sheet: faces and crests, so filter, update and classes all act;
    ``lonely``: 3 % of the normals turned sideways (lonely points)."""
    m = plane_patch(n, n, width=float(n), height=float(n))
    pts = m.points.copy()
    pts[:, 2] = 6.0 * np.abs(np.sin(pts[:, 0] / 9.0))  # ridges: edge points
    nrm = np.column_stack(
        [
            -6.0 / 9.0 * np.sign(np.sin(pts[:, 0] / 9.0)) * np.cos(pts[:, 0] / 9.0),
            np.zeros(len(pts)),
            np.ones(len(pts)),
        ]
    )
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    noisy = add_normal_noise(pts, nrm, 0.3, rng=seed)
    if lonely:
        nrm = nrm.copy()
        turn = np.random.default_rng(seed).random(len(pts)) < 0.03
        nrm[turn] = nrm[turn][:, [2, 1, 0]] * [1.0, 1.0, -1.0]
    return noisy, nrm


def _rings_around(table, owned, rings):
    """Points within ``rings`` hops of ``owned`` in the k-NN graph of ``table``."""
    inside = owned.copy()
    front = owned.copy()
    for _ in range(rings):
        reach = np.zeros_like(inside)
        reach[table[front].ravel()] = True
        front = reach & ~inside
        inside |= reach
    return inside


@pytest.mark.parametrize(
    "adaptive,n_iter,n_update,n_filter_iter,lonely",
    [
        (False, 1, 1, 1, False),
        (True, 1, 1, 1, False),
        (False, 2, 1, 1, False),
        (False, 2, 1, 1, True),
    ],
)
def test_tile_with_the_halo_equals_untiled(adaptive, n_iter, n_update, n_filter_iter, lonely):
    pts, nrm = _wavy(lonely=lonely)
    method = "normal-voting-adaptive" if adaptive else "normal-voting"
    halo = denoise_halo(method, n_iter=n_iter, n_update=n_update, n_filter_iter=n_filter_iter)
    assert halo.exact and halo.columns == (58 if adaptive else 48)
    table = query_knn(pts, halo.columns)[0]
    opts = dict(adaptive=adaptive, n_iter=n_iter, n_update=n_update, n_filter_iter=n_filter_iter)
    full = normal_voting_denoise(pts, nrm, neighbors=table, **opts)
    assert np.array_equal(full.points, normal_voting_denoise(pts, nrm, **opts).points)
    owned = pts[:, 0] < pts[:, 0].min() + 12.0
    tile = _rings_around(table, owned, halo.rings)
    assert tile.sum() < 0.8 * len(pts)  # a real tile, not everything
    # the tile's table: exact rows (remapped) wherever they lie inside the tile
    ids = np.flatnonzero(tile)
    local = np.full(len(pts), -1)
    local[ids] = np.arange(ids.size)
    sub = local[table[ids]]
    rows_ok = (sub >= 0).all(axis=1)
    sub[~rows_ok] = query_knn(pts[ids], halo.columns)[0][~rows_ok]
    assert rows_ok[local[np.flatnonzero(_rings_around(table, owned, halo.rings - 1))]].all()
    part = normal_voting_denoise(pts[ids], nrm[ids], neighbors=sub, spacing=full.spacing, **opts)
    mine = local[np.flatnonzero(owned)]
    assert np.array_equal(part.points[mine], full.points[owned])
    assert np.array_equal(part.normals[mine], full.normals[owned])
    assert np.array_equal(part.feature_class[mine], full.feature_class[owned])
    assert np.array_equal(part.k[mine], full.k[owned])
    assert (full.displacement[owned] > 0).mean() > 0.9
    if n_iter == 1:  # the ridges are edges (two rounds of PCA normals round them)
        assert set(full.feature_class[owned].tolist()) >= {1, 2}


def test_halo_counts_and_units():
    h = denoise_halo("normal-voting", n_iter=2, n_update=3)
    # given normals: 2 rounds x (5 steps + 1 lonely-normal pass) + 1 re-estimate +
    # 2 x 3 updates + 5 final steps + classes
    assert h == DenoiseHalo(rings=2 * 6 + 1 + 2 * 3 + 5 + 1, columns=48, exact=True)
    assert denoise_halo("normal-voting", n_iter=2, n_update=3, n_filter_iter=1).rings == 13
    # estimated normals: 1 step and a lonely pass per round, the refit instead of
    # final steps, the PCA hop
    est = denoise_halo("normal-voting", n_iter=2, n_update=3, estimate=True)
    assert est.rings == 2 * 2 + 1 + 2 * 3 + 1 + 1 and not est.exact
    assert h.length(0.25) == pytest.approx(h.rings * 0.25)
    auto = denoise_halo("normal-voting-adaptive", n_iter=None)
    assert not auto.exact and auto.columns == 58
    assert auto.rings == 4 * 6 + 3 + 4 * 12 + 5 + 1 + 1  # + the polish step
    assert not denoise_halo("normal-voting", n_iter=1, n_update=2, estimate=True).exact
    flat = denoise_halo("flatness", n_iter=60, k=14, schedule="decreasing")
    assert flat == DenoiseHalo(rings=60, columns=56, exact=False)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"method": "auto", "n_iter": 1}, "method must be one of"),
        ({"method": "flatness", "n_iter": 3, "schedule": "up"}, "schedule must be one of"),
        ({"n_iter": -1}, "n_iter"),
    ],
)
def test_halo_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        denoise_halo(**kwargs)


def test_bad_neighbor_table():
    pts, nrm = _wavy(12)
    table = query_knn(pts, 48)[0]
    with pytest.raises(ValueError, match="at least 58 columns"):
        normal_voting_denoise(pts, nrm, neighbors=table, adaptive=True)
    with pytest.raises(ValueError, match="every point first"):
        normal_voting_denoise(pts, nrm, neighbors=table[:, ::-1], adaptive=False)
    with pytest.raises(ValueError, match="spacing"):
        normal_voting_denoise(pts, nrm, spacing=0.0)

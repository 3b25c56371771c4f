"""Small handles of the voxel surface cut and capped (`simplify._handles`)."""

from __future__ import annotations

import numpy as np
import pytest
from skimage.measure import marching_cubes

from pointatlas.simplify import _handles, mesh_checks
from pointatlas.simplify._handles import (
    HANDLE_MARGIN,
    HANDLE_STEPS,
    _graph,
    _grow_all,
    _one_piece,
    _region_triangles,
    cut_handles,
)
from pointatlas.simplify._mesh import vertex_pieces

STEP = 0.05
#: the grid step handed to `cut_handles`: handles up to 3 x 0.12 around
CUT = 0.12


def _euler(tri):
    sides = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    return np.unique(tri).size - np.unique(sides, axis=0).shape[0] + tri.shape[0]


def _surface(field):
    """Marching cubes of ``field(x, y, z)`` (negative inside) on a grid of `STEP`
    over [-1.2, 1.2]^3: a closed, oriented surface (Lewiner's tables)."""
    ax = np.arange(-1.2, 1.2 + STEP / 2, STEP)
    x, y, z = np.meshgrid(ax, ax, ax, indexing="ij")
    # one consistent orientation (inwards here: marching cubes turns its triangles
    # towards the larger values); the cut needs no more
    verts, tri, _, _ = marching_cubes(-field(x, y, z), level=0.0, spacing=(STEP,) * 3)
    return verts.astype(np.float64) - 1.2, tri.astype(np.int64)


def _torus(tube):
    return lambda x, y, z: np.hypot(np.hypot(x, y) - 0.7, z) - tube


def _dumbbell(x, y, z):
    balls = np.minimum(
        np.linalg.norm([x - 0.6, y, z], axis=0), np.linalg.norm([x + 0.6, y, z], axis=0)
    )
    neck = np.maximum(np.hypot(y, z) - 0.06, np.abs(x) - 0.6)
    return np.minimum(balls - 0.4, neck)


def test_a_thin_torus_loses_its_handle_and_stays_closed():
    v, t = _surface(_torus(0.06))
    assert _euler(t) == 0
    v2, t2, n_cut = cut_handles(v, t, CUT)
    assert n_cut == 1
    assert _euler(t2) == 2
    assert all(mesh_checks(v2.shape[0], t2))
    # the cap lies on the tube: no vertex beyond the torus' box
    assert np.all(np.abs(v2) <= np.abs(v).max(axis=0) + 1e-12)


def test_a_torus_wider_than_the_handle_size_is_left_alone():
    v, t = _surface(_torus(0.3))  # half the tube's circumference ~0.94, past 3 x 0.12
    assert 0.3 * np.pi > HANDLE_STEPS * CUT
    v2, t2, n_cut = cut_handles(v, t, CUT)
    assert n_cut == 0
    assert v2 is v and t2 is t


def test_a_thin_neck_is_not_a_handle():
    # the loop around the neck would cut one ball off: a separating loop, kept
    v, t = _surface(_dumbbell)
    assert _euler(t) == 2
    graph = _graph(v, t)
    seeds = np.arange(v.shape[0], dtype=np.int64)
    found = _grow_all(seeds, HANDLE_STEPS * CUT, HANDLE_MARGIN * CUT, *graph[:5], t, *graph[5:], 4)
    assert (found >= 0.0).any()  # regions around the neck are no discs ...
    _, t2, n_cut = cut_handles(v, t, CUT)
    assert n_cut == 0  # ... but their loops separate the balls
    assert np.array_equal(t2, t)


def test_two_thin_handles_on_a_ball_both_go():
    def field(x, y, z):
        ball = np.linalg.norm([x, y, z], axis=0) - 0.5
        ring_a = np.hypot(np.hypot(x - 0.55, y) - 0.25, z) - 0.05
        ring_b = np.hypot(np.hypot(x + 0.55, y) - 0.25, z) - 0.05
        return np.minimum(ball, np.minimum(ring_a, ring_b))

    v, t = _surface(field)
    assert _euler(t) == -2
    v2, t2, n_cut = cut_handles(v, t, CUT)
    assert n_cut == 2
    assert _euler(t2) == 2
    assert all(mesh_checks(v2.shape[0], t2))


@pytest.mark.parametrize("tube", [0.06])
def test_deterministic(tube):
    v, t = _surface(_torus(tube))
    a = cut_handles(v, t, CUT)
    b = cut_handles(v, t, CUT)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def _grow_reference(v, t, seed, radius, margin):
    """Plain numpy/scipy `_grow` of one seed: the distances along the edges
    (`scipy.sparse.csgraph.dijkstra`), the Euler characteristic of the triangles
    within each distance in turn."""
    from scipy.sparse import coo_array, csgraph

    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    w = np.linalg.norm(v[a] - v[b], axis=1)
    g = coo_array((w, (a, b)), shape=(v.shape[0],) * 2).tocsr()
    d = csgraph.dijkstra(g, directed=False, indices=seed)

    def chi(limit):
        inside = t[(d[t] <= limit).all(axis=1)]
        return 1 if inside.shape[0] == 0 else _euler(inside)

    levels = np.unique(d[d <= radius])
    detect = next((x for x in levels if chi(x) < 1), None)
    if detect is None:
        return -1.0
    last = levels[levels <= min(radius, detect + margin)].max()
    return float(detect) if chi(last) < 1 else -1.0


@pytest.mark.parametrize("shape", ["torus", "dumbbell"])
def test_grow_matches_the_plain_reference(shape):
    v, t = _surface(_torus(0.06) if shape == "torus" else _dumbbell)
    graph = _graph(v, t)
    seeds = np.arange(0, v.shape[0], 101, dtype=np.int64)
    radius, margin = HANDLE_STEPS * CUT, HANDLE_MARGIN * CUT
    found = _grow_all(seeds, radius, margin, *graph[:5], t, *graph[5:], 4)
    expected = [_grow_reference(v, t, s, radius, margin) for s in seeds]
    assert (found >= 0.0).sum() > 0
    np.testing.assert_allclose(found, expected, rtol=1e-12)


def _one_piece_reference(starts, tri, vt_ptr, vt_idx, removed, ring):
    """Plain `_one_piece`: the pieces of the whole surface after the cut (the
    triangles left, the caps as edges along their loops), every loop in the first
    one's."""
    on = np.flatnonzero(ring >= 0)
    caps = np.stack([on, ring[on], ring[on]], axis=1)
    comp = vertex_pieces(np.vstack([tri[~removed], caps]), vt_ptr.shape[0] - 1)
    return bool(np.all(comp[starts] == comp[starts[0]]))


def _own_loops(starts, ring):
    """The vertices of the loops through ``starts`` along ``ring``."""
    mine = []
    for s in starts:
        u = s
        while True:
            mine.append(u)
            u = ring[u]
            if u == s:
                break
    return mine


def _two_rings_and_a_neck(x, y, z):
    """A ball with two thin rings (handles) and a thin neck to a second ball."""
    ball = np.linalg.norm([x, y + 0.3, z], axis=0) - 0.45
    ring_a = np.hypot(np.hypot(x - 0.5, y + 0.3) - 0.25, z) - 0.05
    ring_b = np.hypot(np.hypot(x + 0.5, y + 0.3) - 0.25, z) - 0.05
    other = np.linalg.norm([x, y - 0.85, z], axis=0) - 0.3
    neck = np.maximum(np.hypot(x, z) - 0.06, np.abs(y - 0.3) - 0.3)
    return np.minimum(np.minimum(ball, other), np.minimum(np.minimum(ring_a, ring_b), neck))


def test_one_piece_and_region_triangles_match_the_plain_pass_over_the_surface(monkeypatch):
    # every candidate of a cut with both answers (two rings cut, the neck's loops
    # kept), and after the first cut with its caps: the search and the pieces of the
    # whole surface agree, and so do the region's triangles and the pass over all
    v, t = _surface(_two_rings_and_a_neck)
    answers = []

    def both(starts, tri, vt_ptr, vt_idx, removed, ring):
        got = _one_piece(starts, tri, vt_ptr, vt_idx, removed, ring)
        assert got == _one_piece_reference(starts, tri, vt_ptr, vt_idx, removed, ring)
        earlier = ring >= 0
        earlier[_own_loops(starts, ring)] = False
        answers.append((got, bool(earlier.any())))
        return got

    def region(inner, mine, tri, vt_ptr, vt_idx):
        got = _region_triangles(inner, mine, tri, vt_ptr, vt_idx)
        assert np.array_equal(got, mine[tri].all(axis=1))
        return got

    monkeypatch.setattr(_handles, "_one_piece", both)
    monkeypatch.setattr(_handles, "_region_triangles", region)
    v2, t2, n_cut = cut_handles(v, t, CUT)
    assert n_cut == 2
    assert _euler(t2) == 2 and all(mesh_checks(v2.shape[0], t2))
    assert (True, True) in answers  # a cut after an earlier one's caps
    assert any(not got for got, _ in answers)  # the neck: a loop that separates

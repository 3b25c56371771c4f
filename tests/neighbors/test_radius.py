"""query_radius / NeighborIndex.radius against the brute-force reference."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from pointatlas.neighbors import NeighborIndex, RadiusNeighbors, query_radius

from .reference import radius_reference

BACKENDS = ["auto", "grid", "kdtree"]


def _clouds():
    rng = np.random.default_rng(11)
    g = np.arange(6.0)
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    sites = rng.random((10, 3))
    return {
        "random": rng.random((300, 3)),
        "grid": grid,
        "duplicates": np.repeat(sites, 8, axis=0)[rng.permutation(80)],
        "plane": np.c_[rng.random((250, 2)), np.zeros(250)],
        "utm": rng.random((200, 3)) * 5.0 + np.array([5e5, 4e6, 100.0]),
    }


CLOUDS = _clouds()


@cache
def _reference(name: str, radius: float):
    return radius_reference(CLOUDS[name], radius)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", list(CLOUDS))
@pytest.mark.parametrize("radius", [0.05, 0.2, 1.0, 1.5, 100.0])
def test_radius_matches_reference(name, radius, backend):
    pts = CLOUDS[name]
    nb = query_radius(pts, radius, backend=backend)
    ref = _reference(name, radius)
    assert isinstance(nb, RadiusNeighbors)
    assert nb.indptr.dtype == np.int64 and nb.indptr.shape == (len(pts) + 1,)
    assert nb.indices.dtype == np.int64 and nb.distances.dtype == np.float64
    np.testing.assert_array_equal(nb.counts, [len(r[0]) for r in ref])
    for i, (row, dist) in enumerate(ref):
        np.testing.assert_array_equal(nb.row(i), row)
        np.testing.assert_array_equal(nb.distances[nb.indptr[i] : nb.indptr[i + 1]], dist)


def test_closed_ball_on_grid():
    # lattice spacing 1 and radius exactly 1: the 6 face neighbours are inside
    pts = CLOUDS["grid"]
    nb = query_radius(pts, 1.0)
    centre = 2 * 36 + 2 * 6 + 2
    assert nb.row(centre).tolist() == [centre, *sorted(centre + d for d in (-36, -6, -1, 1, 6, 36))]
    assert nb.counts[0] == 4  # a corner: itself and three neighbours


def test_radius_rows_start_with_self():
    nb = query_radius(CLOUDS["duplicates"], 0.3)
    for i in range(len(CLOUDS["duplicates"])):
        assert nb.row(i)[0] == i
        d = nb.distances[nb.indptr[i] : nb.indptr[i + 1]]
        assert (np.diff(d) >= 0).all()


def test_radius_huge_gives_everything():
    pts = CLOUDS["random"][:40]
    nb = query_radius(pts, 1e3)
    assert (nb.counts == 40).all()


def test_radius_result_is_readonly():
    nb = query_radius(CLOUDS["random"], 0.1)
    with pytest.raises(ValueError):
        nb.indices[0] = 5


@pytest.mark.parametrize("radius", [0.0, -1.0, np.inf, np.nan])
def test_bad_radius(radius):
    with pytest.raises(ValueError, match=r"radius must be a finite number > 0; got"):
        NeighborIndex(CLOUDS["random"]).radius(radius)


def test_single_point_radius():
    nb = query_radius([[0.0, 0.0, 0.0]], 1.0)
    assert nb.indptr.tolist() == [0, 1] and nb.indices.tolist() == [0]

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas.complex import SurfaceComplex, surface_complex
from pointatlas.neighbors import query_knn
from pointatlas.synth import cube, cylinder, dodecahedron, octahedron

from .reference import q_tuples_reference
from .shapes import plate_with_hole


def _cycle_lengths(K):
    return sorted(c.size for c in K.cycles)


def test_cube_complex_is_dual_to_a_cloud_surface():
    m = cube(8)
    K = surface_complex(m.vertices, m.labels, k=8)
    assert isinstance(K, SurfaceComplex)
    assert K.n_vertices == 8 and K.n_edges == 12 and K.n_cycles == 6
    assert all(len(r) == 3 for r in K.vertex_regions)
    assert _cycle_lengths(K) == [4] * 6
    assert K.is_surface_like and K.is_dual_to_cloud_surface
    # Euler characteristic of the closed genus-0 polyhedron
    assert K.n_vertices - K.n_edges + K.n_cycles == 2
    # every edge separates two regions that both have it in a cycle
    for e, (i, j) in enumerate(K.edge_regions):
        owners = {int(K.cycle_region[c]) for c in range(K.n_cycles) if e in K.cycle_edges[c]}
        assert owners == {int(i), int(j)}


def test_octahedron_has_valence_four_vertices_and_fails_conjecture_4():
    m = octahedron(12)
    K = surface_complex(m.vertices, m.labels, k=8)
    assert K.n_vertices == 6 and K.n_edges == 12 and K.n_cycles == 8
    assert all(len(r) == 4 for r in K.vertex_regions)
    assert K.q_tuples == tuple(sorted(K.vertex_regions))
    assert K.is_surface_like
    assert not K.is_dual_to_cloud_surface
    assert K.vertices_not_triple.tolist() == list(range(6))
    assert K.edges_not_in_two_cycles.size == 0


def test_dodecahedron_complex():
    m = dodecahedron(4)
    K = surface_complex(m.vertices, m.labels)
    assert (K.n_vertices, K.n_edges, K.n_cycles) == (20, 30, 12)
    assert _cycle_lengths(K) == [5] * 12
    assert K.is_dual_to_cloud_surface


def test_plate_with_hole_has_regions_with_two_cycles():
    pts, _, lab = plate_with_hole()
    K = surface_complex(pts, lab, k=8)
    assert K.n_vertices == 16 and K.n_edges == 24
    assert [len(rc) for rc in K.region_cycles] == [2, 2] + [1] * 8
    # Conjecture 4 fails exactly at the two faces with a hole
    assert K.regions_not_one_cycle.tolist() == [0, 1]
    assert K.is_surface_like
    # genus 1 (chi = 0); the two annulus faces have chi = 0 instead of 1 each
    assert K.n_vertices - K.n_edges + K.n_regions == 0 + 2


def test_closed_two_region_boundaries_get_inserted_vertices():
    m = cylinder(n_around=48, n_height=17, capped=True)
    assert int(m.labels.max()) == 2
    K = surface_complex(m.vertices, m.labels, k=8)
    assert K.q_tuples == ()
    assert K.vertex_is_inserted.all() and K.n_vertices == 8
    assert all(len(r) == 2 for r in K.vertex_regions)
    # each cap is bounded by one quadrilateral, the side by two
    assert _cycle_lengths(K) == [4, 4, 4, 4]
    assert sorted(len(rc) for rc in K.region_cycles) == [1, 1, 2]
    assert K.cycles_not_simple.size == 0


def test_two_arcs_between_the_same_regions_stay_apart():
    # a capped cylinder whose side is cut into two halves: the halves meet along two
    # separate vertical lines (two arcs of the same region pair)
    m = cylinder(n_around=48, n_height=17, capped=True)
    side = int(np.bincount(m.labels).argmax())
    lab = m.labels.copy()
    lab[(lab == side) & (m.vertices[:, 0] > 0)] = 3
    lab = np.unique(lab, return_inverse=True)[1].astype(np.int64)
    halves = sorted(
        {
            int(lab[(m.labels == side) & (m.vertices[:, 0] > 0)][0]),
            int(lab[(m.labels == side) & (m.vertices[:, 0] <= 0)][0]),
        }
    )
    K = surface_complex(m.vertices, lab, k=8)
    pairs = [tuple(p) for p in K.arc_regions.tolist()]
    assert pairs.count(tuple(halves)) == 2
    between = [e for e in range(K.n_edges) if tuple(K.edge_regions[e]) == tuple(halves)]
    assert len(between) == 2 and len({int(K.edge_arc[e]) for e in between}) == 2
    assert sum(len(r) == 3 for r in K.vertex_regions) == 4
    assert K.is_surface_like
    assert K.n_vertices - K.n_edges + K.n_cycles == 2


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_regions=st.integers(3, 6))
def test_q_tuples_match_brute_force_eq_3_1(seed, n_regions):
    rng = np.random.default_rng(seed)
    pts = rng.random((60, 3))
    centres = rng.random((n_regions, 3))
    lab = np.argmin(((pts[:, None] - centres[None]) ** 2).sum(-1), axis=1)
    lab = np.unique(lab, return_inverse=True)[1].astype(np.int64)
    idx, _ = query_knn(pts, 6)
    K = surface_complex(pts, lab, k=6, neighbors=idx)
    assert K.q_tuples == q_tuples_reference(lab, idx)
    # every vertex's region set lies inside one Eq. 3.1 tuple
    for regs in K.vertex_regions:
        if len(regs) >= 3:
            assert any(set(regs) <= set(t) for t in K.q_tuples)


def test_seen_sets_are_the_labels_of_the_neighbours():
    m = cube(4)
    idx, _ = query_knn(m.vertices, 8)
    K = surface_complex(m.vertices, m.labels, k=8, neighbors=idx)
    for p in (0, 7, 50):
        assert K.seen(p).tolist() == sorted(set(m.labels[idx[p]].tolist()))
    assert K.seen_regions.dtype == np.int64 and K.seen_indptr.shape == (m.n_vertices + 1,)
    with pytest.raises(ValueError):
        K.edges[0, 0] = 5


def test_bad_input_messages():
    m = cube(2)
    with pytest.raises(ValueError, match="labels"):
        surface_complex(m.vertices, -np.ones(m.n_vertices, dtype=np.int64))
    with pytest.raises(ValueError, match="one entry per point"):
        surface_complex(m.vertices, m.labels[:-1])
    with pytest.raises(ValueError, match="neighbors"):
        surface_complex(m.vertices, m.labels, k=8, neighbors=np.zeros((3, 8), dtype=np.int64))
    with pytest.raises(ValueError, match="neighbors must have shape"):
        surface_complex(m.vertices, m.labels, k=8, neighbors=np.zeros((m.n_vertices, 4), int))
    with pytest.raises(TypeError, match="integer"):
        surface_complex(m.vertices, m.labels, k=8, neighbors=np.zeros((m.n_vertices, 8)))
    with pytest.raises(ValueError, match="points 0..25; got range 26..26"):
        surface_complex(m.vertices, m.labels, k=8, neighbors=np.full((m.n_vertices, 8), 26))
    idx, _ = query_knn(m.vertices, 8)
    with pytest.raises(TypeError, match="not both"):
        surface_complex(m.vertices, m.labels, k=8, neighbors=idx, indices=idx)


def test_neighbour_table_forms_give_the_same_complex():
    # neighbors= takes query_knn's table, its (indices, distances) tuple or a wider
    # table (first k columns); indices=, its former name: tests/test_vocabulary.py
    m = cube(4)
    own = surface_complex(m.vertices, m.labels, k=8)
    idx, dist = query_knn(m.vertices, 12)
    for kwargs in (
        {"neighbors": idx[:, :8]},
        {"neighbors": (idx[:, :8], dist[:, :8])},
        {"neighbors": idx},
    ):
        K = surface_complex(m.vertices, m.labels, k=8, **kwargs)
        assert K.q_tuples == own.q_tuples
        np.testing.assert_array_equal(K.edges, own.edges)
        np.testing.assert_array_equal(K.seen_regions, own.seen_regions)
        assert K.vertex_regions == own.vertex_regions

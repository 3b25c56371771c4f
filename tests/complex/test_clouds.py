"""Cloud sets, the cloud complex (Def. 6, Prop. 1) and its surface report (Defs 7, 8, 13, 14)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas.complex import (
    CloudComplex,
    cloud_complex,
    realize_complex,
    surface_complex,
    surface_report,
)
from pointatlas.synth import cube, icosphere, torus

from .meshes import double_torus_faces, moebius_faces, torus_faces
from .reference import betti_numbers_reference, cloud_simplices_reference


def mesh_clouds(faces: np.ndarray, n_vertices: int):
    """One cloud per mesh vertex holding the vertex, its edge midpoints and barycentres."""
    edges = np.unique(
        np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [0, 2]]]), axis=1),
        axis=0,
    )
    clouds = [[v] for v in range(n_vertices)]
    for e, (a, b) in enumerate(edges.tolist()):
        clouds[a].append(n_vertices + e)
        clouds[b].append(n_vertices + e)
    base = n_vertices + edges.shape[0]
    for t, tri in enumerate(faces.tolist()):
        for v in tri:
            clouds[v].append(base + t)
    return clouds, edges, base + faces.shape[0]


KNOWN = {
    "sphere": (icosphere(1).faces, 2, True, 0),
    "torus": (torus_faces(), 0, True, 1),
    "double torus": (double_torus_faces(), -2, True, 2),
}


@pytest.mark.parametrize("name", sorted(KNOWN))
def test_complex_of_a_meshs_clouds_equals_the_mesh(name):
    faces, chi, orientable, genus = KNOWN[name]
    nv = int(faces.max()) + 1
    clouds, edges, n = mesh_clouds(faces, nv)
    K = cloud_complex(clouds, n_points=n)
    assert K.edges.tolist() == edges.tolist()
    assert K.triangles.tolist() == np.unique(np.sort(faces, axis=1), axis=0).tolist()
    assert K.dimension == 2 and K.simplices_above_2 == ()
    r = surface_report(K)
    assert r.is_cloud_surface and r.is_closed
    assert (r.euler_characteristic, r.is_orientable, r.genus) == (chi, orientable, genus)
    assert r.n_components == 1 and r.n_boundary_loops == 0
    # the same numbers from the triangles directly
    r2 = surface_report(faces)
    assert (r2.euler_characteristic, r2.genus) == (chi, genus)


def test_moebius_strip_is_found_non_orientable():
    faces = moebius_faces(8)
    clouds, _, n = mesh_clouds(faces, 16)
    r = surface_report(cloud_complex(clouds, n_points=n))
    assert r.is_cloud_surface and not r.is_closed
    assert not r.is_orientable and r.incoherent_faces.shape[0] >= 1
    assert r.n_boundary_loops == 1 and r.boundary_loops[0].size == 16
    assert r.euler_characteristic == 0 and r.genus == 1  # one cross-cap


def test_orientable_cylinder_has_two_boundary_loops():
    faces = moebius_faces(8)
    faces[-2:] = [[7, 15, 8], [7, 8, 0]]  # no twist: an annulus
    r = surface_report(faces)
    assert r.is_orientable and r.n_boundary_loops == 2 and r.genus == 0
    assert sorted(b.size for b in r.boundary_loops) == [8, 8]


def test_four_clouds_meeting_are_reported():
    faces = icosphere(1).faces
    clouds, _, n = mesh_clouds(faces, int(faces.max()) + 1)
    a, b, c = faces[0].tolist()
    d = int(faces[5][0]) if int(faces[5][0]) not in (a, b, c) else int(faces[5][1])
    for v in (a, b, c, d):
        clouds[v].append(n)  # one extra point in four clouds
    K = cloud_complex(clouds, n_points=n + 1)
    assert K.dimension == 3 and K.simplices_above_2 == (tuple(sorted((a, b, c, d))),)
    r = surface_report(K)
    assert r.simplices_above_2 == (tuple(sorted((a, b, c, d))),)
    assert not r.is_cloud_surface


def test_edge_in_three_triangles_is_reported():
    # three triangles on the edge (0, 1): a "book" with three pages
    faces = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    clouds, _, n = mesh_clouds(faces, 5)
    r = surface_report(cloud_complex(clouds, n_points=n))
    assert r.edges_in_many_faces.tolist() == [[0, 1]]
    assert r.vertices_not_fan.size == 0  # the three pages at 0 still chain through (0, 1)
    assert not r.is_surface and not r.is_orientable


def test_pinched_vertex_is_reported():
    # two tetrahedron surfaces sharing vertex 0 only
    t1 = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    t2 = np.array([[0, 4, 5], [0, 6, 4], [0, 5, 6], [4, 6, 5]])
    clouds, _, n = mesh_clouds(np.concatenate([t1, t2]), 7)
    r = surface_report(cloud_complex(clouds, n_points=n))
    assert r.vertices_not_fan.tolist() == [0]
    assert r.edges_in_many_faces.shape[0] == 0 and r.vertices_not_in_face.size == 0
    assert not r.is_surface and r.genus is None
    assert r.n_components == 1 and r.euler_characteristic == 3


def test_edge_outside_triangles_and_lonely_vertex_are_reported():
    faces = icosphere(0).faces
    clouds, _, n = mesh_clouds(faces, 12)
    clouds.append([0, n])  # a 13th cloud touching only vertex point 0 -> edge (0, 12)
    clouds.append([n + 1])  # a 14th cloud alone
    r = surface_report(cloud_complex(clouds, n_points=n + 2))
    assert r.edges_not_in_face.tolist() == [[0, 12]]
    assert r.vertices_not_in_face.tolist() == [12, 13]
    assert r.n_components == 2 and not r.is_cloud_surface


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_clouds=st.integers(1, 8))
def test_cloud_complex_matches_definition_6(seed, n_clouds):
    rng = np.random.default_rng(seed)
    n = 30
    clouds = [rng.choice(n, size=rng.integers(0, 10), replace=False) for _ in range(n_clouds)]
    K = cloud_complex(clouds, n_points=n)
    ref = cloud_simplices_reference(clouds, max_size=n_clouds)
    assert K.edges.tolist() == [list(t) for t in ref[2]] if n_clouds >= 2 else True
    if n_clouds >= 3:
        assert K.triangles.tolist() == [list(t) for t in ref[3]]
    top = max((s for s in ref if ref[s]), default=0)
    assert K.dimension == top - 1
    # membership both ways agree
    for p in range(n):
        assert K.clouds_of(p).tolist() == [c for c in range(n_clouds) if p in set(clouds[c])]
    assert K.uncovered_points.tolist() == [p for p in range(n) if K.n_memberships[p] == 0]


def test_membership_shapes_dtypes_and_read_only():
    pts = np.random.default_rng(0).random((6, 3))
    K = cloud_complex([[0, 1, 2], [2, 3], [3, 4, 5, 5]], pts)
    assert isinstance(K, CloudComplex)
    assert K.n_memberships.dtype == np.int64 and K.n_memberships.shape == (6,)
    assert K.cloud_points.shape == (3, 3) and K.cloud_points.dtype == np.float64
    np.testing.assert_allclose(K.cloud_points[2], pts[3:6].mean(axis=0), rtol=0, atol=1e-15)
    assert K.cloud(2).tolist() == [3, 4, 5]
    with pytest.raises(ValueError):
        K.edges[0, 0] = 5


def _gudhi_betti(K):
    gudhi = pytest.importorskip("gudhi")
    st_ = gudhi.SimplexTree()
    for c in range(K.n_clouds):
        if K.cloud(c).size:
            st_.insert([c])
    for e in K.edges.tolist():
        st_.insert(e)
    for t in K.triangles.tolist():
        st_.insert(t)
    st_.compute_persistence(persistence_dim_max=True)
    b = st_.betti_numbers() + [0, 0, 0]
    return b[0], b[1], b[2]


def _covers_for_betti():
    from pointatlas.cover import ball_cover

    for name, faces in (
        ("sphere", icosphere(1).faces),
        ("torus", torus_faces()),
        ("double torus", double_torus_faces()),
        ("moebius", moebius_faces(8)),
    ):
        clouds, _, n = mesh_clouds(faces, int(faces.max()) + 1)
        yield name, cloud_complex(clouds, n_points=n)
    tor = torus(n_major=48, n_minor=24)
    for s in (0.15, 0.2, 0.3):
        yield f"torus cover s={s}", ball_cover(tor.vertices, s).cloud_complex


@pytest.mark.parametrize("case", list(range(7)))
def test_topology_agrees_with_gudhi_betti_numbers(case):
    name, K = list(_covers_for_betti())[case]
    r = surface_report(K)
    b0, b1, b2 = _gudhi_betti(K)
    # the independent plain-numpy rank computation agrees with gudhi too
    assert betti_numbers_reference(K.triangles, K.edges, K.n_clouds) == (b0, b1, b2), name
    assert r.euler_characteristic == b0 - b1 + b2, name
    assert r.n_components == b0, name
    if r.is_closed:
        assert (b2 == r.n_components) == r.is_orientable, name
        if r.is_orientable and r.n_components == 1:
            assert b1 == 2 * r.genus, name


def test_realisation_is_coherently_oriented_and_outward():
    m = icosphere(2)
    clouds, _, n = mesh_clouds(m.faces, m.vertices.shape[0])
    K = cloud_complex(clouds, n_points=n, cloud_points=m.vertices)
    v, f = realize_complex(K)
    directed = {(int(a), int(b)) for t in f for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))}
    assert len(directed) == 3 * f.shape[0]  # every directed edge once: coherent
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    assert (np.einsum("ij,ij->i", np.cross(b - a, c - a), a + b + c) > 0).all()  # outward


def test_report_of_the_surface_like_complex_shares_the_checks():
    m = cube(6)
    Kp = surface_complex(m.vertices, m.labels, k=8)
    r = surface_report(Kp)
    assert r.is_closed and r.euler_characteristic == 2 and r.is_orientable and r.genus == 0
    assert r.vertices_not_fan.tolist() == Kp.vertices_not_fan.tolist() == []
    assert r.n_faces == Kp.n_cycles


def test_summary_and_table_name_every_condition():
    r = surface_report(moebius_faces(8))
    s = r.summary()
    assert s["is_orientable"] is False and len(s["conditions"]["def14_incoherent_faces"]) >= 1
    assert "def7_iii_vertices_not_fan" in r.table()


def test_bad_input_messages():
    with pytest.raises(ValueError, match=r"clouds\[1\] must hold indices in \[0, 3\)"):
        cloud_complex([[0], [5]], n_points=3)
    with pytest.raises(TypeError, match=r"clouds\[0\] must hold integer point indices"):
        cloud_complex([[0.5]], n_points=3)
    with pytest.raises(TypeError, match="clouds must be a sequence"):
        cloud_complex(3)
    with pytest.raises(ValueError, match=r"cloud_points must have shape \(2, 3\)"):
        cloud_complex([[0], [1]], n_points=2, cloud_points=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"faces must have shape \(F, 3\)"):
        surface_report(np.zeros((2, 4), dtype=int))
    with pytest.raises(ValueError, match="three distinct vertices"):
        surface_report([[0, 0, 1]])
    with pytest.raises(TypeError, match="CloudComplex"):
        realize_complex(np.zeros((1, 3)))

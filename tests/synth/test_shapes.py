"""Shapes: vertex counts, closed consistently oriented manifolds, exact normals, labels."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pointatlas._core import PointSet
from pointatlas.synth import (
    SynthMesh,
    cube,
    cylinder,
    dodecahedron,
    face_areas,
    fibonacci_sphere,
    icosphere,
    line,
    octahedron,
    plane_patch,
    sphere,
    torus,
    vertex_normals,
)

from .reference import area_weighted_normals, edge_counts, signed_volume

PHI = (1 + np.sqrt(5)) / 2

CLOSED = {
    "cube": lambda: cube(5),
    "cube_odd": lambda: cube(3),
    "icosphere": lambda: icosphere(2),
    "fibonacci": lambda: fibonacci_sphere(500),
    "torus": lambda: torus(1.0, 0.3, n_major=24, n_minor=12),
    "octahedron": lambda: octahedron(5),
    "dodecahedron": lambda: dodecahedron(3),
    "cylinder_capped": lambda: cylinder(n_around=20, n_height=6, capped=True),
}


@pytest.mark.parametrize(
    ("make", "n_vertices"),
    [
        (lambda: cube(8), 386),
        (lambda: cube(16), 1538),
        (lambda: cube(18), 1946),
        (lambda: icosphere(4), 2562),
        (lambda: icosphere(5), 10242),
        (lambda: sphere(2562), 2562),
        (lambda: sphere(5122), 5122),
        (lambda: dodecahedron(4), 962),
        (lambda: dodecahedron(8), 3842),
        (lambda: octahedron(64), 16386),
        (lambda: plane_patch(65, 65), 4225),
        (lambda: fibonacci_sphere(1234), 1234),
        (lambda: torus(n_major=10, n_minor=7), 70),
    ],
)
def test_vertex_counts(make, n_vertices):
    mesh = make()
    assert mesh.n_vertices == n_vertices
    assert mesh.vertices.shape == (n_vertices, 3) and mesh.vertices.dtype == np.float64
    assert mesh.faces.dtype == np.int64 and mesh.faces.shape[1] == 3
    assert str(n_vertices) in mesh.name


@pytest.mark.parametrize("n", [1, 2, 3, 4, 7])
def test_cube_formula(n):
    mesh = cube(n)
    assert mesh.n_vertices == 6 * n * n + 2
    assert mesh.n_faces == 12 * n * n


@pytest.mark.parametrize("f", [1, 2, 3, 6])
def test_polyhedron_formulas(f):
    assert octahedron(f).n_vertices == 4 * f * f + 2
    assert dodecahedron(f).n_vertices == 60 * f * f + 2
    assert icosphere(f).n_vertices == 10 * 4**f + 2


@pytest.mark.parametrize("name", sorted(CLOSED))
def test_closed_oriented_manifold(name):
    mesh = CLOSED[name]()
    undirected, directed = edge_counts(mesh.faces)
    assert set(undirected.values()) == {2}, "every edge in exactly two triangles"
    assert set(directed.values()) == {1}, "neighbours traverse a shared edge oppositely"
    euler = mesh.n_vertices - len(undirected) + mesh.n_faces
    assert euler == (0 if name == "torus" else 2)
    assert np.unique(mesh.faces).size == mesh.n_vertices, "every vertex used"
    nearest, _ = cKDTree(mesh.vertices).query(mesh.vertices, k=2)
    assert nearest[:, 1].min() > 1e-6, "no duplicated vertices"
    assert signed_volume(mesh.vertices, mesh.faces) > 0, "outward orientation"
    assert face_areas(mesh.vertices, mesh.faces).min() > 0


@pytest.mark.parametrize(
    ("mesh", "volume", "rtol"),
    [
        (cube(4, size=2.0), 8.0, 1e-12),
        (octahedron(3, radius=2.0), 4 / 3 * 8, 1e-12),
        # circumradius 1: edge a = 4 / (sqrt 3 (1 + sqrt 5)), V = (15 + 7 sqrt 5) / 4 a^3
        (
            dodecahedron(2),
            (15 + 7 * np.sqrt(5)) / 4 * (4 / (np.sqrt(3) * (1 + np.sqrt(5)))) ** 3,
            1e-12,
        ),
        (icosphere(4), 4 / 3 * np.pi, 5e-3),
        (torus(1.0, 0.25, n_major=64, n_minor=32), 2 * np.pi**2 * 0.25**2, 1e-2),
        (cylinder(1.0, 2.0, n_around=64, n_height=5, capped=True), 2 * np.pi, 5e-3),
    ],
)
def test_volumes(mesh, volume, rtol):
    assert signed_volume(mesh.vertices, mesh.faces) == pytest.approx(volume, rel=rtol)


def test_open_meshes_have_boundary():
    for mesh in (plane_patch(6, 4), cylinder(n_around=10, n_height=4)):
        undirected, directed = edge_counts(mesh.faces)
        assert set(undirected.values()) == {1, 2}
        assert set(directed.values()) == {1}
    plane = plane_patch(6, 4)
    boundary = sum(1 for c in edge_counts(plane.faces)[0].values() if c == 1)
    assert boundary == 2 * (5 + 3)


@pytest.mark.parametrize("name", sorted(CLOSED))
def test_normals_unit_and_close_to_mesh_normals(name):
    mesh = CLOSED[name]()
    assert mesh.normals.shape == mesh.vertices.shape
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-12)
    # exact normals agree with the mesh's own vertex normals (coarse meshes: loosely)
    dots = np.einsum("ij,ij->i", mesh.normals, vertex_normals(mesh.vertices, mesh.faces))
    assert dots.min() > 0.98


@pytest.mark.parametrize("n", [2, 8, 16])
def test_cube_normals_exact(n):
    mesh = cube(n, size=3.0)
    v, nrm, lab = mesh.vertices, mesh.normals, mesh.labels
    on_bound = np.isclose(np.abs(v), 1.5)
    n_planes = on_bound.sum(axis=1)
    np.testing.assert_array_equal(mesh.is_sharp, n_planes >= 2)
    assert mesh.is_sharp.sum() == 12 * (n - 1) + 8
    # face interiors: the axis direction of the face
    inner = n_planes == 1
    np.testing.assert_array_equal(nrm[inner], np.sign(v[inner]) * on_bound[inner])
    axis = lab // 2
    sign = np.where(lab % 2 == 1, 1.0, -1.0)
    np.testing.assert_array_equal(v[np.arange(len(v)), axis], sign * 1.5)
    # sharp vertices: the area-weighted normal, which the symmetric split makes the
    # exact bisector (edges) or (+-1, +-1, +-1)/sqrt 3 (corners)
    sharp = mesh.is_sharp
    np.testing.assert_allclose(nrm[sharp], area_weighted_normals(v, mesh.faces)[sharp], atol=1e-12)
    expected = np.sign(v) * on_bound
    expected /= np.linalg.norm(expected, axis=1, keepdims=True)
    np.testing.assert_allclose(nrm[sharp], expected[sharp], atol=1e-12)
    assert np.bincount(lab[inner]).tolist() == [(n - 1) ** 2] * 6


def test_cube_face_labels_match_face_normals():
    mesh = cube(4)
    v, f = mesh.vertices, mesh.faces
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    unit = cross / np.linalg.norm(cross, axis=1, keepdims=True)
    axis, sign = mesh.face_labels // 2, np.where(mesh.face_labels % 2 == 1, 1.0, -1.0)
    expected = np.zeros_like(unit)
    expected[np.arange(len(f)), axis] = sign
    np.testing.assert_allclose(unit, expected, atol=1e-12)
    assert np.bincount(mesh.face_labels).tolist() == [32] * 6


def test_sphere_normals_are_positions():
    for mesh in (icosphere(3, radius=2.5), fibonacci_sphere(777, radius=2.5)):
        np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 2.5, rtol=1e-12)
        np.testing.assert_allclose(mesh.normals, mesh.vertices / 2.5, atol=1e-12)
        assert not mesh.is_sharp.any() and mesh.labels is None


def test_fibonacci_without_faces():
    mesh = fibonacci_sphere(50, triangulate=False)
    assert mesh.faces.shape == (0, 3)
    np.testing.assert_array_equal(mesh.vertices, fibonacci_sphere(50).vertices)


def test_torus_normals_analytic():
    big, small = 2.0, 0.5
    mesh = torus(big, small, n_major=20, n_minor=10)
    v = mesh.vertices
    ring = np.c_[v[:, :2], np.zeros(len(v))]
    ring = big * ring / np.linalg.norm(ring, axis=1, keepdims=True)
    np.testing.assert_allclose(np.linalg.norm(v - ring, axis=1), small, rtol=1e-12)
    np.testing.assert_allclose(mesh.normals, (v - ring) / small, atol=1e-12)


@pytest.mark.parametrize(
    ("make", "n_labels", "inradius"),
    [
        (lambda: octahedron(6, radius=2.0), 8, 2.0 / np.sqrt(3)),
        # inradius / circumradius of the dodecahedron = phi^2 / (sqrt 3 * sqrt(1 + phi^2))
        (lambda: dodecahedron(5), 12, PHI**2 / (np.sqrt(3) * np.sqrt(1 + PHI**2))),
    ],
)
def test_polyhedron_planes_and_labels(make, n_labels, inradius):
    mesh = make()
    v, f, flab = mesh.vertices, mesh.faces, mesh.face_labels
    assert sorted(np.unique(flab).tolist()) == list(range(n_labels))
    assert sorted(np.unique(mesh.labels).tolist()) == list(range(n_labels))
    # each planar face's normal (from a non-sharp vertex) puts all its vertices at the
    # inradius: the triangles of a label are coplanar and the normals exact
    for label in range(n_labels):
        inner = (mesh.labels == label) & ~mesh.is_sharp
        normal = mesh.normals[inner][0]
        np.testing.assert_allclose(
            mesh.normals[inner], np.tile(normal, (inner.sum(), 1)), atol=1e-12
        )
        corners = v[np.unique(f[flab == label])]
        np.testing.assert_allclose(corners @ normal, inradius, rtol=1e-12)
    # sharp vertices are exactly those on two or more planar faces
    touch = np.zeros((len(v), n_labels), dtype=bool)
    for c in range(3):
        touch[f[:, c], flab] = True
    np.testing.assert_array_equal(mesh.is_sharp, touch.sum(axis=1) >= 2)
    np.testing.assert_array_equal(mesh.labels, np.argmax(touch, axis=1))
    sharp = mesh.is_sharp
    np.testing.assert_allclose(mesh.normals[sharp], area_weighted_normals(v, f)[sharp], atol=1e-12)


def test_dodecahedron_regular():
    mesh = dodecahedron(1)
    corners = mesh.vertices[mesh.is_sharp & (np.bincount(mesh.faces.ravel()) == 6)]
    assert corners.shape == (20, 3)
    np.testing.assert_allclose(np.linalg.norm(corners, axis=1), 1.0, rtol=1e-12)
    d = np.linalg.norm(corners[:, None] - corners[None], axis=2)
    edge = np.sort(d, axis=1)[:, 1:4]
    np.testing.assert_allclose(edge, 4 / (np.sqrt(3) * (1 + np.sqrt(5))), rtol=1e-12)
    # each pentagon has area 1/12 of the surface and its ten triangles' areas sum up
    areas = np.bincount(mesh.face_labels, weights=face_areas(mesh.vertices, mesh.faces))
    np.testing.assert_allclose(areas, areas.mean(), rtol=1e-12)


def test_cylinder_normals():
    mesh = cylinder(2.0, 3.0, n_around=16, n_height=5, capped=True, n_radial=3)
    v, nrm = mesh.vertices, mesh.normals
    side = (mesh.labels == 0) & ~mesh.is_sharp
    np.testing.assert_allclose(np.hypot(v[side, 0], v[side, 1]), 2.0, rtol=1e-12)
    np.testing.assert_allclose(
        nrm[side], np.c_[v[side, :2] / 2.0, np.zeros(side.sum())], atol=1e-12
    )
    for label, z in ((1, -1.5), (2, 1.5)):
        cap = mesh.labels == label
        np.testing.assert_allclose(v[cap, 2], z)
        np.testing.assert_allclose(nrm[cap], np.tile([0, 0, np.sign(z)], (cap.sum(), 1)))
    assert mesh.is_sharp.sum() == 32
    assert (np.abs(v[mesh.is_sharp, 2]) == 1.5).all()
    open_mesh = cylinder(2.0, 3.0, n_around=16, n_height=5)
    assert not open_mesh.is_sharp.any() and set(open_mesh.labels.tolist()) == {0}


def test_plane_patch():
    mesh = plane_patch(200, 3, width=10.0, height=0.1)
    assert mesh.n_vertices == 600 and mesh.n_faces == 2 * 199 * 2
    assert np.ptp(mesh.vertices[:, 0]) == pytest.approx(10.0)
    assert np.ptp(mesh.vertices[:, 1]) == pytest.approx(0.1)
    np.testing.assert_array_equal(mesh.vertices[:, 2], 0.0)
    np.testing.assert_array_equal(mesh.normals, np.tile([0.0, 0.0, 1.0], (600, 1)))
    v, f = mesh.vertices, mesh.faces
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert (cross[:, 2] > 0).all(), "triangles face +z"


def test_line():
    ps = line(11, start=(1, 1, 1), end=(1, 1, 3))
    assert isinstance(ps, PointSet) and not ps.has_normals
    np.testing.assert_allclose(ps.points[:, 2], np.linspace(1, 3, 11))
    a = line(50, jitter=0.01, rng=3)
    b = line(50, jitter=0.01, rng=3)
    np.testing.assert_array_equal(a.points, b.points)
    assert not np.array_equal(a.points, line(50, jitter=0.01, rng=4).points)
    dev = a.points - line(50).points
    assert 0 < np.abs(dev).max() < 0.01 * (1 / 49) * 6


def test_to_point_set_and_readonly():
    mesh = dodecahedron(2)
    ps = mesh.to_point_set()
    assert isinstance(ps, PointSet)
    np.testing.assert_array_equal(ps.points, mesh.points)
    np.testing.assert_allclose(ps.normals, mesh.normals, atol=1e-15)
    np.testing.assert_array_equal(ps.attributes["labels"], mesh.labels)
    np.testing.assert_array_equal(ps.attributes["is_sharp"], mesh.is_sharp)
    assert ps.name == "dodecahedron_242"
    for arr in (mesh.vertices, mesh.faces, mesh.normals, mesh.labels, mesh.face_labels):
        assert not arr.flags.writeable
    with pytest.raises(AttributeError):
        mesh.name = "x"


def test_shapes_deterministic():
    for make in CLOSED.values():
        a, b = make(), make()
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)


def test_synthmesh_validation():
    v = np.eye(3)
    with pytest.raises(ValueError, match="faces must index"):
        SynthMesh(v, [[0, 1, 3]], v)
    with pytest.raises(ValueError, match=r"faces must have shape \(F, 3\)"):
        SynthMesh(v, [[0, 1]], v)
    with pytest.raises(ValueError, match="labels must have shape"):
        SynthMesh(v, [[0, 1, 2]], v, labels=[0, 1])
    with pytest.raises(ValueError, match="zero-length"):
        SynthMesh(v, [[0, 1, 2]], np.zeros((3, 3)))


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: cube(0), ValueError, "n must be >= 1"),
        (lambda: cube(2.5), TypeError, "n must be an integer"),
        (lambda: cube(2, size=-1), ValueError, "size must be a positive"),
        (lambda: icosphere(10), ValueError, "subdivisions must be <= 9"),
        (lambda: torus(1.0, 1.0), ValueError, "minor_radius must be smaller"),
        (lambda: fibonacci_sphere(3), ValueError, "n_points must be >= 4"),
        (lambda: plane_patch(1, 5), ValueError, "n_u must be >= 2"),
        (lambda: cylinder(n_height=1), ValueError, "n_height must be >= 2"),
        (lambda: line(5, start=(0, 0, 0), end=(0, 0, 0)), ValueError, "start and end must"),
        (lambda: line(5, jitter=-1), ValueError, "jitter must be"),
        (lambda: dodecahedron(1, radius=np.nan), ValueError, "radius must be a positive"),
    ],
)
def test_bad_arguments(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_vertex_normals_is_the_io_function():
    import pointatlas.io

    assert vertex_normals is pointatlas.io.vertex_normals


@pytest.mark.parametrize("name", sorted(CLOSED))
def test_sharp_vertex_normals_agree_with_the_public_function_to_the_last_bits(name):
    # the generated models keep their own summation order (synth._mesh._vertex_normals);
    # it may differ from io.vertex_normals by a few ulps, never more
    from pointatlas.synth._mesh import _vertex_normals

    mesh = CLOSED[name]()
    ours = _vertex_normals(mesh.vertices, mesh.faces)
    public = vertex_normals(mesh.vertices, mesh.faces)
    np.testing.assert_allclose(ours, public, rtol=0, atol=4 * np.finfo(float).eps)
    np.testing.assert_allclose(ours, area_weighted_normals(mesh.vertices, mesh.faces), atol=1e-14)

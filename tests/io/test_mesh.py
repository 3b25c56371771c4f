"""Mesh container, fan triangulation and area-weighted vertex normals."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas import PointAtlasError
from pointatlas.io import Mesh, fan_triangulate, vertex_normals

from ..strategies import rigid_motions, seeds
from .reference import newell_area, vertex_normals_loop


def test_mesh_layout_and_triangles(mixed_mesh):
    v, faces = mixed_mesh
    m = Mesh(v, faces)
    assert m.faces.dtype == np.int64 and m.face_offsets.dtype == np.int64
    assert m.face_offsets.tolist() == [0, 4, 7, 10, 13, 16]
    assert m.face_sizes.tolist() == [4, 3, 3, 3, 3]
    assert not m.is_triangular
    assert m.triangles.tolist()[:2] == [[0, 3, 2], [0, 2, 1]]
    assert [f.tolist() for f in m.face_list()] == faces
    assert m.face(0).tolist() == faces[0]
    assert not m.vertices.flags.writeable and not m.faces.flags.writeable


def test_mesh_accepts_flat_and_rectangular_faces(mixed_mesh):
    v, faces = mixed_mesh
    m = Mesh(v, faces)
    again = Mesh(v, m.faces, m.face_offsets)
    np.testing.assert_array_equal(again.faces, m.faces)
    tri = Mesh(v, np.array(faces[1:]))
    assert tri.is_triangular and tri.n_faces == 4


@pytest.mark.parametrize(
    ("faces", "offsets", "match"),
    [
        ([[0, 1]], None, "at least 3"),
        ([[0, 1, 7]], None, "outside"),
        ([[0, -1, 2]], None, "outside"),
        ([0, 1, 2], [0, 2], "end at len"),
        ([[0.5, 1, 2]], None, "integer"),
    ],
)
def test_mesh_rejects_bad_faces(faces, offsets, match):
    with pytest.raises(PointAtlasError, match=match):
        Mesh(np.eye(3), faces, offsets)


def test_mesh_rejects_nonfinite_vertices():
    with pytest.raises(PointAtlasError, match="non-finite"):
        Mesh([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


def test_fan_triangulate_counts():
    tri, src = fan_triangulate(np.arange(12), [0, 3, 7, 12])
    assert tri.shape == (6, 3) and src.tolist() == [0, 1, 1, 2, 2, 2]
    assert tri[-1].tolist() == [7, 10, 11]


def test_vertex_normals_cube_corners(cube_quads):
    v, faces = cube_quads
    n = vertex_normals(v, faces)
    expected = (v - 0.5) / np.linalg.norm(v - 0.5, axis=1, keepdims=True)
    np.testing.assert_allclose(n, expected, atol=1e-15)


def test_vertex_normals_match_loop_reference(mixed_mesh):
    v, faces = mixed_mesh
    np.testing.assert_allclose(vertex_normals(v, faces), vertex_normals_loop(v, faces), atol=1e-14)


def test_polygon_area_is_newell_vector():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(6, 3))
    face = [0, 1, 2, 3, 4, 5]
    raw = vertex_normals(v, [face], normalize=False)
    np.testing.assert_allclose(raw[0], newell_area(v, face), atol=1e-12)
    rotated = vertex_normals(v, [face[2:] + face[:2]], normalize=False)
    np.testing.assert_allclose(rotated[0], raw[0], atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(seed=seeds(), n_faces=st.integers(1, 30))
def test_vertex_normals_random_polygons(seed, n_faces):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(20, 3))
    faces = [list(rng.choice(20, size=rng.integers(3, 7), replace=False)) for _ in range(n_faces)]
    got = vertex_normals(v, faces)
    ref = vertex_normals_loop(v, faces)
    np.testing.assert_array_equal(np.isnan(got[:, 0]), np.isnan(ref[:, 0]))
    ok = ~np.isnan(ref[:, 0])
    np.testing.assert_allclose(got[ok], ref[ok], atol=1e-10)


@settings(max_examples=15, deadline=None)
@given(motion=rigid_motions())
def test_vertex_normals_rotate_with_the_mesh(cube_quads, motion):
    r, t = motion
    v, faces = cube_quads
    np.testing.assert_allclose(
        vertex_normals(v @ r.T + t, faces), vertex_normals(v, faces) @ r.T, atol=1e-12
    )


def test_undefined_normals_are_nan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5], [2, 0, 0]], dtype=float)
    # vertex 3 unreferenced; vertex 4 only on a zero-area (collinear) face
    n = vertex_normals(v, [[0, 1, 2], [0, 1, 4]])
    assert np.isnan(n[3]).all() and np.isnan(n[4]).all()
    np.testing.assert_allclose(n[:3], [[0, 0, 1]] * 3)


def test_cancelling_faces_give_nan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    n = vertex_normals(v, [[0, 1, 2], [0, 2, 1]])
    assert np.isnan(n).all()

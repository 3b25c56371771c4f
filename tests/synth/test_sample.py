"""Area-weighted mesh sampling."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pointatlas.synth import MeshSample, cube, dodecahedron, face_areas, sample_mesh

from ..strategies import seeds
from .reference import barycentric


def test_samples_lie_on_their_triangles():
    mesh = dodecahedron(2)
    pts, nrm, face = sample_mesh(mesh.vertices, mesh.faces, 5000, rng=1)
    assert pts.shape == (5000, 3) and nrm.shape == (5000, 3) and face.shape == (5000,)
    assert pts.dtype == np.float64 and face.dtype == np.int64
    tri = mesh.vertices[mesh.faces[face]]
    weights, dist = barycentric(pts, tri[:, 0], tri[:, 1], tri[:, 2])
    np.testing.assert_allclose(dist, 0.0, atol=1e-12)
    assert weights.min() > -1e-12 and weights.max() < 1 + 1e-12
    # normals: the unit outward normal of the sampled triangle
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(nrm, cross / np.linalg.norm(cross, axis=1, keepdims=True))
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0)


def test_area_weighting_and_uniformity():
    # two triangles with areas 1/2 and 3/2
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [3, 0, 0], [0, 3, 0]], dtype=float)
    faces = np.array([[0, 1, 2], [1, 3, 4]])
    areas = face_areas(v, faces)
    n = 40000
    pts, _, face = sample_mesh(v, faces, n, rng=7)
    frac = np.bincount(face, minlength=2) / n
    expected = areas / areas.sum()
    # binomial standard error ~ 0.0022; 5 sigma
    np.testing.assert_allclose(frac, expected, atol=0.011)
    # uniform on a triangle: the sample mean is the centroid
    first = pts[face == 0]
    np.testing.assert_allclose(first.mean(axis=0), v[[0, 1, 2]].mean(axis=0), atol=0.01)
    # and the fraction in the sub-triangle near corner 0 with half the edge is 1/4
    near = (first[:, 0] + first[:, 1]) < 0.5
    assert near.mean() == pytest.approx(0.25, abs=0.02)


def test_degenerate_faces_never_drawn():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    faces = np.array([[0, 1, 3], [0, 1, 2], [1, 3, 0]])  # first and last have area 0
    _, _, face = sample_mesh(v, faces, 2000, rng=0)
    assert set(face.tolist()) == {1}


def test_deterministic_and_unpackable():
    mesh = cube(3)
    a = sample_mesh(mesh.vertices, mesh.faces, 300, rng=42)
    b = sample_mesh(mesh.vertices, mesh.faces, 300, rng=np.random.default_rng(42))
    assert isinstance(a, MeshSample)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    c = sample_mesh(mesh.vertices, mesh.faces, 300, rng=43)
    assert not np.array_equal(a.points, c.points)
    assert not a.points.flags.writeable
    assert sample_mesh(mesh.vertices, mesh.faces, 0, rng=0).points.shape == (0, 3)


def test_inputs_not_modified():
    mesh = cube(2)
    v = np.array(mesh.vertices)
    f = np.array(mesh.faces)
    sample_mesh(v, f, 10, rng=0)
    np.testing.assert_array_equal(v, mesh.vertices)
    np.testing.assert_array_equal(f, mesh.faces)


@pytest.mark.parametrize(
    ("vertices", "faces", "n", "error", "match"),
    [
        (np.eye(3), [[0, 1, 2]], -1, ValueError, "n_points must be >= 0"),
        (np.eye(3), [[0, 1, 2]], 2.0, TypeError, "n_points must be an integer"),
        (np.eye(3), [[0, 1, 5]], 2, ValueError, "faces must index"),
        (np.eye(3), [[0.5, 1, 2]], 2, ValueError, "integer vertex indices"),
        (np.zeros((3, 3)), [[0, 1, 2]], 2, ValueError, "total area 0"),
        (np.eye(3), np.zeros((0, 3), dtype=int), 2, ValueError, "total area 0"),
        (np.eye(3)[:, :2], [[0, 1, 2]], 2, ValueError, r"vertices must have shape \(N, 3\)"),
    ],
)
def test_bad_input(vertices, faces, n, error, match):
    with pytest.raises(error, match=match):
        sample_mesh(vertices, faces, n, rng=0)


@settings(max_examples=25, deadline=None)
@given(seed=seeds(), frequency=st.integers(min_value=1, max_value=4), n=st.integers(0, 200))
def test_samples_on_mesh_for_any_seed(seed, frequency, n):
    mesh = dodecahedron(frequency)
    pts, nrm, face = sample_mesh(mesh.vertices, mesh.faces, n, rng=seed)
    assert pts.shape == (n, 3) and face.shape == (n,)
    tri = mesh.vertices[mesh.faces[face]]
    weights, dist = barycentric(pts, tri[:, 0], tri[:, 1], tri[:, 2])
    assert np.all(np.abs(dist) < 1e-12)
    assert np.all(weights > -1e-12)
    # points lie on the face of their label: at the inradius along its normal
    labels = mesh.face_labels[face]
    normal_of_label = np.array(
        [mesh.normals[(mesh.labels == k) & ~mesh.is_sharp][0] for k in range(12)]
    )
    heights = np.einsum("ij,ij->i", pts, normal_of_label[labels])
    np.testing.assert_allclose(heights, heights.max(initial=0.0) if n else heights, rtol=1e-12)


@pytest.mark.parametrize("n", [0, 1, 5_000])
def test_face_points_is_numpys_weighted_sum_bit_for_bit(n):
    # the kernel (`_kernels.weighted_corners`) against numpy's expression, on corners
    # of mixed magnitude (any reordering of the products' sum would show)
    from pointatlas.synth._sample import face_points

    rng = np.random.default_rng(3)
    v = rng.normal(size=(300, 3)) * 10.0 ** rng.integers(-3, 4, size=(300, 1))
    t = rng.integers(0, 300, size=(700, 3)).astype(np.int32)
    face = rng.integers(0, 700, size=n)
    w = rng.random((3, n))
    wa, wb, wc = w
    a, b, c = (v[t[face, i]] for i in range(3))
    expected = wa[:, None] * a + wb[:, None] * b + wc[:, None] * c
    got = face_points(v, t, face, w)
    assert got.shape == (n, 3) and got.dtype == np.float64
    np.testing.assert_array_equal(got, expected)

"""Region growing baseline (Rabbani et al. 2006 / PCL RegionGrowing)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pointatlas.neighbors import query_knn
from pointatlas.segment import region_growing, surface_curvature
from pointatlas.synth import cube, plane_patch

from . import reference


def test_curvature_matches_reference_and_is_zero_on_planes():
    rng = np.random.default_rng(0)
    points = rng.random((60, 3))
    table, _ = query_knn(points, 8)
    np.testing.assert_allclose(
        surface_curvature(points, k=8), reference.curvature_reference(points, table), atol=1e-12
    )
    flat = plane_patch(8, 8).vertices
    assert np.abs(surface_curvature(flat, k=8)).max() < 1e-12


def test_cube_faces_are_regions():
    mesh = cube(8)
    res = region_growing(mesh.vertices, mesh.normals, k=8, smoothness_angle=math.radians(10))
    inner = ~mesh.is_sharp
    for face in range(6):
        assert np.unique(res.labels[inner & (mesh.labels == face)]).size == 1
    assert res.assigned_fraction == 1.0
    assert res.labels.min() == 0 and res.labels.max() == res.n_regions - 1
    assert res.region_counts.sum() == mesh.n_vertices
    assert res.mse < 1e-3 and res.n_degenerate == 0


def test_min_cluster_size_leaves_points_unassigned():
    mesh = cube(8)
    res = region_growing(
        mesh.vertices, mesh.normals, k=8, smoothness_angle=math.radians(10), min_cluster_size=20
    )
    assert res.n_regions == 6
    dropped = res.labels < 0
    assert dropped.any() and mesh.is_sharp[dropped].all()
    assert res.assigned_fraction == pytest.approx(1 - dropped.mean())


def test_orientation_ignored_and_zero_proxy_normal_flagged():
    flat = plane_patch(6, 6).vertices
    normals = np.tile([0.0, 0.0, 1.0], (flat.shape[0], 1))
    normals[1::2] *= -1  # antipodal normals: one region, zero mean normal
    res = region_growing(flat, normals, k=8, curvature_threshold=1.0)
    assert res.n_regions == 1
    if flat.shape[0] % 2 == 0:
        assert res.n_degenerate == 1 and math.isnan(res.mse)


def test_region_growing_errors():
    mesh = cube(2)
    with pytest.raises(ValueError, match="smoothness_angle"):
        region_growing(mesh.vertices, mesh.normals, smoothness_angle=-1.0)
    with pytest.raises(ValueError, match="curvature must"):
        region_growing(mesh.vertices, mesh.normals, curvature=np.ones(3))
    with pytest.raises(ValueError, match="min_cluster_size"):
        region_growing(mesh.vertices, mesh.normals, min_cluster_size=0)

"""Small meshes and point sets for the io tests, built in code."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def cube_quads():
    """A unit cube with 6 outward quad faces (vertices, list of faces)."""
    v = np.array(
        [[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)],
    )
    faces = [
        [0, 1, 3, 2],  # x = 0
        [4, 6, 7, 5],  # x = 1
        [0, 4, 5, 1],  # y = 0
        [2, 3, 7, 6],  # y = 1
        [0, 2, 6, 4],  # z = 0
        [1, 5, 7, 3],  # z = 1
    ]
    return v, faces


@pytest.fixture(scope="module")
def mixed_mesh():
    """A square pyramid: one quad base and four triangles, plus a pentagon cap mesh."""
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1.0]], dtype=np.float64)
    faces = [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
    return v, faces


@pytest.fixture
def cloud():
    """A seeded sphere sample with exact normals and two attributes."""
    rng = np.random.default_rng(7)
    p = rng.normal(size=(200, 3))
    n = p / np.linalg.norm(p, axis=1, keepdims=True)
    return p, n, rng

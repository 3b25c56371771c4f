"""Slow, obvious references for the io tests (plain Python loops)."""

from __future__ import annotations

import numpy as np


def vertex_normals_loop(vertices, faces) -> np.ndarray:
    """Area-weighted vertex normals: for each polygon, add its vector area (sum of its
    fan triangles' cross products) to each of its vertices; normalise; NaN if zero.

    ``faces`` is a list of index lists (any sizes).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    acc = [np.zeros(3) for _ in range(len(vertices))]
    total = [0.0 for _ in range(len(vertices))]
    for face in faces:
        area = np.zeros(3)
        for j in range(1, len(face) - 1):
            a, b, c = vertices[face[0]], vertices[face[j]], vertices[face[j + 1]]
            area += np.cross(b - a, c - a)
        for v in face:
            acc[v] = acc[v] + area
            total[v] += float(np.linalg.norm(area))
    out = np.full((len(vertices), 3), np.nan)
    for i, vec in enumerate(acc):
        length = float(np.linalg.norm(vec))
        if length > 1e-12 * total[i]:
            out[i] = vec / length
    return out


def newell_area(vertices, face) -> np.ndarray:
    """Twice the vector area of a polygon by Newell's formula sum v_i x v_{i+1}."""
    vertices = np.asarray(vertices, dtype=np.float64)
    out = np.zeros(3)
    for i in range(len(face)):
        out += np.cross(vertices[face[i]], vertices[face[(i + 1) % len(face)]])
    return out

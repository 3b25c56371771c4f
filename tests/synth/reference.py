"""Slow, obvious plain-numpy references for the synth tests."""

from __future__ import annotations

from collections import Counter

import numpy as np


def edge_counts(faces):
    """Undirected edge -> number of faces, and directed edge -> count."""
    undirected, directed = Counter(), Counter()
    for a, b, c in np.asarray(faces).tolist():
        for p, q in ((a, b), (b, c), (c, a)):
            undirected[(min(p, q), max(p, q))] += 1
            directed[(p, q)] += 1
    return undirected, directed


def signed_volume(vertices, faces):
    """Sum of signed tetrahedron volumes (origin, a, b, c)."""
    total = 0.0
    for a, b, c in np.asarray(faces).tolist():
        total += float(np.dot(vertices[a], np.cross(vertices[b], vertices[c]))) / 6.0
    return total


def area_weighted_normals(vertices, faces):
    """Per-vertex sum of face cross products, one face at a time, normalised."""
    acc = np.zeros((len(vertices), 3))
    for a, b, c in np.asarray(faces).tolist():
        n = np.cross(vertices[b] - vertices[a], vertices[c] - vertices[a])
        acc[a] += n
        acc[b] += n
        acc[c] += n
    return acc / np.linalg.norm(acc, axis=1, keepdims=True)


def barycentric(p, a, b, c):
    """Barycentric coordinates of the projection of p onto triangle (a, b, c), and the
    distance of p from the triangle's plane (row-wise)."""
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n, axis=1)
    unit = n / area2[:, None]
    dist = np.einsum("ij,ij->i", p - a, unit)
    q = p - dist[:, None] * unit
    wa = np.einsum("ij,ij->i", np.cross(b - q, c - q), unit) / area2
    wb = np.einsum("ij,ij->i", np.cross(c - q, a - q), unit) / area2
    wc = 1.0 - wa - wb
    return np.stack([wa, wb, wc], axis=1), dist

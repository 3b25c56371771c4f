"""Thesis configurations built in code from their description (Figs. 4.1, 4.2)."""

from __future__ import annotations

import numpy as np
from scipy import sparse


def chain_adjacency(n: int, *, closed: bool = False) -> sparse.csr_array:
    """Adjacency of points connected along a line (a closed loop if ``closed``)."""
    i = np.arange(n - 1 if not closed else n)
    j = (i + 1) % n
    data = np.ones(i.size)
    return sparse.csr_array((data, (i, j)), shape=(n, n))


def figure_4_1(n: int = 100):
    """Fig. 4.1(a): n points with normal (-1, 1)/sqrt 2 on a line, next to n points
    with normal (0, 1), then one point with normal (-1, 0) and one with
    N = (-1, n)/sqrt(n^2 + 1); 2-D, embedded in the z = 0 plane.

    Returns points, normals, the chain adjacency and the two seeds (yellow on the
    first line, blue on the second).
    """
    h = 1.0
    t = np.arange(n) * h
    line_a = np.stack([t / np.sqrt(2), t / np.sqrt(2), 0 * t], 1)  # along (1, 1)
    start_b = line_a[-1] + [h, 0, 0]
    line_b = start_b + np.stack([t, 0 * t, 0 * t], 1)
    tail = line_b[-1] + np.array([[h, 0, 0], [2 * h, 0, 0]])
    points = np.vstack([line_a, line_b, tail])
    normals = np.vstack(
        [
            np.tile([-1 / np.sqrt(2), 1 / np.sqrt(2), 0], (n, 1)),
            np.tile([0.0, 1.0, 0.0], (n, 1)),
            [[-1.0, 0.0, 0.0]],
            [[-1.0 / np.sqrt(n * n + 1), n / np.sqrt(n * n + 1), 0.0]],
        ]
    )
    seeds = np.array([n // 2, n + n // 2])
    return points, normals, chain_adjacency(2 * n + 2), seeds


def figure_4_1_energies(n: int = 100):
    """E1 and E2 of the thesis' closed forms (4.3.1)."""
    e1 = -2.0 * (np.sqrt(n * n + 1) - n - 1)
    d = np.array([-1.0, 1.0]) / np.sqrt(2)
    s = n * d + n * np.array([0.0, 1.0]) + np.array([-1.0, 0.0])
    nn = s / np.linalg.norm(s)
    e2 = (
        n * np.sum((d - nn) ** 2)
        + n * np.sum((np.array([0.0, 1.0]) - nn) ** 2)
        + np.sum((np.array([-1.0, 0.0]) - nn) ** 2)
    )
    return float(e1), float(e2)


def _unit_vector(angle):
    return np.array([np.cos(angle), np.sin(angle), 0.0])


def figure_4_2(n: int = 5, alpha_deg: float = 25.0, tail_deg: float = 41.0):
    """The closed 10-gon of Fig. 4.2 as a closed chain of ten Fig. 4.1 units.

    Unit k (side k of a regular 10-gon, base normal turned by -36 k degrees):
    n points with the base normal turned by ``alpha``, n points with the base
    normal, one point with the base normal turned by ``tail`` and one whose normal
    is the fixed point N of Fig. 4.1 (parallel to n * base + tail normal). The
    chain is closed (the thesis "closes the loop"); one seed per unit on the
    first point of its second line. Angles were chosen among Fig. 4.1-like units
    for which classic VSA cycles with a changing energy (7.155 <-> 6.843).
    """
    per = 2 * n + 2
    normals, seeds = [], []
    for k in range(10):
        base = np.pi / 2 - np.radians(36.0) * k
        s = n * _unit_vector(base) + _unit_vector(base + np.radians(tail_deg))
        normals += [_unit_vector(base + np.radians(alpha_deg))] * n
        normals += [_unit_vector(base)] * n
        normals += [_unit_vector(base + np.radians(tail_deg)), s / np.linalg.norm(s)]
        seeds.append(k * per + n + 1)
    normals = np.array(normals)
    total = normals.shape[0]
    # points on a regular 10-gon, one side per unit (positions only matter for MSE)
    corners = np.array([_unit_vector(-np.radians(36.0) * k) for k in range(11)])
    t = (np.arange(per) + 0.5) / per
    points = np.vstack([corners[k] + t[:, None] * (corners[k + 1] - corners[k]) for k in range(10)])
    return points, normals, chain_adjacency(total, closed=True), np.array(seeds)

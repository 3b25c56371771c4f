"""Slow, obvious plain-numpy references for the neighbour kernels (CONTRIBUTING.md, Tests).

Every function builds the full N x N matrix of squared distances on coordinates
centred on their bounding-box centre, evaluated as ``dx*dx + dy*dy + dz*dz`` (the
same float64 expression the kernels use), so exact ties are exact here too.
"""

from __future__ import annotations

import numpy as np


def centred(points) -> np.ndarray:
    """Coordinates minus their bounding-box centre."""
    p = np.asarray(points, dtype=np.float64)
    return p - 0.5 * (p.min(axis=0) + p.max(axis=0))


def squared_distances(points) -> np.ndarray:
    """Full (N, N) matrix of squared distances."""
    q = centred(points)
    dx = q[:, None, 0] - q[None, :, 0]
    dy = q[:, None, 1] - q[None, :, 1]
    dz = q[:, None, 2] - q[None, :, 2]
    return dx * dx + dy * dy + dz * dz


def knn_reference(points, k: int) -> tuple[np.ndarray, np.ndarray]:
    """k nearest: the point itself in column 0, the others by (distance, index)."""
    q = centred(points)
    n = q.shape[0]
    idx = np.empty((n, k), dtype=np.int64)
    dist = np.empty((n, k), dtype=np.float64)
    ids = np.arange(n)
    for i in range(n):
        d = q - q[i]  # one row of `squared_distances`, the same expression
        d2 = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
        order = np.lexsort((ids, d2))  # by distance, then index
        row = np.concatenate([[i], order[order != i][: k - 1]])
        idx[i] = row
        dist[i] = np.sqrt(d2[row])
        dist[i, 0] = 0.0
    return idx, dist


def radius_reference(points, radius: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Closed balls (squared distance <= radius**2): itself first, then by (distance, index)."""
    d2 = squared_distances(points)
    rows = []
    for i in range(d2.shape[0]):
        inside = np.flatnonzero(d2[i] <= radius * radius)
        others = inside[inside != i]
        order = np.lexsort((others, d2[i, others]))
        row = np.concatenate([[i], others[order]]).astype(np.int64)
        rows.append((row, np.sqrt(d2[i, row])))
    return rows


def graph_reference(indices: np.ndarray, symmetric: bool) -> np.ndarray:
    """Dense boolean adjacency of the k-NN graph (column 0 of ``indices`` ignored)."""
    n = indices.shape[0]
    adj = np.zeros((n, n), dtype=bool)
    for i in range(n):
        for j in indices[i, 1:]:
            adj[i, j] = True
            if symmetric:
                adj[j, i] = True
    return adj


def components_reference(adj: np.ndarray) -> np.ndarray:
    """Component labels by depth-first search, numbered by smallest member."""
    n = adj.shape[0]
    labels = np.full(n, -1, dtype=np.int64)
    current = 0
    for start in range(n):
        if labels[start] >= 0:
            continue
        stack = [start]
        labels[start] = current
        while stack:
            i = stack.pop()
            for j in np.flatnonzero(adj[i] | adj[:, i]):
                if labels[j] < 0:
                    labels[j] = current
                    stack.append(j)
        current += 1
    return labels

"""The Riemannian k-NN graph of the orientation step and small helpers (numba).

Validated input assumed. Plain-numpy reference: ``tests/normals/reference.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..._core._sort import morton_bits, morton_order

__all__ = ["component_tops_kernel", "offsets_kernel", "riemannian_graph_kernel"]


@njit(cache=True, parallel=True)
def riemannian_graph_kernel(
    points, normals, indices, k, eps, penalty, keep, cols, weights, opposed
):
    """Weighted undirected k-NN graph, each edge once (CSR, upper or lower row).

    Edge {i, j} exists when j is among indices[i, 1:k] or i among indices[j, 1:k]
    (the symmetric k-NN graph). It is stored once: in row i when j is in i's list
    and j > i, or j < i and i is not in j's list (otherwise row j holds it). Self
    entries are skipped.

    The outputs are written into buffers of N (k - 1) slots (allocated by numpy:
    its large arrays get huge pages, whose first touch is several times cheaper
    than that of numba's; slots past E are never touched); the first E are the
    edges:

    - keep : ndarray of shape (N, k - 1), bool -- whether row i stores
      indices[i, c + 1] (work space);
    - cols : int64 -- the other end of each edge;
    - weights : float64 -- 1 - |n_i . n_j| + penalty (|n_i . e| + |n_j . e|) / 2
      + eps (1 + |p_i - p_j| / mean edge length), e the unit edge direction
      (the penalty term is dropped for coincident points); always > 0;
    - opposed : uint8 -- 1 where n_i . n_j < 0 (sign propagation flips there).

    Returns
    -------
    indptr : ndarray of shape (N + 1,), int64
        Row pointers into the buffers; E = indptr[N].

    Notes
    -----
    Two parallel passes over the rows, visited in Morton order of the points
    (`pointatlas._core._sort.morton_order`; each row writes its own slots, so the output does not
    depend on the order): the first selects the stored edges and sums their
    lengths per row, the second writes the weights. The mean edge length adds
    the row sums in row order, so it does not depend on the threads either (a
    parallel ``lengths.sum()`` split the sum differently from run to run, which
    moved some weights by an ulp).
    """
    n = indices.shape[0]
    visit = morton_order(points, morton_bits(n))
    counts = np.zeros(n, dtype=np.int64)
    row_length = np.zeros(n)
    for t in prange(n):
        i = visit[t]
        cnt = 0
        row_sum = 0.0
        for c in range(1, k):
            j = indices[i, c]
            keep[i, c - 1] = False
            if j == i:
                continue
            if j < i:
                mutual = False
                for c2 in range(1, k):
                    if indices[j, c2] == i:
                        mutual = True
                        break
                if mutual:
                    continue
            keep[i, c - 1] = True
            cnt += 1
            dx = points[j, 0] - points[i, 0]
            dy = points[j, 1] - points[i, 1]
            dz = points[j, 2] - points[i, 2]
            row_sum += np.sqrt(dx * dx + dy * dy + dz * dz)
        counts[i] = cnt
        row_length[i] = row_sum
    indptr = np.zeros(n + 1, dtype=np.int64)
    total = 0.0
    for i in range(n):  # serial: a fixed summation order
        indptr[i + 1] = indptr[i] + counts[i]
        total += row_length[i]
    m = indptr[n]
    mean = total / max(m, 1)
    inv = 1.0 / mean if mean > 0.0 else 0.0
    for t in prange(n):
        i = visit[t]
        pos = indptr[i]
        for c in range(1, k):
            if not keep[i, c - 1]:
                continue
            j = indices[i, c]
            dx = points[j, 0] - points[i, 0]
            dy = points[j, 1] - points[i, 1]
            dz = points[j, 2] - points[i, 2]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            d = normals[i, 0] * normals[j, 0]
            d += normals[i, 1] * normals[j, 1]
            d += normals[i, 2] * normals[j, 2]
            w = 1.0 - min(abs(d), 1.0) + eps * (1.0 + length * inv)
            if penalty != 0.0 and length > 0.0:
                ex = dx / length
                ey = dy / length
                ez = dz / length
                a = abs(normals[i, 0] * ex + normals[i, 1] * ey + normals[i, 2] * ez)
                b = abs(normals[j, 0] * ex + normals[j, 1] * ey + normals[j, 2] * ez)
                w += 0.5 * penalty * (a + b)
            cols[pos] = j
            weights[pos] = w
            opposed[pos] = d < 0.0
            pos += 1
    return indptr


@njit(cache=True, parallel=True)
def offsets_kernel(points, targets):
    """``points[targets] - points`` without numpy's fancy-indexing copy (the same
    subtractions, so the same bits)."""
    n = points.shape[0]
    out = np.empty((n, 3))
    for i in prange(n):
        j = targets[i]
        out[i, 0] = points[j, 0] - points[i, 0]
        out[i, 1] = points[j, 1] - points[i, 1]
        out[i, 2] = points[j, 2] - points[i, 2]
    return out


@njit(cache=True)
def component_tops_kernel(z, labels, n_comp):
    """Per component the index with the largest z (ties: the smaller index).

    Returns
    -------
    roots : ndarray of shape (n_comp,), int64
        -1 for a label that does not occur.
    """
    roots = np.full(n_comp, -1, dtype=np.int64)
    for i in range(z.shape[0]):
        c = labels[i]
        r = roots[c]
        if r < 0 or z[i] > z[r]:
            roots[c] = i
    return roots

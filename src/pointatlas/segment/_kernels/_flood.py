"""The flood of thesis 4.2.1/4.2.2 (priority queue from seeds) and the re-seeding
of the classic loop (the best point of every region)."""

from __future__ import annotations

import numpy as np
from numba import njit

from ._heap import heap_new, heap_pop, heap_push, key_buffer


@njit(cache=True)
def _push_neighbours(
    indptr, indices, normals, seed_normals, labels, p, r, n_seeds, heap, base, size, bits, bits_i
):
    """Queue every unlabelled neighbour j of point p for region r: key
    |n_j - N_r|^2 (a sum of squares: never -0.0), code j * n_seeds + r, so ties
    go to the smaller point, then the smaller region. Returns the (possibly
    grown) heap, its base and size."""
    for t in range(indptr[p], indptr[p + 1]):
        j = indices[t]
        if labels[j] >= 0:
            continue
        d0 = normals[j, 0] - seed_normals[r, 0]
        d1 = normals[j, 1] - seed_normals[r, 1]
        d2 = normals[j, 2] - seed_normals[r, 2]
        bits[0] = d0 * d0 + d1 * d1 + d2 * d2
        heap, base = heap_push(heap, base, size, bits_i[0], j * n_seeds + r)
        size += 1
    return heap, base, size


def flood(indptr, indices, normals, seeds, seed_normals):
    """Priority-queue flood of thesis 4.2.1/4.2.2 from ``seeds`` (region r = seeds[r]).

    Queue key |n_j - N_r|^2; ties by smaller point index, then smaller region.
    Points the flood cannot reach keep label -1.
    """
    bits, bits_i = key_buffer()
    return _flood(indptr, indices, normals, seeds, seed_normals, bits, bits_i)


@njit(cache=True)
def _flood(indptr, indices, normals, seeds, seed_normals, bits, bits_i):
    """`flood` with its key buffer (`key_buffer`)."""
    n = normals.shape[0]
    n_seeds = seeds.shape[0]
    labels = np.full(n, -1, dtype=np.int64)
    heap, base = heap_new(max(16, 2 * n_seeds + 16))
    size = 0
    for r in range(n_seeds):
        labels[seeds[r]] = r
    for r in range(n_seeds):
        heap, base, size = _push_neighbours(
            indptr,
            indices,
            normals,
            seed_normals,
            labels,
            seeds[r],
            r,
            n_seeds,
            heap,
            base,
            size,
            bits,
            bits_i,
        )
    while size > 0:
        code = heap[base, 1]
        heap_pop(heap, base, size)
        size -= 1
        p = code // n_seeds
        if labels[p] >= 0:
            continue
        r = code - p * n_seeds
        labels[p] = r
        heap, base, size = _push_neighbours(
            indptr,
            indices,
            normals,
            seed_normals,
            labels,
            p,
            r,
            n_seeds,
            heap,
            base,
            size,
            bits,
            bits_i,
        )
    return labels


@njit(cache=True)
def best_points(labels, m, normals, proxy_normals):
    """Point of every region with least |n_j - N_i|^2 (ties: smaller index)."""
    best = np.empty(m, dtype=np.int64)  # np.empty + a loop: one spelling less to compile
    best_dev = np.empty(m)
    for r in range(m):
        best[r] = -1
        best_dev[r] = np.inf
    for i in range(labels.shape[0]):
        r = labels[i]
        d0 = normals[i, 0] - proxy_normals[r, 0]
        d1 = normals[i, 1] - proxy_normals[r, 1]
        d2 = normals[i, 2] - proxy_normals[r, 2]
        dev = d0 * d0 + d1 * d1 + d2 * d2
        if dev < best_dev[r]:
            best_dev[r] = dev
            best[r] = i
    return best

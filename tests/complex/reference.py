"""Plain reference for Eq. 3.1: enlarged clouds and inclusion-maximal sets by brute force."""

from __future__ import annotations

from itertools import combinations

import numpy as np


def q_tuples_reference(labels: np.ndarray, indices: np.ndarray) -> tuple:
    """I* = {subsets of size >= 3 whose enlarged clouds intersect}; keep maximal ones."""
    n_regions = int(labels.max()) + 1
    clouds = [set() for _ in range(n_regions)]
    for p in range(labels.size):
        for q in indices[p]:
            clouds[int(labels[q])].add(p)  # p lies in the enlarged cloud of q's region
    star = []
    for size in range(3, n_regions + 1):
        for sub in combinations(range(n_regions), size):
            common = set.intersection(*(clouds[i] for i in sub))
            if common:
                star.append(frozenset(sub))
    maximal = [s for s in star if not any(s < t for t in star)]
    return tuple(sorted(tuple(sorted(s)) for s in maximal))


def cloud_simplices_reference(clouds, max_size: int = 4) -> dict:
    """Def. 6 literally: every set of up to ``max_size`` clouds with a common point.

    Returns {size: sorted list of tuples}; slow (all subsets), for small inputs.
    """
    sets = [set(int(x) for x in c) for c in clouds]
    nonempty = [i for i, s in enumerate(sets) if s]
    out = {}
    for size in range(1, max_size + 1):
        found = []
        for sub in combinations(nonempty, size):
            if set.intersection(*(sets[i] for i in sub)):
                found.append(tuple(sub))
        out[size] = sorted(found)
    return out


def betti_numbers_reference(triangles: np.ndarray, edges: np.ndarray, n_vertices: int):
    """Betti numbers b0, b1, b2 over the rationals by ranks of boundary matrices."""
    vid = {v: i for i, v in enumerate(sorted(set(range(n_vertices))))}
    eid = {tuple(e): i for i, e in enumerate(map(tuple, edges.tolist()))}
    d1 = np.zeros((len(vid), len(eid)))
    for (a, b), j in eid.items():
        d1[vid[a], j], d1[vid[b], j] = -1.0, 1.0
    d2 = np.zeros((len(eid), len(triangles)))
    for j, (a, b, c) in enumerate(triangles.tolist()):
        d2[eid[(a, b)], j] += 1.0
        d2[eid[(b, c)], j] += 1.0
        d2[eid[(a, c)], j] -= 1.0
    r1 = np.linalg.matrix_rank(d1) if d1.size else 0
    r2 = np.linalg.matrix_rank(d2) if d2.size else 0
    return len(vid) - r1, len(eid) - r1 - r2, len(triangles) - r2

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

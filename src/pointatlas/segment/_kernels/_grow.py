"""The region-growing kernel (Rabbani et al. 2006, as PCL's ``RegionGrowing``)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def region_growing(nbr, normals, curvature, order, cos_threshold, curvature_threshold):
    """Rabbani et al. (2006) smooth region growing as PCL's ``RegionGrowing``.

    ``nbr`` (N, k) directed k-NN table (column 0 the point itself), ``order`` the
    points sorted by increasing curvature (ties by index). A neighbour joins when
    |n_current . n_neighbour| >= cos_threshold; it becomes a further seed when its
    curvature is <= curvature_threshold. Returns raw region labels (every point
    labelled) in growth order.
    """
    n = normals.shape[0]
    labels = np.full(n, -1, dtype=np.int64)
    queue = np.empty(n, dtype=np.int64)
    region = 0
    for s in range(order.shape[0]):
        start = order[s]
        if labels[start] >= 0:
            continue
        labels[start] = region
        head = 0
        tail = 0
        queue[tail] = start
        tail += 1
        while head < tail:
            cur = queue[head]
            head += 1
            for t in range(nbr.shape[1]):
                j = nbr[cur, t]
                if j < 0 or labels[j] >= 0:
                    continue
                d = (
                    normals[cur, 0] * normals[j, 0]
                    + normals[cur, 1] * normals[j, 1]
                    + normals[cur, 2] * normals[j, 2]
                )
                if abs(d) < cos_threshold:
                    continue
                labels[j] = region
                if curvature[j] <= curvature_threshold:
                    queue[tail] = j
                    tail += 1
        region += 1
    return labels

"""Two-sided distances between the output and the input (what a user sees both ways).

Input -> output (`distances`: every input vertex or point to the output triangles)
misses a spike or a sheet the output adds where the input has nothing; output ->
input catches it: the output's vertices and a seeded, area-uniform sample of its
triangles, measured to the input's triangles (a mesh) or to the nearest input
point (a point set).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from ..neighbors import point_mesh_distance
from ..synth import sample_mesh

__all__ = ["BACK_SAMPLES", "back_distances", "output_samples"]

#: Area-uniform samples of the output surface measured back to the input.
BACK_SAMPLES = 20_000


def output_samples(vertices, triangles, n: int = BACK_SAMPLES, seed: int = 0) -> np.ndarray:
    """The used output vertices and ``n`` area-uniform samples of the triangles (seeded).

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    >>> output_samples(v, np.array([[0, 1, 2]]), n=5).shape
    (8, 3)
    """
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    corners = v[np.unique(t)]
    area = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
    if t.shape[0] == 0 or not area.sum() > 0.0:
        return corners
    return np.vstack([corners, sample_mesh(v, t, n, rng=seed).points])


def back_distances(out_v, out_t, in_v, in_t=None) -> np.ndarray:
    """Distance of `output_samples` to the input: its triangles, or its points.

    Examples
    --------
    >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    >>> spike = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 2.0]])
    >>> float(back_distances(spike, [[0, 1, 2]], v, [[0, 1, 2]]).max())
    2.0
    """
    samples = output_samples(out_v, out_t)
    if in_t is None:
        return cKDTree(np.asarray(in_v, dtype=np.float64)).query(samples, workers=-1)[0]
    return point_mesh_distance(samples, in_v, np.asarray(in_t, dtype=np.int64))

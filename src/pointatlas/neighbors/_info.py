"""A summary of a point set: size, bounding box, spacing, k-NN components, duplicates."""

from __future__ import annotations

import numpy as np

from .._core import PointAtlasError, PointSet
from .._core._deprecation import renamed_keywords
from ._graph import mean_spacing
from ._knn import query_knn

__all__ = ["knn_component_sizes", "point_set_info"]


def _duplicates(points: np.ndarray) -> int:
    """Number of redundant copies: N minus the number of distinct positions."""
    if points.shape[0] < 2:
        return 0
    canon = np.ascontiguousarray(points + 0.0)  # -0.0 == 0.0
    rows = canon.view(np.dtype((np.void, canon.dtype.itemsize * 3))).ravel()
    return int(points.shape[0] - np.unique(rows).shape[0])


@renamed_keywords(indices="neighbors")
def knn_component_sizes(neighbors: np.ndarray) -> np.ndarray:
    """Sizes of the connected components of the symmetric k-NN graph, largest first.

    Same partition as `pointatlas.neighbors.knn_components` (i ~ j when either is
    among the other's neighbours), computed as the *weakly* connected components
    of the directed k-NN graph: no symmetrisation, de-duplication or distances,
    so it stays linear-time at 1e6 points.

    Parameters
    ----------
    neighbors : ndarray of shape (N, k), int64
        `query_knn`'s neighbour table (column 0 is the point itself); ``indices=``
        is its former name (deprecated).

    Returns
    -------
    sizes : ndarray of shape (n_components,), int64
        Points per component, largest first.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [10, 0, 0], [11, 0, 0], [12, 0, 0]])
    >>> knn_component_sizes(query_knn(pts, 2)[0]).tolist()
    [3, 2]
    """
    from scipy import sparse
    from scipy.sparse import csgraph

    n, k = neighbors.shape
    rows = np.repeat(np.arange(n, dtype=np.int64), k)
    graph = sparse.csr_array(
        (np.ones(n * k, dtype=np.int8), (rows, neighbors.reshape(-1))), shape=(n, n)
    )
    _, labels = csgraph.connected_components(graph, directed=True, connection="weak")
    return np.sort(np.bincount(labels))[::-1]


def point_set_info(ps: PointSet, *, k: int = 8, n_faces: int | None = None, face_sizes=None):
    """Summary of a point set as a JSON-ready dict (used by ``info`` and ``demo``).

    Parameters
    ----------
    ps : PointSet
        The points (normals and attributes optional).
    k : int
        Neighbourhood size (point itself included) of the k-NN graph whose
        connected components are counted.
    n_faces : int, optional
        Number of faces when the file is a mesh.
    face_sizes : ndarray of shape (F,), int, optional
        Vertices per face, to tell triangle from polygon meshes.

    Returns
    -------
    info : dict
        points, faces, face_kind, normals, bbox_min/max/size, mean_spacing (l:
        mean distance to the 12 nearest; None below 2 points), knn_k,
        knn_components, largest_component, duplicates, attributes.

    Raises
    ------
    PointAtlasError
        k < 2.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> info = point_set_info(cube(4).to_point_set())
    >>> info["points"], info["knn_components"], info["duplicates"]
    (98, 1, 0)
    """
    if k < 2:
        raise PointAtlasError(f"--k must be at least 2 (the point itself and a neighbour); got {k}")
    pts = ps.points
    n = ps.n_points
    info: dict = {"name": ps.name, "points": n}
    info["faces"] = None if n_faces is None else int(n_faces)
    if face_sizes is not None and len(face_sizes):
        lo, hi = int(np.min(face_sizes)), int(np.max(face_sizes))
        info["face_kind"] = "triangles" if lo == hi == 3 else f"polygons ({lo}-{hi} vertices)"
    else:
        info["face_kind"] = None
    info["normals"] = bool(ps.has_normals)
    if n:
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        info["bbox_min"] = lo.tolist()
        info["bbox_max"] = hi.tolist()
        info["bbox_size"] = (hi - lo).tolist()
    else:
        info["bbox_min"] = info["bbox_max"] = info["bbox_size"] = None
    k_eff = min(k, n)
    k_query = min(max(k, 13), n)
    info["knn_k"] = k_eff
    if n >= 2:
        indices, distances = query_knn(pts, k_query)
        k_l = min(12, n - 1)
        info["mean_spacing"] = mean_spacing(pts, k=k_l, distances=distances)
        info["mean_spacing_k"] = k_l
        sizes = knn_component_sizes(indices[:, :k_eff])
        info["knn_components"] = int(sizes.size)
        info["largest_component"] = int(sizes[0])
    else:
        info["mean_spacing"] = None
        info["mean_spacing_k"] = None
        info["knn_components"] = n
        info["largest_component"] = n
    info["duplicates"] = _duplicates(pts)
    info["attributes"] = {
        name: {"dtype": str(arr.dtype), "shape": list(arr.shape[1:])}
        for name, arr in sorted(ps.attributes.items())
    }
    return info

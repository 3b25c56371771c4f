"""Normal orientation: MST propagation (Hoppe et al. 1992), viewpoint, outward, up."""

from __future__ import annotations

import numpy as np

from .._core import as_float, as_k, as_normals, as_points
from .._core._sort import permute_table, spatial_renumbering
from .._core.tolerances import MST_WEIGHT_EPS, OUTWARD_VOTE_RTOL
from ._estimate import _neighbor_indices
from ._kernels import (
    component_tops_kernel,
    offsets_kernel,
    riemannian_graph_kernel,
    spanning_forest_kernel,
)

__all__ = ["orient_normals"]

_METHODS = ("outward", "mst", "viewpoint", "up")


def _check_viewpoint(viewpoint) -> np.ndarray:
    if viewpoint is None:
        raise ValueError("viewpoint is required for method='viewpoint'; got None")
    try:
        vp = np.asarray(viewpoint, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"viewpoint must be 3 numbers; got {viewpoint!r}: {exc}") from None
    if vp.shape != (3,):
        raise ValueError(f"viewpoint must have shape (3,); got {vp.shape}")
    if not np.isfinite(vp).all():
        raise ValueError(f"viewpoint must be finite; got {vp.tolist()}")
    return vp


def _flip_up(nrm: np.ndarray) -> np.ndarray:
    """``method="up"`` in place: the first non-zero of (n_z, n_y, n_x) made positive.

    n_z < 0 flips (PDAL ``filters.normal`` ``always_up``); n_z == 0 (either sign of
    zero) falls back to n_y, then n_x, so the result depends on the unoriented axis
    only: n and -n give the same bits.
    """
    nx, ny, nz = nrm[:, 0], nrm[:, 1], nrm[:, 2]
    flip = (nz < 0.0) | ((nz == 0.0) & ((ny < 0.0) | ((ny == 0.0) & (nx < 0.0))))
    np.negative(nrm, out=nrm, where=flip[:, None])
    return nrm


def _riemannian_graph(points, normals, idx, k, eps, edge_penalty):
    """`riemannian_graph_kernel` with numpy-allocated buffers, trimmed to the edges.

    Returns indptr, cols, weights and opposed (see the kernel).
    """
    n = idx.shape[0]
    slots = n * max(k - 1, 0)
    keep = np.empty((n, max(k - 1, 0)), dtype=np.bool_)
    cols = np.empty(slots, dtype=np.int64)
    weights = np.empty(slots)
    opposed = np.empty(slots, dtype=np.uint8)
    indptr = riemannian_graph_kernel(
        points, normals, idx, k, eps, edge_penalty, keep, cols, weights, opposed
    )
    m = int(indptr[-1])
    return indptr, cols[:m], weights[:m], opposed[:m]


def _spanning_forest(indptr, cols, weights, opposed):
    """`spanning_forest_kernel` with numpy-allocated scratch space."""
    work = np.empty((6, cols.shape[0]), dtype=np.uint64)
    return spanning_forest_kernel(indptr, cols, weights, opposed, work)


def _forest_signs(points, normals, idx, edge_penalty):
    """Signs from the minimum spanning forest of the k-NN Riemannian graph.

    Kruskal over the edges in stable order of weight (each undirected edge
    stored once), as scipy's ``minimum_spanning_tree`` does, so it keeps the
    same edges (Filter-Kruskal with a radix sort, no sparse-matrix round trips).
    Each tree is rooted at its top point (`_top_roots`) and every node gets the
    sign that breadth-first propagation from the root gives: the root's sign,
    flipped once per edge with opposed normals on the tree path (the forest
    kernel tracks these parities in its union-find, so no traversal is needed).
    Returns the signs, the number of trees and the tree of every point.
    """
    # the graph and the forest on spatially renumbered points (the union-find
    # then walks nearby memory); trees and parities mapped back
    order, inv = spatial_renumbering(points)
    graph = _riemannian_graph(
        np.take(points, order, axis=0),
        np.take(normals, order, axis=0),
        permute_table(idx, order, inv),
        idx.shape[1],
        MST_WEIGHT_EPS,
        edge_penalty,
    )
    _, _, labels, n_comp, parity = _spanning_forest(*graph)
    labels, parity = labels[inv], parity[inv]
    n_comp = int(n_comp)
    roots, root_signs = _top_roots(points, normals, labels, n_comp)
    signs = root_signs[labels]
    signs[parity != parity[roots][labels]] *= -1.0
    return signs, n_comp, labels


def _top_roots(points, normals, labels, n_comp):
    """Per component the point with the largest z (ties: smaller index), and its sign."""
    roots = component_tops_kernel(
        np.ascontiguousarray(points[:, 2]), labels.astype(np.int64), n_comp
    )
    root_signs = np.where(normals[roots, 2] >= 0.0, 1.0, -1.0)
    return roots, root_signs


def _outward_flip(points, oriented, labels, n_comp, idx):
    """Per-component sign (+1/-1) making sum_i a_i n_i . (p_i - c) >= 0 (outward).

    a_i = squared distance to the k-th neighbour (local area proxy, so uneven
    sampling does not bias the vote); 0 (undecided) when the vote is below
    OUTWARD_VOTE_RTOL of sum_i a_i |p_i - c|.
    """
    far = offsets_kernel(points, np.ascontiguousarray(idx[:, -1]))
    area = np.einsum("ij,ij->i", far, far)
    if not (area > 0).any():
        area = np.ones_like(area)
    wsum = np.bincount(labels, weights=area, minlength=n_comp)
    wsum[wsum == 0] = 1.0
    centroid = (
        np.stack(
            [np.bincount(labels, weights=area * points[:, c], minlength=n_comp) for c in range(3)],
            axis=1,
        )
        / wsum[:, None]
    )
    rel = points - centroid[labels]
    vote = np.bincount(
        labels, weights=area * np.einsum("ij,ij->i", oriented, rel), minlength=n_comp
    )
    scale = np.bincount(labels, weights=area * np.linalg.norm(rel, axis=1), minlength=n_comp)
    flip = np.zeros(n_comp)
    decided = np.abs(vote) > OUTWARD_VOTE_RTOL * scale
    flip[decided] = np.sign(vote[decided])
    return flip


def orient_normals(
    points,
    normals,
    *,
    k: int = 10,
    method: str = "outward",
    viewpoint=None,
    neighbors=None,
    edge_penalty: float = 1.0,
):
    """Give unoriented normals a consistent sign.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates.
    normals : array_like of shape (N, 3)
        Normals of any sign (rescaled to unit length; zero length raises).
    k : int
        Neighbourhood size of the k-NN Riemannian graph, the point itself
        included (2 <= k <= N; default 10). Ignored by ``method="viewpoint"``
        and ``method="up"``.
    method : {"outward", "mst", "viewpoint", "up"}
        ``"mst"``: minimum-spanning-tree propagation (Hoppe et al. 1992); in
        every connected component of the k-NN graph the root is the point with
        the largest z and its normal is made to point to +z (Hoppe's and
        Open3D's convention; on a closed surface the topmost point's outward
        normal is +z, but a noisy or spiky top point can invert a whole
        component). ``"outward"`` (default): the same propagation, then every
        component is flipped so that the area-weighted sum of n_i . (p_i - c)
        over its points is positive (c its centroid; for a closed surface this
        sum is 3 x its enclosed volume, divergence theorem); components where
        the sum is negligible (open, flat patches) keep the ``"mst"`` rule.
        ``"viewpoint"``: each normal independently faces ``viewpoint``.
        ``"up"``: each normal independently gets n_z >= 0 (the lidar convention,
        PDAL's ``filters.normal`` ``always_up``); a horizontal normal (n_z == 0)
        gets n_y > 0, or n_x > 0 when n_y == 0 too. Per point, no neighbours.
    viewpoint : array_like of shape (3,), optional
        Sensor position, required for ``method="viewpoint"``.
    neighbors : ndarray of shape (N, m), int, or tuple, optional
        Precomputed neighbour indices with m >= k (the first k columns are used),
        or the tuple returned by `pointatlas.neighbors.query_knn`; lets one k-NN
        query serve `estimate_normals` and this function.
    edge_penalty : float
        Weight (finite, >= 0) of the term penalising graph edges along the
        normals (see Notes); 0 gives Hoppe's weight exactly.

    Returns
    -------
    oriented : ndarray of shape (N, 3), float64
        Unit normals, each equal to +/- the (normalised) input normal.

    Raises
    ------
    ValueError
        Bad points or normals, unknown method, missing/bad viewpoint, k outside
        [2, N] (a `PointAtlasError`), negative or non-finite edge_penalty, bad
        neighbour indices.
    TypeError
        Non-integer k, non-numeric edge_penalty or viewpoint.

    Notes
    -----
    Hoppe et al. 1992 (the thesis takes point-set normals from this pipeline):
    Riemannian graph = the symmetric k-NN graph (Hoppe and Open3D add the
    Euclidean MST; the k-NN graph is connected wherever that matters here and
    disconnected parts are oriented separately), edge weight
    ``1 - |n_i . n_j| + edge_penalty * (|n_i . e| + |n_j . e|) / 2
    + 1e-9 * (1 + |p_i - p_j| / mean edge length)`` with e the unit edge
    direction. The penalty keeps the tree off edges that jump between two close
    sheets (thin ears, fins), whose normals are parallel but whose edge runs
    along them; the 1e-9 term keeps parallel normals' edges (scipy drops zero
    weights) and prefers short edges among ties. The minimum spanning forest
    (Kruskal, edges in stable weight order: the edges scipy's
    ``minimum_spanning_tree`` keeps) is traversed breadth-first from each root
    and n_j is flipped when n_parent . n_j < 0 (in effect: the signs come from
    the parity of such edges on each tree path, tracked while the forest is
    built). Each connected component of the k-NN graph is oriented on its own.
    ``"up"`` and ``"viewpoint"`` are per point: a point's result depends on its
    own normal only (and, for ``"up"``, not on its sign), so they split over
    tiles exactly. Decisions: docs/decisions/normals.md, "Orientation".

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])
    >>> nrm = np.array([[0.0, 0, 1], [0, 0, -1], [0, 0, 1], [0, 0, -1]])
    >>> orient_normals(pts, nrm, k=3)[:, 2].tolist()
    [1.0, 1.0, 1.0, 1.0]
    >>> orient_normals(pts, nrm, method="viewpoint", viewpoint=[0, 0, -5])[:, 2].tolist()
    [-1.0, -1.0, -1.0, -1.0]
    >>> up = orient_normals(pts, [[0.0, 0.6, -0.8], [0, -1, 0], [-1, 0, 0], [0, 0, 1]],
    ...                     method="up")
    >>> (up + 0.0).tolist()  # + 0.0: -0.0 printed as 0.0
    [[0.0, -0.6, 0.8], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}; got {method!r}")
    edge_penalty = as_float(edge_penalty, "edge_penalty", lo=0.0)
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n)
    if method == "viewpoint":
        vp = _check_viewpoint(viewpoint)
        facing = np.einsum("ij,ij->i", vp - pts, nrm)
        nrm[facing < 0] *= -1.0
        return nrm
    if method == "up":
        return _flip_up(nrm)
    k = as_k(k, n, minimum=2)
    idx = _neighbor_indices(pts, k, neighbors)
    signs, n_comp, labels = _forest_signs(pts, nrm, idx, edge_penalty)
    nrm *= signs[:, None]
    if method == "outward":
        flip = _outward_flip(pts, nrm, labels, n_comp, idx)
        nrm[flip[labels] < 0] *= -1.0
    return nrm

"""Slow, obvious plain-numpy references for the normals kernels (CONTRIBUTING.md, Tests)."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

DEGENERATE_RATIO = 1e-10


def covariance_reference(points, indices, k):
    """Covariance about the neighbourhood mean (divided by k) of every point, (N, 3, 3)."""
    out = np.empty((points.shape[0], 3, 3))
    for i in range(points.shape[0]):
        nb = points[indices[i, :k]]
        d = nb - nb.mean(axis=0)
        out[i] = d.T @ d / k
    return out


def pca_normals_reference(points, indices, k):
    """Eigenvalues (descending), smallest eigenvector and degeneracy flag via eigh."""
    cov = covariance_reference(points, indices, k)
    w, v = np.linalg.eigh(cov)  # ascending
    eigenvalues = np.clip(w[:, ::-1], 0.0, None)
    normals = v[:, :, 0]
    degenerate = eigenvalues[:, 1] <= DEGENERATE_RATIO * eigenvalues[:, 0]
    return normals, eigenvalues, degenerate


def riemannian_graph_reference(points, normals, indices, k, eps, penalty):
    """Undirected symmetric k-NN graph weights as a dict {(i, j), i < j: weight}.

    1 - |n_i . n_j| + penalty (|n_i . e| + |n_j . e|) / 2 + eps (1 + d_ij / mean d),
    the mean taken over the undirected edges.
    """
    pairs = sorted(
        {
            (min(i, int(j)), max(i, int(j)))
            for i in range(points.shape[0])
            for j in indices[i, 1:k]
            if int(j) != i
        }
    )
    if not pairs:
        return {}
    a, b = np.array(pairs).T
    diff = points[b] - points[a]
    length = np.linalg.norm(diff, axis=1)
    mean = length.mean()
    w = 1.0 - np.minimum(np.abs(np.sum(normals[a] * normals[b], axis=1)), 1.0)
    w = w + eps * (1.0 + (length / mean if mean > 0 else 0.0))
    pos = length > 0
    e = diff[pos] / length[pos, None]
    w[pos] += (
        0.5
        * penalty
        * (
            np.abs(np.sum(normals[a[pos]] * e, axis=1))
            + np.abs(np.sum(normals[b[pos]] * e, axis=1))
        )
    )
    return dict(zip(pairs, w.tolist(), strict=True))


def propagate_signs_reference(tree, normals, roots, root_signs):
    """Signs by scipy's breadth_first_order and predecessors, one Python step per node."""
    n = normals.shape[0]
    signs = np.ones(n)
    for root, root_sign in zip(roots, root_signs, strict=True):
        order, pred = csgraph.breadth_first_order(tree, root, directed=False)
        signs[root] = root_sign
        for j in order[1:]:
            p = pred[j]
            signs[j] = signs[p] if normals[p] @ normals[j] >= 0 else -signs[p]
    return signs


def orient_mst_reference(points, normals, indices, k, eps, penalty):
    """MST orientation with the top-point root rule (method="mst"), numpy/scipy only."""
    n = points.shape[0]
    normals = normals / np.linalg.norm(normals, axis=1)[:, None]
    edges = riemannian_graph_reference(points, normals, indices, k, eps, penalty)
    a, b = np.array(list(edges)).T
    w = np.array(list(edges.values()))
    graph = sparse.coo_array((w, (a, b)), shape=(n, n)).tocsr()
    tree = csgraph.minimum_spanning_tree(graph)
    n_comp, labels = csgraph.connected_components(tree, directed=False)
    roots, root_signs = [], []
    for c in range(n_comp):
        members = np.flatnonzero(labels == c)
        top = members[np.argmax(points[members, 2])]  # first maximum = smallest index
        roots.append(top)
        root_signs.append(1.0 if normals[top, 2] >= 0 else -1.0)
    signs = propagate_signs_reference(tree, normals, roots, root_signs)
    return normals * signs[:, None]

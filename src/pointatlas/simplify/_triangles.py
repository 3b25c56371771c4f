"""The input triangles as the mesh path reads them: normals, areas, centroids and edge
structure (`_Surface`), and the faces' edge adjacency (private).

Shared by the steps of the mesh path (`_surface.py`, `_arcs.py`, `_mesh_path.py`),
each of which imports it, so no step imports another's module for it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from ._mesh import unique_pairs

__all__ = ["DEGENERATE_AREA", "_Surface", "_face_graph", "_surface"]

#: Smallest area-weight fraction of a face treated as non-degenerate (relative to the
#: mean face area); smaller faces take a neighbour's normal and no weight.
DEGENERATE_AREA = 1e-14


@dataclass(frozen=True, slots=True)
class _Surface:
    """Triangles with their normals, areas, centroids and edge structure (private)."""

    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    centroids: np.ndarray
    edge_faces: np.ndarray  # (E, 2) faces of every undirected edge, -1 when missing
    face_edges: np.ndarray  # (F, 3) edge of (v0 v1), (v1 v2), (v2 v0)
    edge_verts: np.ndarray  # (E, 2) sorted vertex pair


def _surface(vertices: np.ndarray, triangles: np.ndarray) -> _Surface:
    v = vertices
    t = triangles
    n_faces = t.shape[0]
    cross = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    length = np.linalg.norm(cross, axis=1)
    areas = 0.5 * length
    directed = np.stack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]], axis=1).reshape(-1, 2)
    und = np.sort(directed, axis=1)
    edge_verts, inverse, counts = unique_pairs(und, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    face_edges = inverse.reshape(n_faces, 3)
    owner = np.repeat(np.arange(n_faces, dtype=np.int64), 3)
    order = np.argsort(inverse, kind="stable")
    starts = np.concatenate([[0], np.cumsum(counts)])
    edge_faces = np.full((edge_verts.shape[0], 2), -1, dtype=np.int64)
    first = owner[order[starts[:-1]]]
    edge_faces[:, 0] = first
    two = counts >= 2
    edge_faces[two, 1] = owner[order[starts[:-1][two] + 1]]
    # an edge in three or more faces is non-manifold: its faces are not neighbours
    edge_faces[counts > 2, 1] = -1
    normals = np.zeros_like(cross)
    mean_area = float(areas.mean()) if n_faces else 0.0
    ok = length > 2.0 * DEGENERATE_AREA * max(mean_area, np.finfo(float).tiny)
    normals[ok] = cross[ok] / length[ok, None]
    if not ok.all():
        normals, areas = _borrow_normals(normals, areas, ok, edge_faces, face_edges)
    centroids = v[t].mean(axis=1)
    return _Surface(v, t, normals, areas, centroids, edge_faces, face_edges, edge_verts)


def _borrow_normals(normals, areas, ok, edge_faces, face_edges):
    """Degenerate triangles take a neighbour's normal and no weight."""
    normals, areas, ok = normals.copy(), areas.copy(), ok.copy()
    areas[~ok] = 0.0
    for _ in range(64):
        todo = np.flatnonzero(~ok)
        if todo.size == 0:
            break
        across = edge_faces[face_edges[todo]]  # (m, 3, 2)
        other = np.where(across[..., 0] == todo[:, None], across[..., 1], across[..., 0])
        good = (other >= 0) & ok[np.maximum(other, 0)]
        has = good.any(axis=1)
        pick = other[np.arange(todo.size), np.argmax(good, axis=1)]
        normals[todo[has]] = normals[pick[has]]
        ok[todo[has]] = True
    normals[~ok] = (0.0, 0.0, 1.0)
    return normals, areas


def _face_graph(s: _Surface) -> sparse.csr_array:
    inner = s.edge_faces[(s.edge_faces >= 0).all(axis=1)]
    n = s.triangles.shape[0]
    rows = np.concatenate([inner[:, 0], inner[:, 1], np.arange(n)])
    cols = np.concatenate([inner[:, 1], inner[:, 0], np.arange(n)])
    return sparse.csr_array((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n, n))

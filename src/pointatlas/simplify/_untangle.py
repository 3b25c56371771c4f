"""Triangles that placing vertices on their planes turned over, mended by merging
vertices (private).

At a coarse level of the points path a row of vertices lies along the rounded edge of
the voxel surface, with vertices of the faces beside it within a grid step of the
edge's line. Placed on the line of their two planes, the row's vertices pass those
neighbours (a triangle turns over) or meet them on the line (a triangle loses its
area), and putting them back (`_place._unflip`) left them up to 0.3 % of the diagonal
off their planes: their faces were not planar (the polygons split into their
triangles) and a plane refitted to the points made a sampled L-bracket's corner come
out 0.3 % off. `untangle` instead merges a vertex of every such triangle into
another (an edge collapse under the link condition, `_caps`): the vertex on more
flat faces stays where it was placed, so the row ends on the line, and no triangle
around the merge turns over. What it cannot merge is put back as before. The passes
run in numba (`_untangle_kernels`).
"""

from __future__ import annotations

import numpy as np

from ._caps import CAP_RTOL, compact, outline_vertices
from ._mesh import unique_pairs
from ._place import _cross
from ._untangle_kernels import merge_round, triangle_rings

__all__ = ["ROUNDS", "untangle"]

#: Passes over the triangles left without area (each merges what it can).
ROUNDS = 4


def untangle(v0, placed, triangles, face, flat, source, kept, went):
    """Merge away the triangles that ``placed`` turned over or left without area.

    Parameters
    ----------
    v0, placed : ndarray of shape (V, 3)
        The vertices before and after their placement on their planes.
    triangles : ndarray of shape (T, 3), int64
        Consistently oriented triangles of a manifold mesh.
    face : ndarray of shape (T,), int64
        The face of each triangle; ``flat`` (F,) bool: which faces are flat.
    source, kept, went : ndarray
        The lineage, as `_caps.weld_needles` takes it.

    Returns
    -------
    tuple
        ``(v0, placed, triangles, face, source, kept, went, normals)`` without the
        merged vertices and the triangles the merges removed (the inputs when every
        triangle keeps more than `CAP_RTOL` of the mean triangle's area along its
        former normal, or nothing can be merged); ``normals``: each triangle's unit
        normal before the placement (zero where it had no area), for `_place._unflip`
        (a merged triangle never was at ``v0``: its shape there says nothing).

    Examples
    --------
    Vertices 3 and 4 inside a triangle placed onto its edge x = 0: the triangles
    they leave without area go, the triangle is whole again.

    >>> v = np.array([[0, 0, 0], [0, 2, 0], [2, 1, 0], [0.1, 1, 0], [0.3, 1.5, 0.0]])
    >>> t = np.array([[0, 2, 3], [3, 2, 4], [4, 2, 1], [0, 3, 1], [3, 4, 1]])
    >>> x = v.copy(); x[3, 0] = x[4, 0] = 0.0
    >>> out = untangle(v, x, t, np.array([0, 0, 0, 1, 1]), np.ones(2, bool),
    ...                np.arange(5), np.arange(5), np.arange(5))
    >>> out[1].tolist(), out[2].tolist(), (out[7] == [0, 0, 1]).all()
    ([[0.0, 0.0, 0.0], [0.0, 2.0, 0.0], [2.0, 1.0, 0.0]], [[0, 2, 1]], np.True_)
    """
    return _untangle(merge_round, v0, placed, triangles, face, flat, source, kept, went)


def _untangle(one_pass, v0, placed, triangles, face, flat, source, kept, went):
    """`untangle`, each pass over the triangles left without area made by
    ``one_pass`` (`_untangle_kernels.merge_round`, or the tests' plain Python one:
    the same arguments and answer)."""
    v0 = np.asarray(v0, dtype=np.float64)
    x = np.asarray(placed, dtype=np.float64)
    rows = np.array(triangles, dtype=np.int64)
    face = np.array(face, dtype=np.int64)  # a flipped cap takes its neighbour's face
    c0 = _cross(v0, rows)
    twice = np.linalg.norm(c0, axis=1)
    side = c0 / np.maximum(twice, 1e-300)[:, None]
    out = (v0, x, rows, face, source, kept, went, side)
    if rows.shape[0] == 0:
        return out
    tiny = 2.0 * CAP_RTOL * float(0.5 * twice.mean())  # twice the area, as `_cross`
    rank = _flat_faces(rows, face, flat, x.shape[0]).astype(np.float64)
    rank[outline_vertices(rows)] = np.inf  # an open boundary's vertex is never merged away
    into = np.arange(x.shape[0])
    alive = np.ones(rows.shape[0], dtype=bool)
    ring, deg = triangle_rings(rows, alive, x.shape[0])
    merged = False
    for _ in range(ROUNDS):
        area = np.einsum("ij,ij->i", side, _cross(x, rows))
        bad = np.flatnonzero(alive & (area <= tiny) & (twice > 0.0))
        if bad.size == 0:
            break
        order = bad[np.argsort(area[bad], kind="stable")]
        done, ring = one_pass(x, rows, side, face, ring, deg, alive, into, rank, order, tiny)
        if done == 0:
            break
        merged = True
    if not merged:
        return out
    return (*compact(rows, alive, into, (v0, x), face, source, kept, went), side[alive])


def _flat_faces(rows, face, flat, n_v: int) -> np.ndarray:
    """The number of flat faces around every vertex."""
    pairs = unique_pairs(np.column_stack([rows.reshape(-1), np.repeat(face, 3)]))
    pairs = pairs[flat[pairs[:, 1]]]
    return np.bincount(pairs[:, 0], minlength=n_v)

"""Triangles of a mesh that pass through each other (`self_intersections`), and a
step's moves that made them put back (`uncrossed`).

"Closed, manifold, oriented" counts edges and cannot see a surface that passes
through itself, which a boolean operation or a 3-D printer's slicer trips on. Two
triangles cross when they share no edge and have a common segment beyond a corner
they share, longer than `CROSSING_RTOL` of the diagonal (each reaching past it to
both sides of the other's plane; a planar face's triangles are tested in its plane):
tested pair by pair on the candidates whose boxes meet (`_crossing_kernels`).
Open3D's `is_self_intersecting` skips every pair with a common corner (two triangles
of one fan can cross) and counts triangles that only touch, or do not meet.
"""

from __future__ import annotations

import numpy as np

from .._core import as_points
from .._core.tolerances import CROSSING_FLAT_RTOL, CROSSING_RTOL
from ._crossing_kernels import crossings
from ._mesh import _as_triangles

__all__ = ["between_faces", "crossing_pairs", "self_intersections", "uncrossed"]


def self_intersections(vertices, triangles) -> np.ndarray:
    """Pairs of triangles of a mesh that pass through each other.

    Parameters
    ----------
    vertices : array_like of shape (V, 3), float64
        Mesh vertices (finite).
    triangles : array_like of shape (T, 3), int
        Triangles (T >= 1).

    Returns
    -------
    pairs : ndarray of shape (P, 2), int64
        Triangle indices ``(a, b)``, ``a < b``, in lexicographic order, of every pair
        that shares no edge and has a common point other than a shared corner, by
        more than ``CROSSING_RTOL`` of the bounding-box diagonal (pairs that only
        touch are not counted). Triangles without area never cross.

    Raises
    ------
    ValueError
        If ``vertices`` is not finite of shape (V, 3), or ``triangles`` does not have
        shape (T, 3) with indices into ``vertices``.

    Notes
    -----
    Candidates are the pairs whose bounding boxes meet (a sweep along x); each is
    decided by the interval test of Möller (1997). Coordinates are taken from the
    box's centre, so the test does not lose digits far from the origin.

    Examples
    --------
    >>> import numpy as np
    >>> v = [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0.5, 0.5, -1], [0.5, 0.5, 1], [2, 2, 0]]
    >>> self_intersections(v, [[0, 1, 2], [3, 4, 5]])
    array([[0, 1]])
    >>> self_intersections(v, [[0, 1, 2], [1, 5, 2]]).shape
    (0, 2)
    """
    x = as_points(vertices, name="vertices")
    return crossing_pairs(x, _as_triangles(triangles, x.shape[0]))


def crossing_pairs(x: np.ndarray, tri: np.ndarray, live=None) -> np.ndarray:
    """`self_intersections` of vertices ``x`` (V, 3) float64 and triangles ``tri``
    (T, 3) int64, both valid (not checked); no triangle: none. ``live``: (T,) bool,
    only the pairs with a live triangle (default: all)."""
    if tri.shape[0] == 0:
        return np.zeros((0, 2), dtype=np.int64)
    lo = x.min(axis=0)
    hi = x.max(axis=0)
    centred = np.ascontiguousarray(x - 0.5 * (lo + hi))
    diag = float(np.linalg.norm(hi - lo))
    if live is None:
        live = np.ones(tri.shape[0], dtype=bool)
    pairs = crossings(centred, tri, CROSSING_RTOL * diag, CROSSING_FLAT_RTOL * diag, live)
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    return pairs[order]


def _codes(pairs: np.ndarray, n: int) -> np.ndarray:
    return pairs[:, 0] * n + pairs[:, 1]


def between_faces(pairs: np.ndarray, face) -> np.ndarray:
    """The ``pairs`` of triangles in two faces (``face``: each triangle's; None: all)."""
    if face is None:
        return pairs
    return pairs[face[pairs[:, 0]] != face[pairs[:, 1]]]


def uncrossed(before, after, tri, rounds: int = 8, face=None):
    """``after`` with a moved vertex of every triangle pair that crosses there and not
    at ``before`` put back where it was in ``before`` (the corner of the pair that
    moved most), pass by pass (at most ``rounds``): a step's moves that made the
    surface pass through itself undone where they did (private; valid arrays). Only
    pairs with a triangle at a moved vertex can be new: only those are tried. With
    ``face`` (each triangle's), only pairs in two faces (one face's folds are left to
    `_unfold`)."""
    n = max(tri.shape[0], 1)
    moved = (after != before).any(axis=1)
    live = moved[tri].any(axis=1)
    if not live.any():
        return after
    was = _codes(crossing_pairs(before, tri, live), n)
    y = after.copy()
    for _ in range(rounds):
        pairs = between_faces(crossing_pairs(y, tri, live), face)
        new = pairs[~np.isin(_codes(pairs, n), was)]
        if new.shape[0] == 0:
            break
        corners = tri[new].reshape(-1, 6)  # each pair's six corners
        move = np.linalg.norm(y[corners] - before[corners], axis=2)
        if not (move > 0).any():
            break
        verts = np.unique(corners[np.arange(corners.shape[0]), np.argmax(move, axis=1)])
        y[verts] = before[verts]
    return y

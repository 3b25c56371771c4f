"""Planar pieces after the local denoise: a global step for normals and positions.

The local pipeline (`normal_voting_denoise`) fits each returned normal over at
most 48 neighbours; at about 1 l of noise the denoised positions keep a
low-frequency residual at that scale, which tilts the fits near sharp edges
(docs/decisions/denoise.md, "Edges in the benchmark"). Here the denoised points
are grouped into planar pieces with a larger support (region growing on a fixed
plane, refitted twice); the points of a piece take its plane normal and move onto
the plane. The decisions and measurements are in docs/decisions/denoise.md,
"Planar pieces".

Kernels assume validated input (finite float64 arrays, unit normals, index tables
whose rows start with the point itself) and never validate.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .._core import readonly_view
from ..neighbors import query_knn
from ..normals._kernels.eig3 import eig3_fast, sym3_eigen_scalars

__all__ = ["snap_to_pieces"]

#: neighbours (the point itself included) of the growth graph and of the assignment
PIECE_GRAPH = 13
#: neighbours (the point itself included) of a seed's plane and of the seed order
PIECE_SEED = 25
#: growth and assignment: distance to the piece's plane at most PIECE_DIST l ...
PIECE_DIST = 0.4
#: ... and, in the growth, the point's normal within PIECE_ANGLE degrees of the
#: plane's (up to sign)
PIECE_ANGLE = 10.0
#: assignment: the point's normal within PIECE_ASSIGN_ANGLE degrees of the plane's
#: (fewer curved points next to a face take its plane), PIECE_ASSIGN_ANGLE_HIGH after
#: a denoise of several rounds (about 1 l of noise, where the local normals near
#: edges are 15-20 degrees off)
PIECE_ASSIGN_ANGLE = 7.0
PIECE_ASSIGN_ANGLE_HIGH = 15.0
#: points of an accepted piece (the sharp sphere's and fertility's pieces stay below)
PIECE_MIN = 150
#: a point within PIECE_AMBIGUOUS l of a second piece's plane (at an edge) keeps its normal
PIECE_AMBIGUOUS = 0.75
#: a piece is kept when at least PIECE_EDGE_SHARE of its border (the neighbours
#: outside it) has normals more than PIECE_EDGE_ANGLE degrees off its plane: CAD
#: faces end at sharp edges (0.22-0.9 on the bench's CAD inputs), the flattest
#: patches of smooth surfaces do not (torus 0.01-0.06, double torus 0.08-0.18)
PIECE_EDGE_ANGLE = 30.0
PIECE_EDGE_SHARE = 0.2
#: share of its distance a point that takes a piece moves onto the piece's plane
PIECE_PROJECT = 1.0
#: refits of a growing piece's plane (grow, fit, grow again), skipped once a
#: growth stays below 1 / PIECE_HOPELESS of PIECE_MIN
PIECE_REFITS = 2
PIECE_HOPELESS = 3


@njit(cache=True, inline="always")
def _scatter(points, idx, m):
    """Centroid (c0, c1, c2) and scatter matrix entries (a00, a01, a02, a11, a12, a22)
    of ``points[idx[:m]]`` (two passes: the mean, then the centred sums)."""
    c0 = 0.0
    c1 = 0.0
    c2 = 0.0
    for a in range(m):
        j = idx[a]
        c0 += points[j, 0]
        c1 += points[j, 1]
        c2 += points[j, 2]
    c0 /= m
    c1 /= m
    c2 /= m
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    for a in range(m):
        j = idx[a]
        d0 = points[j, 0] - c0
        d1 = points[j, 1] - c1
        d2 = points[j, 2] - c2
        a00 += d0 * d0
        a01 += d0 * d1
        a02 += d0 * d2
        a11 += d1 * d1
        a12 += d1 * d2
        a22 += d2 * d2
    return c0, c1, c2, a00, a01, a02, a11, a12, a22


@njit(cache=True)
def _fit_plane(points, members, m, centre, normal):
    """Least-squares plane of ``points[members[:m]]``: writes its centroid and unit
    normal (least eigenvector of the covariance), signed like the ``normal`` given."""
    c0, c1, c2, a00, a01, a02, a11, a12, a22 = _scatter(points, members, m)
    _, _, _, _, _, _, n0, n1, n2 = sym3_eigen_scalars(a00, a01, a02, a11, a12, a22)
    s = -1.0 if n0 * normal[0] + n1 * normal[1] + n2 * normal[2] < 0.0 else 1.0
    centre[0], centre[1], centre[2] = c0, c1, c2
    normal[0], normal[1], normal[2] = s * n0, s * n1, s * n2


@njit(cache=True)
def _grow(points, normals, graph, seed, centre, normal, free, mark, stamp, members, dist, cos_a):
    """Breadth-first growth from ``seed`` over ``graph`` through ``free`` points within
    ``dist`` of the fixed plane (centre, normal) whose normal is within the angle of
    ``cos_a`` (up to sign); ``mark``/``stamp`` flag the visited points. Returns the
    number of members (written to ``members``, the seed first)."""
    members[0] = seed
    mark[seed] = stamp
    m = 1
    head = 0
    while head < m:
        i = members[head]
        head += 1
        for c in range(1, graph.shape[1]):
            j = graph[i, c]
            if mark[j] == stamp or not free[j]:
                continue
            h = (
                (points[j, 0] - centre[0]) * normal[0]
                + (points[j, 1] - centre[1]) * normal[1]
                + (points[j, 2] - centre[2]) * normal[2]
            )
            g = normals[j, 0] * normal[0] + normals[j, 1] * normal[1] + normals[j, 2] * normal[2]
            if abs(h) > dist or abs(g) < cos_a:
                continue
            mark[j] = stamp
            members[m] = j
            m += 1
    return m


@njit(cache=True)
def _edge_share(normals, graph, members, m, mark, inside, seen, seen_stamp, normal, cos_edge):
    """Share of the piece's border (``graph`` neighbours of its ``m`` members, not
    marked ``inside``, each counted once via ``seen``) whose normal is more than
    arccos(cos_edge) from the plane's (up to sign): how much of it ends at a sharp edge."""
    border = 0
    sharp = 0
    for a in range(m):
        i = members[a]
        for c in range(1, graph.shape[1]):
            j = graph[i, c]
            if mark[j] == inside or seen[j] == seen_stamp:
                continue
            seen[j] = seen_stamp
            border += 1
            g = normals[j, 0] * normal[0] + normals[j, 1] * normal[1] + normals[j, 2] * normal[2]
            if abs(g) < cos_edge:
                sharp += 1
    return sharp / border if border else 0.0


@njit(cache=True)
def pieces_kernel(
    points,
    normals,
    graph,
    seeds,
    order,
    seedable,
    dist,
    cos_a,
    min_size,
    refits,
    cos_edge,
    edge_share,
    label,
    centres,
    plane_normals,
):
    """Greedy planar pieces (docs/decisions/denoise.md, "Planar pieces").

    ``seedable`` points, in ``order``, not yet tried start a piece on the plane of
    their ``seeds`` row; it grows (`_grow`) through points of no piece on that
    fixed plane, which is then refitted to the members ``refits`` times, each
    followed by a new growth. A piece of at least ``min_size`` points whose
    border ends at a sharp edge (normals more than arccos(cos_edge) off its
    plane) for at least ``edge_share`` of its points is kept (its plane refitted
    to its points); the points of a rejected one seed no more.
    Writes ``label`` (piece or -1), ``centres`` and ``plane_normals`` (one row per
    piece) and returns the number of pieces.
    """
    n = points.shape[0]
    tried = ~seedable
    free = np.ones(n, dtype=np.bool_)
    mark = np.full(n, -1, dtype=np.int64)
    members = np.empty(n, dtype=np.int64)
    seen = np.full(n, -1, dtype=np.int64)
    centre = np.empty(3)
    normal = np.empty(3)
    stamp = 0
    count = 0
    tests = 0
    for s in order:
        if tried[s]:
            continue
        for c in range(3):
            normal[c] = normals[s, c]
        _fit_plane(points, seeds[s], seeds.shape[1], centre, normal)
        m = 0
        for it in range(refits + 1):
            m = _grow(
                points, normals, graph, s, centre, normal, free, mark, stamp, members, dist, cos_a
            )
            stamp += 1
            if m * PIECE_HOPELESS < min_size:  # a curved patch or noise: no refits
                break
            if it < refits:
                _fit_plane(points, members, m, centre, normal)
        for a in range(m):
            tried[members[a]] = True
        if m < min_size:
            continue
        _fit_plane(points, members, m, centre, normal)
        tests += 1
        share = _edge_share(
            normals, graph, members, m, mark, stamp - 1, seen, tests, normal, cos_edge
        )
        if share < edge_share:  # bounded by smooth surface: a curved patch
            continue
        for a in range(m):
            label[members[a]] = count
            free[members[a]] = False
        for c in range(3):
            centres[count, c] = centre[c]
            plane_normals[count, c] = normal[c]
        count += 1
    return count


@njit(parallel=True, cache=True)
def assign_kernel(
    points,
    normals,
    graph,
    label,
    centres,
    plane_normals,
    dist,
    cos_a,
    ambiguous,
    project,
    out,
    out_points,
    assigned,
):
    """Each point takes the plane normal (signed like its own) of the piece among its
    ``graph`` row whose plane is nearest, when that plane is within ``dist``, its
    normal within the angle of ``cos_a`` and no second piece's plane is within
    ``ambiguous`` (a point at an edge keeps its normal); such a point also moves
    ``project`` (0-1) of its distance onto the plane. ``out``/``out_points``: the
    new normals and positions (copies of the old elsewhere); ``assigned``: the
    piece or -1.
    """
    n = points.shape[0]
    for i in prange(n):
        best = -1
        second = -1
        d_best = math.inf
        d_second = math.inf
        h_best = 0.0
        for c in range(graph.shape[1]):
            q = label[graph[i, c]]
            if q < 0 or q == best or q == second:
                continue
            h = (
                (points[i, 0] - centres[q, 0]) * plane_normals[q, 0]
                + (points[i, 1] - centres[q, 1]) * plane_normals[q, 1]
                + (points[i, 2] - centres[q, 2]) * plane_normals[q, 2]
            )
            if abs(h) < d_best:
                second, d_second = best, d_best
                best, d_best, h_best = q, abs(h), h
            elif abs(h) < d_second:
                second, d_second = q, abs(h)
        for c in range(3):
            out[i, c] = normals[i, c]
            out_points[i, c] = points[i, c]
        assigned[i] = -1
        if best < 0 or d_best > dist or d_second < ambiguous:
            continue
        g = (
            normals[i, 0] * plane_normals[best, 0]
            + normals[i, 1] * plane_normals[best, 1]
            + normals[i, 2] * plane_normals[best, 2]
        )
        if abs(g) < cos_a:
            continue
        s = -1.0 if g < 0.0 else 1.0
        for c in range(3):
            out[i, c] = s * plane_normals[best, c]
            out_points[i, c] = points[i, c] - project * h_best * plane_normals[best, c]
        assigned[i] = best


@njit(parallel=True, cache=True)
def flatness_ratio_kernel(points, table, out):
    """``out[i]`` = lambda_min / (lambda_1 + lambda_2 + lambda_3) of the covariance of
    point i's ``table`` row (0 where the row is a single point repeated)."""
    n = points.shape[0]
    k = table.shape[1]
    for i in prange(n):
        _, _, _, a00, a01, a02, a11, a12, a22 = _scatter(points, table[i], k)
        l1, l2, l3 = eig3_fast(a00, a01, a02, a11, a12, a22)
        total = l1 + l2 + l3
        out[i] = l3 / total if total > 0.0 else 0.0


def _seed_order(points, table):
    """Points by increasing flatness ratio of their ``table`` row (the flattest seed
    first; ties by index)."""
    ratio = np.empty(points.shape[0])
    flatness_ratio_kernel(points, table, ratio)
    return np.argsort(ratio, kind="stable")


def snap_to_pieces(points, normals, is_face, spacing, *, high_noise=False, table=None):
    """Normals (and positions) of the points of planar pieces from their planes
    (validated input).

    Parameters
    ----------
    points : ndarray of shape (N, 3), float64
        Denoised positions.
    normals : ndarray of shape (N, 3), float64
        Their unit normals (the local pipeline's).
    is_face : ndarray of shape (N,), bool
        Points that may seed a piece (face class); pieces grow through all.
    spacing : float
        l, the unit of the distances.
    high_noise : bool
        The denoise ran several rounds (about 1 l of noise): the assignment
        accepts normals up to PIECE_ASSIGN_ANGLE_HIGH off the plane.
    table : ndarray of shape (N, K), int64, optional
        Nearest neighbours, each row starting with its point, K >= PIECE_SEED
        (the denoise's table of the input serves: the points moved by less
        than l); None: queried on ``points``.

    Returns
    -------
    normals : ndarray of shape (N, 3), float64
        The new normals (a copy; unchanged where no piece is taken).
    points : ndarray of shape (N, 3), float64
        The new positions: a point that takes a piece moves PIECE_PROJECT of its
        distance onto its plane (a copy; unchanged elsewhere).
    piece : ndarray of shape (N,), int64
        The piece a point took, or -1.
    """
    # one kernel signature for API, CLI and tile inputs (docs/decisions/cli.md)
    points, normals = readonly_view(points), readonly_view(normals)
    n = points.shape[0]
    out = normals.copy()
    out_points = points.copy()
    piece = np.full(n, -1, dtype=np.int64)
    if n < max(PIECE_MIN, PIECE_SEED):
        return out, out_points, piece
    if table is None:
        table = query_knn(points, PIECE_SEED)[0]
    table = np.ascontiguousarray(table[:, :PIECE_SEED])
    graph = np.ascontiguousarray(table[:, :PIECE_GRAPH])
    order = _seed_order(points, table)
    label = np.full(n, -1, dtype=np.int64)
    centres = np.empty((n // PIECE_MIN + 1, 3))
    plane_normals = np.empty_like(centres)
    count = pieces_kernel(
        points,
        normals,
        graph,
        table,
        order,
        is_face,
        PIECE_DIST * spacing,
        math.cos(math.radians(PIECE_ANGLE)),
        PIECE_MIN,
        PIECE_REFITS,
        math.cos(math.radians(PIECE_EDGE_ANGLE)),
        PIECE_EDGE_SHARE,
        label,
        centres,
        plane_normals,
    )
    if count:
        angle = PIECE_ASSIGN_ANGLE_HIGH if high_noise else PIECE_ASSIGN_ANGLE
        assign_kernel(
            points,
            normals,
            graph,
            label,
            centres[:count],
            plane_normals[:count],
            PIECE_DIST * spacing,
            math.cos(math.radians(angle)),
            PIECE_AMBIGUOUS * spacing,
            PIECE_PROJECT,
            out,
            out_points,
            piece,
        )
    return out, out_points, piece

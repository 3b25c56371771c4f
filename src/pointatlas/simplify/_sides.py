"""Normals turned to the outside of a closed point set whose orientation broke
(private): `simplify_points` runs it on its input before anything else.

PCA normals oriented by propagation (`pointatlas.normals.orient_normals`) lose the
sign on thin walls: when both sides of a wall lie within a neighbourhood, the
propagation crosses the wall and turns one side's whole surface inward (every 6th
collection model sampled with 20,000 points: a connected half of `hfd_edge`'s points,
a third of a cable holder's). The robust path then takes the sample for an open one
and its surface comes out open. Here, when the normals' dipole test says open
(`is_closed_sample`), every point asks a voxel grid which of its two sides is the
outside: the grid's cells farther than a sampling gap from every point, connected to
the grid's border, are the outside; a point's outward side is the one where the
distance to the outside falls (probed a little beyond that gap on both sides). The
answers are smoothed over the point's neighbours on its own side of a wall, and the
new normals are kept only when they make the sample closed. Decisions:
docs/decisions/simplify.md, "Normals turned to the outside".
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as ss
from numba import njit
from scipy import ndimage
from scipy.sparse.csgraph import connected_components

from ..neighbors import query_knn
from ._edt import distance_to
from ._reconstruct import CLOSED_DIPOLE

__all__ = [
    "GAP_SPACINGS",
    "MAX_CELLS",
    "OPPOSED_COS",
    "TANGENT_COS",
    "TURN_CONFLICTS",
    "TURN_DIPOLE",
    "added_conflicts",
    "enclosed_volume",
    "neighbour_pairs",
    "outside_votes",
    "pair_components",
    "sheet_dots",
    "table_spacing",
    "turn_outward",
]

#: Cells farther than this many point spacings (median nearest-neighbour distance)
#: plus one cell from every point are empty: the largest sampling gap of 20,000
#: uniform samples is about 3.6 spacings across its radius, and a gap let the
#: outside into a cable holder's inside at 2.5.
GAP_SPACINGS = 4.5
#: At most about this many cells in the grid (a coarser cell beyond).
MAX_CELLS = 4_000_000
#: The votes are taken where the normals' dipole sum (normal times disc area, summed)
#: passes this share of the points' area: the true normals of every collection model
#: sampled with 20,000 points stay below 0.025, and the normals estimated with
#: `surface_normals` of a sampled cable clip (`prusai3_extruder-cable-clip`) read
#: 0.046 with 1,383 of them turned in, under the closed test's 0.05 (`CLOSED_DIPOLE`).
TURN_DIPOLE = 0.03
#: Neighbours smoothing the votes (the point itself included), and the rounds.
SMOOTH_K = 10
SMOOTH_ROUNDS = 2
#: The turn is kept only where it sets at most this many pairs of neighbours on one
#: sheet against each other per normal turned (`added_conflicts`): a right turn turns
#: whole sheets, which met the rest across walls and edges (0.02-0.19 on the
#: collection's estimated normals it turns), a wrong one cuts a rightly oriented
#: surface in two (a scan without its bottom, whose inside the grid's outside
#: reaches through the missing side: 0.8-2.1, and no surface at all after it) ...
TURN_CONFLICTS = 0.5
#: ... neighbours on one sheet: their edge within this cosine of both tangent planes;
#: opposed when their normals' cosine is below minus this, agreeing above it.
TANGENT_COS = 0.25
OPPOSED_COS = 0.7


def _grid(q: np.ndarray, spacing: float):
    """Cell size, origin, shape and the empty-cell radius of the probing grid."""
    lo, hi = q.min(axis=0), q.max(axis=0)
    ext = hi - lo
    step = spacing
    while True:
        reach = GAP_SPACINGS * spacing + step
        pad = int(np.ceil(reach / step)) + 4
        shape = np.ceil(ext / step).astype(np.int64) + 2 * pad + 1
        if int(np.prod(shape)) <= MAX_CELLS:
            break
        step *= 1.25
    return step, lo - pad * step, shape, reach


def table_spacing(dist) -> float:
    """The points' spacing from a k-NN table's ``dist`` (the point itself first): the
    median distance to the nearest other point, repeats left out; 0 if all repeat."""
    near = np.asarray(dist)[:, 1]
    return float(np.median(near[near > 0])) if (near > 0).any() else 0.0


def outside_votes(q: np.ndarray, normals: np.ndarray, spacing: float) -> np.ndarray:
    """Per point +1 when its normal points to the outside, -1 when it points in,
    0 when both sides are alike (an open sheet: both sides outside).

    The outside: grid cells farther than the empty-cell radius from every point,
    connected to the grid's border (the inside of a closed sample does not reach
    it). Each point compares the distance to the outside at two depths on either side.
    """
    step, origin, shape, reach = _grid(q, spacing)
    cells = np.floor((q - origin) / step).astype(np.int64)
    occupied = np.ones(tuple(shape), dtype=bool)
    occupied[tuple(cells.T)] = False
    empty = distance_to(~occupied) * step > reach
    del occupied
    lab, _ = ndimage.label(empty)
    outside = lab == lab[0, 0, 0]  # the padded corner is always empty
    del lab, empty
    depth = distance_to(outside)
    top = shape - 1

    def at(x):
        c = np.clip(np.floor((x - origin) / step).astype(np.int64), 0, top)
        return depth[tuple(c.T)]

    votes = np.zeros(q.shape[0])
    for probe in (reach + 1.5 * step, reach + 2.5 * step):
        votes += np.sign(at(q - probe * normals) - at(q + probe * normals))
    return np.sign(votes)


def _smoothed(q, normals, votes, indices) -> np.ndarray:
    """Votes taken over the neighbours on the same side of a wall (normals within
    60 degrees of parallel, the edge within 30 degrees of the tangent plane; a
    neighbour's vote counts with the sign of n_i . n_j), `SMOOTH_ROUNDS` times
    (`_smoothed_kernel`; plain numpy: `_smoothed_reference` in
    tests/simplify/test_sides.py)."""
    # writable C copies: one compiled signature whatever the caller's arrays
    q = np.array(q, dtype=np.float64, order="C")
    normals = np.array(normals, dtype=np.float64, order="C")
    votes = np.array(votes, dtype=np.float64, order="C")
    indices = np.array(indices, dtype=np.int64, order="C")
    return _smoothed_kernel(q, normals, votes, indices, SMOOTH_ROUNDS)


@njit(cache=True)
def _smoothed_kernel(q, normals, votes, indices, rounds):
    n, k = indices.shape
    w = np.zeros((n, k))
    for i in range(n):
        for a in range(k):
            j = indices[i, a]
            e0, e1, e2 = q[j, 0] - q[i, 0], q[j, 1] - q[i, 1], q[j, 2] - q[i, 2]
            length = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            h = normals[i, 0] * e0 + normals[i, 1] * e1 + normals[i, 2] * e2
            c = normals[i, 0] * normals[j, 0] + normals[i, 1] * normals[j, 1]
            c += normals[i, 2] * normals[j, 2]
            if length == 0.0 or (abs(h) < 0.5 * length and abs(c) > 0.5):
                w[i, a] = np.sign(c)
    v = votes.copy()
    for _ in range(rounds):
        out = v.copy()
        for i in range(n):
            s = 0.0
            for a in range(k):
                s += w[i, a] * v[indices[i, a]]
            if s != 0.0:
                out[i] = np.sign(s)
        v = out
    return v


def turn_outward(
    q: np.ndarray, normals: np.ndarray, neighbors=None, areas=None
) -> tuple[np.ndarray, int]:
    """``normals`` with the inward-turned ones flipped, and how many were; unchanged
    (0) when the points' dipole sum is at most `TURN_DIPOLE` of their area, or the
    flipped normals would not make the sample closed (`CLOSED_DIPOLE`) with a
    smaller sum (an open sheet, a shape open to the grid's border). All of them are
    flipped where the dipole sum says closed but the volume they enclose is negative
    (`enclosed_volume`: normals given pointing in).

    ``neighbors``: ``(indices, distances)``, a `query_knn` table of ``q`` with at
    least `SMOOTH_K` columns (its first `SMOOTH_K` are used; searched when None);
    ``areas``: the points' disc areas (`is_closed_sample`; found when None)."""
    from ._winding import dipole_share, point_areas

    if q.shape[0] < SMOOTH_K:
        return normals, 0
    area = point_areas(q) if areas is None else areas
    before = dipole_share(q, normals, area)
    if before <= TURN_DIPOLE:
        if enclosed_volume(q, normals, area) < 0.0:  # closed, and every normal in
            return -normals, int(normals.shape[0])
        return normals, 0
    if neighbors is None:
        idx, dist = query_knn(q, SMOOTH_K)
    else:
        idx, dist = neighbors[0][:, :SMOOTH_K], neighbors[1][:, :SMOOTH_K]
    near = np.asarray(dist)[:, 1:]
    positive = near[near > 0]
    if positive.size == 0:
        return normals, 0
    spacing = table_spacing(dist) or float(np.median(positive))
    votes = _smoothed(q, normals, outside_votes(q, normals, spacing), np.asarray(idx))
    flip = votes < 0
    if not flip.any():
        return normals, 0
    turned = np.where(flip[:, None], -normals, normals)
    after = dipole_share(q, turned, area)
    if after > CLOSED_DIPOLE or after >= before:  # not closed, or no nearer it
        return normals, 0
    if added_conflicts(q, normals, flip, np.asarray(idx)) > TURN_CONFLICTS * flip.sum():
        return normals, 0  # it cuts a rightly oriented surface: not a whole sheet
    return turned, int(flip.sum())


def enclosed_volume(q, normals, areas) -> float:
    """The volume a closed sample's oriented points enclose, by the divergence
    theorem: the sum of area x (q . normal) / 3 (negative when the normals point in).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(4000, 3)); u /= np.linalg.norm(u, axis=1)[:, None]
    >>> round(enclosed_volume(u, u, np.full(4000, 4 * np.pi / 4000)), 2)  # 4 pi / 3
    4.19
    """
    areas = np.asarray(areas, dtype=np.float64)
    total = float(areas.sum())
    # about the points' centroid: a sample not quite closed (its dipole sum D not 0)
    # is off by D . c / 3 for an origin c away (a part 400 units from the origin
    # read +9,669 with every normal in)
    c = areas @ q / total if total > 0.0 else np.zeros(3)
    return float(np.dot(areas, np.einsum("ij,ij->i", q - c, normals)) / 3.0)


def added_conflicts(q, normals, flip, indices) -> int:
    """How many more pairs of neighbours (rows of ``indices``, the point itself first)
    on one sheet (their edge within `TANGENT_COS` of both tangent planes) have
    opposite normals (cosine below -`OPPOSED_COS`) after the normals ``flip`` marks are turned
    than before (fewer: negative); only the pairs with one end turned change.

    Examples
    --------
    >>> g = np.stack(np.meshgrid(np.arange(4.0), np.arange(4.0)), -1).reshape(-1, 2)
    >>> q = np.c_[g, np.zeros(16)]
    >>> n = np.tile([0.0, 0.0, 1.0], (16, 1))
    >>> idx = np.argsort(((q[:, None] - q[None]) ** 2).sum(-1), axis=1, kind="stable")[:, :5]
    >>> added_conflicts(q, n, q[:, 0] < 1.5, idx) > 0  # half a flat sheet turned
    True
    >>> added_conflicts(q, n, np.ones(16, dtype=bool), idx)  # all of it
    0
    """
    rows, cols = neighbour_pairs(indices)
    one = flip[rows] != flip[cols]
    _, dot = sheet_dots(q, normals, rows[one], cols[one])
    return int(np.count_nonzero(dot > OPPOSED_COS)) - int(np.count_nonzero(dot < -OPPOSED_COS))


def neighbour_pairs(indices):
    """``(rows, cols)``: every point and each of its neighbours in a k-NN table
    ``indices`` (the point itself first, left out), row by row."""
    rows = np.repeat(np.arange(indices.shape[0]), indices.shape[1] - 1)
    return rows, indices[:, 1:].reshape(-1)


def pair_components(size: int, rows, cols) -> np.ndarray:
    """Each of ``size`` points' label: the connected components of the pairs
    ``rows[a]``, ``cols[a]``."""
    graph = ss.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(size, size))
    return connected_components(graph, directed=False)[1]


def sheet_dots(q, normals, i, j):
    """``(sheet, dot)``: which pairs of points ``i[a]``, ``j[a]`` lie on one sheet
    (their edge within `TANGENT_COS` of both tangent planes), and the cosine of their
    normals for those pairs."""
    e = q[j] - q[i]
    e /= np.maximum(np.linalg.norm(e, axis=1), 1e-300)[:, None]
    ni, nj = normals[i], normals[j]
    sheet = (np.abs(np.einsum("ij,ij->i", ni, e)) < TANGENT_COS) & (
        np.abs(np.einsum("ij,ij->i", nj, e)) < TANGENT_COS
    )
    return sheet, np.einsum("ij,ij->i", ni[sheet], nj[sheet])

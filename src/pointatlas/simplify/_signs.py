"""Estimated normals turned outward: whole sheets, then the small patches the
orientation left inward (private; public as `outward_normals`).

On a closed sample, whole sheets the voxel outside cannot judge (a tube's inner
wall: both its sides are outside) are first turned by the winding number far from
the points (`_sheets.far_sheet_flips`).

Normals oriented by propagation (`pointatlas.normals.orient_normals`) cross thin
walls and edges: whole sheets come out turned inward (`_sides.turn_outward` turns
them back by the voxel outside), and so do patches of tens to hundreds of points
beside thin walls, slots and edges, which the voxel outside does not reach (on the
collection's raw points, 20,000 a model: 0-2,040 points left inward after the
sheets were turned). The robust path's field takes its sides from those normals,
and an inward patch puts a handle or a pocket in the surface: given the true signs
with the estimated directions, 9 of the 30 models that missed the input's Euler
characteristic got it. Here the points are cut into patches whose neighbours lie
on one plane (within `PATCH_SPACINGS` point spacings) with agreeing normals; a
patch that disagrees with more of its neighbours on one sheet than it agrees with
is asked which of its sides is inside: the winding number of all the other points
(`_winding`, Barill et al. 2018), a little behind and a little in front of each
of its points (`PROBE_SPACINGS`), its own points left out (a patch's own discs
always read as consistent with themselves). It is turned where the rest says its
front is inside. Last, sheets of tens of points or more are turned by the winding
number of all the points near them (`_sheets.near_sheet_flips`): a pocket turned
inward as a whole, walls and floor, agrees with itself across its edges, so no
patch of it disagrees. Then the patches are asked once more, by the parity of ray
crossings (`_parity`, `parity_turns`): a patch whose neighbours are wrong too (a
wall's side turned with the wall) reads them through the winding number, but the
crossings need no signs. Only a closed sample has an inside: open ones keep their
normals. A closed sample can read open (`_reconstruct.is_closed_sample`) where
whole parts of it are turned in (a thin-walled lid, 40 % of its points inward): the
crossings are asked there too, and their turns kept where the sample then reads
closed.
Decisions: docs/decisions/simplify.md, "Normals for raw points".
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from .._core import as_normals, as_points
from ..neighbors import query_knn
from ._parity import parity_votes
from ._reconstruct import is_closed_sample
from ._sheets import far_sheet_flips, near_sheet_flips
from ._sides import (
    OPPOSED_COS,
    SMOOTH_K,
    neighbour_pairs,
    pair_components,
    sheet_dots,
    table_spacing,
    turn_outward,
)
from ._winding import AREA_NEIGHBOR, MAX_POINTS, dipoles, table_areas

__all__ = [
    "FLIP_MARGIN",
    "MAX_PATCH_SHARE",
    "PATCH_COS",
    "PARITY_CLEAR",
    "PARITY_MARGIN",
    "PARITY_MIN_PATCH",
    "PARITY_SPREAD",
    "PARITY_VETO",
    "PATCH_SPACINGS",
    "PROBE_SPACINGS",
    "outward_normals",
    "parity_turns",
    "patch_signals",
    "winding_turns",
]

#: Neighbours (of the point's `SMOOTH_K` nearest) on one patch lie within this many
#: point spacings of both their tangent planes (or three times the neighbours'
#: median offset from them, on noisy points) ...
PATCH_SPACINGS = 0.15
#: ... and their normals agree this well (cosine).
PATCH_COS = 0.7
#: The probes lie this many spacings behind and in front of a patch's points (inside
#: a thin wall of 1.4 spacings).
PROBE_SPACINGS = 0.5
#: A patch is turned where the rest's winding number, behind its points less in
#: front of them (area-weighted mean), is below minus this.
FLIP_MARGIN = 0.02
#: Patches of more than this share of the points are left as they are (the bulk:
#: turned, where it was, by the voxel outside).
MAX_PATCH_SHARE = 0.25
#: Winding-number cells, in point spacings.
CELL_SPACINGS = 4.0
#: A patch of at least `PARITY_MIN_PATCH` points is turned where its points' mean
#: crossing parity vote (`_parity.parity_votes`, in [-1, 1]) is below minus this
#: margin, and below minus `PARITY_SPREAD` over the square root of its size (a
#: point's vote spreads by about 0.5-0.7: small patches need a clearer mean).
PARITY_MARGIN = 0.2
PARITY_SPREAD = 1.0
PARITY_MIN_PATCH = 10
#: ... unless its mean is above minus `PARITY_CLEAR` and the winding number of the
#: other points says its front is outside (`patch_signals` above this).
PARITY_CLEAR = 0.5
PARITY_VETO = 0.1


def outward_normals(points, normals, *, neighbors=None) -> np.ndarray:
    """Oriented normals of a closed point set turned outward: whole sheets turned
    inward by the voxel outside (`_sides.turn_outward`), then by the winding number
    far from the points (`_sheets.far_sheet_flips`), then the patches still turned
    inward by the winding number of the other points, then those the parity of ray
    crossings finds inward (`parity_turns`; see the module's notes). An open sample
    keeps its normals (no inside); one that reads open, but closed once the
    crossings' turns are made, is a closed sample with parts turned in: the winding
    number's steps and the crossings are asked again on those.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, finite.
    normals : array_like of shape (N, 3)
        Oriented unit normals (`sharpen_normals`' or
        `pointatlas.normals.orient_normals`').
    neighbors : tuple, optional
        `pointatlas.neighbors.query_knn`'s ``(indices, distances)`` with at least
        `_sides.SMOOTH_K` columns, itself first; searched when None.

    Returns
    -------
    normals : ndarray of shape (N, 3), float64
        ``normals``, some turned (times -1).

    Raises
    ------
    ValueError
        If ``normals`` is not one unit row per point.
    NonFiniteError
        If ``points`` or ``normals`` hold NaN or Inf.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.normal(size=(4000, 3))
    >>> u /= np.linalg.norm(u, axis=1)[:, None]  # a sphere, normals out
    >>> n = u.copy()
    >>> patch = u @ [0.0, 0.0, 1.0] > 0.95  # a cap turned inward
    >>> n[patch] *= -1.0
    >>> inward = lambda m: int(((m * u).sum(axis=1) < 0.0).sum())
    >>> inward(n), inward(outward_normals(u, n))
    (95, 0)
    """
    pts = as_points(points)
    n = pts.shape[0]
    nrm = as_normals(normals, n, normalize=False)
    if n <= SMOOTH_K:
        return nrm.copy()
    if not isinstance(neighbors, tuple) or neighbors[0].shape[1] < SMOOTH_K:
        neighbors = query_knn(pts, SMOOTH_K)
    idx = np.ascontiguousarray(neighbors[0][:, :SMOOTH_K], dtype=np.int64)
    dist = np.asarray(neighbors[1][:, :SMOOTH_K], dtype=np.float64)
    areas = table_areas(dist, AREA_NEIGHBOR)
    out, _ = turn_outward(pts, nrm, (idx, dist), areas)
    out = winding_turns(pts, out, idx, dist, areas)
    if not is_closed_sample(pts, out, areas):
        # open, or closed with sheets turned in: the crossings need no signs
        trial = parity_turns(pts, out, idx, dist)
        if not is_closed_sample(pts, trial, areas):
            return out  # open: no inside to cross into
        out = winding_turns(pts, trial, idx, dist, areas)
    return parity_turns(pts, out, idx, dist)


def parity_turns(pts, out, idx, dist) -> np.ndarray:
    """The normals ``out`` of a closed sample ``pts`` (its `_sides.SMOOTH_K`-column
    k-NN table ``idx``, ``dist``) with the patches the rays' crossings say face
    inward turned: those of `PARITY_MIN_PATCH` points or more (and at most
    `MAX_PATCH_SHARE` of them) whose mean `_parity.parity_votes` is below
    -`PARITY_MARGIN` and -`PARITY_SPREAD` / sqrt(size), unless the other points'
    winding number says their front is outside (`patch_signals` above
    `PARITY_VETO`) and the crossings are not clear (the mean above -`PARITY_CLEAR`).
    The crossings need the normals' directions only: a patch is judged with no help
    from its neighbours' signs, which the winding number leans on; but a part whose
    shells overlap (two bodies of one STL) has a point inside the other body vote
    inward, where the winding number (2 there) still reads the side. Above
    `_winding.MAX_POINTS` points it decides on an even stride of them, as
    `winding_turns` does (each point as its nearest there, where they face alike)."""
    n = pts.shape[0]
    if n > MAX_POINTS:

        def decide(q, o, i, d):
            return np.einsum("ij,ij->i", parity_turns(q, o, i, d), o) < 0.0

        return np.where(_strided_flips(pts, out, decide)[:, None], -out, out)
    spacing = table_spacing(dist)
    if spacing == 0.0:
        return out
    lab = _patches(pts, out, idx, spacing)
    size = np.bincount(lab)
    mean = np.bincount(lab, weights=parity_votes(pts, out, spacing)) / size
    margin = np.maximum(PARITY_MARGIN, PARITY_SPREAD / np.sqrt(size))
    asked = (mean < -margin) & (size >= PARITY_MIN_PATCH)
    asked &= size <= MAX_PATCH_SHARE * n
    unclear = np.flatnonzero(asked & (mean >= -PARITY_CLEAR))
    if unclear.size:
        members = np.flatnonzero(np.isin(lab, unclear))
        probe, cell = PROBE_SPACINGS * spacing, CELL_SPACINGS * spacing
        signal = patch_signals(pts, out, lab, members, probe, cell)
        asked[unclear[signal[unclear] > PARITY_VETO]] = False
    return np.where(asked[lab][:, None], -out, out)


def winding_turns(pts, out, idx, dist, areas) -> np.ndarray:
    """`outward_normals`' steps after the voxel outside's vote: normals ``out`` of
    the points ``pts`` (their `_sides.SMOOTH_K`-column k-NN table ``idx``, ``dist``,
    disc ``areas``) with the sheets and patches the winding number finds turned
    inward turned out; unchanged on an open sample."""
    n = pts.shape[0]
    if not is_closed_sample(pts, out, areas):
        return out  # open: both sides outside
    if n <= MAX_POINTS:
        flip = _turned(pts, out, idx, dist, areas)
    else:

        def decide(q, o, i, d):
            return _turned(q, o, i, d, table_areas(d, AREA_NEIGHBOR))

        flip = _strided_flips(pts, out, decide)
    return np.where(flip[:, None], -out, out)


def _strided_flips(pts, out, decide) -> np.ndarray:
    """Which of the normals ``out`` to turn, decided on an even stride of the points
    (at most `_winding.MAX_POINTS`; ``decide(sub, sub_normals, idx, dist)``, given
    their own `_sides.SMOOTH_K`-column k-NN table, says which of them): each point
    as its nearest there, where their normals face alike."""
    stride = -(-pts.shape[0] // MAX_POINTS)
    sub = np.ascontiguousarray(pts[::stride])
    sub_out = out[::stride]
    sub_idx, sub_dist = query_knn(sub, SMOOTH_K)
    sub_flip = decide(sub, sub_out, np.asarray(sub_idx, dtype=np.int64), np.asarray(sub_dist))
    j = cKDTree(sub).query(pts, 1, workers=-1)[1]
    same = np.einsum("ij,ij->i", out, sub_out[j]) > 0.0
    return sub_flip[j] & same


def _turned(q, n, idx, dist, areas) -> np.ndarray:
    """Which normals of a closed sample to turn: whole sheets by the winding number
    far from the points (`_sheets.far_sheet_flips`), then the patches still turned
    inward (`_inward_patches`), then the sheets by the winding number near them
    (`_sheets.near_sheet_flips`)."""
    sheets = far_sheet_flips(q, n, idx, dist, areas)
    flip = sheets ^ _inward_patches(q, np.where(sheets[:, None], -n, n), idx, dist)
    return flip ^ near_sheet_flips(q, np.where(flip[:, None], -n, n), idx, dist, areas)


def _patches(q, n, idx, spacing: float):
    """Each point's patch label: components of the neighbour pairs within a
    tolerance of both tangent planes whose normals agree (`PATCH_COS`); the
    tolerance `PATCH_SPACINGS` point ``spacing``s, or three times the neighbours'
    median offset from their tangent planes on noisy points."""
    offsets = np.abs(np.einsum("ijk,ik->ij", q[idx[:, 1:]] - q[:, None, :], n))
    tol = max(PATCH_SPACINGS * spacing, 3.0 * float(np.median(offsets)))
    rows, cols = neighbour_pairs(idx)
    e = q[cols] - q[rows]
    on = (np.abs(np.einsum("ij,ij->i", n[rows], e)) <= tol) & (
        np.abs(np.einsum("ij,ij->i", n[cols], e)) <= tol
    )
    on &= np.einsum("ij,ij->i", n[rows], n[cols]) > PATCH_COS
    return pair_components(q.shape[0], rows[on], cols[on])


def _disagreeing(q, n, idx, lab) -> np.ndarray:
    """Per patch: whether more of its points' neighbours on one sheet in other patches
    face against it (cosine below -`OPPOSED_COS`) than with it (above it): turning it would
    set fewer pairs against each other (`_sides.added_conflicts`, per patch)."""
    rows, cols = neighbour_pairs(idx)
    keep = lab[rows] != lab[cols]
    rows, cols = rows[keep], cols[keep]
    sheet, dot = sheet_dots(q, n, rows, cols)
    m = int(lab.max()) + 1
    against, along = np.zeros(m, dtype=np.int64), np.zeros(m, dtype=np.int64)
    for end in (rows[sheet], cols[sheet]):  # a pair counts for the patches at both ends
        against += np.bincount(lab[end[dot < -OPPOSED_COS]], minlength=m)
        along += np.bincount(lab[end[dot > OPPOSED_COS]], minlength=m)
    return against > along


def _inward_patches(q, n, idx, dist) -> np.ndarray:
    """Which points lie on a patch whose front the other points' winding number
    says is inside (`patch_signals` below -`FLIP_MARGIN`)."""
    spacing = table_spacing(dist)
    flip = np.zeros(q.shape[0], dtype=bool)
    if spacing == 0.0:
        return flip
    lab = _patches(q, n, idx, spacing)
    size = np.bincount(lab)
    asked = np.flatnonzero(_disagreeing(q, n, idx, lab) & (size <= MAX_PATCH_SHARE * q.shape[0]))
    if asked.size == 0:
        return flip
    members = np.flatnonzero(np.isin(lab, asked))
    signal = patch_signals(q, n, lab, members, PROBE_SPACINGS * spacing, CELL_SPACINGS * spacing)
    turned = asked[signal[asked] < -FLIP_MARGIN]
    flip[np.isin(lab, turned)] = True
    return flip


def patch_signals(q, n, lab, members, probe: float, cell: float) -> np.ndarray:
    """Per patch label (a full-length array; NaN where no member): the area-weighted
    mean over its ``members`` of the winding number of the points outside the patch
    at ``probe`` behind each member less that at ``probe`` in front (positive:
    the normals point out). ``cell``: the winding number's cells (`_winding.dipoles`).
    Plain numpy: `patch_signals_reference` in tests/simplify/test_signs.py."""
    src = dipoles(q, n, cell)  # every point (at most MAX_POINTS: the caller's stride)
    behind, front = q[members] - probe * n[members], q[members] + probe * n[members]
    w_all = src.at(np.vstack([behind, front]))
    m = members.size
    order = np.argsort(lab, kind="stable")
    starts = np.searchsorted(lab[order], np.arange(int(lab.max()) + 2))
    own = _own_winding(behind, front, lab[members], q[order], src.dipoles[order], starts)
    diff = (w_all[:m] - own[:, 0]) - (w_all[m:] - own[:, 1])
    area = np.linalg.norm(src.dipoles[members], axis=1)
    total = np.bincount(lab[members], weights=area, minlength=starts.size - 1)
    signal = np.bincount(lab[members], weights=area * diff, minlength=starts.size - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return signal / total


@njit(cache=True, parallel=True)
def _own_winding(behind, front, patch, p, d, starts):
    """(m, 2): the winding number at ``behind[a]`` and ``front[a]`` of the points of
    patch ``patch[a]`` alone (``p``, ``d``: points and dipoles in patch order, patch
    c's at ``starts[c]:starts[c + 1]``)."""
    m = behind.shape[0]
    out = np.zeros((m, 2))
    for a in prange(m):
        c = patch[a]
        for side in range(2):
            x = behind[a] if side == 0 else front[a]
            s = 0.0
            for t in range(starts[c], starts[c + 1]):
                e0, e1, e2 = p[t, 0] - x[0], p[t, 1] - x[1], p[t, 2] - x[2]
                r2 = e0 * e0 + e1 * e1 + e2 * e2
                if r2 > 0.0:
                    s += (d[t, 0] * e0 + d[t, 1] * e1 + d[t, 2] * e2) / (r2 * np.sqrt(r2))
            out[a, side] = s / (4.0 * np.pi)
    return out

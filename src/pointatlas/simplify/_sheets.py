"""Whole sheets of a closed point set turned by the winding number far from the points,
and near them (private; steps of `outward_normals`).

Propagated normals cross a thin wall between its two sides: a tube whose wall is two
point spacings thick (`trimesh_round`, 20,000 points) came out with its whole inner
wall facing into the wall. The dipole test cannot see it (the two walls' normals
cancel in the sum, so the sample reads closed) and neither can the voxel outside
(both sides of the inner wall are outside). The winding number can: far from the
points (`FAR_SPACINGS`) a closed surface's is 0 outside and 1 inside, and a sheet
turned the wrong way sets it near 2 or -1 wherever it encloses (the tube's hole read
2). The points are cut into sheets (neighbours on one plane with agreeing normals,
`_sides.sheet_dots`); each sheet of at least `SHEET_SHARE` of the points is a
variable whose winding number at `FAR_PROBES` random points far from every point is
found once (the winding number is linear in the normals); normals that enclose a
negative volume are first all turned (inside, their winding number reads -1), then
sheets are turned one at a time, the one that brings the probes' winding numbers
nearest to 0 or 1 first, while a turn gains at least `FAR_GAIN` per probe. Where the
turned normals then enclose a negative volume, all of them are turned (a tube's
outer wall turned is its inner wall turned, seen from inside).

The last step of `outward_normals` (`near_sheet_flips`) asks the same of smaller
sheets, down to `NEAR_MIN_POINTS`, at probes near them too (`near_probes`): a pocket
turned inward as a whole, walls and floor, is a few sheets each far below
`SHEET_SHARE` that the box's probes seldom reach. Its gain is counted per probe a
turn moves, and sheets that touch are also turned together (a pocket's walls, whose
turns alone each leave its hollow read halfway). Decisions:
docs/decisions/simplify.md, "Normals for raw points".
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from ._sides import (
    OPPOSED_COS,
    enclosed_volume,
    neighbour_pairs,
    pair_components,
    sheet_dots,
    table_spacing,
)
from ._winding import cell_groups

__all__ = [
    "CELL_SPACINGS",
    "FAR_GAIN",
    "FAR_PROBES",
    "FAR_SPACINGS",
    "SHEET_SHARE",
    "far_sheet_flips",
    "near_probes",
    "near_sheet_flips",
    "sheet_winding",
]

#: Probes lie at least this many point spacings from every point (nearer, the
#: winding number of a few discs swings with the sampling) ...
FAR_SPACINGS = 2.0
#: ... at most this many, uniform in the points' box grown by `PAD_SPACINGS`.
FAR_PROBES = 2000
PAD_SPACINGS = 3.0
#: Sheets of at least this share of the points are turned (smaller ones are the
#: patches' step, `_signs`).
SHEET_SHARE = 0.01
#: Points of one sheet in a cube of this many spacings act as one dipole far off.
CELL_SPACINGS = 4.0
#: A turn is kept where the squared distance of the probes' winding numbers to the
#: nearer of 0 and 1, summed, falls by at least this much per probe.
FAR_GAIN = 1e-3
#: Sheets of at least this many points, and at most `NEAR_MAX_SHARE` of them, are
#: turned by the winding number near them too (`near_sheet_flips`: a pocket's walls
#: and floor, each below `SHEET_SHARE`, which the probes in the box seldom reach) ...
NEAR_MIN_POINTS = 20
NEAR_MAX_SHARE = 0.25
#: ... at probes this many point spacings in front of and behind every
#: `NEAR_STRIDE`-th of their points (those at least `FAR_SPACINGS` from every point) ...
NEAR_OFFSETS = (2.5, 4.0)
NEAR_STRIDE = 4
#: ... or a wider stride that leaves at most this many of them (a 20,000-point sample
#: keeps every 4th; the 50,000 of a large one's stride, `_winding.MAX_POINTS`, every
#: 10th: the winding number at the probes, probes x groups, took 1.3 of its 1.7 s) ...
NEAR_SOURCES = 5000
#: ... where the squared distance of the probes' winding numbers to the nearer of 0
#: and 1 falls by at least this much per probe the turn moves by more than
#: `NEAR_MOVED` (the probes of the whole box would ask a small sheet for a gain it
#: cannot give anywhere but near itself).
NEAR_GAIN = 0.02
NEAR_MOVED = 0.05
#: Sheets that touch are also turned together where each alone loses less than this
#: share of its need (and together they gain theirs) ...
JOINT_LOSS = 0.5
#: ... one at a time and together, at most this many rounds.
NEAR_ROUNDS = 3


def _sheets(q, n, idx):
    """Each point's sheet: components of the neighbour pairs on one plane
    (`_sides.sheet_dots`) whose normals agree (cosine above `_sides.OPPOSED_COS`)."""
    rows, cols = neighbour_pairs(idx)
    sheet, dot = sheet_dots(q, n, rows, cols)
    on = np.flatnonzero(sheet)[dot > OPPOSED_COS]
    return pair_components(q.shape[0], rows[on], cols[on])


def far_probes(q, spacing: float, count: int = FAR_PROBES, tree=None) -> np.ndarray:
    """Up to ``count`` points uniform in the box of ``q`` grown by `PAD_SPACINGS`
    spacings, each at least `FAR_SPACINGS` spacings from every point (seeded: the
    same for the same points). ``tree``: a `cKDTree` of ``q``, built when None."""
    lo = q.min(axis=0) - PAD_SPACINGS * spacing
    hi = q.max(axis=0) + PAD_SPACINGS * spacing
    rng = np.random.default_rng(0)
    candidates = lo + (hi - lo) * rng.random((40 * count, 3))
    return _clear_of(q, candidates, FAR_SPACINGS * spacing, tree)[:count]


def _clear_of(q, x, clear: float, tree=None) -> np.ndarray:
    """The rows of ``x`` at least ``clear`` from every point ``q`` (``tree``: a
    `cKDTree` of them, built when None), contiguous."""
    tree = cKDTree(q) if tree is None else tree
    # a search bounded by that distance: inf where no point is nearer (fast)
    dist = tree.query(x, 1, distance_upper_bound=clear, workers=-1)[0]
    return np.ascontiguousarray(x[dist >= clear])


def far_sheet_flips(q, n, idx, dist, areas) -> np.ndarray:
    """Which points of the closed sample ``q`` (normals ``n``, k-NN table ``idx``,
    ``dist`` with the point itself first, disc ``areas``) lie on a sheet turned the
    wrong way by the winding number far from the points (see the module's notes):
    a boolean mask, all True where every normal is to be turned."""
    # normals that enclose a negative volume are first turned all (the sheets'
    # winding numbers near -1 inside, not 1)
    inverted = enclosed_volume(q, n, areas) < 0.0
    flip = np.full(q.shape[0], inverted)
    spacing = table_spacing(dist)
    if spacing == 0.0:
        return flip
    n = -n if inverted else n
    lab = _sheets(q, n, idx)
    size = np.bincount(lab)
    var = np.flatnonzero(size >= SHEET_SHARE * q.shape[0])
    x = far_probes(q, spacing)
    if var.size == 0 or x.shape[0] == 0:
        return flip
    w_by = _winding_by(x, q, n, areas, _sheet_rows(lab, var), var.size, spacing)
    sign = _greedy_turns(w_by, np.full(var.size, FAR_GAIN * x.shape[0]))
    turn = np.isin(lab, var[sign < 0])
    if enclosed_volume(q, np.where(turn[:, None], -n, n), areas) < 0.0:
        turn = ~turn
    return turn ^ inverted


def near_sheet_flips(q, n, idx, dist, areas) -> np.ndarray:
    """Which points of the closed sample ``q`` (normals ``n``, the rest as
    `far_sheet_flips`') lie on a sheet of `NEAR_MIN_POINTS` or more turned the wrong
    way by the winding number near the sheets (`near_probes`, and the box's
    `far_probes`): sheets turned one at a time, the one that brings the probes'
    winding numbers nearest to 0 or 1 first, while a turn gains `NEAR_GAIN` per probe
    it moves. A pocket turned inward as a whole (its walls and floor, each a sheet
    of its own, bounded by edges) reads near 1 in its hollow and near 0 in the
    material around it; each of its sheets turned brings both back."""
    spacing = table_spacing(dist)
    flip = np.zeros(q.shape[0], dtype=bool)
    if spacing == 0.0:
        return flip
    lab = _sheets(q, n, idx)
    size = np.bincount(lab)
    var = np.flatnonzero((size >= NEAR_MIN_POINTS) & (size <= NEAR_MAX_SHARE * q.shape[0]))
    if var.size == 0:
        return flip
    row = _sheet_rows(lab, var)  # var.size: no variable
    tree = cKDTree(q)
    x = np.vstack(
        [
            far_probes(q, spacing, tree=tree),
            near_probes(q, n, np.flatnonzero(row < var.size), spacing, tree),
        ]
    )
    w_by = _winding_by(x, q, n, areas, row, var.size, spacing)
    moved = (np.abs(2.0 * w_by[: var.size]) > NEAR_MOVED).sum(axis=1)
    rows, cols = neighbour_pairs(idx)
    a, b = row[rows], row[cols]
    touch = (a < var.size) & (b < var.size) & (a != b)
    sign = np.ones(var.size)
    for _ in range(NEAR_ROUNDS):
        before = sign.copy()
        sign = _greedy_turns(w_by, NEAR_GAIN * moved, sign)
        sign = _joint_turns(w_by, sign, a[touch], b[touch])
        if np.array_equal(sign, before):
            break
    return np.isin(lab, var[sign < 0])


def near_probes(q, n, rows, spacing: float, tree=None) -> np.ndarray:
    """Probes `NEAR_OFFSETS` spacings in front of and behind every `NEAR_STRIDE`-th of
    the points ``rows`` (at most about `NEAR_SOURCES` of them) along their normals
    ``n``, those at least `FAR_SPACINGS` spacings from every point (``tree``: as
    `far_probes`')."""
    at = rows[:: max(NEAR_STRIDE, -(-rows.size // NEAR_SOURCES))]
    x = np.vstack([q[at] + s * d * spacing * n[at] for d in NEAR_OFFSETS for s in (1.0, -1.0)])
    return _clear_of(q, x, FAR_SPACINGS * spacing, tree)


def _sheet_rows(lab, var) -> np.ndarray:
    """Each point's row: r where its sheet (``lab``) is ``var[r]``, else ``var.size``
    (the rest: one more row)."""
    col = np.full(int(lab.max()) + 1, var.size, dtype=np.int64)
    col[var] = np.arange(var.size)
    return col[lab]


def _winding_by(x, q, n, areas, row, m: int, spacing):
    """(m + 1, len(x)): the winding number at the probes ``x`` of the points of each
    row (``row``: `_sheet_rows`, the rest's the last)."""
    dip = np.ascontiguousarray(n * areas[:, None])
    return sheet_winding(x, q, dip, row, m + 1, CELL_SPACINGS * spacing)


def _signed_sum(w_by, sign) -> np.ndarray:
    """The winding number of all the points with the sheets ``sign`` < 0 turned
    (the rows of ``w_by`` but its last, the rest)."""
    return w_by.sum(axis=0) - 2.0 * ((1.0 - sign) / 2.0) @ w_by[:-1]


def _greedy_turns(w_by, need, sign=None) -> np.ndarray:
    """Each sheet's sign (-1: turned): the rows of ``w_by`` but its last turned one at
    a time, the turn that brings the probes' winding numbers nearest to 0 or 1 first
    (`_off_integer`), among those that gain at least their ``need``."""
    m = w_by.shape[0] - 1
    sign = np.ones(m) if sign is None else sign.copy()
    w = _signed_sum(w_by, sign)
    while True:
        now = _off_integer(w)
        after = _off_integer(w - 2.0 * sign[:, None] * w_by[:m])  # each turned
        after = np.where(now - after >= need, after, np.inf)
        best = int(np.argmin(after))
        if not np.isfinite(after[best]):
            return sign
        w = w - 2.0 * sign[best] * w_by[best]
        sign[best] = -sign[best]


def _joint_turns(w_by, sign, a, b) -> np.ndarray:
    """``sign`` after turning together the sheets that touch (pairs ``a[k]``,
    ``b[k]`` of rows of ``w_by``, components of them) and that each lose less than
    `JOINT_LOSS` of their need turned alone, where together they gain `NEAR_GAIN`
    per probe they move (a pocket's walls turned inward, its floor turned back:
    each wall alone leaves the hollow read halfway either way)."""
    m = w_by.shape[0] - 1
    w = _signed_sum(w_by, sign)
    now = _off_integer(w)
    step = -2.0 * sign[:, None] * w_by[:m]  # each sheet's turn
    gains = now - _off_integer(w + step)
    # a sheet of a pocket turned alone can lose a little (the hollow read halfway
    # either way); a right sheet turned loses several times its need
    moved = (np.abs(step) > NEAR_MOVED).sum(axis=1)
    good = gains > -JOINT_LOSS * NEAR_GAIN * moved
    keep = good[a] & good[b]
    groups = pair_components(m, a[keep], b[keep])
    sign = sign.copy()
    for g in np.unique(groups[good]):
        members = np.flatnonzero((groups == g) & good)
        if members.size < 2:
            continue
        moved_by = step[members].sum(axis=0)
        gain = now - _off_integer(w + moved_by)
        if gain >= NEAR_GAIN * int((np.abs(moved_by) > NEAR_MOVED).sum()):
            w = w + moved_by
            now = _off_integer(w)
            sign[members] = -sign[members]
    return sign


def _off_integer(w):
    """The squared distances of the winding numbers ``w`` to the nearer of 0 and 1,
    summed along the last axis."""
    return np.minimum(w * w, (w - 1.0) ** 2).sum(axis=-1)


def sheet_winding(x, p, dip, row, rows: int, cell: float) -> np.ndarray:
    """(rows, len(x)): the winding number at every probe ``x[j]`` of the points ``p``
    (``dip``: normal times disc area) of each row (``row[i]``: point i's). The points
    of one row in one cube of side ``cell`` act as one dipole beyond
    `_winding.FAR_RADII` of their radius (`_winding.cell_groups`), point by point
    nearer. Plain numpy: `sheet_winding_reference` in tests/simplify/test_sheets.py."""
    key = np.floor((p - p.min(axis=0)) / cell).astype(np.int64)
    group, order, starts, centres, group_dip, reach2 = cell_groups(
        p, dip, np.column_stack([key, row])
    )
    group_row = np.zeros(centres.shape[0], dtype=np.int64)
    group_row[group] = row
    return _sheet_winding_kernel(
        np.ascontiguousarray(x, dtype=np.float64),
        centres,
        group_dip,
        reach2,
        group_row,
        starts,
        np.ascontiguousarray(p[order]),
        np.ascontiguousarray(dip[order]),
        rows,
    )


@njit(cache=True, parallel=True)
def _sheet_winding_kernel(x, centres, group_dip, reach2, group_row, starts, p, dip, rows):
    """`sheet_winding` on its groups: group c (centre, dipole, squared reach, row)
    holds the points ``starts[c]:starts[c + 1]`` of ``p`` and ``dip``."""
    out = np.zeros((rows, x.shape[0]))
    for j in prange(x.shape[0]):
        for c in range(centres.shape[0]):
            e0 = centres[c, 0] - x[j, 0]
            e1 = centres[c, 1] - x[j, 1]
            e2 = centres[c, 2] - x[j, 2]
            r2 = e0 * e0 + e1 * e1 + e2 * e2
            if r2 > reach2[c] and r2 > 0.0:
                s = group_dip[c, 0] * e0 + group_dip[c, 1] * e1 + group_dip[c, 2] * e2
                out[group_row[c], j] += s / (r2 * np.sqrt(r2) * 4.0 * np.pi)
                continue
            for i in range(starts[c], starts[c + 1]):
                e0, e1, e2 = p[i, 0] - x[j, 0], p[i, 1] - x[j, 1], p[i, 2] - x[j, 2]
                r2 = e0 * e0 + e1 * e1 + e2 * e2
                if r2 > 0.0:
                    s = dip[i, 0] * e0 + dip[i, 1] * e1 + dip[i, 2] * e2
                    out[group_row[c], j] += s / (r2 * np.sqrt(r2) * 4.0 * np.pi)
    return out

"""Whole sheets of a closed point set turned by the winding number far from the points
(private; a step of `outward_normals`).

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
outer wall turned is its inner wall turned, seen from inside). Decisions:
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


def _sheets(q, n, idx):
    """Each point's sheet: components of the neighbour pairs on one plane
    (`_sides.sheet_dots`) whose normals agree (cosine above `_sides.OPPOSED_COS`)."""
    rows, cols = neighbour_pairs(idx)
    sheet, dot = sheet_dots(q, n, rows, cols)
    on = np.flatnonzero(sheet)[dot > OPPOSED_COS]
    return pair_components(q.shape[0], rows[on], cols[on])


def far_probes(q, spacing: float, count: int = FAR_PROBES) -> np.ndarray:
    """Up to ``count`` points uniform in the box of ``q`` grown by `PAD_SPACINGS`
    spacings, each at least `FAR_SPACINGS` spacings from every point (seeded: the
    same for the same points)."""
    lo = q.min(axis=0) - PAD_SPACINGS * spacing
    hi = q.max(axis=0) + PAD_SPACINGS * spacing
    rng = np.random.default_rng(0)
    candidates = lo + (hi - lo) * rng.random((40 * count, 3))
    far = FAR_SPACINGS * spacing
    # a search bounded by that distance: inf where no point is nearer (fast)
    dist = cKDTree(q).query(candidates, 1, distance_upper_bound=far, workers=-1)[0]
    return np.ascontiguousarray(candidates[dist >= far][:count])


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
    col = np.full(size.size, var.size, dtype=np.int64)  # the rest: one more row
    col[var] = np.arange(var.size)
    dip = np.ascontiguousarray(n * areas[:, None])
    w_by = sheet_winding(x, q, dip, col[lab], var.size + 1, CELL_SPACINGS * spacing)
    w = w_by.sum(axis=0)
    sign = np.ones(var.size)
    gain = FAR_GAIN * x.shape[0]
    while True:
        now = _off_integer(w)
        after = _off_integer(w - 2.0 * sign[:, None] * w_by[: var.size])  # each turned
        best = int(np.argmin(after))
        if now - after[best] < gain:
            break
        w = w - 2.0 * sign[best] * w_by[best]
        sign[best] = -sign[best]
    turn = np.isin(lab, var[sign < 0])
    if enclosed_volume(q, np.where(turn[:, None], -n, n), areas) < 0.0:
        turn = ~turn
    return turn ^ inverted


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

"""The winding number of an oriented point set (private): inside or outside, far
from the points, for the robust path's field (`_reconstruct._field`).

w(x) = sum_i a_i n_i . (p_i - x) / (4 pi |p_i - x|^3), each point a small oriented
disc of area a_i (Barill, Dickson, Schmidt, Levin and Jacobson 2018, "Fast winding
numbers for soups and clouds"): about 1 inside a closed sampled surface, 0 outside,
whatever the shape's thin walls, pockets and sampling gaps, where a field from the
nearest points' tangent planes can take the wrong side. Points are grouped into
cells; a cell farther than `FAR_RADII` of its radius acts as one dipole at its
centre, a near cell point by point. Plain-numpy reference in
tests/simplify/reference.py (`winding_reference`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from .._core import readonly_view

__all__ = [
    "AREA_NEIGHBOR",
    "Dipoles",
    "FAR_RADII",
    "MAX_POINTS",
    "LEVEL_FAR_STEPS",
    "LEVEL_ROUNDS",
    "DIPOLE_AREA_CAP",
    "cell_groups",
    "dipole_share",
    "dipoles",
    "far_sides",
    "level_sides",
    "point_areas",
    "table_areas",
    "winding_numbers",
]

#: A point's disc area is pi r^2 / k, r the distance to its k-th nearest neighbour.
AREA_NEIGHBOR = 8
#: In `dipole_share` no point's disc counts for more than this many times the median
#: one: a stray point apart from the rest has a disc of hundreds of theirs, and a few
#: strays with sharp normals tipped a closed sample open (`oded_human_man` with 1 % of
#: its points stray: 0.089, 10 discs over the cap and up to 1,316 times the median;
#: capped 0.0099; `_reconstruct.CLOSED_DIPOLE` is 0.05).
DIPOLE_AREA_CAP = 10.0
#: A cell acts as one dipole beyond this many of its radii (Barill et al.: 2).
FAR_RADII = 2.0
#: At most this many points (evenly strided) speak: the winding number is used far
#: from the points only, where a subsample gives the same side.
MAX_POINTS = 50_000
#: Nodes next to the field's level farther than this many grid steps from every
#: point take the winding number's side computed at the node (`level_sides`): the
#: lattice's interpolation reaches only past a spacing and a lattice step, and the
#: tangent planes of a face extended past a knife edge leave a blob there ...
LEVEL_FAR_STEPS = 2.0
#: ... in at most this many rounds (a node turned brings its neighbours to the level).
LEVEL_ROUNDS = 3


def point_areas(points: np.ndarray, k: int = AREA_NEIGHBOR) -> np.ndarray:
    """Each point's disc area, pi r^2 / k (r: distance to its k-th neighbour)."""
    k = min(k, points.shape[0] - 1)
    if k < 1:
        return np.zeros(points.shape[0])
    d, _ = cKDTree(points).query(points, k=k + 1, workers=-1)
    return table_areas(d, k)


def dipole_share(q, normals, areas=None) -> float:
    """The length of the points' normals times their disc areas, summed, as a share of
    their area (``areas``: `point_areas` of ``q``, found when None; none counting for
    more than `DIPOLE_AREA_CAP` times the median): zero for a closed surface, by the
    divergence theorem; one for a flat sheet; 0 for points of no area."""
    area = point_areas(q) if areas is None else np.asarray(areas, dtype=np.float64)
    if area.size:
        area = np.minimum(area, DIPOLE_AREA_CAP * float(np.median(area)))
    total = float(area.sum())
    return float(np.linalg.norm(area @ normals)) / total if total > 0.0 else 0.0


def table_areas(distances: np.ndarray, k: int = AREA_NEIGHBOR) -> np.ndarray:
    """`point_areas` from a k-NN table's ``distances`` (the point itself first, at
    least ``min(k, N - 1) + 1`` columns): the same values (up to the distances'
    rounding), without a search."""
    n = distances.shape[0]
    k = min(k, n - 1)
    if k < 1:
        return np.zeros(n)
    if distances.shape[1] < k + 1:
        raise ValueError(f"table_areas needs {k + 1} neighbours; got {distances.shape[1]}")
    return np.pi * distances[:, k] ** 2 / k


@njit(cache=True, parallel=True)
def _winding_kernel(x, centres, cell_dipoles, reach2, starts, points, dipoles):
    """The winding number at every row of ``x`` from the cells (``centres`` and
    ``cell_dipoles`` (3, C), squared reach ``reach2``) and the points in cell order
    (``points``, ``dipoles`` (3, n); cell c's at ``starts[c]:starts[c + 1]``). Per
    row, every cell's far term first, in one loop without branches (vectorised: half
    the time of a loop that tests each cell first), then the sum in the cells'
    order, a near cell's points one by one: the same sum, bit for bit (a test
    compares it with a plain loop)."""
    n_c = centres.shape[1]
    cx, cy, cz = centres[0], centres[1], centres[2]
    c0, c1, c2 = cell_dipoles[0], cell_dipoles[1], cell_dipoles[2]
    px, py, pz = points[0], points[1], points[2]
    d0, d1, d2 = dipoles[0], dipoles[1], dipoles[2]
    out = np.zeros(x.shape[0])
    for i in prange(x.shape[0]):
        x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
        r2 = np.empty(n_c)
        far = np.empty(n_c)
        for c in range(n_c):
            dx = cx[c] - x0
            dy = cy[c] - x1
            dz = cz[c] - x2
            rr = dx * dx + dy * dy + dz * dz
            r2[c] = rr
            far[c] = (c0[c] * dx + c1[c] * dy + c2[c] * dz) / (rr * np.sqrt(rr))
        s = 0.0
        for c in range(n_c):
            if r2[c] > reach2[c] and r2[c] > 0.0:
                s += far[c]
                continue
            for t in range(starts[c], starts[c + 1]):
                ex = px[t] - x0
                ey = py[t] - x1
                ez = pz[t] - x2
                e2 = ex * ex + ey * ey + ez * ez
                if e2 > 0.0:
                    s += (d0[t] * ex + d1[t] * ey + d2[t] * ez) / (e2 * np.sqrt(e2))
        out[i] = s / (4.0 * np.pi)
    return out


@dataclass(frozen=True, slots=True)
class Dipoles:
    """Oriented points grouped in cells for `winding_numbers` (private): the points
    ``p``, their ``dipoles`` (normal x disc area), the points of cell c at
    ``order[starts[c]:starts[c + 1]]``, each cell's ``centres``, ``cell_dipoles``
    and squared reach (``reach2``: beyond it the cell is one dipole); the kernel's
    copies, one row per axis: ``axes`` (the centres, the cells' dipoles, the points
    and their dipoles in cell order)."""

    p: np.ndarray
    dipoles: np.ndarray
    order: np.ndarray
    starts: np.ndarray
    centres: np.ndarray
    cell_dipoles: np.ndarray
    reach2: np.ndarray
    axes: tuple

    def at(self, x: np.ndarray) -> np.ndarray:
        """The winding number at every row of ``x``."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        centres, cell_dipoles, points, dipoles = self.axes
        return _winding_kernel(x, centres, cell_dipoles, self.reach2, self.starts, points, dipoles)


def dipoles(points, normals, cell: float) -> Dipoles:
    """The oriented ``points`` grouped in cells of side ``cell`` (`Dipoles`); at most
    `MAX_POINTS` of them, evenly strided."""
    stride = max(1, -(-points.shape[0] // MAX_POINTS))
    # read-only: one kernel signature whatever the caller's array (docs/decisions/cli.md)
    p = readonly_view(np.ascontiguousarray(points[::stride], dtype=np.float64))
    n = np.asarray(normals[::stride], dtype=np.float64)
    dip = np.ascontiguousarray(n * point_areas(p)[:, None])
    key = np.floor((p - p.min(axis=0)) / cell).astype(np.int64)
    _, order, starts, centres, cell_dipoles, reach2 = cell_groups(p, dip, key)
    axes = tuple(np.ascontiguousarray(a.T) for a in (centres, cell_dipoles, p[order], dip[order]))
    return Dipoles(p, dip, order, starts, centres, cell_dipoles, reach2, axes)


def cell_groups(p, dip, key):
    """The points ``p`` with dipoles ``dip`` grouped by the rows of ``key`` (a cell's
    integer coordinates, and whatever else must tell groups apart): ``(lab, order,
    starts, centres, group_dipoles, reach2)``, each point's group, the points in
    group order (group c's at ``order[starts[c]:starts[c + 1]]``), each group's
    centre (the mean of its points), summed dipole and squared reach (beyond
    `FAR_RADII` of its radius it acts as one dipole)."""
    _, lab = np.unique(key, axis=0, return_inverse=True)
    lab = lab.reshape(-1)
    n_cells = int(lab.max()) + 1
    order = np.argsort(lab, kind="stable").astype(np.int64)
    starts = np.searchsorted(lab[order], np.arange(n_cells + 1)).astype(np.int64)
    weight = np.bincount(lab, minlength=n_cells).astype(np.float64)
    centres = np.stack([np.bincount(lab, p[:, i], n_cells) for i in range(3)], axis=1)
    centres /= weight[:, None]
    cell_dipoles = np.stack([np.bincount(lab, dip[:, i], n_cells) for i in range(3)], 1)
    radius = np.zeros(n_cells)
    np.maximum.at(radius, lab, np.linalg.norm(p - centres[lab], axis=1))
    return lab, order, starts, centres, cell_dipoles, (FAR_RADII * radius) ** 2


def winding_numbers(x, points, normals, cell: float) -> np.ndarray:
    """The winding number of the oriented ``points`` at every row of ``x``.

    ``cell``: the side of the cells the points are grouped in (their far field is
    one dipole each). At most `MAX_POINTS` points, evenly strided, are used.
    """
    return dipoles(points, normals, cell).at(x)


@njit(cache=True, parallel=True)
def far_sides(f, w, far_from, near, stride, clear):
    """The field ``f`` with the side of every node farther than ``near`` from the
    points (``far_from``) taken from the winding number: ``w`` on the lattice of
    every ``stride``-th node, interpolated trilinearly (axis 0, then 1, then 2;
    beyond the last lattice node the nearest one's value); below ``clear`` the node
    is outside (+max(|f|, far_from)), above 1 - ``clear`` inside (-max(|f|,
    far_from)), else it keeps ``f``. Plain-numpy reference in
    tests/simplify/reference.py (`far_sides_reference`)."""
    n0, n1, n2 = f.shape
    m0, m1, m2 = w.shape
    out = f.copy()
    for i in prange(n0):
        i0, i1, ti = _lattice_at(i, stride, m0)
        for j in range(n1):
            j0, j1, tj = _lattice_at(j, stride, m1)
            for k in range(n2):
                if far_from[i, j, k] <= near:
                    continue
                k0, k1, tk = _lattice_at(k, stride, m2)
                b0 = _along(w, i0, i1, ti, j0, k0) * (1.0 - tj)
                b0 += _along(w, i0, i1, ti, j1, k0) * tj
                b1 = _along(w, i0, i1, ti, j0, k1) * (1.0 - tj)
                b1 += _along(w, i0, i1, ti, j1, k1) * tj
                value = b0 * (1.0 - tk) + b1 * tk
                size = max(abs(f[i, j, k]), far_from[i, j, k])
                if value > 1.0 - clear:
                    out[i, j, k] = -size
                if value < clear:
                    out[i, j, k] = size
    return out


@njit(cache=True, inline="always")
def _lattice_at(i, stride, m):
    """The lattice nodes either side of node ``i`` and its weight on the second."""
    pos = i / stride
    lo = min(int(np.floor(pos)), m - 1)
    hi = min(lo + 1, m - 1)
    return lo, hi, min(max(pos - lo, 0.0), 1.0)


@njit(cache=True, inline="always")
def _along(w, i0, i1, ti, j, k):
    """``w`` interpolated along axis 0 at lattice row ``j``, column ``k``."""
    return w[i0, j, k] * (1.0 - ti) + w[i1, j, k] * ti


#: The six axis neighbours of a node, and the node itself.
_AXIS_STEPS = np.vstack([np.zeros((1, 3)), np.eye(3), -np.eye(3)]).astype(np.int64)


def level_sides(f, nearest, sources: Dipoles, origin, step: float, clear: float):
    """The field ``f`` (grid nodes at ``origin`` + index x ``step``; changed in place
    and returned) with every node next to its level (a neighbour along an axis on
    the other side) and farther than `LEVEL_FAR_STEPS` steps from the points
    (``nearest``: each node's distance to the nearest point, inf where farther than
    known) on the side of the points' winding number at the node (``sources``) where
    it is clear (below ``clear``: outside, above 1 - ``clear``: inside; the value then
    the distance to the nearest point, or its size where that is not known), in
    `LEVEL_ROUNDS` rounds, each over the nodes that the last one brought to the
    level."""
    inside = f < 0.0
    nodes = np.argwhere(_on_level(inside))
    seen = np.zeros(f.shape, dtype=bool)
    for _ in range(LEVEL_ROUNDS):
        nodes = nodes[~seen[tuple(nodes.T)]]
        seen[tuple(nodes.T)] = True
        nodes = nodes[nearest[tuple(nodes.T)] > LEVEL_FAR_STEPS * step]
        if nodes.shape[0] == 0:
            break
        w = sources.at(origin + nodes * step)
        side = np.where(w < clear, 1.0, np.where(w > 1.0 - clear, -1.0, 0.0))
        turn = side * np.where(inside[tuple(nodes.T)], -1.0, 1.0) < 0.0  # the other side
        if not turn.any():
            break
        nodes, side = nodes[turn], side[turn]
        at = tuple(nodes.T)
        size = nearest[at].astype(np.float64)
        size = np.where(np.isfinite(size), size, np.abs(f[at]))
        f[at] = side * size
        inside[at] = side < 0.0
        # the turned nodes' neighbours now on the level: the next round's
        near = (nodes[:, None, :] + _AXIS_STEPS[None, :, :]).reshape(-1, 3)
        near = near[((near >= 0) & (near < np.array(f.shape))).all(axis=1)]
        near = np.unique(near, axis=0)
        nodes = near[_on_level(inside, near)]
    return f


def _on_level(inside: np.ndarray, nodes=None) -> np.ndarray:
    """Whether nodes have a neighbour along an axis on the other side of the level
    (``inside``: the field below 0): a mask of the grid, or of the rows of
    ``nodes``."""
    if nodes is None:
        edge = np.zeros(inside.shape, dtype=bool)
        for axis in range(3):
            lo, hi = [slice(None)] * 3, [slice(None)] * 3
            lo[axis], hi[axis] = slice(0, -1), slice(1, None)
            differ = inside[tuple(lo)] != inside[tuple(hi)]
            edge[tuple(lo)] |= differ
            edge[tuple(hi)] |= differ
        return edge
    shape = np.array(inside.shape)
    here = inside[tuple(nodes.T)]
    out = np.zeros(nodes.shape[0], dtype=bool)
    for step in _AXIS_STEPS[1:]:
        nb = nodes + step
        ok = ((nb >= 0) & (nb < shape)).all(axis=1)
        out[ok] |= inside[tuple(nb[ok].T)] != here[ok]
    return out

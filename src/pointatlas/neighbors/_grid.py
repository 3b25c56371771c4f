"""The compact sorted-cell grid behind the fast k-NN and radius queries.

Private helpers; inputs are validated, centred float64 points.

Cell size for k-NN (decision, docs/decisions/neighbors.md): the *point-weighted* occupancy
``W(h) = sum_c n_c**2 / N`` (the mean number of points sharing a query's cell)
is driven to a target that grows with k. W, unlike the plain mean occupancy,
bounds the total work of the 3 x 3 x 3 block search even for strongly
inhomogeneous clouds (surfaces in 3-D, dense clusters, LiDAR strips), because
a cell holding many points is weighted by its many queries. W is measured at h,
h/2 and h/4 from one sort (sub-cell counts), refined by at most a few more sorts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core._sort import sorted_key_runs
from .._core.tolerances import RADIUS_QUERY_WIDEN
from . import _kernels as K

#: Largest number of grid cells (nx * ny * nz) so cell keys fit in int64.
_MAX_CELLS = 2.0**60

#: The x/y column index (`Grid.colptr`, nx * ny + 1 entries) is built when it has at
#: most this many entries per point (a 2.5-D scan has about 0.1-0.5).
_MAX_COLUMNS_PER_POINT = 4


@dataclass(frozen=True, slots=True)
class Grid:
    """Points sorted by cell (structure of arrays) and the occupied cells."""

    xs: np.ndarray
    ys: np.ndarray
    zs: np.ndarray
    ids: np.ndarray
    ukeys: np.ndarray
    cstart: np.ndarray
    lo: np.ndarray
    h: float
    nx: int
    ny: int
    nz: int


def _dims(ext: np.ndarray, h: float) -> tuple[int, int, int]:
    return tuple(int(math.floor(e / h)) + 1 for e in ext)


def min_cell_size(ext: np.ndarray) -> float:
    """Smallest cell size whose grid keys fit in int64."""
    big = float(ext.max())
    if big == 0.0:
        return 1.0
    lo_h, hi_h = big * 1e-300 + 1e-300, big
    for _ in range(200):
        mid = math.sqrt(lo_h * hi_h)
        nx, ny, nz = _dims(ext, mid)
        if float(nx) * ny * nz > _MAX_CELLS:
            lo_h = mid
        else:
            hi_h = mid
        if hi_h <= lo_h * (1 + 1e-9):
            break
    return hi_h


def _cell_keys(pts: np.ndarray, lo: np.ndarray, inv_h: float, dims) -> np.ndarray:
    """Cell key ``(i * ny + j) * nz + k`` of every point, clamped into the grid."""
    keys = np.zeros(pts.shape[0], dtype=np.int64)
    for d, size in enumerate(dims):
        cell = np.floor((pts[:, d] - lo[d]) * inv_h).astype(np.int64)
        np.clip(cell, 0, size - 1, out=cell)
        keys *= size
        keys += cell
    return keys


def build_grid(pts: np.ndarray, h: float, h_min: float | None = None) -> Grid:
    """Sort ``pts`` into cells of size ``h`` (enlarged if keys would overflow; ``h_min``:
    `min_cell_size` of the points' extent when the caller has it).

    numpy around one kernel, the shared radix sort of the cell keys (stable:
    ``np.argsort(kind="stable")``): each pass over the points is one numpy call, as
    fast as a kernel's loop, and compiles nothing (docs/decisions/cli.md, "First run").
    """
    lo, hi = K.bounds(pts)
    ext = hi - lo
    h = max(float(h), min_cell_size(ext) if h_min is None else h_min)
    nx, ny, nz = _dims(ext, h)
    keys = _cell_keys(pts, lo, 1.0 / h, (nx, ny, nz))
    n = keys.shape[0]
    sorted_keys, order, first = sorted_key_runs(keys)
    starts = np.flatnonzero(first)
    ukeys = sorted_keys[starts]
    cstart = np.append(starts, n).astype(np.int64)
    xs, ys, zs = (pts[order, d] for d in range(3))
    return Grid(xs, ys, zs, order, ukeys, cstart, lo, h, nx, ny, nz)


def column_index(grid: Grid) -> np.ndarray:
    """The grid's x/y column index ``colptr`` (n_cols + 1,): the occupied cells of
    column ``col = i * ny + j`` are ``colptr[col]:colptr[col + 1]`` (positions in
    ``ukeys``); an empty array when it would hold more than `_MAX_COLUMNS_PER_POINT`
    entries per point (the kernels then bisect all cells)."""
    n_cols = grid.nx * grid.ny
    if n_cols > _MAX_COLUMNS_PER_POINT * grid.xs.shape[0] + 1024:
        return np.empty(0, dtype=np.int64)
    colptr = np.zeros(n_cols + 1, dtype=np.int64)
    np.cumsum(np.bincount(grid.ukeys // grid.nz, minlength=n_cols), out=colptr[1:])
    return colptr


def group_queries(grid: Grid, queries: np.ndarray):
    """Point indices ``queries`` grouped by grid cell for `_kernels.knn_grid`:
    ``(qcells, qstart, qpos, qout)``: group g is cell ``qcells[g]`` with the cell-order
    positions ``qpos[qstart[g]:qstart[g + 1]]``, answered into rows ``qout`` (the
    queries' places in ``queries``, in their order within a position). A counting sort
    (`_kernels.group_by_cell`); the stable argsort it replaced cost 0.046 s for
    620,000 rows of a 742,000-point tile."""
    return K.group_by_cell(grid.ids, grid.cstart, queries)


def _volume_cell_size(ext: np.ndarray, n: int, target: float) -> float:
    """h such that the bounding box holds about n / target cells."""
    big = float(ext.max())
    if big == 0.0:
        return 1.0
    want = n / target
    if want <= 1.0:
        return big * 1.0001
    lo_h, hi_h = big * 1e-12, big * 1.0001

    def n_cells(h):
        return math.prod(max(e / h, 1.0) for e in ext)

    for _ in range(100):
        mid = math.sqrt(lo_h * hi_h)
        if n_cells(mid) > want:
            lo_h = mid
        else:
            hi_h = mid
    return hi_h


def knn_target(k: int) -> float:
    """Target point-weighted occupancy for k nearest neighbours: half the k - 1 other
    neighbours, plus up to 4 for small k (fewer queries then search past the 3 x 3 x 3
    block; measured in docs/decisions/neighbors.md)."""
    half = 0.5 * (k - 1)
    return max(2.0, half, min(half + 4.0, 16.0))


def grid_too_coarse(grid: Grid, limit: float) -> bool:
    """Whether ``grid``'s point-weighted occupancy, counting each distinct position of
    a cell once, exceeds ``limit`` (docs/decisions/neighbors.md, "Backends").

    The plain occupancy W = sum_c n_c**2 / N is checked first (O(cells)); only above
    ``limit`` are the cells' distinct positions counted (one sort of the points).
    """
    counts = np.diff(grid.cstart).astype(np.float64)
    n = max(int(grid.ids.size), 1)
    if float(counts @ counts) / n <= limit:
        return False
    cell = np.repeat(np.arange(counts.size, dtype=np.int64), np.diff(grid.cstart))
    order = np.lexsort((grid.zs, grid.ys, grid.xs, cell))
    c, x, y, z = cell[order], grid.xs[order], grid.ys[order], grid.zs[order]
    new = np.ones(c.size, dtype=bool)
    new[1:] = (c[1:] != c[:-1]) | (x[1:] != x[:-1]) | (y[1:] != y[:-1]) | (z[1:] != z[:-1])
    distinct = np.bincount(c[new], minlength=counts.size).astype(np.float64)
    return float(distinct @ distinct) / n > limit


def knn_grid_for(pts: np.ndarray, k: int, *, max_rounds: int = 6) -> Grid:
    """A grid whose point-weighted occupancy is close to `knn_target` (k)."""
    n = pts.shape[0]
    target = knn_target(k)
    lo, hi = K.bounds(pts)
    ext = hi - lo
    h_min = min_cell_size(ext)
    h = max(_volume_cell_size(ext, n, target), h_min)
    grid = build_grid(pts, h, h_min)
    for _ in range(max_rounds):
        s0, s1, s2 = K.occupancy_levels(
            grid.xs, grid.ys, grid.zs, grid.ukeys, grid.cstart, grid.lo, grid.h, grid.ny, grid.nz
        )
        w = np.array([s0, s1, s2]) / n
        hs = grid.h / np.array([1.0, 2.0, 4.0])
        if w[0] <= 1.5 * target:
            return grid
        if w[2] > target:
            # still too coarse at h/4: extrapolate along the measured slope
            slope = math.log2(max(w[1], 1e-300) / max(w[2], 1e-300))
            slope = min(max(slope, 0.5), 3.0)
            # at most 8x finer per round: a flat slope (one cluster in one cell at all
            # three levels, far outliers around it) says nothing about the finer levels
            h_new = max(hs[2] * (target / w[2]) ** (1.0 / slope), hs[2] / 8.0)
        else:
            # interpolate log W linearly in log h between bracketing levels
            a = 0 if w[1] <= target else 1
            lw0, lw1 = math.log(w[a]), math.log(max(w[a + 1], 1e-300))
            frac = 0.0 if lw0 == lw1 else (lw0 - math.log(target)) / (lw0 - lw1)
            h_new = hs[a] * (hs[a + 1] / hs[a]) ** frac
        h_new = max(h_new, h_min)
        if h_new >= grid.h * 0.98:
            return grid
        grid = build_grid(pts, h_new, h_min)
        if w[2] <= target:
            return grid
    return grid


def radius_grid_for(pts: np.ndarray, radius: float) -> Grid:
    """A grid with cells no smaller than ``radius`` (a ball fits in 3 x 3 x 3)."""
    return build_grid(pts, radius * (1.0 + RADIUS_QUERY_WIDEN))

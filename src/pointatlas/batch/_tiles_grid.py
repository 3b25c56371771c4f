"""Spatial tiles: the x/y grid, the owner rule, halo membership and exact k-NN per tile.

Private helpers of `pointatlas.batch` tiled processing (decisions in
docs/decisions/batch.md). Everything here is a pure function of the coordinates,
so a tile computes the same thing on any worker.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._core import PointAtlasError, warn_renamed

__all__ = ["TileGrid", "exact_tile_knn", "make_grid"]

#: Absolute distance tolerance, in units of eps x the largest centred coordinate, by
#: which a certified k-th distance must stay below the distance to the halo box.
_TOL_ULPS = 64.0


@dataclass(frozen=True, slots=True)
class TileGrid:
    """An x/y grid of square tiles over a point set's bounding box.

    Parameters
    ----------
    lo, hi : tuple of float
        Bounding box (x, y, z minima and maxima) of all points.
    size : float
        Tile edge length (same units as the coordinates).
    nx, ny : int
        Tiles along x and y.

    Notes
    -----
    Owner rule: a point belongs to tile ``(i, j)`` with ``i = floor((x - lo_x) /
    size)`` clipped to ``[0, nx - 1]`` (same for y), tile id ``j * nx + i``. The
    cells are half-open except the last row/column, so every point has exactly one
    owner, computed from its own coordinates only.
    """

    lo: tuple
    hi: tuple
    size: float
    nx: int
    ny: int

    @property
    def n_tiles(self) -> int:
        """Number of tiles (nx * ny)."""
        return self.nx * self.ny

    @property
    def center(self) -> np.ndarray:
        """Bounding-box centre: the centring `pointatlas.neighbors` uses on all points."""
        return 0.5 * (np.asarray(self.lo, dtype=np.float64) + np.asarray(self.hi, dtype=np.float64))

    def cell(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tile column and row of every point (the owner rule)."""
        i = np.floor((xy[:, 0] - self.lo[0]) / self.size)
        j = np.floor((xy[:, 1] - self.lo[1]) / self.size)
        i = np.clip(i, 0, self.nx - 1).astype(np.int64)
        j = np.clip(j, 0, self.ny - 1).astype(np.int64)
        return i, j

    def owner(self, xy: np.ndarray) -> np.ndarray:
        """Owner tile id of every point."""
        i, j = self.cell(xy)
        return j * self.nx + i

    def core_box(self, tile: int) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1) of a tile's own cell."""
        i, j = tile % self.nx, tile // self.nx
        x0 = self.lo[0] + i * self.size
        y0 = self.lo[1] + j * self.size
        return x0, x0 + self.size, y0, y0 + self.size

    def members(self, xy: np.ndarray, owner: np.ndarray, tile: int, halo: float) -> np.ndarray:
        """Points of a tile with its halo: owned, or inside the cell grown by ``halo``.

        The halo box is ``[x0 - halo, x1 + halo] x [y0 - halo, y1 + halo]``
        (closed); z is not cut.
        """
        x0, x1, y0, y1 = self.core_box(tile)
        inside = (
            (xy[:, 0] >= x0 - halo)
            & (xy[:, 0] <= x1 + halo)
            & (xy[:, 1] >= y0 - halo)
            & (xy[:, 1] <= y1 + halo)
        )
        return inside | (owner == tile)

    def boundary_distance(self, xy: np.ndarray, tile: int, halo: float) -> np.ndarray:
        """Distance of points to the nearest side of the tile's halo box that can cut
        a neighbourhood; sides at or beyond the bounding box of all points cut
        nothing (infinite)."""
        x0, x1, y0, y1 = self.core_box(tile)
        inf = np.full(xy.shape[0], np.inf)
        sides = []
        if x0 - halo > self.lo[0]:
            sides.append(xy[:, 0] - (x0 - halo))
        if x1 + halo < self.hi[0]:
            sides.append((x1 + halo) - xy[:, 0])
        if y0 - halo > self.lo[1]:
            sides.append(xy[:, 1] - (y0 - halo))
        if y1 + halo < self.hi[1]:
            sides.append((y1 + halo) - xy[:, 1])
        for s in sides:
            inf = np.minimum(inf, s)
        return inf

    def neighbors(self, tile: int, rings: int) -> list[int]:
        """Tiles within ``rings`` cells of ``tile`` (itself included), sorted."""
        i, j = tile % self.nx, tile // self.nx
        out = []
        for jj in range(max(0, j - rings), min(self.ny, j + rings + 1)):
            for ii in range(max(0, i - rings), min(self.nx, i + rings + 1)):
                out.append(jj * self.nx + ii)
        return out

    def neighbours(self, tile: int, rings: int) -> list[int]:
        """Former name of `neighbors` (deprecated)."""
        warn_renamed("TileGrid.neighbours", "TileGrid.neighbors")
        return self.neighbors(tile, rings)


def make_grid(lo, hi, tile_size: float) -> TileGrid:
    """The grid of ``tile_size`` tiles over the box ``lo``..``hi`` (x/y).

    Parameters
    ----------
    lo, hi : sequence of float
        The box's lower and upper corners (x, y first; further coordinates are kept).
    tile_size : float
        The tiles' side, finite and > 0.

    Returns
    -------
    TileGrid
        At least one tile each way, at most 10**6 tiles.

    Raises
    ------
    PointAtlasError
        A tile size that is not a finite number > 0, or one giving over 10**6 tiles.
    """
    if not (isinstance(tile_size, int | float) and math.isfinite(tile_size) and tile_size > 0):
        raise PointAtlasError(f"--tile-size must be a finite number > 0; got {tile_size!r}")
    lo = tuple(float(v) for v in lo)
    hi = tuple(float(v) for v in hi)
    nx = max(1, math.ceil((hi[0] - lo[0]) / tile_size))
    ny = max(1, math.ceil((hi[1] - lo[1]) / tile_size))
    if nx * ny > 1_000_000:
        raise PointAtlasError(
            f"--tile-size {tile_size:g} gives {nx * ny:,} tiles over a "
            f"{hi[0] - lo[0]:g} x {hi[1] - lo[1]:g} box; choose a larger tile size"
        )
    return TileGrid(lo=lo, hi=hi, size=float(tile_size), nx=nx, ny=ny)


def exact_tile_knn(xyz, rows, k: int, center, bdist, *, min_cols: int = 0, rows_only=False):
    """k-NN rows of a tile's points, identical to `query_knn` on all points.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        The tile's points (owned and halo), in increasing global index order.
    rows : ndarray of int
        Local rows to certify (the owned points).
    k : int
        Neighbourhood size, the point itself included.
    center : ndarray of shape (3,)
        Bounding-box centre of *all* points (what `query_knn` centres on).
    bdist : ndarray of shape (n,)
        Distance of every tile point to its halo box (`TileGrid.boundary_distance`).
    min_cols : int
        Least number of columns of the returned table (e.g. an orientation graph's k).
    rows_only : bool
        Query only ``rows`` (`NeighborIndex.knn` with ``rows``): for callers that read
        no halo row (features; normals without a tile-wide orientation).

    Returns
    -------
    table : ndarray of shape (n, kq), or (len(rows), kq) with ``rows_only``, int64
        The tile's k-NN table (kq = max(k, min_cols) columns, at most n): self
        first, then by (squared distance in the global arithmetic, index).
    bad : ndarray of int
        Rows whose k-th neighbour may lie outside the halo box.
    r_k : ndarray of shape (len(rows),)
        k-th neighbour distance of every certified row.

    Notes
    -----
    `query_knn` compares ``dx*dx + dy*dy + dz*dz`` on coordinates minus the
    bounding-box centre of all points and breaks ties by index. The tile is
    queried in the same frame (a `NeighborIndex` with ``center`` = the global
    centre): its squared distances are the global ones bit for bit, and its
    local index order is the global one.
    A row is certified when its k-th distance plus a tolerance (for the rounding
    of the halo box distance) is below its distance to the halo box: no point
    outside the tile can then be nearer, and the row equals the untiled row.
    Rows that are not certified are returned in ``bad``.
    """
    n = xyz.shape[0]
    rows = np.asarray(rows, dtype=np.int64)
    if n < k:
        return None, rows, np.full(rows.size, np.inf)
    from ..neighbors import NeighborIndex

    index = NeighborIndex(xyz, center=center)
    tol = _TOL_ULPS * np.finfo(np.float64).eps * max(1.0, float(np.abs(index.points_).max()))
    if rows_only:
        table, dist = index.knn(min(max(k, min_cols), n), rows=rows)
        r_k = dist[:, k - 1]
    else:
        table, dist = index.knn(min(max(k, min_cols), n))
        r_k = dist[rows, k - 1]
    bad = rows[~(r_k + 2.0 * tol < bdist[rows])]
    return table, bad, r_k

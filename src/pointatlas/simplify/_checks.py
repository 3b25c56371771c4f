"""Input checks of the simplify room: point count, k, memory, unusable normals,
repeated positions, points on a line, points far off the surface the others sample.

Private helpers of the public functions; the decisions are recorded in
docs/decisions/simplify.md, "The thesis path".
"""

from __future__ import annotations

import os

import numpy as np

from .._core import PointAtlasError, as_int, as_normals, as_vectors, describe_indices
from .._core.tolerances import NORMAL_ZERO_LENGTH

__all__ = [
    "MIN_POINTS",
    "available_memory",
    "check_memory",
    "check_size",
    "distinct_positions",
    "off_surface",
    "off_surface_ratio",
    "usable_normals",
    "without_repeats",
]

#: fewest points a simplification can use: a closed polyhedron has at least four
#: faces, each of them a region with at least one point
MIN_POINTS = 4

#: bytes per (point, neighbour) pair of the k-NN rows, measured on the room's
#: largest stage (the surface-like complex: about 160-220 bytes per pair at
#: k = 8..256 on synth:torus; the k-NN query and VSA take less), rounded up
BYTES_PER_NEIGHBOUR = 256

#: bytes per pair of regions: the dense region-by-region tables of the repair
#: step (contacts, proxy similarities, piece/region counts), int64/float64 each
BYTES_PER_REGION_PAIR = 32

#: A point lies off the surface the others sample (an outlier: a scanner's stray
#: return, a reflection) when the median of its heights over its `OFF_NEIGHBORS`
#: nearest points' tangent planes is over `OFF_SURFACE` times the points' median
#: distance to their `OFF_SPACING_NEIGHBOR`-th nearest. Over all 149 collection models
#: the points of whole samples stay below 2.1 (20,000 and 5,000 points, noise 0.1 and
#: 0.2 %, true and estimated normals) and 3.9 with a density falling tenfold; scans
#: missing a side reach 10.5 (a few points on a grazing facet apart from the rest, which
#: the surface drops as strays anyway); one stray a diagonal off reads 50-80
#: (docs/decisions/simplify.md, "Points off the surface").
OFF_NEIGHBORS = 8
OFF_SPACING_NEIGHBOR = 4
OFF_SURFACE = 4.0
#: A point kept whose ratio is over this, and alone, is not counted among the points
#: the voxel surface lost (a stray return near the surface: `_voxel_grid.LOST_LINK`).
#: On clean collection samples the lost points alone whose count decides a rebuild
#: read up to 0.21 (0.25 beside others); 1 % of the points moved off, the lost strays
#: of `cad_a_a38` read 0.29-3.9 (46 of 48 over 1.0).
STRAY_RATIO = 0.25
#: ... and one whose ratio is over this and over `STRAY_NOISE` times the points'
#: median ratio (their noise), alone and farther than `_voxel_grid.LOST_STEPS` steps
#: from the voxel surface, is left out (`_voxel_grid.lost_strays`): with 1 % of the
#: points moved off, 187 of the 193 such strays of four models read over 1.0; the
#: noise tails that far off noisy samples (sigma 0.2 % of the diagonal, estimated
#: normals) read 1.0-1.9, at most 6.8 times their sample's median ratio (0.23-0.38).
STRAY_DROP = 1.0
STRAY_NOISE = 8.0
#: Points whose second singular value (of their centred coordinates) is at most this
#: share of their first lie on one line: no surface to mesh (float rounding of points
#: on a line leaves about 1e-16; a scanned wire of 1 mm over 1 m, 1e-3).
LINE_RTOL = 1e-9


def check_size(n_points: int, k) -> int:
    """Validate ``k`` against the point count; return it as an int.

    Raises a `PointAtlasError` naming the real problem: too few points for any
    simplification, or fewer points than the neighbourhood size ``k``.
    """
    k = as_int(k, "k", lo=1)
    if n_points < MIN_POINTS:
        raise PointAtlasError(
            f"simplify needs at least {MIN_POINTS} points (a closed polyhedron has four "
            f"faces); got {n_points}"
        )
    if k > n_points:
        raise PointAtlasError(
            f"simplify needs at least k = {k} points; got {n_points} "
            f"(k must be <= the number of points)"
        )
    return k


def available_memory() -> int | None:
    """Bytes of memory available to this process: ``MemAvailable`` of /proc/meminfo,
    else the physical memory (``os.sysconf``); None where neither can be read."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - non-POSIX
        return None


def memory_estimate(n_points: int, k: int, n_regions: int = 0) -> int:
    """Rough peak bytes of the simplification of ``n_points`` with ``k`` neighbours
    and ``n_regions`` regions (0: not known yet)."""
    return BYTES_PER_NEIGHBOUR * n_points * k + BYTES_PER_REGION_PAIR * n_regions**2


def check_memory(n_points: int, k: int, n_regions: int = 0, columns: int | None = None) -> None:
    """Raise a `PointAtlasError` before the work starts when its estimated memory
    exceeds the available memory (a clear message instead of running out of it).
    ``columns``: the neighbour table's width when it is wider than ``k`` (the points
    path's one table serves VSA's k and the discs' neighbours)."""
    need = memory_estimate(n_points, k if columns is None else max(k, columns), n_regions)
    have = available_memory()
    if have is not None and need > have:
        regions = f" and {n_regions} regions" if n_regions else ""
        raise PointAtlasError(
            f"simplify with k = {k} on {n_points} points{regions} needs about "
            f"{need / 2**30:.1f} GiB of memory; {have / 2**30:.1f} GiB are available "
            f"(lower k{', or merge regions' if n_regions else ''})"
        )


def usable_normals(normals, n_points: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals of the points that have a usable one, and which points those are.

    A normal is unusable when it is zero length (below ``NORMAL_ZERO_LENGTH``) or
    has a NaN/Inf entry; such points are left out (reported by the callers as
    ``n_dropped``). Returns (unit normals (M, 3), keep mask (N,)). Raises on a
    wrong shape or when no point keeps a normal.
    """
    arr = as_vectors(normals, n_points, name="normals")
    with np.errstate(invalid="ignore", over="ignore"):
        length = np.linalg.norm(arr, axis=1)
    bad = ~(np.isfinite(arr).all(axis=1) & np.isfinite(length) & (length >= NORMAL_ZERO_LENGTH))
    if bad.all():
        raise PointAtlasError(
            f"no point has a usable normal (zero-length or non-finite normals at "
            f"{describe_indices(bad)})"
        )
    return as_normals(arr[~bad]), ~bad


def distinct_positions(points) -> tuple[np.ndarray, np.ndarray]:
    """``(first, inverse)``: the index of the first point at every distinct position,
    ascending, and each point's row in ``points[first]`` (``points[first][inverse]``
    equals ``points``; -0.0 and 0.0 are one position).

    One sort by x; only the points that share their x with another are sorted by all
    three coordinates (0.3 s for 10^6 distinct points, against 1.1 s for the three).

    Examples
    --------
    >>> first, inverse = distinct_positions([[1, 0, 0], [0, 0, 0], [1, 0, 0], [-0.0, 0, 0]])
    >>> first.tolist(), inverse.tolist()
    ([0, 1], [0, 1, 0, 1])
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = p.shape[0]
    order = np.argsort(p[:, 0], kind="stable")
    same = p[order[1:], 0] == p[order[:-1], 0]
    shares = np.zeros(n, dtype=bool)  # its x is another point's too
    shares[order[1:][same]] = True
    shares[order[:-1][same]] = True
    ids = np.flatnonzero(shares)
    rep = np.arange(n)  # the first point at each point's position
    if ids.size:
        q = p[ids]
        by = np.lexsort((ids, q[:, 2], q[:, 1], q[:, 0]))  # ties: the first point first
        new = np.ones(ids.size, dtype=bool)
        new[1:] = (q[by[1:]] != q[by[:-1]]).any(axis=1)
        group = np.cumsum(new) - 1
        rep[ids[by]] = ids[by[np.flatnonzero(new)]][group]
    first = np.flatnonzero(rep == np.arange(n))
    return first, np.searchsorted(first, rep)


def without_repeats(points, normals, keep) -> tuple[np.ndarray, int]:
    """The normals of the kept points (``keep`` (N,) bool, updated in place) after
    leaving out every kept point at a position a kept point before it has (a merged
    scan's overlap, a mesh's vertices written once per face), and how many were left
    out. The first point at a position keeps its normal: the points used then give
    exactly what their distinct positions give.

    Raises a `PointAtlasError` when the kept points lie on one line (or one point):
    no surface spans them.
    """
    kept = np.flatnonzero(keep)
    first, _ = distinct_positions(np.asarray(points)[kept])
    n_repeated = kept.size - first.size
    if n_repeated:
        keep[kept] = False
        keep[kept[first]] = True
        normals = normals[first]
    q = np.asarray(points, dtype=np.float64)[kept[first]]
    spread = np.linalg.svd(q - q.mean(axis=0), compute_uv=False) if q.shape[0] > 1 else [0.0]
    if len(spread) < 2 or spread[1] <= LINE_RTOL * spread[0]:
        raise PointAtlasError(
            f"simplify needs points that span a surface; the {q.shape[0]:,} distinct "
            "positions given lie on one line"
        )
    return normals, n_repeated


def off_surface(q, normals, indices, distances) -> np.ndarray:
    """Which points lie far off the surface their neighbours sample: their
    `off_surface_ratio` is over `OFF_SURFACE`. A point of the surface has half its
    neighbours' planes through it within a few spacings (on a face, at an edge, across
    a thin wall); a stray point far from it has none.

    Examples
    --------
    >>> g = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2)
    >>> q = np.vstack([np.c_[g, np.zeros(36)], [[2.5, 2.5, 30.0]]])
    >>> n = np.tile([0.0, 0.0, 1.0], (37, 1))
    >>> from scipy.spatial import cKDTree
    >>> d, j = cKDTree(q).query(q, 10)
    >>> np.flatnonzero(off_surface(q, n, j, d)).tolist()
    [36]
    """
    return off_surface_ratio(q, normals, indices, distances) > OFF_SURFACE


def off_surface_ratio(q, normals, indices, distances) -> np.ndarray:
    """The median of the points' heights over their `OFF_NEIGHBORS` nearest points'
    tangent planes (``q`` and unit ``normals``; ``indices``, ``distances``: the k-NN
    table, the point itself first, at least `OFF_NEIGHBORS` + 1 columns) over the
    points' median distance to their `OFF_SPACING_NEIGHBOR`-th nearest. Zero with
    fewer columns, or where the median distance is zero (duplicates)."""
    if indices.shape[1] <= max(OFF_NEIGHBORS, OFF_SPACING_NEIGHBOR):
        return np.zeros(q.shape[0])
    spacing = float(np.median(distances[:, OFF_SPACING_NEIGHBOR]))
    if not spacing > 0.0:
        return np.zeros(q.shape[0])
    j = indices[:, 1 : OFF_NEIGHBORS + 1]
    heights = np.abs(np.einsum("ikx,ikx->ik", normals[j], q[:, None, :] - q[j]))
    return np.median(heights, axis=1) / spacing

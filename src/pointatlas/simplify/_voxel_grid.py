"""The voxel grid of the points' surface (private; `_reconstruct.reconstruct_surface`):
its step from the points' spacing, finer on a thin sheet, its node counts, and the
measures that decide whether a finer grid's surface replaces the first.

Decisions in docs/decisions/simplify.md ("The points path's robust path").
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .._core._threads import query_workers

__all__ = [
    "BAND",
    "BAND_SPACINGS",
    "LOST_POINTS",
    "LOST_SHARE",
    "LOST_STEPS",
    "MAX_CELLS",
    "MAX_NODES",
    "SPACING_STEPS",
    "THIN_NEIGHBORS",
    "THIN_SHARE",
    "THIN_SPACING_STEPS",
    "THIN_STEPS",
    "THIN_WALL_STEPS",
    "UNEVEN",
    "band_steps",
    "euler_characteristic",
    "finer_step",
    "grid_shape",
    "grid_step",
    "lost_points",
    "lost_strays",
    "point_spacing",
    "thin_sample",
    "thin_share",
    "uneven_factor",
]

#: Largest number of grid cells across the bounding box's second-longest side (a long
#: thin part gets as many along its length as its points need: across its longest
#: side, 192 cells lost most of a part 88 units long and 6 thick) ...
MAX_CELLS = 192
#: ... and of grid nodes (a cube of 192 cells a side: the field and its work arrays
#: about 0.5 GB; 2^24 nodes made a 10^6-point scene take 270 s instead of 31 s).
MAX_NODES = 192**3
#: Grid step in point spacings (median nearest-neighbour distance) ...
SPACING_STEPS = 1.5
#: ... and one spacing where the sample is a sheet thinner than that grid resolves:
#: most of its points have a point facing the other way (normals more than 135
#: degrees apart) among their `THIN_NEIGHBORS` nearest within `THIN_STEPS` steps
#: (`thin_sample`). The smoothing took such walls away whole: `hfd_edge` sampled
#: with 5,000 points came out 43.6 % of the diagonal from its points (0.73 % at one
#: spacing); every collection model at 20,000 points keeps 1.5 (the median distance
#: across at least 1.57 steps, 1.79 on `hfd_edge`).
THIN_SPACING_STEPS = 1.0
THIN_STEPS = 1.25
THIN_NEIGHBORS = 16
#: Where the surface at `SPACING_STEPS` leaves at least `LOST_POINTS` points
#: farther than `LOST_STEPS` steps from it (a fin or a wall thinner than the grid
#: resolves, lost or cut through), it is built again at `THIN_SPACING_STEPS`, and that
#: one kept where it leaves at most half as many that far and no more handles (a
#: finer grid's sign noise makes tunnels: with estimated normals, 2 of every 6th
#: collection model lost 10-16 from their Euler characteristic at one lost point) ...
LOST_STEPS = 2.0
LOST_POINTS = 4
#: ... or handles too where at least this share of the points was lost (a part lost
#: whole: a fin 0.8 steps thin on a block, 25 % of its points 40 % of the diagonal off
#: the first surface, comes back with holes through it). `_reconstruct.reconstruct_surface`.
LOST_SHARE = 0.01
#: The finer grid is built too, no point lost, where at least `THIN_SHARE` of the
#: points have a point facing the other way within `THIN_WALL_STEPS` steps
#: (`thin_share`: walls and gaps about two grid steps thin over part of the shape,
#: which the coarser grid rounds off or bridges), and kept where it adds no handle
#: (all 149 collection models, true normals: within 1 % of the truth 133 -> 138, the
#: input's Euler characteristic 140 -> 142, the finer grid built on the 37 models at
#: or above 0.007; built on all, none below it gained).
THIN_SHARE = 0.007
THIN_WALL_STEPS = 2.0
#: A lost point off its neighbours' tangent planes (`_checks.STRAY_RATIO`) with no
#: other lost point within this many point spacings is a stray return near the
#: surface, not a part the grid lost: not counted (with 1 % of the points moved off,
#: `cad_a_a38`'s 37 lost strays built the surface twice more for nothing: 9.0 s
#: instead of 3.9 s; every clean collection sample's output is the same with it).
LOST_LINK = 2.0
#: Band around the points where the field is the tangent-plane distance (grid steps,
#: Chebyshev); beyond it every connected region of nodes takes one sign by a vote ...
BAND = 3
#: ... and at least this many point spacings wide (where the band leaks through the
#: sampling's gaps, the inside of a closed surface takes its side from the winding
#: number, `_reconstruct._winding_sides`).
BAND_SPACINGS = 4.5
#: Points sampled unevenly (a scan's density falls with the range): where the 90th
#: percentile of the distance to the 8th nearest other point passes this many times its
#: median (uniform samples of every collection model: 1.18-1.25; a density falling
#: tenfold along the part: 1.33-1.78), the spacing the grid is built from grows by
#: their ratio over this, so that the sparse parts' gaps stay within the field's reach
#: (`uneven_factor`).
UNEVEN = 1.3


def grid_step(q: np.ndarray, normals: np.ndarray, tree: cKDTree, factor=None):
    """``(spacing, step, shape)`` of the grid of points ``q`` (working frame): the
    points' spacing (`point_spacing`, times ``factor``: `uneven_factor` when None), a
    step of `SPACING_STEPS` spacings (one on a thin sheet, `thin_sample`), at least 1
    / `MAX_CELLS` of the box's second-longest side, and the node counts
    (`grid_shape`)."""
    factor = uneven_factor(q, tree) if factor is None else factor
    spacing = point_spacing(q, tree) * factor
    step, shape = _grid_at(q, spacing, SPACING_STEPS)
    if thin_sample(q, normals, tree, THIN_STEPS * step):
        step, shape = finer_step(q, spacing)
    return spacing, step, shape


def finer_step(q: np.ndarray, spacing: float):
    """``(step, shape)`` of the finer grid of points ``q`` (`grid_step`'s, at
    `THIN_SPACING_STEPS` point ``spacing``)."""
    return _grid_at(q, spacing, THIN_SPACING_STEPS)


def _grid_at(q: np.ndarray, spacing: float, spacings: float):
    """``(step, shape)``: ``spacings`` point spacings a step, at least 1 / `MAX_CELLS`
    of the box's second-longest side (`grid_shape`)."""
    lo, hi = q.min(axis=0), q.max(axis=0)
    across = float(np.sort(hi - lo)[-2])
    return grid_shape(hi - lo, max(spacings * spacing, across / MAX_CELLS), spacing)


def point_spacing(q: np.ndarray, tree: cKDTree) -> float:
    """Median distance to the nearest other position (repeated points count once) of
    at most 20,000 evenly strided points."""
    stride = max(1, q.shape[0] // 20000)
    d, _ = tree.query(q[::stride], k=min(4, q.shape[0]))
    d = d.reshape(d.shape[0], -1)
    apart = np.where(d > 0.0, d, np.inf).min(axis=1)  # the nearest at another position
    apart = apart[np.isfinite(apart)]
    return float(np.median(apart)) if apart.size else 0.0


def thin_sample(q, normals, tree, within: float) -> bool:
    """Whether most of at most 5,000 evenly strided points have a point facing the
    other way (`THIN_NEIGHBORS` nearest) nearer than ``within``: a thin sheet."""
    return bool(np.median(_across(q, normals, tree, 5000)) < within)


def thin_share(q, normals, tree, within: float) -> float:
    """The share of at most 20,000 evenly strided points with a point facing the
    other way (`THIN_NEIGHBORS` nearest) nearer than ``within``: how much of the
    sample lies on walls and gaps that thin."""
    return float(np.mean(_across(q, normals, tree, 20000) < within))


def _across(q, normals, tree, most: int) -> np.ndarray:
    """For at most ``most`` evenly strided points, the distance to the nearest of
    their `THIN_NEIGHBORS` nearest points facing the other way (normals more than 135
    degrees apart; inf where none)."""
    stride = max(1, q.shape[0] // most)
    rows, k = q[::stride], min(THIN_NEIGHBORS, q.shape[0])
    d, j = tree.query(rows, k=k, workers=query_workers(rows.shape[0], k))
    d, j = d.reshape(-1, k), j.reshape(-1, k)
    facing = np.einsum("ij,ikj->ik", normals[::stride], normals[j])
    return np.where(facing < -0.7, d, np.inf).min(axis=1)


def grid_shape(size, step: float, spacing: float):
    """The grid step (at least ``step``) and node counts for a box of ``size``, padded
    by the band and two steps, with at most about `MAX_NODES` nodes."""
    for _ in range(8):
        pad = band_steps(step, spacing) + 2
        shape = np.ceil(size / step).astype(np.int64) + 2 * pad + 1
        grow = (float(np.prod(shape.astype(np.float64))) / MAX_NODES) ** (1.0 / 3.0)
        if grow <= 1.0:
            break
        step *= grow * 1.01
    return step, tuple(int(x) for x in shape)


def band_steps(step: float, spacing: float) -> int:
    """The band's width in grid steps: `BAND`, and at least `BAND_SPACINGS` spacings."""
    return max(BAND, int(np.ceil(BAND_SPACINGS * spacing / step)))


def lost_points(q, vertices, triangles, far: float, off=None, link: float = 0.0, index=None) -> int:
    """How many points ``q`` lie farther than ``far`` from the triangles, strays left
    out (`not_strays`: ``off``, ``link``; None: none). ``index``: the triangles'
    `neighbors.MeshDistanceIndex` (`Reconstruction.distance_index`), built when None."""
    lost = _mesh_index(vertices, triangles, index).distance(q, within=far) > far
    return int(not_strays(q, lost, off, link).sum())


def lost_strays(q, vertices, triangles, step: float, off, link: float, index=None) -> np.ndarray:
    """Mask of the points ``q`` farther than `LOST_STEPS` grid ``step`` from the
    triangles, ``off`` (mask: off their neighbours' tangent planes) and with no other
    such far point within ``link``; ``index`` as in `lost_points`."""
    far = LOST_STEPS * step
    lost = np.zeros(q.shape[0], dtype=bool)
    index = _mesh_index(vertices, triangles, index)
    # the points off their planes first: most samples have none that far
    for part in (np.flatnonzero(off), np.flatnonzero(~off)):
        if part.size:
            lost[part] = index.distance(q[part], within=far) > far
        if not (lost & off).any():
            return lost & off
    return lost & ~not_strays(q, lost, off, link)


def _mesh_index(vertices, triangles, index=None):
    """``index``, or the triangles' `neighbors.MeshDistanceIndex` (its distances are
    `point_mesh_distance`'s)."""
    from ..neighbors import MeshDistanceIndex

    return MeshDistanceIndex(vertices, triangles) if index is None else index


def not_strays(q, lost, off, link: float) -> np.ndarray:
    """``lost`` (mask of points ``q``) without its strays: the points ``off`` (mask:
    off their neighbours' tangent planes; None: none) with no other ``lost`` point
    within ``link``.

    Examples
    --------
    >>> q = np.array([[0.0, 0, 0], [1, 0, 0], [9, 0, 0], [20, 0, 0]])
    >>> lost, off = np.array([True, True, True, True]), np.array([True, False, True, False])
    >>> not_strays(q, lost, off, 2.0).tolist()  # the third: off its planes and alone
    [True, True, False, True]
    """
    if off is None or not (lost & off).any():
        return lost
    return lost & ~(off & ~linked(q, lost, link))


def linked(q, mask, link: float) -> np.ndarray:
    """``mask`` without its points that have no other point of ``mask`` within
    ``link`` (``mask`` itself where ``link`` <= 0).

    Examples
    --------
    >>> q = np.array([[0.0, 0, 0], [1, 0, 0], [9, 0, 0], [20, 0, 0]])
    >>> linked(q, np.array([True, True, True, False]), 2.0).tolist()
    [True, True, False, False]
    """
    if not link > 0.0 or not mask.any():
        return mask
    idx = np.flatnonzero(mask)
    pairs = cKDTree(q[idx]).query_pairs(link, output_type="ndarray")
    alone = np.ones(idx.size, dtype=bool)
    alone[pairs.reshape(-1)] = False
    out = mask.copy()
    out[idx[alone]] = False
    return out


def euler_characteristic(triangles) -> int:
    """V - E + F of ``triangles`` (the vertices they use, their distinct edges).

    Examples
    --------
    >>> euler_characteristic(np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]))
    2
    """
    from ._mesh import unique_pairs

    t = np.asarray(triangles, dtype=np.int64)
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    return int(np.unique(t).size - unique_pairs(edges).shape[0] + t.shape[0])


def uneven_factor(q: np.ndarray, tree: cKDTree) -> float:
    """1, or where the points are sampled unevenly the ratio of the 90th percentile of
    the distance to the 8th nearest other point to its median (at most 20,000 evenly
    strided points), over `UNEVEN`."""
    stride = max(1, q.shape[0] // 20000)
    k = min(9, q.shape[0])
    if k < 2:
        return 1.0
    d, _ = tree.query(q[::stride], k=k)
    far = d.reshape(-1, k)[:, -1]
    middle = float(np.median(far))
    if not middle > 0.0:
        return 1.0
    return max(1.0, float(np.quantile(far, 0.9)) / middle / UNEVEN)

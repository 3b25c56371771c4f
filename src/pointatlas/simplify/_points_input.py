"""The points path's input step: the points checked, repeated positions and points
far off the surface left out, inward normals turned out, the working frame and one
k-NN table (`prepare_points`, for `simplify_points`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._core import as_points
from ..neighbors import query_knn
from ._checks import (
    OFF_SURFACE,
    STRAY_RATIO,
    check_memory,
    check_size,
    off_surface_ratio,
    usable_normals,
    without_repeats,
)
from ._frame import Frame, frame_of
from ._sides import SMOOTH_K, turn_outward

if TYPE_CHECKING:  # pragma: no cover
    from ..segment import VSAOptions

__all__ = ["PreparedPoints", "knn_table", "prepare_points"]


@dataclass(frozen=True, slots=True)
class PreparedPoints:
    """The points used by `simplify_points`, in input and working coordinates."""

    points: np.ndarray  # the points with a usable normal
    normals: np.ndarray
    keep: np.ndarray  # (N_input,) bool: the point is used
    n_input: int
    k: int
    options: VSAOptions  # weights given per point follow the points used
    frame: Frame
    q: np.ndarray  # the points in the working frame
    indices: np.ndarray  # their k-NN table (working frame)
    n_turned: int  # normals turned to the outside (`_outward`)
    areas: np.ndarray  # the points' disc areas (`_winding.point_areas`)
    radius: np.ndarray  # ... and the radii of `PointSurface`'s discs (`disc_radii`)
    n_off_surface: int  # points left out far off the surface (`_checks.off_surface`)
    ratio: np.ndarray  # the points' heights off their neighbours' planes (`off_surface_ratio`)
    n_repeated: int  # points left out at a position an earlier point has (`without_repeats`)

    @property
    def off_planes(self) -> np.ndarray:
        """The points off their neighbours' planes (`STRAY_RATIO`)."""
        return self.ratio > STRAY_RATIO

    @property
    def point_index(self) -> np.ndarray:
        return np.flatnonzero(self.keep)


def prepare_points(points, normals, vsa, vsa_settings, strays=None) -> PreparedPoints:
    """Check the input, leave out points without a usable normal, the ``strays`` (mask
    of the input points, or None) and points far off the surface the others sample
    (`off_surface`), turn inward normals out (`_outward`), find the working frame
    and the k-NN table (memory checked first); ``vsa`` and ``vsa_settings`` give the
    VSA options."""
    # imported here so the meshing half of the room works on its own
    from ..segment import VSAOptions
    from ._distance import disc_radii
    from ._winding import table_areas

    opts = (VSAOptions() if vsa is None else vsa).replace(**vsa_settings)
    given = as_points(points)
    n_input = given.shape[0]
    k = check_size(n_input, opts.k)
    nrm, keep = usable_normals(normals, n_input)
    n_strays = 0
    if strays is not None:
        nrm, n_strays = nrm[~strays[keep]], int((strays & keep).sum())
        keep &= ~strays
    nrm, n_repeated = without_repeats(given, nrm, keep)
    pts = given if keep.all() else given[keep]
    k = check_size(pts.shape[0], k)
    frame, q, wide, dist = knn_table(pts, k)
    ratio = off_surface_ratio(q, nrm, wide, dist)
    off = ratio > OFF_SURFACE
    n_off = 0 if off.all() else int(off.sum())
    if n_off:  # left out: the frame and the table again without them
        keep[np.flatnonzero(keep)[off]] = False
        pts, nrm = given[keep], nrm[~off]
        k = check_size(pts.shape[0], k)
        frame, q, wide, dist = knn_table(pts, k)
        ratio = off_surface_ratio(q, nrm, wide, dist)
    if not isinstance(opts.weights, str) and not keep.all():
        # given per-point weights follow the points
        if opts.weights.shape != (n_input,):
            raise ValueError(f"weights must have shape ({n_input},); got {opts.weights.shape}")
        opts = opts.replace(weights=opts.weights[keep])
    areas, radius = table_areas(dist), disc_radii(dist, q, nrm, wide)
    nrm, n_turned = _outward(q, nrm, (wide, dist), areas)
    idx = wide if wide.shape[1] == k else np.ascontiguousarray(wide[:, :k])
    n_off += n_strays  # the strays given are counted with them
    return PreparedPoints(
        pts,
        nrm,
        keep,
        n_input,
        k,
        opts,
        frame,
        q,
        idx,
        n_turned,
        areas,
        radius,
        n_off,
        ratio,
        n_repeated,
    )


def _outward(q, normals, neighbors, areas) -> tuple[np.ndarray, int]:
    """``normals`` turned to the outside, and how many were: by the voxel outside's
    vote (`turn_outward`), and where that vote turns some of a closed sample's
    normals but not all, then by the rest of `outward_normals`' steps, which check it
    by the winding number (`_signs.winding_turns`; the vote alone undid their turns:
    `prusamini_mini-fsenzor-box`, 20,000 points, normals estimated and turned by
    `outward_normals`, 1,157 of them pointing in, 2,163 after the vote)."""
    from ._signs import winding_turns

    turned, count = turn_outward(q, normals, neighbors, areas)
    if count == 0 or count == q.shape[0]:
        return turned, count
    idx = np.ascontiguousarray(neighbors[0][:, :SMOOTH_K], dtype=np.int64)
    dist = np.asarray(neighbors[1][:, :SMOOTH_K], dtype=np.float64)
    out = winding_turns(q, turned, idx, dist, areas)
    return out, int((np.einsum("ij,ij->i", out, normals) < 0.0).sum())


def knn_table(pts, k: int):
    """``(frame, q, indices, distances)``: the working frame of ``pts``, the points in
    it, and one k-NN table for VSA, the discs (areas, radii), `off_surface` and
    `turn_outward` (its first ``k`` columns are `query_knn(q, k)`'s: ties go to the
    smaller index); memory checked first."""
    from ._distance import DISC_NEIGHBOR
    from ._winding import AREA_NEIGHBOR

    columns = min(max(k, SMOOTH_K, AREA_NEIGHBOR + 1, DISC_NEIGHBOR + 1), pts.shape[0])
    check_memory(pts.shape[0], k, columns=columns)
    frame = frame_of(pts)
    q = frame.to_local(pts)
    return (frame, q, *query_knn(q, columns))

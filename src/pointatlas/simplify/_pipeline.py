"""Segment with VSA, then simplify (the thesis' pipeline, Fig. 4.4 and 4.4)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._core import as_points, readonly
from ..neighbors import query_knn
from ._checks import check_memory, check_size, usable_normals
from ._frame import frame_of
from ._mesh import SimplifiedMesh, simplify_segmentation
from ._proxies import region_proxies

if TYPE_CHECKING:  # pragma: no cover
    from ..segment import VSAResult

__all__ = ["PointSimplification", "simplify_points"]


@dataclass(frozen=True, slots=True)
class PointSimplification:
    """Result of `simplify_points`: the VSA segmentation and the simplified mesh.

    Attributes
    ----------
    segmentation : VSAResult
        VSA segmentation of the points used (``point_index``).
    mesh : SimplifiedMesh
        The simplified mesh; its ``point_index`` and ``n_dropped`` refer to the
        input points too.
    point_index : ndarray of shape (M,), int64
        Input index of every point used: points whose normal is zero-length or
        has a NaN/Inf entry are left out.
    n_dropped : int
        Number of input points left out.
    """

    segmentation: VSAResult
    mesh: SimplifiedMesh
    point_index: np.ndarray
    n_dropped: int

    def __post_init__(self):
        readonly(self.point_index)


def simplify_points(
    points,
    normals,
    *,
    k: int = 8,
    seeds="all",
    eta: float | None = None,
    max_angle: float | None = None,
    split: bool = True,
    merge: bool = True,
    switch: str = "batch",
    classic: bool = False,
    weights="uniform",
    max_iter: int = 1000,
    rng=None,
    vertices: str = "fit",
    faces: str = "general",
    centers: str = "centroid",
    weight: float = 1.0,
    anchor_weight: float | None = None,
    min_region_size: int | None = None,
    repair: bool = True,
    smooth: int = 2,
    max_boundary_fraction: float = 0.95,
) -> PointSimplification:
    """Segment a point set by VSA and build its simplified polygon mesh.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Coordinates.
    normals : array_like of shape (N, 3), float64
        Oriented normals. Points whose normal is zero-length or has a NaN/Inf entry
        are left out and counted in ``n_dropped``.
    k : int
        Neighbourhood size of segmentation and complex (thesis: 8; 12 with noise);
        1 <= k <= the number of points used.
    seeds, eta, max_angle, split, merge, switch, classic, weights, max_iter, rng
        Passed to `pointatlas.segment.vsa_segment`.
    vertices, faces, centers, weight, anchor_weight, min_region_size, repair, smooth,
    max_boundary_fraction
        Passed to `simplify_segmentation`; ``centers="seed"`` uses the VSA seed
        points C_i.

    Returns
    -------
    result : PointSimplification
        ``segmentation`` (VSAResult), ``mesh`` (SimplifiedMesh), ``point_index``
        and ``n_dropped`` (points left out for want of a usable normal).

    Raises
    ------
    ValueError
        Bad shapes or options.
    TypeError
        Non-numeric arrays, non-integer ``k``.
    PointAtlasError
        Too few points ("simplify needs at least 4 points", or fewer than ``k``),
        more memory than available for this ``k`` (estimated before any work), no
        point with a usable normal, or a degenerate segmentation (see
        `simplify_segmentation`).

    Notes
    -----
    Thesis Fig. 4.4: segmentation (4.2-4.3), complex (3), vertices (4.4.1), faces
    (4.4.2). The proxy planes are the VSA proxies (normal N_i through the centroid,
    Eq. 4.7, or through the seed point C_i). The neighbourhoods of the meshing
    steps are found in the room's working coordinates (centred and scaled, see
    `simplify_segmentation`); VSA itself sees the points as given.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> r = simplify_points(m.vertices, m.normals, max_angle=0.3)
    >>> r.mesh.n_faces, r.mesh.n_vertices, r.mesh.is_closed, r.n_dropped
    (6, 8, True, 0)
    """
    # imported here so the meshing half of the room works on its own
    from ..segment import vsa_segment

    pts = as_points(points)
    n_input = pts.shape[0]
    k = check_size(n_input, k)
    nrm, keep = usable_normals(normals, n_input)
    if not keep.all():
        pts = pts[keep]
        k = check_size(pts.shape[0], k)
        if not isinstance(weights, str):  # given per-point weights follow the points
            weights = np.asarray(weights, dtype=np.float64)
            if weights.shape != (n_input,):
                raise ValueError(f"weights must have shape ({n_input},); got {weights.shape}")
            weights = weights[keep]
    check_memory(pts.shape[0], k)
    frame = frame_of(pts)
    q = frame.to_local(pts)
    idx, _ = query_knn(q, k)
    seg = vsa_segment(
        pts,
        nrm,
        k=k,
        seeds=seeds,
        eta=eta,
        max_angle=max_angle,
        split=split,
        merge=merge,
        switch=switch,
        classic=classic,
        weights=weights,
        max_iter=max_iter,
        rng=rng,
    )
    if isinstance(centers, str) and centers == "seed":
        ctr = seg.seed_points
    elif isinstance(centers, str) and centers == "centroid":
        ctr = _centroids(frame, q, nrm, seg, weights, k, idx)
    else:
        raise ValueError(f"centers must be 'centroid' or 'seed'; got {centers!r}")
    mesh = simplify_segmentation(
        pts,
        nrm,
        seg.labels,
        k=k,
        vertices=vertices,
        faces=faces,
        centers=ctr,
        proxy_normals=seg.proxy_normals,
        weight=weight,
        anchor_weight=anchor_weight,
        min_region_size=min_region_size,
        repair=repair,
        smooth=smooth,
        max_boundary_fraction=max_boundary_fraction,
        indices=idx,
    )
    point_index = np.flatnonzero(keep)
    n_dropped = n_input - point_index.size
    mesh = dataclasses.replace(mesh, point_index=point_index, n_dropped=n_dropped)
    return PointSimplification(
        segmentation=seg, mesh=mesh, point_index=point_index, n_dropped=n_dropped
    )


def _centroids(frame, q, normals, seg, weights, k, indices):
    """The VSA regions' (weighted) centroids, summed in the working frame.

    ``VSAResult.centroids`` sums the coordinates as given: far from the origin
    (1e8) the sums lose ~1e-8 absolute accuracy, which would move the mesh. Uniform
    weights: ``"centroid"`` (`simplify_segmentation` sums in its frame itself);
    other weights: the same weighted means in the frame, mapped back.
    """
    if isinstance(weights, str) and weights == "uniform":
        return "centroid"
    if isinstance(weights, str) and weights == "area":
        from ..segment import area_weights

        w = area_weights(q, k=k, neighbors=indices)
    else:
        w = np.asarray(weights, dtype=np.float64)
    return frame.to_input(region_proxies(q, normals, seg.labels, weights=w).centroids)

"""Segment with VSA, then simplify (the thesis' pipeline, Fig. 4.4 and 4.4)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .._core import as_normals, as_points
from ..neighbors import query_knn
from ._mesh import SimplifiedMesh, simplify_segmentation

if TYPE_CHECKING:  # pragma: no cover
    from ..segment import VSAResult

__all__ = ["PointSimplification", "simplify_points"]


@dataclass(frozen=True, slots=True)
class PointSimplification:
    """Result of `simplify_points`: the VSA segmentation and the simplified mesh."""

    segmentation: VSAResult
    mesh: SimplifiedMesh


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
        Oriented normals.
    k : int
        Neighbourhood size of segmentation and complex (thesis: 8; 12 with noise).
    seeds, eta, max_angle, split, merge, switch, classic, weights, max_iter, rng
        Passed to `pointatlas.segment.vsa_segment`.
    vertices, faces, centers, weight, anchor_weight, min_region_size, repair, smooth,
    max_boundary_fraction
        Passed to `simplify_segmentation`; ``centers="seed"`` uses the VSA seed
        points C_i.

    Returns
    -------
    result : PointSimplification
        ``segmentation`` (VSAResult) and ``mesh`` (SimplifiedMesh).

    Raises
    ------
    ValueError
        Bad shapes or options.
    PointAtlasError
        Degenerate segmentation (see `simplify_segmentation`).

    Notes
    -----
    Thesis Fig. 4.4: segmentation (4.2-4.3), complex (3), vertices (4.4.1), faces
    (4.4.2). The proxy planes are the VSA proxies (normal N_i through the centroid,
    Eq. 4.7, or through the seed point C_i).

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(6)
    >>> r = simplify_points(m.vertices, m.normals, max_angle=0.3)
    >>> r.mesh.n_faces, r.mesh.n_vertices, r.mesh.is_closed
    (6, 8, True)
    """
    # imported here so the meshing half of the room works on its own
    from ..segment import vsa_segment

    pts = as_points(points)
    nrm = as_normals(normals, pts.shape[0])
    idx, _ = query_knn(pts, k)
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
        ctr = seg.centroids
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
    return PointSimplification(segmentation=seg, mesh=mesh)

"""Denoising measures: normal MSE (Eq. 5.10), Chamfer, point-to-mesh, drift."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from scipy.spatial import cKDTree

from .._core import as_int, as_normals, as_points
from ..neighbors import mean_spacing, point_mesh_distance

__all__ = [
    "DenoiseMeasures",
    "chamfer_distance",
    "denoise_measures",
    "normal_mse",
    "unit_sphere_transform",
]


def normal_mse(normals, reference) -> float:
    """Mean squared error between two normal fields (thesis Eq. 5.10).

    Parameters
    ----------
    normals : array_like of shape (N, 3), float64
        Changed normals (rescaled to unit length).
    reference : array_like of shape (N, 3), float64
        Ground-truth normals (rescaled to unit length).

    Returns
    -------
    mse : float
        (1/N) sum_i |n_i - n~_i|^2, in [0, 4]; orientation matters (a flipped
        normal costs 4).

    Raises
    ------
    ValueError
        Shapes that differ, non-finite or zero-length normals.

    Examples
    --------
    >>> normal_mse([[0, 0, 1], [0, 0, 1]], [[0, 0, 1], [0, 1, 0]])
    1.0
    """
    ref = as_normals(reference, name="reference")
    nrm = as_normals(normals, ref.shape[0])
    return float(np.mean(np.sum((nrm - ref) ** 2, axis=1)))


def unit_sphere_transform(points) -> tuple[np.ndarray, float]:
    """Centre and radius that map ``points`` into the unit sphere (PU-Net protocol).

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        The reference (clean) points, N >= 1.

    Returns
    -------
    center : ndarray of shape (3,), float64
        The centroid.
    radius : float
        The largest distance of a point to the centroid (1.0 when all coincide).

    Examples
    --------
    >>> c, r = unit_sphere_transform([[0, 0, 0], [2, 0, 0]])
    >>> c.tolist(), r
    ([1.0, 0.0, 0.0], 1.0)
    """
    pts = as_points(points)
    center = pts.mean(axis=0)
    radius = float(np.sqrt(((pts - center) ** 2).sum(axis=1).max()))
    return center, (radius if radius > 0 else 1.0)


def chamfer_distance(points, reference, *, normalize: bool = True) -> float:
    """Squared Chamfer distance in both directions, after normalising to the unit sphere.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Denoised (or noisy) points.
    reference : array_like of shape (M, 3), float64
        Clean points (a mesh's vertices or a dense sample of it).
    normalize : bool
        Map both sets with the reference's `unit_sphere_transform` first (default),
        so numbers compare with published tables.

    Returns
    -------
    cd : float
        mean_i min_j |p_i - q_j|^2 + mean_j min_i |q_j - p_i|^2, in squared units of
        the unit sphere (or of the input when ``normalize`` is False).

    Raises
    ------
    ValueError
        Bad shapes, empty or non-finite input.

    Examples
    --------
    >>> chamfer_distance([[0, 0, 0], [1, 0, 0]], [[0, 0, 0], [1, 0, 0]])
    0.0
    """
    p = as_points(points)
    q = as_points(reference, name="reference")
    if normalize:
        center, radius = unit_sphere_transform(q)
        p = (p - center) / radius
        q = (q - center) / radius
    d_pq = cKDTree(q).query(p, k=1)[0]
    d_qp = cKDTree(p).query(q, k=1)[0]
    return float(np.mean(d_pq**2) + np.mean(d_qp**2))


@dataclass(frozen=True, slots=True)
class DenoiseMeasures:
    """What the denoising literature reports, for one result against the clean model.

    Attributes
    ----------
    chamfer : float
        Squared Chamfer distance, both directions, in the unit sphere of the clean
        points (`chamfer_distance`).
    p2m_mean, p2m_max : float
        Mean and max point-to-mesh distance to the clean mesh (input units; NaN
        without a clean mesh).
    p2m_mean_unit : float
        ``p2m_mean`` in units of the clean model's unit sphere (NaN without faces).
    normal_mse : float
        Eq. 5.10 against the clean normals (NaN without normals).
    distance_mean, distance_max : float
        Mean and max |p_i - c_i| to the corresponding clean point (input units).
    drift_share : float
        Share of points whose displacement from their clean point, projected on the
        clean tangent plane, exceeds l (NaN without clean normals).
    spacing : float
        l: the mean 6-NN spacing of the clean points.
    matched : str
        ``"index"`` (clean point i belongs to point i) or ``"nearest"`` (counts
        differ: the nearest clean point).
    """

    chamfer: float
    p2m_mean: float
    p2m_max: float
    p2m_mean_unit: float
    normal_mse: float
    distance_mean: float
    distance_max: float
    drift_share: float
    spacing: float
    matched: str

    def as_dict(self) -> dict:
        """The measures as a plain dict (for JSON and tables).

        Returns
        -------
        measures : dict of str to float or str
            One entry per attribute.
        """
        return {f.name: getattr(self, f.name) for f in fields(self)}


def denoise_measures(
    points,
    clean_points,
    *,
    normals=None,
    clean_normals=None,
    clean_faces=None,
    spacing_k: int = 6,
) -> DenoiseMeasures:
    """Compare a denoised (or noisy) point set with its clean model.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        The points to judge.
    clean_points : array_like of shape (M, 3), float64
        The clean model's points (mesh vertices); M = N means point i corresponds
        to clean point i (noise added to the clean model), else the nearest clean
        point is taken.
    normals : array_like of shape (N, 3), float64, optional
        The normals to judge (for Eq. 5.10).
    clean_normals : array_like of shape (M, 3), float64, optional
        Ground-truth normals (area-weighted vertex normals of the clean mesh).
    clean_faces : array_like of shape (F, 3), int, optional
        Triangles of the clean mesh (for the point-to-mesh distances).
    spacing_k : int
        Neighbours for l (thesis 5.4: 6).

    Returns
    -------
    measures : DenoiseMeasures
        NaN where an input needed is missing.

    Raises
    ------
    ValueError
        Bad shapes, non-finite input, too few clean points for ``spacing_k``.

    Examples
    --------
    >>> from pointatlas.synth import cube
    >>> m = cube(4)
    >>> r = denoise_measures(m.points, m.points, normals=m.normals, clean_normals=m.normals,
    ...                      clean_faces=m.faces)
    >>> r.chamfer, r.p2m_max, r.normal_mse, r.drift_share
    (0.0, 0.0, 0.0, 0.0)
    """
    pts = as_points(points)
    clean = as_points(clean_points, name="clean_points")
    k = as_int(spacing_k, "spacing_k", lo=1, hi=clean.shape[0] - 1, note="clean points - 1")
    nrm = None if normals is None else as_normals(normals, pts.shape[0])
    cnrm = None
    if clean_normals is not None:
        cnrm = as_normals(clean_normals, clean.shape[0], name="clean_normals")
    ell = mean_spacing(clean, k)
    if clean.shape[0] == pts.shape[0]:
        match = np.arange(pts.shape[0])
        matched = "index"
    else:
        match = cKDTree(clean).query(pts, k=1)[1]
        matched = "nearest"
    disp = pts - clean[match]
    dist = np.sqrt((disp**2).sum(axis=1))
    nan = math.nan
    mse = nan if nrm is None or cnrm is None else normal_mse(nrm, cnrm[match])
    drift = nan
    if cnrm is not None and matched == "index":
        along = (disp * cnrm).sum(axis=1)
        tangential = np.sqrt(np.maximum((disp**2).sum(axis=1) - along**2, 0.0))
        drift = float(np.mean(tangential > ell))
    p2m_mean = p2m_max = p2m_unit = nan
    if clean_faces is not None:
        d = point_mesh_distance(pts, clean, clean_faces)
        p2m_mean, p2m_max = float(d.mean()), float(d.max())
        p2m_unit = p2m_mean / unit_sphere_transform(clean)[1]
    return DenoiseMeasures(
        chamfer=chamfer_distance(pts, clean),
        p2m_mean=p2m_mean,
        p2m_max=p2m_max,
        p2m_mean_unit=p2m_unit,
        normal_mse=mse,
        distance_mean=float(dist.mean()),
        distance_max=float(dist.max()),
        drift_share=drift,
        spacing=ell,
        matched=matched,
    )

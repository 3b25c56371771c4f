"""Comparing normal fields: flipped fraction and angle errors."""

from __future__ import annotations

import numpy as np

from .._core import as_normals

__all__ = ["angle_error", "flipped_fraction"]


def _pair(normals, reference):
    nrm = as_normals(normals)
    ref = as_normals(reference, nrm.shape[0], name="reference")
    return nrm, ref


def flipped_fraction(normals, reference) -> float:
    """Fraction of normals pointing against their reference normal.

    Parameters
    ----------
    normals : array_like of shape (N, 3)
        Normals to check (any non-zero length).
    reference : array_like of shape (N, 3)
        Reference normals, same N.

    Returns
    -------
    fraction : float
        Share of rows with n_i . r_i < 0, in [0, 1]; 0.0 for N = 0.

    Raises
    ------
    ValueError
        Shapes differ, non-finite or zero-length vectors.

    Notes
    -----
    Measures orientation only (perpendicular pairs, dot = 0, count as not flipped).

    Examples
    --------
    >>> flipped_fraction([[0, 0, 1], [0, 0, -1]], [[0, 0, 1], [0, 0, 1]])
    0.5
    """
    nrm, ref = _pair(normals, reference)
    if nrm.shape[0] == 0:
        return 0.0
    return float(np.mean(np.einsum("ij,ij->i", nrm, ref) < 0))


def angle_error(normals, reference, *, unoriented: bool = False) -> np.ndarray:
    """Angle between every normal and its reference normal.

    Parameters
    ----------
    normals : array_like of shape (N, 3)
        Normals (any non-zero length).
    reference : array_like of shape (N, 3)
        Reference normals, same N.
    unoriented : bool
        If True compare lines, not directions: the angle to the closer of +r and
        -r, in [0, pi/2].

    Returns
    -------
    angles : ndarray of shape (N,), float64
        Radians in [0, pi] (or [0, pi/2] when unoriented).

    Raises
    ------
    ValueError
        Shapes differ, non-finite or zero-length vectors.

    Notes
    -----
    Computed as atan2(|n x r|, n . r), accurate also for tiny and near-pi angles
    (arccos of the dot product loses half the digits there).

    Examples
    --------
    >>> angle_error([[0, 0, 1], [0, 0, -1]], [[0, 0, 1], [0, 1, 1]]).round(4).tolist()
    [0.0, 2.3562]
    >>> angle_error([[0, 0, -1]], [[0, 0, 1]], unoriented=True).tolist()
    [0.0]
    """
    nrm, ref = _pair(normals, reference)
    dot = np.einsum("ij,ij->i", nrm, ref)
    cross = np.linalg.norm(np.cross(nrm, ref), axis=1)
    if unoriented:
        dot = np.abs(dot)
    return np.arctan2(cross, dot)

"""Cosine sigmoid weights on normal deviations (thesis 5.2, Def. 15, Eq. 5.2)."""

from __future__ import annotations

import math

import numpy as np

from .._core import as_float, as_vectors, check_neighbors, readonly_view
from .._core.tolerances import ANGLE_ZERO
from ._kernels import angles_kernel, unit_normals_kernel

__all__ = ["cosine_sigmoid", "normal_angles", "normal_weights"]


def _check_ab(a, b) -> tuple[float, float]:
    """Sigmoid thresholds: 0 <= a <= b <= pi (radians), finite."""
    a = as_float(a, "a", lo=0.0, hi=math.pi, what="angle", unit="radians")
    b = as_float(b, "b", lo=a, hi=math.pi, what="angle", unit="radians", note="b >= a")
    return a, b


def cosine_sigmoid(x, a: float, b: float) -> np.ndarray:
    """The cosine sigmoid of Def. 15 evaluated at angles ``x``.

    Parameters
    ----------
    x : array_like of float64
        Angles in radians, in [0, pi]. Angles below ``ANGLE_ZERO`` (1e-7) count as 0.
    a : float
        Start of the cosine ramp, in [0, pi] (radians).
    b : float
        End of the ramp, in [a, pi] (radians).

    Returns
    -------
    weights : ndarray of float64, same shape as ``x``
        1 for x <= a, 0.5 cos(pi (x - a) / (b - a)) + 0.5 for a < x < b, 0 for x >= b;
        NaN where ``x`` is NaN.

    Raises
    ------
    ValueError
        ``a`` outside [0, pi] or ``b`` outside [a, pi] (NaN included).
    TypeError
        ``a`` or ``b`` not a real number.

    Notes
    -----
    Thesis Def. 15 writes 1 for x < a and the cosine on [a, b]; both agree at x = a
    (cos 0 = 1). For a = b the printed formula divides by zero; pointatlas reads
    it as the sharp cut-off "weight 1 iff x <= a", so a = b = pi gives equal weights
    and identical normals keep weight 1 at a = b = 0.

    Examples
    --------
    >>> import numpy as np
    >>> cosine_sigmoid(np.array([0.0, 0.5, 1.0]), 0.0, 1.0).round(3).tolist()
    [1.0, 0.5, 0.0]
    >>> cosine_sigmoid(np.array([0.0, 3.0]), np.pi, np.pi).tolist()
    [1.0, 1.0]
    """
    a, b = _check_ab(a, b)
    x = np.asarray(x, dtype=np.float64)
    x = np.where(x < ANGLE_ZERO, 0.0, x)
    out = np.where(x <= a, 1.0, 0.0)
    ramp = (x > a) & (x < b)
    if ramp.any():
        out[ramp] = 0.5 * np.cos(np.pi * (x[ramp] - a) / (b - a)) + 0.5
    out[np.isnan(x)] = np.nan
    return out


def _unit_normals_or_nan(normals, n_points: int | None = None) -> np.ndarray:
    """Unit normals; rows that are non-finite or of zero length become NaN (flagged later)."""
    arr = as_vectors(normals, n_points, name="normals")
    out = np.empty(arr.shape)
    unit_normals_kernel(readonly_view(np.ascontiguousarray(arr)), out)
    return out


def normal_angles(normals, neighbors) -> np.ndarray:
    """Angles between each point's normal and its neighbours' normals.

    Parameters
    ----------
    normals : array_like of shape (N, 3)
        Oriented normals (rescaled to unit length; non-finite or zero rows give NaN).
    neighbors : array_like of shape (N, k), int
        Neighbour indices (e.g. from `pointatlas.neighbors.query_knn`).

    Returns
    -------
    angles : ndarray of shape (N, k), float64
        Angles in [0, pi] (radians), computed as 2 atan2(|n_i - n_j|, |n_i + n_j|),
        which stays accurate near 0 and pi where arccos of the dot product does not;
        angles below ``ANGLE_ZERO`` are set to exactly 0.

    Raises
    ------
    ValueError
        Wrong shapes or indices out of range.
    TypeError
        Non-integer ``neighbors``.

    Examples
    --------
    >>> normal_angles([[0, 0, 1], [0, 1, 0]], [[0, 1], [1, 0]]).round(4).tolist()
    [[0.0, 1.5708], [0.0, 1.5708]]
    """
    nrm = _unit_normals_or_nan(normals)
    idx = check_neighbors(neighbors, nrm.shape[0])
    out = np.empty(idx.shape, dtype=np.float64)
    angles_kernel(nrm, idx, np.arange(idx.shape[0]), out)
    return out


def normal_weights(normals, neighbors, a: float, b: float) -> np.ndarray:
    """Weights w_ij = sig_{a,b}(angle(n_i, n_j)) of Eq. 5.2 for every neighbour.

    Parameters
    ----------
    normals : array_like of shape (N, 3)
        Oriented normals.
    neighbors : array_like of shape (N, k), int
        Neighbour indices.
    a : float
        Start of the ramp (radians, [0, pi]).
    b : float
        End of the ramp (radians, [a, pi]).

    Returns
    -------
    weights : ndarray of shape (N, k), float64
        In [0, 1]; NaN where a normal is non-finite.

    Raises
    ------
    ValueError
        Bad shapes, indices or thresholds (a outside [0, pi], b outside [a, pi]).
    TypeError
        Non-numeric thresholds or non-integer ``neighbors``.

    Examples
    --------
    >>> normal_weights([[0, 0, 1], [0, 1, 0]], [[0, 1], [1, 0]], 0.0, 0.0).tolist()
    [[1.0, 0.0], [1.0, 0.0]]
    """
    a, b = _check_ab(a, b)
    return cosine_sigmoid(normal_angles(normals, neighbors), a, b)

"""The eta estimate of thesis Eq. 4.9 (`estimate_eta`)."""

from __future__ import annotations

import math

import numpy as np

from .._core import as_float, as_int

__all__ = ["estimate_eta"]


def estimate_eta(mean_curvature: float, n_points: int, *, curvature_split: float = 0.5) -> float:
    """Initial eta from a curvature and a target region size (thesis Eq. 4.9).

    The region is modelled as the elliptic paraboloid (u, v, u^2/a^2 + v^2/b^2) on
    [-1, 1]^2, sampled on a regular (2 nu + 1)^2 grid with nu = ceil(sqrt(n - 1) / 2),
    proxy normal (0, 0, 1).

    Parameters
    ----------
    mean_curvature : float
        H(0, 0) = 1/a^2 + 1/b^2 of Eq. 4.8, in units of 1 / (half the region width).
    n_points : int
        Number of points a region should roughly hold (>= 1).
    curvature_split : float
        Share s in [0, 1] of the curvature along u: 1/a^2 = s H, 1/b^2 = (1 - s) H.

    Returns
    -------
    eta : float
        The L21 energy (Eq. 4.9) of such a region.

    Raises
    ------
    ValueError
        Negative or non-finite curvature, n_points < 1, or curvature_split
        outside [0, 1] (or NaN).
    TypeError
        Non-integer n_points, non-numeric curvature or curvature_split.

    Notes
    -----
    Eq. 4.9: L21 = 2 (2 nu + 1)^2 - sum_{j,l=-nu..nu} 1 / sqrt((j/(nu a^2))^2 +
    (l/(nu b^2))^2 + 1/4). For n_points = 1 (nu = 0) the region is one point and
    eta = 0.

    Examples
    --------
    >>> round(estimate_eta(0.0, 100), 12)
    0.0
    >>> estimate_eta(1.0, 100) > estimate_eta(0.5, 100)
    True
    """
    h = as_float(mean_curvature, "mean_curvature", lo=0.0)
    n = as_int(n_points, "n_points", lo=1)
    s = as_float(curvature_split, "curvature_split", lo=0.0, hi=1.0)
    nu = math.ceil(math.sqrt(n - 1) / 2.0)
    if nu == 0:
        return 0.0
    inv_a2, inv_b2 = s * h, (1.0 - s) * h
    j = np.arange(-nu, nu + 1, dtype=np.float64)
    ju = (j / nu * inv_a2)[:, None]
    lv = (j / nu * inv_b2)[None, :]
    total = np.sum(1.0 / np.sqrt(ju**2 + lv**2 + 0.25))
    return float(max(2.0 * (2 * nu + 1) ** 2 - total, 0.0))

"""Gaussian noise along normals or in all directions, in units of the mean spacing l."""

from __future__ import annotations

import numpy as np

from .._core import as_normals, as_points, as_rng
from ..neighbors import mean_spacing

__all__ = ["add_normal_noise", "add_gaussian_noise"]


def _noise_scale(points: np.ndarray, amplitude, k, spacing) -> float:
    amp = float(amplitude)
    if not np.isfinite(amp) or amp < 0:
        raise ValueError(f"amplitude must be a finite number >= 0; got {amplitude!r}")
    if spacing is None:
        if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
            raise ValueError(f"k must be a positive integer; got {k!r}")
        if points.shape[0] < k + 1:
            raise ValueError(
                f"points must hold at least k + 1 = {k + 1} points to measure the "
                f"spacing; got {points.shape[0]} (or pass spacing=)"
            )
        spacing = mean_spacing(points, int(k))
    else:
        spacing = float(spacing)
        if not np.isfinite(spacing) or spacing < 0:
            raise ValueError(f"spacing must be a finite number >= 0; got {spacing!r}")
    return amp * spacing


def add_normal_noise(points, normals, amplitude: float, *, k: int = 12, spacing=None, rng=None):
    """Move every point along its normal by Gaussian noise of std ``amplitude * l``.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Clean positions.
    normals : array_like of shape (N, 3)
        Normals (rescaled to unit length).
    amplitude : float
        Noise amplitude as a fraction of l: "noise of amplitude x %" is
        ``amplitude = x / 100``.
    k : int
        Neighbours for l (12 by default; the 5.4 denoising experiment uses 6).
    spacing : float, optional
        Use this l instead of measuring it.
    rng : None, int or numpy.random.Generator
        Randomness (``np.random.default_rng(rng)``).

    Returns
    -------
    noisy : ndarray of shape (N, 3), float64
        ``points + e_i * normals`` with ``e_i ~ N(0, (amplitude * l)**2)``; a new
        array (inputs are not modified).

    Raises
    ------
    ValueError, TypeError
        Bad shapes, non-finite values, negative amplitude, fewer than k + 1 points.

    Notes
    -----
    l is the mean distance of all points to their k nearest neighbours
    (`pointatlas.neighbors.mean_spacing`; docs/decisions/synth.md; thesis 2.2.2, 4.4.3, 5.4,
    6.2).

    Examples
    --------
    >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    >>> nrm = [[0, 0, 1]] * 4
    >>> noisy = add_normal_noise(pts, nrm, 0.1, k=1, rng=0)
    >>> noisy[:, :2].tolist() == [[0, 0], [1, 0], [0, 1], [1, 1]]
    True
    """
    pts = as_points(points)
    nrm = as_normals(normals, pts.shape[0])
    scale = _noise_scale(pts, amplitude, k, spacing)
    gen = as_rng(rng)
    offsets = gen.normal(0.0, 1.0, size=pts.shape[0]) * scale
    return pts + offsets[:, None] * nrm


def add_gaussian_noise(points, amplitude: float, *, k: int = 12, spacing=None, rng=None):
    """Add isotropic Gaussian noise with per-coordinate std ``amplitude * l``.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Clean positions.
    amplitude : float
        Standard deviation of each coordinate's noise as a fraction of l.
    k : int
        Neighbours for l (12 by default).
    spacing : float, optional
        Use this l instead of measuring it.
    rng : None, int or numpy.random.Generator
        Randomness (``np.random.default_rng(rng)``).

    Returns
    -------
    noisy : ndarray of shape (N, 3), float64
        A new array.

    Raises
    ------
    ValueError, TypeError
        Bad shapes, non-finite values, negative amplitude, fewer than k + 1 points.

    Notes
    -----
    l as in `add_normal_noise`. The displacement length then has mean about
    ``1.6 * amplitude * l`` (a chi distribution with 3 degrees of freedom).

    Examples
    --------
    >>> add_gaussian_noise([[0, 0, 0], [1, 0, 0]], 0.0, k=1, rng=0).tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
    """
    pts = as_points(points)
    scale = _noise_scale(pts, amplitude, k, spacing)
    gen = as_rng(rng)
    return pts + gen.normal(0.0, 1.0, size=pts.shape) * scale

"""Noise for denoising experiments: Gaussian along normals (synth) and impulsive."""

from __future__ import annotations

import numpy as np

from .._core import as_float, as_int, as_normals, as_points, as_rng
from ..neighbors import mean_spacing
from ..synth import add_gaussian_noise, add_normal_noise

__all__ = ["NOISE_KINDS", "add_impulsive_noise", "add_noise"]

#: the noise models of `add_noise`
NOISE_KINDS = ("normal", "impulsive", "isotropic")


def _spacing(pts: np.ndarray, k, spacing) -> float:
    if spacing is not None:
        return as_float(spacing, "spacing", lo=0.0)
    k = as_int(k, "k", lo=1, hi=pts.shape[0] - 1, note="the number of other points")
    return mean_spacing(pts, k)


def add_impulsive_noise(
    points, normals, amplitude: float, *, fraction: float = 0.1, k: int = 6, spacing=None, rng=None
) -> np.ndarray:
    """Move a random share of the points along their normals by large Gaussian noise.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Clean positions.
    normals : array_like of shape (N, 3), float64
        Normals (rescaled to unit length).
    amplitude : float
        Standard deviation of the displacement of a chosen point, as a fraction of l.
    fraction : float
        Share of the points that are moved, in [0, 1]; the others stay.
    k : int
        Neighbours for l (thesis 5.4: 6; 6.2: 12).
    spacing : float, optional
        Use this l instead of measuring it.
    rng : None, int or numpy.random.Generator
        Randomness (``np.random.default_rng(rng)``): which points, then how far.

    Returns
    -------
    noisy : ndarray of shape (N, 3), float64
        A new array.

    Raises
    ------
    ValueError, TypeError
        Bad shapes, non-finite values, negative amplitude, fraction outside [0, 1].

    Notes
    -----
    The "impulsive" noise of the mesh-denoising benchmarks (a few vertices moved
    far along their normal): round(fraction N) points drawn without replacement.

    Examples
    --------
    >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]
    >>> noisy = add_impulsive_noise(pts, [[0, 0, 1]] * 4, 1.0, fraction=0.5, k=1, rng=0)
    >>> int((noisy[:, 2] != 0).sum())
    2
    """
    pts = as_points(points)
    nrm = as_normals(normals, pts.shape[0])
    amp = as_float(amplitude, "amplitude", lo=0.0)
    frac = as_float(fraction, "fraction", lo=0.0, hi=1.0)
    scale = amp * _spacing(pts, k, spacing)
    gen = as_rng(rng)
    chosen = gen.choice(pts.shape[0], size=int(round(frac * pts.shape[0])), replace=False)
    offsets = np.zeros(pts.shape[0])
    offsets[np.sort(chosen)] = gen.normal(0.0, 1.0, size=chosen.size) * scale
    return pts + offsets[:, None] * nrm


def add_noise(
    points,
    normals,
    amplitude: float,
    *,
    kind: str = "normal",
    k: int = 6,
    spacing=None,
    fraction: float = 0.1,
    rng=None,
) -> np.ndarray:
    """Corrupt a clean point set with one of the noise models of the experiments.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Clean positions.
    normals : array_like of shape (N, 3), float64
        Clean normals (needed by "normal" and "impulsive").
    amplitude : float
        Standard deviation as a fraction of l (0.3 for "0.3 l").
    kind : {"normal", "impulsive", "isotropic"}
        Gaussian along the normals (thesis 5.4, 6.2), impulsive (`add_impulsive_noise`)
        or Gaussian in every coordinate.
    k : int
        Neighbours for l: 6 (thesis 5.4) or 12 (thesis 6.2).
    spacing : float, optional
        Use this length instead of l (e.g. the bounding-sphere radius, with
        ``amplitude`` 0.01 for the literature's "1 % noise").
    fraction : float
        Share of moved points for "impulsive".
    rng : None, int or numpy.random.Generator
        Randomness.

    Returns
    -------
    noisy : ndarray of shape (N, 3), float64
        A new array.

    Raises
    ------
    ValueError
        Unknown kind, bad shapes or values.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch
    >>> m = plane_patch()
    >>> noisy = add_noise(m.points, m.normals, 0.3, rng=1)
    >>> bool(abs(noisy[:, 2]).max() > 0)
    True
    """
    if kind not in NOISE_KINDS:
        raise ValueError(f"kind must be one of {', '.join(NOISE_KINDS)}; got {kind!r}")
    if kind == "impulsive":
        return add_impulsive_noise(
            points, normals, amplitude, fraction=fraction, k=k, spacing=spacing, rng=rng
        )
    if kind == "isotropic":
        return add_gaussian_noise(points, amplitude, k=k, spacing=spacing, rng=rng)
    return add_normal_noise(points, normals, amplitude, k=k, spacing=spacing, rng=rng)

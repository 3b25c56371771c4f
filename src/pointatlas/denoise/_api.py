"""One entry point over the denoisers, and the choice of ``method="auto"``."""

from __future__ import annotations

from .._core import as_points
from ._flatness import flatness_denoise
from ._result import DenoiseResult
from ._voting import normal_voting_denoise

__all__ = ["DENOISE_METHODS", "choose_method", "denoise"]

#: the methods of `denoise` (and ``pointatlas denoise --method``)
DENOISE_METHODS = ("normal-voting", "normal-voting-adaptive", "flatness", "auto")


def choose_method(points, normals=None) -> str:
    """The method ``"auto"`` runs on these inputs.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals, if any.

    Returns
    -------
    method : str
        ``"normal-voting-adaptive"`` when normals are given (the most accurate
        method in our measurements, docs/decisions/denoise.md), else ``"flatness"``
        (Eq. 6.3 needs no normals).

    Examples
    --------
    >>> choose_method([[0, 0, 0]] * 3)
    'flatness'
    """
    as_points(points)
    return "flatness" if normals is None else "normal-voting-adaptive"


def denoise(points, normals=None, *, method: str = "auto", progress=None) -> DenoiseResult:
    """Denoise a point set with one of `DENOISE_METHODS` at its default parameters.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals; required by the normal voting methods.
    method : str
        ``"normal-voting"`` (fixed [YRS+18] neighbourhoods), ``"normal-voting-adaptive"``
        (k by least E_dim, thesis 5.4), ``"flatness"`` (Eq. 6.3, k = 28, eta = 1,
        60 iterations) or ``"auto"`` (`choose_method`).
    progress : callable, optional
        Called with 1 after every iteration step.

    Returns
    -------
    result : DenoiseResult
        The denoised points and per-point details.

    Raises
    ------
    ValueError
        Unknown method, a normal voting method without normals, bad input.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(12, 12)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> denoise(noisy, m.normals).method
    'normal-voting-adaptive'
    """
    if method not in DENOISE_METHODS:
        raise ValueError(f"method must be one of {', '.join(DENOISE_METHODS)}; got {method!r}")
    if method == "auto":
        method = choose_method(points, normals)
    if method == "flatness":
        return flatness_denoise(points, normals=normals, progress=progress)
    if normals is None:
        raise ValueError(
            f"method {method!r} needs oriented normals; estimate them with "
            "pointatlas.normals.estimate_normals and orient_normals, or use 'flatness'"
        )
    return normal_voting_denoise(
        points, normals, adaptive=method == "normal-voting-adaptive", progress=progress
    )

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
        Oriented normals, if any (without them normal voting estimates PCA normals).

    Returns
    -------
    method : str
        ``"normal-voting"``: in our benchmark it and the adaptive variant beat every
        peer in Chamfer and point-to-mesh distance on all inputs, by about the
        same margins, and the fixed neighbourhoods take a third of the time
        (docs/decisions/denoise.md, "auto"). Flatness (Eq. 6.3) is the thesis'
        experiment, not a default.

    Examples
    --------
    >>> choose_method([[0, 0, 0]] * 3)
    'normal-voting'
    """
    as_points(points)
    return "normal-voting"


def denoise(points, normals=None, *, method: str = "auto", progress=None) -> DenoiseResult:
    """Denoise a point set with one of `DENOISE_METHODS` at its default parameters.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions.
    normals : array_like of shape (N, 3), float64, optional
        Oriented normals. Normal voting estimates PCA normals (k = 20, MST
        orientation) when None; flatness only uses them to sign its normals.
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
        Unknown method, bad input.

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(12, 12)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> denoise(noisy, m.normals).method
    'normal-voting'
    """
    if method not in DENOISE_METHODS:
        raise ValueError(f"method must be one of {', '.join(DENOISE_METHODS)}; got {method!r}")
    if method == "auto":
        method = choose_method(points, normals)
    if method == "flatness":
        return flatness_denoise(points, normals=normals, progress=progress)
    return normal_voting_denoise(
        points, normals, adaptive=method == "normal-voting-adaptive", progress=progress
    )

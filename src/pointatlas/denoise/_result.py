"""The result of a point denoiser (all methods)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from .._core import readonly

__all__ = ["DenoiseResult", "NormalFilterResult"]


def _freeze(obj) -> None:
    for f in fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            object.__setattr__(obj, f.name, readonly(value))


@dataclass(frozen=True, slots=True)
class DenoiseResult:
    """Denoised points, their normals and what each point went through.

    Attributes
    ----------
    points : ndarray of shape (N, 3), float64
        Denoised positions (point i is input point i).
    normals : ndarray of shape (N, 3), float64
        Filtered normals (normal voting) or the last PCA normals oriented like the
        input normals (flatness).
    displacement : ndarray of shape (N,), float64
        |new - input| per point, in the input's units.
    feature_class : ndarray of shape (N,), int8
        Normal voting: 1 face, 2 edge, 3 corner (last iteration); flatness: 0.
    energy : ndarray of shape (N,), float64
        Flatness (Eq. 6.1) of the last iteration's neighbourhood (NaN for normal
        voting, and where degenerate).
    k : ndarray of shape (N,), int64
        Neighbourhood size of the last iteration (-1 where none was valid).
    method : str
        ``"normal-voting"``, ``"normal-voting-adaptive"`` or ``"flatness"``.
    n_iter : int
        Outer iterations run (point updates).
    n_fallback : int
        Adaptive variant: points that fell back to the default k and equal weights in
        the last filter step (0 otherwise).
    spacing : float
        l, the mean 6-NN spacing of the input (unit of the step bounds).
    """

    points: np.ndarray
    normals: np.ndarray
    displacement: np.ndarray
    feature_class: np.ndarray
    energy: np.ndarray
    k: np.ndarray
    method: str
    n_iter: int
    n_fallback: int
    spacing: float

    def __post_init__(self):
        _freeze(self)

    @property
    def n_points(self) -> int:
        """Number of points N."""
        return int(self.points.shape[0])


@dataclass(frozen=True, slots=True)
class NormalFilterResult:
    """Filtered normals of the normal voting tensor stage (thesis 5.4, Table 5.3).

    Attributes
    ----------
    normals : ndarray of shape (N, 3), float64
        Filtered unit normals.
    k : ndarray of shape (N,), int64
        Neighbourhood size of the last iteration (the chosen k in the adaptive
        variant, the default k where it fell back).
    default_k : ndarray of shape (N,), int64
        k_i of the default ([YRS+18]) neighbourhoods.
    is_fallback : ndarray of shape (N,), bool
        Adaptive variant: every k in the range degenerated in the last iteration, so
        the default k with equal weights was used.
    n_iter : int
        Filter iterations (p).
    rho, tau : float
        Cut-off on n_i . n_j and eigenvalue threshold.
    adaptive : bool
        Whether each point chose its k by least E_dim.
    """

    normals: np.ndarray
    k: np.ndarray
    default_k: np.ndarray
    is_fallback: np.ndarray
    n_iter: int
    rho: float
    tau: float
    adaptive: bool

    def __post_init__(self):
        _freeze(self)

"""Dimension classes of points: the largest of linearity, planarity, scattering (Fig. 5.3)."""

from __future__ import annotations

import numpy as np

from ._features import FeatureResult

__all__ = ["DIMENSION_CLASSES", "classify_dimension"]

#: class names of the dimension classification (Fig. 5.3 bottom row), label -1 = degenerate
DIMENSION_CLASSES = ("linear", "planar", "scattered")


def classify_dimension(result: FeatureResult) -> np.ndarray:
    """Label every point by its largest of linearity / planarity / scattering.

    Parameters
    ----------
    result : FeatureResult
        Output of `covariance_features`, `optimal_k_features` or
        `optimal_neighborhood`.

    Returns
    -------
    labels : ndarray of shape (N,), int64
        0 linear, 1 planar, 2 scattered (`DIMENSION_CLASSES`); -1 where the
        features are undefined (degenerate neighbourhood). Ties go to the smaller
        label.

    Examples
    --------
    >>> import numpy as np
    >>> from pointatlas.features import covariance_features
    >>> g = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)), -1).reshape(-1, 2)
    >>> pts = np.column_stack([g, np.zeros(25)])
    >>> int(np.bincount(classify_dimension(covariance_features(pts, 8)) + 1).argmax()) - 1
    1
    """
    lps = np.column_stack([result.linearity, result.planarity, result.scattering])
    ok = np.isfinite(lps).all(axis=1)
    cls = np.full(result.n_points, -1, dtype=np.int64)
    cls[ok] = np.argmax(lps[ok], axis=1)
    return cls

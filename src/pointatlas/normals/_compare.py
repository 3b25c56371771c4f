"""Normals against a reference: mean and median angle errors, flipped fraction."""

from __future__ import annotations

import numpy as np

from ._metrics import angle_error, flipped_fraction

__all__ = ["compare_normals"]


def compare_normals(estimated, reference) -> dict:
    """Angle errors (degrees) and flipped fraction of normals against a reference.

    Parameters
    ----------
    estimated : array_like of shape (N, 3), float64
        Unit normals to judge.
    reference : array_like of shape (N, 3), float64
        Unit reference normals (e.g. a mesh's area-weighted normals).

    Returns
    -------
    stats : dict
        ``mean_angle_error_deg``, ``median_angle_error_deg`` (oriented),
        ``mean_unoriented_error_deg`` (ignoring the sign) and ``flipped_fraction``.

    Examples
    --------
    >>> import numpy as np
    >>> ref = np.tile([0.0, 0.0, 1.0], (4, 1))
    >>> est = ref * np.array([[1.0], [1.0], [1.0], [-1.0]])
    >>> s = compare_normals(est, ref)
    >>> s["flipped_fraction"], s["mean_unoriented_error_deg"]
    (0.25, 0.0)
    """
    oriented = np.degrees(angle_error(estimated, reference))
    unoriented = np.degrees(angle_error(estimated, reference, unoriented=True))
    return {
        "mean_angle_error_deg": float(oriented.mean()),
        "median_angle_error_deg": float(np.median(oriented)),
        "mean_unoriented_error_deg": float(unoriented.mean()),
        "flipped_fraction": float(flipped_fraction(estimated, reference)),
    }

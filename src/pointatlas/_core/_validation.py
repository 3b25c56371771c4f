"""Validation helpers used once at every public boundary (STYLE section 5)."""

from __future__ import annotations

import numpy as np

from .tolerances import MAX_LISTED_INDICES, NORMAL_ZERO_LENGTH

__all__ = ["as_points", "as_normals", "as_labels", "as_rng", "describe_indices"]


def describe_indices(mask: np.ndarray) -> str:
    """Return ``"<count> (indices i, j, ...)"`` for the True entries of ``mask``.

    Parameters
    ----------
    mask : ndarray of shape (N,), bool
        Which entries are offending.

    Returns
    -------
    text : str
        Count and the first few indices, for error messages.
    """
    idx = np.flatnonzero(mask)
    shown = ", ".join(str(int(i)) for i in idx[:MAX_LISTED_INDICES])
    more = ", ..." if idx.size > MAX_LISTED_INDICES else ""
    return f"{idx.size} (indices {shown}{more})"


def _as_float_array(values, name: str) -> np.ndarray:
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric; got {type(values).__name__}: {exc}") from None
    return arr


def as_points(points, *, name: str = "points", min_points: int = 1) -> np.ndarray:
    """Validate and convert a point array.

    Parameters
    ----------
    points : array_like of shape (N, 3)
        Coordinates, converted to float64.
    name : str
        Parameter name used in error messages.
    min_points : int
        Smallest accepted N (0 allows an empty set).

    Returns
    -------
    points : ndarray of shape (N, 3), float64
        C-contiguous; a view of the input when no conversion was needed.

    Raises
    ------
    ValueError
        Wrong shape, too few points, or non-finite coordinates (count and
        first indices given).
    TypeError
        Non-numeric input.

    Examples
    --------
    >>> as_points([[0, 0, 0], [1, 0, 0]]).shape
    (2, 3)
    """
    arr = _as_float_array(points, name)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3); got {arr.shape}")
    if arr.shape[0] < min_points:
        raise ValueError(f"{name} must hold at least {min_points} point(s); got {arr.shape[0]}")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        raise ValueError(f"{name} has non-finite (NaN/Inf) coordinates at {describe_indices(bad)}")
    return np.ascontiguousarray(arr)


def as_normals(
    normals, n_points: int | None = None, *, name: str = "normals", normalize: bool = True
) -> np.ndarray:
    """Validate normals and return unit-length copies.

    Parameters
    ----------
    normals : array_like of shape (N, 3)
        Normal vectors; any non-zero length is accepted and rescaled.
    n_points : int, optional
        Required N (the number of points they belong to).
    name : str
        Parameter name used in error messages.
    normalize : bool
        Rescale to unit length (default). If False the input must already be unit.

    Returns
    -------
    normals : ndarray of shape (N, 3), float64
        Unit normals (a new array).

    Raises
    ------
    ValueError
        Wrong shape, non-finite entries, or zero-length normals (count and first
        indices given).

    Examples
    --------
    >>> as_normals([[0, 0, 2.0]])
    array([[0., 0., 1.]])
    """
    arr = _as_float_array(normals, name)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3); got {arr.shape}")
    if n_points is not None and arr.shape[0] != n_points:
        raise ValueError(f"{name} must have one row per point ({n_points}); got {arr.shape[0]}")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        raise ValueError(f"{name} has non-finite (NaN/Inf) entries at {describe_indices(bad)}")
    length = np.linalg.norm(arr, axis=1)
    zero = length < NORMAL_ZERO_LENGTH
    if zero.any():
        raise ValueError(f"{name} has zero-length vectors at {describe_indices(zero)}")
    if normalize:
        return arr / length[:, None]
    off = np.abs(length - 1.0) > 1e-6
    if off.any():
        raise ValueError(f"{name} must be unit length; not at {describe_indices(off)}")
    return np.array(arr, dtype=np.float64, copy=True)


def as_labels(labels, n_points: int | None = None, *, name: str = "labels") -> np.ndarray:
    """Validate integer labels.

    Parameters
    ----------
    labels : array_like of shape (N,)
        Integer labels; negative values mean "unassigned".
    n_points : int, optional
        Required N.
    name : str
        Parameter name used in error messages.

    Returns
    -------
    labels : ndarray of shape (N,), int64

    Raises
    ------
    ValueError
        Wrong shape or non-integral values.

    Examples
    --------
    >>> as_labels([0, 1, 1]).dtype
    dtype('int64')
    """
    arr = np.asarray(labels)
    if arr.ndim != 1:
        raise ValueError(f"{name} must have shape (N,); got {arr.shape}")
    if n_points is not None and arr.shape[0] != n_points:
        raise ValueError(f"{name} must have one entry per point ({n_points}); got {arr.shape[0]}")
    if arr.dtype.kind == "f":
        bad = ~np.isfinite(arr) | (arr != np.round(arr))
        if bad.any():
            raise ValueError(f"{name} must be integers; not at {describe_indices(bad)}")
    elif arr.dtype.kind not in "iub" and arr.size:
        raise ValueError(f"{name} must be integers; got dtype {arr.dtype}")
    return arr.astype(np.int64, copy=True)


def as_rng(rng=None) -> np.random.Generator:
    """Return ``np.random.default_rng(rng)`` (a seed, a Generator, or None).

    Parameters
    ----------
    rng : None, int, SeedSequence or Generator
        Source of randomness.

    Returns
    -------
    rng : numpy.random.Generator
    """
    return np.random.default_rng(rng)

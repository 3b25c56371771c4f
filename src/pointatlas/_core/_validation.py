"""Validation helpers used once at every public boundary (docs/decisions/core.md)."""

from __future__ import annotations

import numpy as np

from .errors import NonFiniteError, PointAtlasError
from .tolerances import MAX_LISTED_INDICES, NORMAL_ZERO_LENGTH

__all__ = [
    "as_labels",
    "as_normals",
    "as_points",
    "as_rng",
    "as_vectors",
    "check_finite",
    "check_neighbors",
    "describe_indices",
]


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


def check_finite(values: np.ndarray, name: str) -> None:
    """Refuse an array holding NaN or Inf, naming the argument, the count and the rows.

    The one finiteness check of every public function (as_points, as_normals and
    the functions that take coordinates without them call it).

    Parameters
    ----------
    values : ndarray of shape (N, ...), float
        The array to check (rows along the first axis).
    name : str
        Parameter name used in the message.

    Raises
    ------
    NonFiniteError
        Some entry is NaN or infinite: ``points contains 3 non-finite values (NaN
        or Inf) at rows 0, 5, 9`` (the first few rows are listed).

    Examples
    --------
    >>> try:
    ...     check_finite(np.array([[0.0, np.nan, 0.0], [1.0, 1.0, np.inf]]), "points")
    ... except ValueError as exc:
    ...     print(exc)
    points contains 2 non-finite values (NaN or Inf) at rows 0, 1
    """
    bad = ~np.isfinite(values)
    if not bad.any():
        return
    rows = np.flatnonzero(bad.reshape(bad.shape[0], -1).any(axis=1) if bad.ndim else bad)
    shown = ", ".join(str(int(i)) for i in rows[:MAX_LISTED_INDICES])
    more = ", ..." if rows.size > MAX_LISTED_INDICES else ""
    n_bad = int(bad.sum())
    values_word = "value" if n_bad == 1 else "values"
    rows_word = "row" if rows.size == 1 else "rows"
    raise NonFiniteError(
        f"{name} contains {n_bad} non-finite {values_word} (NaN or Inf) "
        f"at {rows_word} {shown}{more}"
    )


def _as_float_array(values, name: str) -> np.ndarray:
    # None, also as np.asarray(None) (a 0-d object array), is a missing array,
    # not a NaN of shape ()
    if values is None or (
        isinstance(values, np.ndarray)
        and values.dtype == object
        and values.ndim == 0
        and values.item() is None
    ):
        raise TypeError(f"{name} must be an array of shape (N, 3); got None")
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be numeric; got {type(values).__name__}: {exc}") from None
    return arr


def as_vectors(values, n_points: int | None = None, *, name: str = "vectors") -> np.ndarray:
    """Convert an (N, 3) array to float64, checking only its shape (NaN/Inf allowed).

    The shape checks shared by `as_points` and `as_normals`, for callers that flag
    non-finite rows instead of refusing them.

    Parameters
    ----------
    values : array_like of shape (N, 3)
        Numbers, converted to float64.
    n_points : int, optional
        Required N (the number of points the rows belong to).
    name : str
        Parameter name used in error messages.

    Returns
    -------
    values : ndarray of shape (N, 3), float64
        A view of the input when no conversion was needed (not necessarily
        C-contiguous).

    Raises
    ------
    ValueError
        Wrong shape, or not one row per point.
    TypeError
        Non-numeric input or None.

    Examples
    --------
    >>> as_vectors([[0, 0, float("nan")]], 1).shape
    (1, 3)
    """
    arr = _as_float_array(values, name)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3); got {arr.shape}")
    if n_points is not None and arr.shape[0] != n_points:
        raise ValueError(f"{name} must have one row per point ({n_points}); got {arr.shape[0]}")
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
        C-contiguous and read-only; a view of the input when no conversion was
        needed. Read-only always: the input is never written through it, and numba
        kernels see one array type whether the caller's array was writeable (a
        numpy array) or not (a `PointSet`'s): a kernel compiled by the warm-up for
        the command line serves the Python API too, and is not compiled again.

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
    arr = as_vectors(points, name=name)
    if arr.shape[0] < min_points:
        raise ValueError(f"{name} must hold at least {min_points} point(s); got {arr.shape[0]}")
    check_finite(arr, name)
    view = np.ascontiguousarray(arr).view()
    view.flags.writeable = False
    return view


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
    arr = as_vectors(normals, n_points, name=name)
    check_finite(arr, name)
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


# --------------------------------------------------------------------------- neighbours


def check_neighbors(
    neighbors,
    n_points: int,
    *,
    k: int | None = None,
    name: str = "neighbors",
    allow_negative: bool = False,
    check_range: bool = True,
) -> np.ndarray:
    """Validate a neighbour index table (the ``neighbors=`` argument of every room).

    Parameters
    ----------
    neighbors : array_like of shape (N, m), int, or tuple
        Row i lists neighbour indices of point i (e.g. the first array returned by
        `pointatlas.neighbors.query_knn`); the ``(indices, distances)`` tuple that
        `query_knn` returns is accepted as well.
    n_points : int
        N, the number of points the table belongs to.
    k : int, optional
        Keep the first ``k`` columns (the table must have at least ``k``); None
        keeps all columns (at least one).
    name : str
        Parameter name used in error messages.
    allow_negative : bool
        Accept entries < 0 (they mean "no neighbour" to the caller).
    check_range : bool
        Check that the indices lie in [0, N) (or < N with ``allow_negative``);
        False leaves the check to a kernel that reports bad indices itself.

    Returns
    -------
    neighbors : ndarray of shape (N, k or m), int64
        C-contiguous; a view of the input when no conversion was needed.

    Raises
    ------
    TypeError
        Non-integer entries.
    ValueError
        Wrong shape, too few columns, or indices out of range (the range found is
        given).

    Examples
    --------
    >>> check_neighbors([[0, 1], [1, 0], [2, 1]], 3, k=1).ravel().tolist()
    [0, 1, 2]
    """
    if isinstance(neighbors, tuple) and len(neighbors) == 2:
        neighbors = neighbors[0]
    table = np.asarray(neighbors)
    if table.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an integer index array; got dtype {table.dtype}")
    n_cols = 1 if k is None else k
    if table.ndim != 2 or table.shape[0] != n_points or table.shape[1] < n_cols:
        raise ValueError(
            f"{name} must have shape (N, m) with N = {n_points} points and m >= {n_cols}; "
            f"got {table.shape}"
        )
    if k is not None and table.shape[1] != k:
        table = table[:, :k]
    table = np.ascontiguousarray(table, dtype=np.int64)
    if check_range and table.size:
        # numpy's reductions: a few milliseconds per million rows, and no kernel for a
        # first run to compile (docs/decisions/cli.md, "First run")
        lo, hi = int(table.min()), int(table.max())
        if hi >= n_points or (lo < 0 and not allow_negative):
            allowed = f"< {n_points}" if allow_negative else f"0..{n_points - 1}"
            raise PointAtlasError(f"{name} must index points {allowed}; got range {lo}..{hi}")
    return table

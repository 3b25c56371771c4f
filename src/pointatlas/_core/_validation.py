"""Validation helpers used once at every public boundary (docs/decisions/core.md)."""

from __future__ import annotations

import math
import numbers
import operator

import numpy as np

from .errors import PointAtlasError
from .tolerances import MAX_LISTED_INDICES, NORMAL_ZERO_LENGTH

__all__ = [
    "as_float",
    "as_float_array",
    "as_int",
    "as_k",
    "as_labels",
    "as_normals",
    "as_points",
    "as_rng",
    "as_vectors",
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


def _as_float_array(values, name: str) -> np.ndarray:
    # None, also as np.asarray(None) (a 0-d object array), is a missing array,
    # not a NaN of shape ()
    if values is None or (
        isinstance(values, np.ndarray) and values.dtype == object and values.ndim == 0
        and values.item() is None
    ):  # fmt: skip
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
    arr = as_vectors(points, name=name)
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
    arr = as_vectors(normals, n_points, name=name)
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
        from ._ranges import index_range  # numba: loaded on first use, not on import

        lo, hi = index_range(table)
        if hi >= n_points or (lo < 0 and not allow_negative):
            allowed = f"< {n_points}" if allow_negative else f"0..{n_points - 1}"
            raise PointAtlasError(f"{name} must index points {allowed}; got range {lo}..{hi}")
    return table


# --------------------------------------------------------------------------- scalars


def _describe(value) -> str:
    """``"<type> <repr>"`` of an offending value, shortened for error messages."""
    text = repr(value.item() if isinstance(value, np.generic) else value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def _fmt(x) -> str:
    """A bound or value as it reads in a message: pi as ``pi``, whole numbers without ``.0``."""
    if isinstance(x, int | np.integer):
        return str(int(x))
    x = float(x)
    if x == math.pi:
        return "pi"
    if math.isfinite(x) and x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.12g}"


def _range_text(lo, hi, lo_open: bool, hi_open: bool) -> str:
    """``" in [lo, hi]"``, ``" >= lo"``, ``" < hi"``... (empty when unbounded)."""
    if lo is not None and hi is not None:
        return f" in {'(' if lo_open else '['}{_fmt(lo)}, {_fmt(hi)}{')' if hi_open else ']'}"
    if lo is not None:
        return f" {'>' if lo_open else '>='} {_fmt(lo)}"
    if hi is not None:
        return f" {'<' if hi_open else '<='} {_fmt(hi)}"
    return ""


def _in_range(x, lo, hi, lo_open: bool, hi_open: bool):
    """Elementwise (or scalar) test ``lo <(=) x <(=) hi``; NaN is never in range."""
    ok = np.ones(np.shape(x), dtype=bool) if np.ndim(x) else True
    if lo is not None:
        ok = ok & ((x > lo) if lo_open else (x >= lo))
    if hi is not None:
        ok = ok & ((x < hi) if hi_open else (x <= hi))
    return ok


def as_int(
    value, name: str, *, lo: int | None = None, hi: int | None = None, note: str = ""
) -> int:
    """Validate an integer option (a count, a size, k).

    Parameters
    ----------
    value : int
        A Python or numpy integer (0-d integer arrays too). bool and every float,
        even a whole one such as ``3.0``, are rejected.
    name : str
        Parameter name used in error messages (a CLI flag such as ``"--k"`` too).
    lo, hi : int, optional
        Inclusive bounds; None leaves that side open.
    note : str
        What the bounds mean, appended in parentheses, e.g. ``"the number of points"``.

    Returns
    -------
    value : int

    Raises
    ------
    TypeError
        Not an integer (bool, float, str, None, ...).
    PointAtlasError
        Outside [lo, hi] (a ``ValueError``); always when ``hi < lo`` (e.g. too few
        points for any k), which the message says.

    Examples
    --------
    >>> as_int(8, "k", lo=1, hi=2000)
    8
    >>> try:
    ...     as_int(100000, "k", lo=1, hi=2000, note="the number of points")
    ... except ValueError as exc:
    ...     print(exc)
    k must be an integer in [1, 2000] (the number of points); got 100000
    """
    if isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be an integer; got {_describe(value)}")
    try:
        out = operator.index(value)
    except TypeError:
        raise TypeError(f"{name} must be an integer; got {_describe(value)}") from None
    if not _in_range(out, lo, hi, False, False):
        extra = f" ({note})" if note else ""
        if lo is not None and hi is not None and hi < lo:
            extra += ", which is empty"
        raise PointAtlasError(
            f"{name} must be an integer{_range_text(lo, hi, False, False)}{extra}; got {out}"
        )
    return int(out)


def as_k(k, n_points: int, *, name: str = "k", minimum: int = 1) -> int:
    """Validate a neighbourhood size that counts the point itself.

    Parameters
    ----------
    k : int
        Number of neighbours, the point itself included.
    n_points : int
        Number of points N (the largest k).
    name : str
        Parameter name used in error messages.
    minimum : int
        Smallest accepted k (3 for a PCA plane, 2 for an orientation graph).

    Returns
    -------
    k : int

    Raises
    ------
    TypeError
        Not an integer.
    PointAtlasError
        k outside [minimum, N] (a ``ValueError``).

    Examples
    --------
    >>> as_k(8, 100)
    8
    """
    return as_int(k, name, lo=minimum, hi=n_points, note="the number of points")


def as_float(
    value,
    name: str,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    what: str = "number",
    unit: str = "",
    note: str = "",
) -> float:
    """Validate a real-valued option: a finite number within bounds.

    Parameters
    ----------
    value : float
        A real number (Python or numpy, int or float, or a 0-d array); bool,
        str, None and complex are rejected.
    name : str
        Parameter name used in error messages (a CLI flag such as ``"--eta"`` too).
    lo, hi : float, optional
        Bounds; None leaves that side unbounded (the value must still be finite).
    lo_open, hi_open : bool
        Exclude the bound itself (``> lo`` instead of ``>= lo``).
    what : str
        What the value is, for the message: ``"number"``, ``"angle"``...
    unit : str
        Unit written after the range (``"radians"``, ``"degrees"``).
    note : str
        What the bounds mean, appended in parentheses.

    Returns
    -------
    value : float

    Raises
    ------
    TypeError
        Not a real number.
    PointAtlasError
        NaN, infinite or out of range (a ``ValueError``).

    Examples
    --------
    >>> as_float(0.5, "max_angle", lo=0.0, hi=math.pi, what="angle", unit="radians")
    0.5
    >>> try:
    ...     as_float(float("nan"), "eta", lo=0.0)
    ... except ValueError as exc:
    ...     print(exc)
    eta must be a finite number >= 0; got nan
    """
    real = isinstance(value, numbers.Real) or (
        isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "iuf"
    )
    if isinstance(value, bool | np.bool_) or not real:
        raise TypeError(f"{name} must be a real number; got {_describe(value)}")
    try:
        x = float(value)
    except OverflowError:  # an int beyond the float range
        x = math.inf if value > 0 else -math.inf
    if not (math.isfinite(x) and _in_range(x, lo, hi, lo_open, hi_open)):
        rng = _range_text(lo, hi, lo_open, hi_open)
        extra = (f" {unit}" if unit and rng else "") + (f" ({note})" if note else "")
        raise PointAtlasError(f"{name} must be a finite {what}{rng}{extra}; got {x}")
    return x


def as_float_array(
    values,
    name: str,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    what: str = "numbers",
    unit: str = "",
    note: str = "",
    min_size: int = 1,
) -> np.ndarray:
    """Validate a 1-D list of real values (a grid of thresholds, a list of sizes).

    Parameters
    ----------
    values : array_like of shape (M,) or scalar
        Real numbers (a scalar counts as one value); bool and non-numeric
        entries are rejected.
    name : str
        Parameter name used in error messages.
    lo, hi, lo_open, hi_open : float, bool
        Bounds every value must satisfy, as in `as_float`.
    what, unit, note : str
        Words for the message: ``"a_grid must hold finite angles in [0, pi]
        radians; got nan"``.
    min_size : int
        Fewest values accepted (1: not empty).

    Returns
    -------
    values : ndarray of shape (M,), float64
        A new array, in the given order.

    Raises
    ------
    TypeError
        Non-numeric or boolean values.
    PointAtlasError
        More than one dimension, fewer than ``min_size`` values, or values that
        are non-finite or out of range (the first few are listed).

    Examples
    --------
    >>> as_float_array([0, 30, 60], "--a-grid-deg", lo=0, hi=180).tolist()
    [0.0, 30.0, 60.0]
    """
    if values is None:
        raise TypeError(f"{name} must be a sequence of numbers; got None")
    arr = np.asarray(values)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers; got {_describe(values)}")
    if arr.ndim > 1:
        raise PointAtlasError(f"{name} must be a flat sequence of numbers; got shape {arr.shape}")
    arr = np.array(arr, dtype=np.float64, copy=True).reshape(-1)
    if arr.size < min_size:
        raise PointAtlasError(f"{name} must hold at least {min_size} value(s); got {arr.size}")
    bad = ~(np.isfinite(arr) & _in_range(arr, lo, hi, lo_open, hi_open))
    if bad.any():
        rng = _range_text(lo, hi, lo_open, hi_open)
        extra = (f" {unit}" if unit and rng else "") + (f" ({note})" if note else "")
        shown = ", ".join(str(v) for v in arr[bad][:MAX_LISTED_INDICES])
        more = ", ..." if bad.sum() > MAX_LISTED_INDICES else ""
        raise PointAtlasError(f"{name} must hold finite {what}{rng}{extra}; got {shown}{more}")
    return arr

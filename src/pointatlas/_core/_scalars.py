"""Validation of scalar and list options (counts, sizes, k, real numbers, grids).

The array checks (points, normals, labels, neighbour tables) are in `_validation`.
"""

from __future__ import annotations

import math
import numbers
import operator

import numpy as np

from .errors import PointAtlasError
from .tolerances import MAX_ITERATIONS, MAX_LISTED_INDICES

__all__ = ["as_float", "as_float_array", "as_int", "as_iterations", "as_k"]


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


def as_iterations(value, name: str, note: str) -> int:
    """An iteration count in [0, ``MAX_ITERATIONS``]: each iteration is a pass over
    the points, so a count like 10^12 is refused at once (with ``note`` saying why)
    instead of running for ages or sizing a schedule that does not fit in memory.

    Examples
    --------
    >>> as_iterations(60, "n_iter", "each step is a pass over every point")
    60
    """
    return as_int(value, name, lo=0, hi=MAX_ITERATIONS, note=note)


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

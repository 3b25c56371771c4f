"""Summary statistics of the experiments' tables (one place for all of them).

`describe` summarises one sample (Table 4.1: min, max, mean, sample sd). Tables that
pool many models without keeping every value (Table 5.1) store per-model `moments`
and combine them with `pooled`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["describe", "moments", "pooled"]


def describe(values) -> dict:
    """Min, max, mean (``avg``), sample sd (ddof 1; 0 for one value) and count.

    Parameters
    ----------
    values : array_like of shape (n,)
        Finite values (the caller leaves out the others).

    Returns
    -------
    stats : dict
        ``{"min", "max", "avg", "sd", "n"}``; None for each statistic when empty.

    Examples
    --------
    >>> describe([1.0, 2.0, 3.0])
    {'min': 1.0, 'max': 3.0, 'avg': 2.0, 'sd': 1.0, 'n': 3}
    """
    v = np.asarray(values, dtype=np.float64)
    if v.size == 0:
        return {"min": None, "max": None, "avg": None, "sd": None, "n": 0}
    return {
        "min": float(v.min()),
        "max": float(v.max()),
        "avg": float(v.mean()),
        "sd": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "n": int(v.size),
    }


def moments(values) -> dict:
    """Count, sum, sum of squares, min and max of the finite values (for `pooled`).

    Parameters
    ----------
    values : array_like of shape (n,)
        Values; NaN and infinities are left out.

    Returns
    -------
    parts : dict
        ``{"n", "sum", "sumsq", "min", "max"}`` (min, max None when no value is finite).

    Examples
    --------
    >>> moments([1.0, float("nan"), 3.0])
    {'n': 2, 'sum': 4.0, 'sumsq': 10.0, 'min': 1.0, 'max': 3.0}
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"n": 0, "sum": 0.0, "sumsq": 0.0, "min": None, "max": None}
    return {
        "n": int(v.size),
        "sum": float(v.sum()),
        "sumsq": float((v * v).sum()),
        "min": float(v.min()),
        "max": float(v.max()),
    }


def pooled(parts: list[dict]) -> dict:
    """Min, mean, max and sample sd of the union of samples given by their `moments`.

    Parameters
    ----------
    parts : list of dict
        Outputs of `moments`.

    Returns
    -------
    stats : dict
        ``{"n", "min", "mean", "max", "sd"}``; None for each statistic when empty.

    Examples
    --------
    >>> pooled([moments([1.0, 2.0]), moments([3.0])])
    {'n': 3, 'min': 1.0, 'mean': 2.0, 'max': 3.0, 'sd': 1.0}
    """
    parts = [p for p in parts if p["n"]]
    n = sum(p["n"] for p in parts)
    if n == 0:
        return {"n": 0, "min": None, "mean": None, "max": None, "sd": None}
    s = sum(p["sum"] for p in parts)
    ss = sum(p["sumsq"] for p in parts)
    mean = s / n
    var = max(ss - n * mean * mean, 0.0) / (n - 1) if n > 1 else 0.0
    return {
        "n": n,
        "min": min(p["min"] for p in parts),
        "mean": mean,
        "max": max(p["max"] for p in parts),
        "sd": math.sqrt(var),
    }

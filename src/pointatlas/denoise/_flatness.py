"""Flatness-driven point denoising (thesis 6.2, Eq. 6.3)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .._core import PointAtlasError, as_float, as_int, as_iterations, as_normals, as_points
from ..features import covariance_features
from ..neighbors import mean_spacing, query_knn
from ._defaults import (
    FLATNESS_MAX_ITER,
    FLATNESS_MAX_MOVE,
    FLATNESS_STOP,
    NOISE_K,
    NOISE_PLANE_BIAS,
)
from ._result import DenoiseResult
from ._threads import threads_for

__all__ = [
    "FLATNESS_SCHEDULES",
    "flatness_denoise",
    "flatness_move_kernel",
    "flatness_schedule",
    "flatness_step",
    "estimate_noise",
]

#: "constant": k and eta fixed (thesis Fig. 6.9); "decreasing": the future work of
#: 6.2 -- start with a large k and eta = 1, lower both as the iterations go
FLATNESS_SCHEDULES = ("constant", "decreasing")


def flatness_schedule(
    n_iter: int, k: int, eta: float, *, schedule: str = "constant", k_start=None
) -> tuple[np.ndarray, np.ndarray]:
    """The (k, eta) of every iteration.

    Parameters
    ----------
    n_iter : int
        Iterations (>= 1).
    k : int
        Neighbourhood size (the point itself counts); the last one for "decreasing".
    eta : float
        Weight of the plane term of Eq. 6.3 in [0, 1]; the last one for "decreasing".
    schedule : {"constant", "decreasing"}
        See `FLATNESS_SCHEDULES`.
    k_start : int, optional
        First k of "decreasing" (default 4 k).

    Returns
    -------
    ks : ndarray of shape (n_iter,), int64
        k per iteration ("decreasing": geometric from k_start down to k).
    etas : ndarray of shape (n_iter,), float64
        eta per iteration ("decreasing": linear from 1 down to eta).

    Raises
    ------
    ValueError
        Unknown schedule, k_start < k.

    Examples
    --------
    >>> ks, etas = flatness_schedule(3, 14, 0.5, schedule="decreasing")
    >>> ks.tolist(), etas.tolist()
    ([56, 28, 14], [1.0, 0.75, 0.5])
    """
    if schedule not in FLATNESS_SCHEDULES:
        raise ValueError(
            f"schedule must be one of {', '.join(FLATNESS_SCHEDULES)}; got {schedule!r}"
        )
    if schedule == "constant":
        return np.full(n_iter, k, dtype=np.int64), np.full(n_iter, float(eta))
    k0 = 4 * k if k_start is None else as_int(k_start, "k_start", lo=k)
    t = np.linspace(0.0, 1.0, n_iter) if n_iter > 1 else np.ones(1)
    ks = np.rint(k0 * (k / k0) ** t).astype(np.int64)
    etas = 1.0 + (eta - 1.0) * t
    return ks, etas


@njit(parallel=True, cache=True)
def flatness_move_kernel(points, idx, v1, v3, energy, valid, eta, eps, out, moved):
    """One Jacobi step of thesis Eq. 6.3 from the features of the k-NN (``idx``).

    p <- p + eps (eta (2 - E_p) (-d v3) + (1 - eta) E_p (p_bar - p)), b the
    barycentre of the row's points (equal weights, the point included),
    d = (p - b) . v3 and p_bar the projection of p on the line (b, v1). Points
    whose features are invalid (``valid`` False) or whose step is not finite stay;
    ``moved[i]`` tells which moved.

    Parameters
    ----------
    points : (N, 3) float64
    idx : (N, k) int64
    v1, v3 : (N, 3) float64, unit (largest and smallest eigenvector)
    energy : (N,) float64, the flatness E_p (Eq. 6.1)
    valid : (N,) bool
    eta, eps : float
    out : (N, 3) float64, out
    moved : (N,) bool, out
    """
    k = idx.shape[1]
    for i in prange(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        out[i, 0], out[i, 1], out[i, 2] = px, py, pz
        moved[i] = False
        if not valid[i]:
            continue
        bx = by = bz = 0.0
        for c in range(k):
            j = idx[i, c]
            bx += points[j, 0]
            by += points[j, 1]
            bz += points[j, 2]
        rx, ry, rz = px - bx / k, py - by / k, pz - bz / k
        d = rx * v3[i, 0] + ry * v3[i, 1] + rz * v3[i, 2]
        t = rx * v1[i, 0] + ry * v1[i, 1] + rz * v1[i, 2]
        e = energy[i]
        a = eps * eta * (2.0 - e)
        b = eps * (1.0 - eta) * e
        sx = a * (-d * v3[i, 0]) + b * (t * v1[i, 0] - rx)
        sy = a * (-d * v3[i, 1]) + b * (t * v1[i, 1] - ry)
        sz = a * (-d * v3[i, 2]) + b * (t * v1[i, 2] - rz)
        if math.isfinite(sx) and math.isfinite(sy) and math.isfinite(sz):
            out[i, 0] = px + sx
            out[i, 1] = py + sy
            out[i, 2] = pz + sz
            moved[i] = True


def flatness_step(points, k: int, eta: float, eps: float, *, flatness=(8, 8)):
    """One Jacobi step of Eq. 6.3 for every point (private helper, validated input).

    Returns (new points, flatness energy, PCA normal v3, is_valid).
    """
    idx = query_knn(points, k)[0]
    fr = covariance_features(points, k, neighbors=idx, flatness=flatness)
    v3 = np.ascontiguousarray(fr.eigenvector_3, dtype=np.float64)
    energy = np.ascontiguousarray(fr.flatness, dtype=np.float64)
    out = np.empty_like(points)
    valid = np.empty(points.shape[0], dtype=bool)
    flatness_move_kernel(
        points,
        idx,
        np.ascontiguousarray(fr.eigenvector_1, dtype=np.float64),
        v3,
        energy,
        np.ascontiguousarray(fr.is_valid, dtype=bool),
        float(eta),
        float(eps),
        out,
        valid,
    )
    return out, energy, v3, valid


def estimate_noise(points) -> float:
    """The noise sigma along the normal (private helper, validated input, N > 3).

    1.4826 x the median absolute height of each point over the PCA plane of its
    NOISE_K nearest (itself included), / NOISE_PLANE_BIAS (`_defaults.py`).
    """
    k = min(NOISE_K, points.shape[0])
    idx = query_knn(points, k)[0]
    fr = covariance_features(points, k, neighbors=idx)
    heights = ((points - points[idx].mean(axis=1)) * fr.eigenvector_3).sum(axis=1)
    heights = heights[np.isfinite(heights)]
    if heights.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(heights)) / NOISE_PLANE_BIAS)


def _bounded(cur, start, bound):
    """``cur`` with every point's displacement from ``start`` cut to ``bound``."""
    move = cur - start
    length = np.sqrt((move**2).sum(axis=1))
    far = length > bound
    if far.any():
        cur = cur.copy()
        cur[far] = start[far] + move[far] * (bound / length[far])[:, None]
    return cur


def _flatness_iterations(pts, ks, etas, eps, flatness, *, sigma, progress):
    """The Jacobi steps of Eq. 6.3; ``sigma`` None: all of them (the thesis);
    else bounded by FLATNESS_MAX_MOVE sigma per point and stopped once the RMS
    displacement reaches FLATNESS_STOP sigma. Returns (points, energy, v3,
    valid, steps run)."""
    n = pts.shape[0]
    cur = pts.copy()
    energy = np.full(n, np.nan)
    v3 = np.full((n, 3), np.nan)
    valid = np.zeros(n, dtype=bool)
    ran = 0
    for t in range(ks.shape[0]):
        cur, energy, v3, valid = flatness_step(
            cur, int(ks[t]), float(etas[t]), eps, flatness=flatness
        )
        ran += 1
        if progress is not None:
            progress(1)
        if sigma is not None:
            cur = _bounded(cur, pts, FLATNESS_MAX_MOVE * sigma)
            if np.sqrt(((cur - pts) ** 2).sum(axis=1).mean()) >= FLATNESS_STOP * sigma:
                break
    return cur, energy, v3, valid, ran


def _as_n_iter(n_iter) -> int:
    """A given iteration count, at most ``MAX_ITERATIONS``: the schedule holds one k per
    iteration, so 10^12 would ask for terabytes."""
    return as_iterations(n_iter, "n_iter", "each iteration is a pass over every point")


def flatness_denoise(
    points,
    *,
    k: int = 28,
    eta: float = 1.0,
    eps: float = 0.1,
    n_iter: int | None = None,
    noise: float | None = None,
    flatness=(8, 8),
    schedule: str = "constant",
    k_start=None,
    normals=None,
    progress=None,
) -> DenoiseResult:
    """Move every point by the flatness update of thesis Eq. 6.3, all points at once.

    Parameters
    ----------
    points : array_like of shape (N, 3), float64
        Noisy positions, N > k.
    k : int
        Neighbourhood size, the point itself counted (Fig. 6.9: 14, 8, 28).
    eta : float
        Weight in [0, 1] of the plane term; 1 - eta weighs the line term (Fig. 6.9:
        0.5, 0.5, 1).
    eps : float
        Step scale > 0 (Fig. 6.9: 0.1).
    n_iter : int, optional
        Iterations, all run (Fig. 6.9: 60; at most 100,000). None (default): at most
        60, each point kept within 2.5 noise sigmas of its input (``FLATNESS_MAX_MOVE``),
        stopped once the RMS displacement reaches 0.5 sigma (``FLATNESS_STOP``).
    noise : float, optional
        The noise sigma (input units) of ``n_iter=None``; None: estimated from the
        points (median height over 12-NN planes, docs/decisions/denoise.md).
    flatness : tuple of int
        Even exponents (m1, m2) of Eq. 6.1 (8, 8).
    schedule : {"constant", "decreasing"}
        "decreasing": start with k_start and eta = 1 and lower both to (k, eta)
        (the future work of 6.2; `flatness_schedule`).
    k_start : int, optional
        First k of the "decreasing" schedule (default 4 k, at most N).
    normals : array_like of shape (N, 3), float64, optional
        Input normals; only used to orient the returned PCA normals.
    progress : callable, optional
        Called with 1 after every iteration (progress bars).

    Returns
    -------
    result : DenoiseResult
        ``energy`` is the flatness of the last iteration, ``normals`` its PCA
        normals (oriented like ``normals`` when given, else sign arbitrary),
        ``feature_class`` 0, ``n_iter`` the iterations run.

    Raises
    ------
    ValueError
        Bad shapes or values (k outside [3, N - 1], eta outside [0, 1], eps <= 0).
    TypeError
        Non-integer k or n_iter.

    Notes
    -----
    Eq. 6.3: p <- p + eps (eta (2 - E_p) (-d v3) + (1 - eta) E_p (p_bar - p)), with
    the barycentre b of the k nearest (equal weights), d = (p - b) . v3 and p_bar
    the projection of p on the line (b, v1). Neighbourhoods and energies are
    recomputed every iteration from the current points (Jacobi: every point moves
    with the values of the previous iteration). Degenerate neighbourhoods (NaN
    features) do not move. Eq. 6.3 at eta = 1 is a curvature flow: 60 iterations
    move the points by several noise sigmas and shrink the shape, hence the
    bounded, stopped default (docs/decisions/denoise.md, "Flatness defaults").

    Examples
    --------
    >>> from pointatlas.synth import plane_patch, add_normal_noise
    >>> m = plane_patch(16, 16)
    >>> noisy = add_normal_noise(m.points, m.normals, 0.3, rng=0)
    >>> r = flatness_denoise(noisy, k=14, n_iter=10)
    >>> bool(abs(r.points[:, 2]).mean() < abs(noisy[:, 2]).mean())
    True
    """
    pts = as_points(points)
    n = pts.shape[0]
    nrm = None if normals is None else as_normals(normals, n)
    k = as_int(k, "k", lo=3, hi=n - 1, note="the number of points - 1")
    eta = as_float(eta, "eta", lo=0.0, hi=1.0)
    eps = as_float(eps, "eps", lo=0.0, lo_open=True)
    auto = n_iter is None
    n_iter = FLATNESS_MAX_ITER if auto else _as_n_iter(n_iter)
    if noise is not None:
        noise = as_float(noise, "noise", lo=0.0)
    if k_start is not None:
        k_start = as_int(k_start, "k_start", lo=k, hi=n - 1, note="k .. number of points - 1")
    elif schedule == "decreasing":
        k_start = min(4 * k, n - 1)
    ks, etas = flatness_schedule(max(n_iter, 1), k, eta, schedule=schedule, k_start=k_start)
    with threads_for(n):  # small input, busy machine: one thread (same output)
        ell = mean_spacing(pts, 6) if n > 6 else 0.0
        sigma = None
        if auto:
            sigma = estimate_noise(pts) if noise is None else noise
        cur, energy, v3, valid, ran = _flatness_iterations(
            pts, ks[:n_iter], etas[:n_iter], eps, flatness, sigma=sigma, progress=progress
        )
        if ran == 0 or not valid.any():
            _, energy, v3, valid = flatness_step(cur, k, eta, eps, flatness=flatness)
    out_normals = _oriented(v3, valid, nrm)
    if not np.isfinite(cur).all():
        raise PointAtlasError("flatness denoising produced non-finite points")
    return DenoiseResult(
        points=cur,
        normals=out_normals,
        displacement=np.sqrt(((cur - pts) ** 2).sum(axis=1)),
        feature_class=np.zeros(n, dtype=np.int8),
        energy=np.where(valid, energy, np.nan),
        k=np.where(valid, int(ks[ran - 1]) if ran else k, -1).astype(np.int64),
        method="flatness",
        n_iter=ran,
        n_fallback=0,
        spacing=ell,
    )


def _oriented(v3: np.ndarray, valid: np.ndarray, reference) -> np.ndarray:
    """PCA normals with the sign of ``reference`` (its row where v3 is undefined)."""
    out = np.where(valid[:, None], v3, reference if reference is not None else [0.0, 0.0, 1.0])
    if reference is not None:
        flip = (out * reference).sum(axis=1) < 0
        out[flip] *= -1.0
    return out / np.linalg.norm(out, axis=1)[:, None]

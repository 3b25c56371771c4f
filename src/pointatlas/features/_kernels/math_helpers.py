"""Scalar math of the features kernels (numba): the cosine ramp of the sigmoid
weights, a vectorisable atan2 and the angle between normals, -t ln t and its chord
bounds, integer powers.

Each is written once and shared by the fixed-k kernel and the search, so both give
the same values bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..._core.tolerances import ANGLE_ZERO

__all__ = [
    "CHORD_N",
    "atan2_nonneg",
    "chord_bound",
    "cosine_sigmoid_scalar",
    "normal_angle",
    "pow_even",
    "sigmoid_ramp",
    "xlogx",
]


@njit(cache=True, error_model="numpy")
def cosine_sigmoid_scalar(x, a, b):
    """Def. 15 with the a = b rule (docs/decisions/features.md): weight 1 iff x <= a,
    then the cosine ramp to 0 at b.

    The ramp 0.5 cos(pi u) + 0.5 is `sigmoid_ramp` (a polynomial, error < 3e-16) of
    u = (x - a) * (1 / (b - a)), the form the search (`optimal_kernel`) uses for its weights (so
    both give the same weights bit for bit).
    """
    if x <= a:
        return 1.0
    if x >= b:
        return 0.0
    return sigmoid_ramp((x - a) * (1.0 / (b - a)))


#: odd Taylor coefficients of sin(pi t), |t| <= 1/2 (truncation error < 3e-16)
_SINPI = (
    3.141592653589793,
    -5.167712780049969,
    2.550164039877345,
    -0.5992645293207919,
    0.08214588661112819,
    -0.007370430945714348,
    0.00046630280576761234,
    -2.1915353447830204e-05,
    7.952054001475508e-07,
    -2.2948428997269856e-08,
    5.392664662608125e-10,
)


@njit(cache=True, inline="always", error_model="numpy")
def sigmoid_ramp(u):
    """0.5 cos(pi u) + 0.5 for u in [0, 1] as a polynomial (absolute error < 3e-16).

    = 0.5 - 0.5 sin(pi t) with t = u - 1/2; cheaper than ``math.cos`` and
    vectorisable. Clamped at 0 so round-off never makes a weight negative.
    """
    t = u - 0.5
    t2 = t * t
    # Horner written out (as in `atan2_nonneg`): a helper looping over the
    # coefficient tuple gave the same bits but a slower search
    p = _SINPI[10]
    p = p * t2 + _SINPI[9]
    p = p * t2 + _SINPI[8]
    p = p * t2 + _SINPI[7]
    p = p * t2 + _SINPI[6]
    p = p * t2 + _SINPI[5]
    p = p * t2 + _SINPI[4]
    p = p * t2 + _SINPI[3]
    p = p * t2 + _SINPI[2]
    p = p * t2 + _SINPI[1]
    p = p * t2 + _SINPI[0]
    return max(0.5 - 0.5 * (p * t), 0.0)


@njit(cache=True, error_model="numpy")
def xlogx(x):
    """x ln x, 0 for x <= 0 (the terms of the entropies)."""
    if x <= 0.0:
        return 0.0
    return x * math.log(x)


@njit(cache=True, inline="always", error_model="numpy")
def pow_even(x, m):
    """x ** m for an integer m >= 0 by repeated squaring."""
    r = 1.0
    while m > 0:
        if m & 1:
            r *= x
        x *= x
        m >>= 1
    return r


#: intervals of the chord table of -t ln t on [0, 1]
CHORD_N = 1024


def _chord_table(n):
    """Intercepts and slopes of the chords of the concave -t ln t on [j/n, (j+1)/n].

    A chord lies below a concave function on its interval, so A[j] + B[j] t is a
    lower bound of -t ln t for t in [j/n, (j+1)/n] (error at most 1/(e n) on the
    first interval, 1/(8 n) elsewhere); the last chord serves t slightly above 1.
    """
    t = np.arange(n + 1, dtype=np.float64) / n
    f = np.zeros(n + 1)
    f[1:] = -t[1:] * np.log(t[1:])
    f[n] = 0.0
    slope = (f[1:] - f[:-1]) * n
    return np.ascontiguousarray(f[:-1] - slope * t[:-1]), np.ascontiguousarray(slope)


_CHORD_A, _CHORD_B = _chord_table(CHORD_N)


@njit(cache=True, inline="always", error_model="numpy")
def chord_bound(t):
    """Lower bound of -t ln t for t in [0, 1 + a few ulps] (a table chord, no log)."""
    j = min(int(t * CHORD_N), CHORD_N - 1)
    return _CHORD_A[j] + _CHORD_B[j] * t


#: Cephes' atan: P(z) / Q(z) coefficients (z = x^2, |x| <= 0.66), Q monic
_ATAN_P = (
    -8.750608600031904122785e-1,
    -1.615753718733365076637e1,
    -7.500855792314704667340e1,
    -1.228866684490136173410e2,
    -6.485021904942025371773e1,
)
_ATAN_Q = (
    2.485846490142306297962e1,
    1.650270098316988542046e2,
    4.328810604912902668951e2,
    4.853903996359136964868e2,
    1.945506571482613964425e2,
)
#: pi/2 - fl(pi/2), added where Cephes adds it
_ATAN_MOREBITS = 6.123233995736765886130e-17


@njit(cache=True, inline="always", error_model="numpy")
def atan2_nonneg(y, x):
    """atan2(y, x) for y, x >= 0 (not both 0), in [0, pi/2]; NaN in, NaN out.

    Cephes' atan (relative error ~2e-16) of min/max after the reflection
    atan(t) = pi/2 - atan(1/t), written with selects only, so loops over it
    vectorise (libm's atan2 is a call per value, most of the angles' cost).
    """
    hi = y if y > x else x
    lo = x if y > x else y
    r = lo / hi
    big = r > 0.66
    t = (r - 1.0) / (r + 1.0) if big else r
    z = t * t
    p = _ATAN_P[0]
    p = p * z + _ATAN_P[1]
    p = p * z + _ATAN_P[2]
    p = p * z + _ATAN_P[3]
    p = p * z + _ATAN_P[4]
    q = z + _ATAN_Q[0]
    q = q * z + _ATAN_Q[1]
    q = q * z + _ATAN_Q[2]
    q = q * z + _ATAN_Q[3]
    q = q * z + _ATAN_Q[4]
    a = t + t * (z * p / q)
    a = (0.7853981633974483 + (a + 0.5 * _ATAN_MOREBITS)) if big else a
    a = (1.5707963267948966 - a + _ATAN_MOREBITS) if y > x else a
    return a if (y == y and x == x) else np.nan


@njit(cache=True, inline="always", error_model="numpy")
def normal_angle(nx, ny, nz, mx, my, mz):
    """Angle between unit normals n and m: 2 atan2(|n - m|, |n + m|), below
    ``ANGLE_ZERO`` exactly 0 (NaN stays NaN)."""
    dx = nx - mx
    dy = ny - my
    dz = nz - mz
    sx = nx + mx
    sy = ny + my
    sz = nz + mz
    x = 2.0 * atan2_nonneg(
        math.sqrt(dx * dx + dy * dy + dz * dz), math.sqrt(sx * sx + sy * sy + sz * sz)
    )
    if x < ANGLE_ZERO:
        x = 0.0
    return x

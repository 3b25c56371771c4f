"""The eigenvalue features (thesis Eqs. 5.6, 5.7, 6.1, 6.2), written once (numba).

`write_features` holds the 11 formulas; `eigen_features_row` decomposes one
covariance and writes a packed row (`layout.N_OUT` columns). The search's own
ratios (`lps_ratios`, `edim_of`) rank candidates; the features of the winner come
from `eigen_features_row` like those of the fixed-k kernel.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...normals._kernels.eig3 import eigh3_accurate
from .layout import (
    ANISOTROPY,
    CHANGE_OF_CURVATURE,
    E_DIM,
    EIGEN_SUM,
    EIGENENTROPY,
    FLATNESS,
    LINEARITY,
    N_OUT,
    OMNIVARIANCE,
    OUT_EIGENVALUES,
    OUT_FEATURES,
    OUT_VECTOR_1,
    OUT_VECTOR_3,
    PLANARITY,
    SCATTERING,
    VERTICALITY,
)
from .math_helpers import pow_even, xlogx

__all__ = ["edim_of", "eigen_features_row", "lps_ratios", "write_features"]


@njit(cache=True, inline="always", error_model="numpy")
def write_features(out, i, first, l1, l2, l3, e3z, m1, m2, cbrt_omnivariance):
    """The 11 features of eigenvalues l1 >= l2 >= l3 (l1 > 0) into ``out[i, first:first + 11]``.

    Linearity, planarity, scattering (Eq. 5.6), E_dim (Eq. 5.7), omnivariance,
    anisotropy (reversed, 6.2), change of curvature, eigenentropy, eigenvalue sum,
    verticality 1 - |e3z| (``e3z`` the z component of the unit eigenvector of l3)
    and flatness (Eq. 6.1, even exponents m1, m2).

    Omnivariance is the cube root of e1 e2 e3: ``np.cbrt`` where
    ``cbrt_omnivariance`` (the fixed-k and search kernels) and ``** (1/3)``
    otherwise (`features_kernel`, behind `eigen_features`). The two differ in the
    last bit for most inputs (1/3 is not exact in binary) and both results are
    frozen, so the choice stays a flag, constant at every call site.
    """
    s = l1 + l2 + l3
    lin = (l1 - l2) / l1
    pla = (l2 - l3) / l1
    sca = l3 / l1
    e1 = l1 / s
    e2 = l2 / s
    e3 = l3 / s
    out[i, first + LINEARITY] = lin
    out[i, first + PLANARITY] = pla
    out[i, first + SCATTERING] = sca
    out[i, first + E_DIM] = 0.0 - (xlogx(lin) + xlogx(pla) + xlogx(sca))
    if cbrt_omnivariance:
        out[i, first + OMNIVARIANCE] = np.cbrt(e1 * e2 * e3)
    else:
        out[i, first + OMNIVARIANCE] = (e1 * e2 * e3) ** (1.0 / 3.0)
    out[i, first + ANISOTROPY] = 1.0 - (e1 - e3) / e1
    out[i, first + CHANGE_OF_CURVATURE] = e3 / (e1 + e2 + e3)
    out[i, first + EIGENENTROPY] = 0.0 - (xlogx(e1) + xlogx(e2) + xlogx(e3))
    out[i, first + EIGEN_SUM] = s
    out[i, first + VERTICALITY] = 1.0 - abs(e3z)
    out[i, first + FLATNESS] = pow_even(1.0 - l2 / l1, m1) + 1.0 - pow_even(1.0 - l3 / l1, m2)


@njit(cache=True, inline="always", error_model="numpy")
def eigen_features_row(out, i, c00, c01, c02, c11, c12, c22, m1, m2):
    """Eigen-decomposition (`eigh3_accurate`) and features of one covariance into row
    ``i`` of the packed output (`N_OUT` columns); False (row NaN) when lambda_1 = 0."""
    l1, l2, l3, e1x, e1y, e1z, e3x, e3y, e3z = eigh3_accurate(c00, c01, c02, c11, c12, c22)
    if not l1 > 0.0:
        for c in range(N_OUT):
            out[i, c] = np.nan
        return False
    out[i, OUT_EIGENVALUES + 0] = l1
    out[i, OUT_EIGENVALUES + 1] = l2
    out[i, OUT_EIGENVALUES + 2] = l3
    out[i, OUT_VECTOR_1 + 0] = e1x
    out[i, OUT_VECTOR_1 + 1] = e1y
    out[i, OUT_VECTOR_1 + 2] = e1z
    out[i, OUT_VECTOR_3 + 0] = e3x
    out[i, OUT_VECTOR_3 + 1] = e3y
    out[i, OUT_VECTOR_3 + 2] = e3z
    write_features(out, i, OUT_FEATURES, l1, l2, l3, e3z, m1, m2, True)
    return True


@njit(cache=True, inline="always", error_model="numpy")
def lps_ratios(l1, l2, l3):
    """Linearity, planarity, scattering as the search computes them (one division)."""
    il1 = 1.0 / l1
    return (l1 - l2) * il1, (l2 - l3) * il1, l3 * il1


@njit(cache=True, inline="always", error_model="numpy")
def edim_of(lin, pla, sca):
    """E_dim (Eq. 5.7) of the search's ratios (-t ln t as 0 at t <= 0)."""
    lnl = math.log(lin) if lin > 0.0 else 0.0
    lnp = math.log(pla) if pla > 0.0 else 0.0
    lns = math.log(sca) if sca > 0.0 else 0.0
    return -(lin * lnl + pla * lnp + sca * lns)

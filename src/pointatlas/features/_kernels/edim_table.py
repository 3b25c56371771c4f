"""The table of certified E_dim lower bounds that lets the search skip choices
(plain numpy, built once per process by `pointatlas.features._optimal`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["EDIM_TABLE_SHAPE", "edim_table"]

#: cells of `edim_table` along p/q and along sqrt(1 + r)
EDIM_TABLE_SHAPE = (256, 256)
#: what a table entry stays below the cell's smallest E_dim (covers eig3_fast's
#: rounding: its eigenvalues are those of the stage-1 (q, p, r) to ~1e-8 lambda_1
#: at worst, which moves each -t ln t by at most -d ln d ~ 2e-7 for d = 1e-8)
_TABLE_MARGIN = 2e-6


def _lps_of_cell(rho, theta):
    """Linearity, planarity, scattering of the eigenvalues q (1 + 2 rho cos(theta +
    2 pi j / 3)), theta in [0, pi/3] (exact formulas, unclipped)."""
    den = 1.0 + 2.0 * rho * np.cos(theta)
    lin = 2.0 * math.sqrt(3.0) * rho * np.sin(math.pi / 3.0 - theta) / den
    pla = 2.0 * math.sqrt(3.0) * rho * np.sin(theta) / den
    sca = (1.0 + 2.0 * rho * np.cos(theta + 2.0 * math.pi / 3.0)) / den
    return lin, pla, sca


def _min_tlogt(lo, hi):
    """Smallest -t ln t over [lo, hi] (clipped to [0, 1]): at an end, as it is concave."""
    ends = np.clip(np.stack([lo, hi]), 0.0, 1.0)
    safe = np.where(ends > 0.0, ends, 1.0)
    return np.min(-ends * np.log(safe), axis=0)


def edim_table(n_rho: int = EDIM_TABLE_SHAPE[0], n_v: int = EDIM_TABLE_SHAPE[1]) -> np.ndarray:
    """Certified lower bounds of E_dim (Eq. 5.7) over cells of the closed form's inputs.

    `eig3_fast` (in `pointatlas.normals._kernels.eig3`) writes the eigenvalues as
    q (1 + 2 rho c_j) with rho = p/q in [0, 1] (lambda_3 >= 0 needs rho <= 1) and
    c_j = cos(theta + 2 pi j/3), theta = acos(v^2 - 1)/3, v = sqrt(1 + r) in
    [0, sqrt 2]. Entry (i, j) bounds E_dim from below for rho in [i, i + 1] / n_rho
    and v in [j, j + 1] sqrt(2) / n_v.
    With theta: linearity 2 sqrt(3) rho sin(pi/3 - theta) / (1 + 2 rho cos theta)
    grows with rho and falls with theta, planarity 2 sqrt(3) rho sin(theta) / (...)
    grows with both, and scattering falls with rho and, in theta, falls then rises
    (its derivative has the sign of -(cos(theta + pi/3) + rho)), so the exact range
    of each over a cell comes from its corners and, for the smallest scattering,
    theta* = acos(-rho) - pi/3. Where lambda_3 < 0 in the cell (clipped to 0 by the
    solver: scattering 0, planarity 1 - linearity) the ranges widen to hold that.
    -t ln t is concave, so its smallest value on a range is at an end; the sum of
    the three is a lower bound of E_dim on the cell, less `_TABLE_MARGIN`. Cells
    are widened by 1e-10 on every side for the rounding of the index.

    Returns
    -------
    table : ndarray of shape (n_rho, n_v), float64
    """
    widen = 1e-10
    ra = np.maximum(np.arange(n_rho) / n_rho - widen, 0.0)[:, None]
    rb = (np.arange(1, n_rho + 1) / n_rho + widen)[:, None]
    v = np.arange(n_v + 1) * (math.sqrt(2.0) / n_v)
    t_lo = np.arccos(np.clip((v[1:] + widen) ** 2 - 1.0, -1.0, 1.0)) / 3.0 - widen
    t_hi = np.arccos(np.clip(v[:-1] ** 2 - 1.0, -1.0, 1.0)) / 3.0 + widen
    ta = np.maximum(t_lo, 0.0)[None, :]
    tb = np.minimum(t_hi, math.pi / 3.0)[None, :]
    lin_lo = _lps_of_cell(ra, tb)[0]
    lin_hi = _lps_of_cell(rb, ta)[0]
    pla_lo = _lps_of_cell(ra, ta)[1]
    pla_hi = _lps_of_cell(rb, tb)[1]
    sca_hi = np.maximum(_lps_of_cell(ra, ta)[2], _lps_of_cell(ra, tb)[2])
    t_star = np.clip(np.arccos(-np.minimum(rb, 1.0)) - math.pi / 3.0, ta, tb)
    sca_lo = _lps_of_cell(rb, t_star)[2]
    clipped = sca_lo < 0.0
    pla_lo = np.where(clipped, np.minimum(pla_lo, 1.0 - lin_hi), pla_lo)
    sca_lo = np.maximum(sca_lo, 0.0)
    sca_hi = np.maximum(sca_hi, 0.0)
    bound = _min_tlogt(lin_lo, lin_hi) + _min_tlogt(pla_lo, pla_hi) + _min_tlogt(sca_lo, sca_hi)
    return np.ascontiguousarray(bound - _TABLE_MARGIN)

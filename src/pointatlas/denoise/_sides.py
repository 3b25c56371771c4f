"""Two sides closer than the noise: a thin plate's sides told apart before they merge.

A local denoise without oriented normals (estimated normals are oriented one way
across a thin wall) fits one plane to both sides of a plate thinner than about
3 noise sigmas and pulls them onto the mid-surface, which is farther from the
true surface than the input once the sides are more than about 1.6 sigmas apart.
The heights of the input over that mid-surface then are a mixture of two
Gaussians at +-a (platykurtic, kurtosis below 3) rather than one (docs/decisions/
denoise.md, "Thin plates"). Each point's side is the sign of its height; the
denoisers run again with the sides apart.
"""

from __future__ import annotations

import numpy as np

from ._defaults import SIDES_MIN_HEIGHT, SIDES_MIN_SHARE, SIDES_Z

__all__ = ["two_sides"]


def two_sides(points, moved, normals, table, spacing: float):
    """+1 / -1 per point when the heights are two sheets, else None (private helper,
    validated input; ``table`` the input's k-NN rows, the point first).

    The height h_i = (p_i - x_i) . n_i is centred by its row's mean (a shape the
    denoise shrinks or inflates shifts every height alike), then tested: kurtosis
    below 3 by SIDES_Z standard errors (sqrt(24 / N)) and the two-Gaussian
    moment fit's offset a (a^4 = (3 m2^2 - m4) / 2) carrying at least
    SIDES_MIN_SHARE of the height variance; heights below SIDES_MIN_HEIGHT l (a
    clean input) are never split.
    """
    h = ((points - moved) * normals).sum(axis=1)
    h = h - h[table].mean(axis=1)
    n = h.shape[0]
    m2 = float(np.mean(h**2))
    if n < 8 or m2 <= (SIDES_MIN_HEIGHT * spacing) ** 2:
        return None
    m4 = float(np.mean(h**4))
    deficit = 3.0 - m4 / (m2 * m2)
    a2 = np.sqrt(max(1.5 * m2 * m2 - 0.5 * m4, 0.0))
    if deficit < SIDES_Z * np.sqrt(24.0 / n) or a2 < SIDES_MIN_SHARE * m2:
        return None
    return np.where(h >= 0.0, 1.0, -1.0)

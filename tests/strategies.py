"""Shared hypothesis strategies: small seeded point sets and rigid motions."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st


@st.composite
def seeds(draw):
    """A seed for numpy's default_rng."""
    return draw(st.integers(min_value=0, max_value=2**32 - 1))


@st.composite
def rigid_motions(draw):
    """A random rotation matrix R (3x3, det +1) and translation t (3,)."""
    rng = np.random.default_rng(draw(seeds()))
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    t = rng.normal(scale=draw(st.sampled_from([0.0, 1.0, 100.0])), size=3)
    return q, t


@st.composite
def random_clouds(draw, min_points=20, max_points=200):
    """Uniform random points in the unit cube, seeded."""
    n = draw(st.integers(min_value=min_points, max_value=max_points))
    rng = np.random.default_rng(draw(seeds()))
    return rng.random((n, 3))

"""Plain-numpy references for the cover kernels: every lattice ball tested by brute force."""

from __future__ import annotations

import numpy as np


def cubic_membership_reference(y: np.ndarray, dim: int, r_even: float, r_odd: float):
    """Sorted lattice points (as tuples) whose closed ball holds each point of ``y``."""
    out = []
    for p in y:
        lo = np.floor(p[:dim]).astype(int) - 2
        found = []
        rng3 = range(lo[2], lo[2] + 5) if dim == 3 else range(0, 1)
        for i in range(lo[0], lo[0] + 5):
            for j in range(lo[1], lo[1] + 5):
                for k in rng3:
                    c = np.array([i, j, k], dtype=float)
                    r = r_even if (i + j + k) % 2 == 0 else r_odd
                    d = p[:dim] - c[:dim]
                    if float(d @ d) <= r * r:
                        found.append((i, j, k))
        out.append(sorted(found))
    return out


def tiling_membership_reference(y: np.ndarray, r: float):
    """Sorted tiling vertices (i, j) whose ball (centre (i + j/2, j sqrt(3)/2)) holds each point."""
    out = []
    s3 = np.sqrt(3.0)
    for p in y:
        j0 = int(np.floor(2 * p[1] / s3))
        i0 = int(np.floor(p[0] - p[1] / s3))
        found = []
        for i in range(i0 - 3, i0 + 4):
            for j in range(j0 - 3, j0 + 4):
                cx, cy = i + 0.5 * j, 0.5 * s3 * j
                if (p[0] - cx) ** 2 + (p[1] - cy) ** 2 <= r * r:
                    found.append((i, j))
        out.append(sorted(found))
    return out

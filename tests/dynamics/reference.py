"""Plain per-point reference of the triangle update of Algorithm 3 (Eq. 2.4, 2.5), literally."""

from __future__ import annotations

import numpy as np


def triangle_update_reference(p, tri0, tri1):
    """Move p with triangle tri0 (3, 3) -> tri1 (3, 3), oriented, by Eq. 2.4's two ratios.

    q: projection onto the plane, h: signed height; the ray from the barycentre b
    through q meets the edge (v_i, v_k) at e; keep |e - v_i| / |v_k - v_i| and
    |q - b| / |e - b|; rebuild q~ in the moved triangle; p~ = q~ + omega h n~.
    """

    def normal(t):
        n = np.cross(t[1] - t[0], t[2] - t[0])
        return n / np.linalg.norm(n), 0.5 * np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0]))

    n0, a0 = normal(tri0)
    n1, a1 = normal(tri1)
    h = float((p - tri0[0]) @ n0)
    q = p - h * n0
    b0, b1 = tri0.mean(axis=0), tri1.mean(axis=0)
    d = q - b0
    if np.linalg.norm(d) == 0:
        q1 = b1
    else:
        for i, k in ((0, 1), (1, 2), (2, 0)):
            # solve b0 + mu d = v_i + lam (v_k - v_i), mu > 0, lam in [0, 1]
            A = np.column_stack([d, -(tri0[k] - tri0[i])])
            sol, *_ = np.linalg.lstsq(A, tri0[i] - b0, rcond=None)
            mu, lam = sol
            if mu > 0 and -1e-12 <= lam <= 1 + 1e-12:
                e0 = tri0[i] + lam * (tri0[k] - tri0[i])
                ratio = np.linalg.norm(q - b0) / np.linalg.norm(e0 - b0)
                e1 = tri1[i] + lam * (tri1[k] - tri1[i])
                q1 = b1 + ratio * (e1 - b1)
                break
    return q1 + (a0 / a1) * h * n1

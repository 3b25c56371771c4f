"""numba kernel of the polygons step (`_polygons.fan_starts`); its plain-numpy
reference in tests/simplify/reference.py."""

from __future__ import annotations

from numba import njit

__all__ = ["fan_kind"]


@njit(cache=True)
def fan_kind(p, normal, s: int, tol: float) -> int:
    """How the fan from vertex ``s`` of the polygon ``p`` (n, 3) covers it, about its
    ``normal``: 2 when every fan triangle (p_s, p_s+i, p_s+i+1) turns the polygon's
    way by more than ``tol`` (twice its area along the normal), 1 when none turns
    against it by more than ``tol`` but one does not turn by more, 0 otherwise.

    Assumes ``p`` of shape (n, 3), n >= 3, float64, and ``tol`` >= 0.
    """
    n = p.shape[0]
    kind = 2
    x, y, z = p[s, 0], p[s, 1], p[s, 2]
    for i in range(1, n - 1):
        a, b = (s + i) % n, (s + i + 1) % n
        ax, ay, az = p[a, 0] - x, p[a, 1] - y, p[a, 2] - z
        bx, by, bz = p[b, 0] - x, p[b, 1] - y, p[b, 2] - z
        area = (
            (ay * bz - az * by) * normal[0]
            + (az * bx - ax * bz) * normal[1]
            + (ax * by - ay * bx) * normal[2]
        )
        if area < -tol:
            return 0
        if area <= tol:
            kind = 1
    return kind

"""numba kernels of the simplify room (validated input assumed)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["point_triangle_distances"]


@njit(cache=True)
def _segment_sq(px, py, pz, ax, ay, az, bx, by, bz):
    """Squared distance from p to segment ab (a point when a == b)."""
    dx, dy, dz = bx - ax, by - ay, bz - az
    ll = dx * dx + dy * dy + dz * dz
    t = 0.0
    if ll > 0.0:
        t = ((px - ax) * dx + (py - ay) * dy + (pz - az) * dz) / ll
        t = min(1.0, max(0.0, t))
    qx, qy, qz = ax + t * dx - px, ay + t * dy - py, az + t * dz - pz
    return qx * qx + qy * qy + qz * qz


@njit(cache=True)
def _closest_sq(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Squared distance from p to triangle abc (Ericson, Real-Time Collision Detection 5.1.5)."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    scale = (abx * abx + aby * aby + abz * abz) * (acx * acx + acy * acy + acz * acz)
    if nx * nx + ny * ny + nz * nz <= 1e-24 * scale or scale == 0.0:
        # degenerate (collinear or repeated corners): nearest of the three segments
        d = _segment_sq(px, py, pz, ax, ay, az, bx, by, bz)
        d = min(d, _segment_sq(px, py, pz, bx, by, bz, cx, cy, cz))
        return min(d, _segment_sq(px, py, pz, cx, cy, cz, ax, ay, az))
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        qx, qy, qz = ax + v * abx - px, ay + v * aby - py, az + v * abz - pz
        return qx * qx + qy * qy + qz * qz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        qx, qy, qz = ax + w * acx - px, ay + w * acy - py, az + w * acz - pz
        return qx * qx + qy * qy + qz * qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx = bx + w * (cx - bx) - px
        qy = by + w * (cy - by) - py
        qz = bz + w * (cz - bz) - pz
        return qx * qx + qy * qy + qz * qz
    denom = va + vb + vc
    v = vb / denom
    w = vc / denom
    qx = ax + abx * v + acx * w - px
    qy = ay + aby * v + acy * w - py
    qz = az + abz * v + acz * w - pz
    return qx * qx + qy * qy + qz * qz


@njit(cache=True, parallel=True)
def point_triangle_distances(points, vertices, triangles):
    """Distance from every point to the nearest of the triangles.

    Parameters
    ----------
    points : (N, 3) float64
    vertices : (V, 3) float64
    triangles : (T, 3) int64, T >= 1

    Returns
    -------
    (N,) float64 distances.
    """
    n = points.shape[0]
    t = triangles.shape[0]
    out = np.empty(n)
    for i in prange(n):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        best = np.inf
        for f in range(t):
            a = triangles[f, 0]
            b = triangles[f, 1]
            c = triangles[f, 2]
            d = _closest_sq(
                px,
                py,
                pz,
                vertices[a, 0],
                vertices[a, 1],
                vertices[a, 2],
                vertices[b, 0],
                vertices[b, 1],
                vertices[b, 2],
                vertices[c, 0],
                vertices[c, 1],
                vertices[c, 2],
            )
            if d < best:
                best = d
        out[i] = np.sqrt(best)
    return out

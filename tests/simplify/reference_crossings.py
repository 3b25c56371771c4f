"""Plain numpy reference for `pointatlas.simplify.self_intersections`: one triangle
clipped by the other, every pair whose boxes meet."""

from __future__ import annotations

import numpy as np


def _inward_clip(points, a, b, n):
    """The part of polygon ``points`` (k x 3, in order) on the inner side of the edge
    (a, b) of a triangle with normal ``n`` (Sutherland-Hodgman, one edge)."""
    inward = np.cross(n, b - a)
    s = (points - a) @ inward
    out = []
    for i in range(len(points)):
        j = (i + 1) % len(points)
        if s[i] >= 0:
            out.append(points[i])
        if (s[i] > 0 > s[j]) or (s[i] < 0 < s[j]):
            out.append(points[i] + (points[j] - points[i]) * (s[i] / (s[i] - s[j])))
    return np.array(out).reshape(-1, 3)


def _clipped(points, tri):
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    for e in range(3):
        points = _inward_clip(points, tri[e], tri[(e + 1) % 3], n)
        if len(points) == 0:
            break
    return points


def _plane_cut(p, d):
    """The points where the plane (signed distances ``d`` of p's corners) meets p."""
    cut = [p[i] for i in range(3) if d[i] == 0]
    for i in range(3):
        j = (i + 1) % 3
        if d[i] * d[j] < 0:
            cut.append(p[i] + (p[j] - p[i]) * (d[i] / (d[i] - d[j])))
    return np.array(cut).reshape(-1, 3)


def triangles_cross_reference(p, q, shared_p, shared_q, tol, flat_tol):
    """Whether triangles p and q pass through each other by more than ``tol``, by
    another route than the kernel: in one plane (every corner within ``flat_tol`` of
    the other's plane), clip p by q's three edges and measure what is left (its
    extent across its thinnest direction); else, where each reaches past ``tol`` to
    both sides of the other's plane, clip the segment that q's plane cuts from p to
    q, and the one p's plane cuts from q to p, and measure the shorter (one segment,
    but where the triangles only touch, round-off decides on which side of a plane a
    corner on it lies)."""
    p = np.asarray(p, float)
    q = np.asarray(q, float)
    nq = np.cross(q[1] - q[0], q[2] - q[0])
    np_ = np.cross(p[1] - p[0], p[2] - p[0])
    if not (np.linalg.norm(nq) > 0 and np.linalg.norm(np_) > 0):
        return False
    nq = nq / np.linalg.norm(nq)
    np_ = np_ / np.linalg.norm(np_)
    dp = (p - q[0]) @ nq
    dq = (q - p[0]) @ np_
    if shared_p >= 0:
        dp[shared_p] = 0.0
        dq[shared_q] = 0.0
    if np.abs(dp).max() <= flat_tol and np.abs(dq).max() <= flat_tol:
        flat = p - np.outer(dp, nq)
        left = _clipped(flat, q)
        if len(left) < 3:
            return False
        centre = left.mean(axis=0)
        area = 0.5 * sum(
            np.linalg.norm(np.cross(left[i] - centre, left[(i + 1) % len(left)] - centre))
            for i in range(len(left))
        )
        extent = max(np.linalg.norm(left - centre, axis=1).max(), 1e-300)
        return area / extent > tol
    for d in (dp, dq):  # an edge on the other's plane: touching at most
        if min(d.max(), -d.min()) <= tol:
            return False
    return min(_cut_inside(p, dp, q, nq), _cut_inside(q, dq, p, np_)) > tol


def _cut_inside(p, dp, q, nq) -> float:
    """Length of the segment that q's plane (distances ``dp`` of p's corners) cuts
    from p, clipped to q (0 where it cuts a point or nothing)."""
    cut = _plane_cut(p, dp)
    if len(cut) < 2:
        return 0.0
    seg = np.array([cut[0], cut[-1]])
    if len(cut) == 3:
        far = np.argmax([np.linalg.norm(cut[i] - cut[j]) for i, j in ((0, 1), (0, 2), (1, 2))])
        seg = cut[[(0, 0, 1)[far], (1, 2, 2)[far]]]
    a, b = seg
    for e in range(3):
        i, j = q[e], q[(e + 1) % 3]
        inward = np.cross(nq, j - i)
        sa, sb = (a - i) @ inward, (b - i) @ inward
        if sa < 0 and sb < 0:
            return 0.0
        if sa < 0:
            a = a + (b - a) * (sa / (sa - sb))
        elif sb < 0:
            b = b + (a - b) * (sb / (sb - sa))
    return float(np.linalg.norm(b - a))


def self_intersections_reference(vertices, triangles, tol, flat_tol):
    """Every pair (a < b) of triangles sharing no edge that crosses: every pair whose
    boxes meet tried."""
    v = np.asarray(vertices, float)
    v = v - 0.5 * (v.min(axis=0) + v.max(axis=0))
    corners = v[np.asarray(triangles)]
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    out = []
    for a in range(len(triangles)):
        meets = ((lo[a + 1 :] <= hi[a]) & (hi[a + 1 :] >= lo[a])).all(axis=1)
        for b in a + 1 + np.flatnonzero(meets):
            common = set(triangles[a]) & set(triangles[b])
            if len(common) > 1:
                continue
            sp = sq = -1
            if common:
                (c,) = common
                sp, sq = list(triangles[a]).index(c), list(triangles[b]).index(c)
            if triangles_cross_reference(v[triangles[a]], v[triangles[b]], sp, sq, tol, flat_tol):
                out.append((a, b))
    return np.array(out, dtype=np.int64).reshape(-1, 2)

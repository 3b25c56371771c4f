"""Slow, obvious plain-numpy references for the features kernels (loops over points)."""

from __future__ import annotations

import math

import numpy as np

ANGLE_ZERO = 1e-7


def sigmoid(x: float, a: float, b: float) -> float:
    """Def. 15 with the a = b rule, written as printed."""
    if x < ANGLE_ZERO:
        x = 0.0
    if a == b:
        return 1.0 if x <= a else 0.0
    if x < a:
        return 1.0
    if x <= b:
        return 0.5 * math.cos(math.pi * (x - a) / (b - a)) + 0.5
    return 0.0


def angle(n1, n2) -> float:
    """Angle between two unit vectors by arccos of the clipped dot product."""
    c = float(np.clip(np.dot(n1, n2), -1.0, 1.0))
    x = math.acos(c)
    # arccos loses precision near 0: use the cross-product norm there
    if x < 1e-4:
        x = math.asin(min(1.0, float(np.linalg.norm(np.cross(n1, n2)))))
    return 0.0 if x < ANGLE_ZERO else x


def covariance(pts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Eq. 5.4 for one neighbourhood: weighted outer products about the plain mean."""
    d = pts - pts.mean(axis=0)
    return (d * np.asarray(w)[:, None]).T @ d


def reason(pts: np.ndarray, w: np.ndarray, c: np.ndarray | None = None) -> int:
    """Reason code of one neighbourhood (0 ok, 1 non-finite, 2, 3, 4 as documented)."""
    if not np.isfinite(pts).all() or not np.isfinite(w).all():
        return 1
    if w.sum() <= 0:
        return 2
    pos = pts[w > 0]
    if len({tuple(p) for p in pos}) < 3:
        return 3
    if c is None:
        c = covariance(pts, w)
    if np.linalg.eigvalsh(c).max() <= 0:
        return 4
    return 0


def features(lam, v3=None, m1=8, m2=8) -> dict:
    """Features from eigenvalues lam (descending) as the thesis prints them."""
    l1, l2, l3 = (max(float(v), 0.0) for v in lam)

    def xlx(x):
        return 0.0 if x <= 0 else x * math.log(x)

    s = l1 + l2 + l3
    e = [l1 / s, l2 / s, l3 / s]
    lin, pla, sca = (l1 - l2) / l1, (l2 - l3) / l1, l3 / l1
    out = {
        "linearity": lin,
        "planarity": pla,
        "scattering": sca,
        "e_dim": -(xlx(lin) + xlx(pla) + xlx(sca)),
        "omnivariance": (e[0] * e[1] * e[2]) ** (1 / 3),
        "anisotropy": 1 - (e[0] - e[2]) / e[0],
        "change_of_curvature": e[2] / sum(e),
        "eigenentropy": -sum(xlx(v) for v in e),
        "eigen_sum": s,
        "flatness": (1 - l2 / l1) ** m1 + 1 - (1 - l3 / l1) ** m2,
    }
    if v3 is not None:
        out["verticality"] = 1 - abs(v3[2])
    return out


def point_features(points, normals, idx_row, k, a, b, m1=8, m2=8, angles=None):
    """(reason, eigenvalues descending, features dict or None) for one choice."""
    rows = idx_row[:k]
    pts = points[rows] - points[idx_row[0]]
    if normals is None or (a == math.pi and b == math.pi):
        w = np.ones(k)
    elif angles is not None:
        w = np.array([sigmoid(x, a, b) for x in angles[:k]])
    else:
        w = np.array([sigmoid(angle(normals[idx_row[0]], normals[j]), a, b) for j in rows])
    if not np.isfinite(points[rows]).all():
        return 1, None, None
    c = covariance(pts, w)
    code = reason(pts, w, c)
    if code:
        return code, None, None
    lam, vec = np.linalg.eigh(c)
    lam = lam[::-1]
    return 0, lam, features(lam, vec[:, 0], m1, m2)


def brute_force_search(points, normals, idx, pairs, kmin, kmax, criterion="e_dim"):
    """Loop over every (a, b, k) per point; ties: smallest k, then a, then b."""
    n = points.shape[0]
    best = np.full(n, np.inf)
    best_k = np.full(n, -1)
    best_pair = np.full(n, -1)
    for i in range(n):
        cands = []
        ang = None
        if normals is not None:
            ang = [angle(normals[i], normals[j]) for j in idx[i]]
        for pr, (a, b) in enumerate(pairs):
            for k in range(kmin, kmax + 1):
                code, lam, f = point_features(points, normals, idx[i], k, a, b, angles=ang)
                if code:
                    continue
                cands.append((f[criterion], k, pr))
        if cands:
            v, k, pr = min(cands)
            best[i], best_k[i], best_pair[i] = v, k, pr
    return best, best_k, best_pair

"""Slow, obvious plain-numpy references for the denoise kernels."""

from __future__ import annotations

import math

import numpy as np


def _segment_distance(p, a, b):
    ab = b - a
    denom = float(ab @ ab)
    t = 0.0 if denom == 0 else min(max(float((p - a) @ ab) / denom, 0.0), 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


def point_triangle_distance(p, a, b, c):
    """Distance from p to triangle abc: the plane when the foot is inside, else the edges."""
    n = np.cross(b - a, c - a)
    area2 = float(np.linalg.norm(n))
    edges = min(_segment_distance(p, a, b), _segment_distance(p, b, c), _segment_distance(p, c, a))
    if area2 == 0:
        return edges
    n = n / area2
    foot = p - float((p - a) @ n) * n
    # barycentric signs: inside when the foot is on the inner side of every edge
    inside = all(
        float(np.cross(v1 - v0, foot - v0) @ n) >= 0 for v0, v1 in ((a, b), (b, c), (c, a))
    )
    return abs(float((p - a) @ n)) if inside else edges


def point_to_mesh(points, vertices, faces):
    """Brute force over every triangle."""
    v = np.asarray(vertices, dtype=float)
    return np.array(
        [min(point_triangle_distance(p, *v[f]) for f in faces) for p in np.asarray(points, float)]
    )


def edim(lams):
    """E_dim of descending eigenvalues; inf when l1 <= 0."""
    l1, l2, l3 = np.clip(lams, 0, None)
    if l1 <= 0:
        return math.inf
    return -sum(x * math.log(x) for x in ((l1 - l2) / l1, (l2 - l3) / l1, l3 / l1) if x > 0)


def adaptive_k(points, normals, idx, k_lo, k_hi, cos_a):
    """Per point: loop over k, build Eq. 5.4 with numpy, eigvalsh, keep the least E_dim."""
    n = len(points)
    best_k = np.full(n, -1)
    best_e = np.full(n, math.inf)
    for i in range(n):
        for k in range(k_lo[i], k_hi[i] + 1):
            nb = idx[i, :k]
            w = (normals[nb] @ normals[i] >= cos_a).astype(float)
            if w.sum() < 3:
                continue
            y = points[nb] - points[nb].mean(axis=0)
            cov = (w[:, None, None] * y[:, :, None] * y[:, None, :]).sum(axis=0)
            e = edim(np.linalg.eigvalsh(cov)[::-1])
            if e < best_e[i]:
                best_e[i], best_k[i] = e, k
    return best_k, best_e


def _binarised(t, tau):
    lam, vec = np.linalg.eigh(t)
    if lam[2] <= 0:
        return np.zeros((3, 3)), 0, lam, vec
    keep = lam / lam[2] >= tau
    return vec[:, keep] @ vec[:, keep].T, int(keep.sum()), lam, vec


def voting_filter(normals, idx, k_of, use_cut, cos_rho, tau):
    """One voting step, point by point."""
    out = np.empty_like(normals)
    for i in range(len(normals)):
        nb = idx[i, : k_of[i]]
        w = np.ones(len(nb))
        if use_cut[i]:
            w = (normals[nb] @ normals[i] >= cos_rho).astype(float)
        t = (w[:, None, None] * normals[nb][:, :, None] * normals[nb][:, None, :]).sum(axis=0)
        proj, _, _, _ = _binarised(t, tau)
        x = proj @ normals[i]
        out[i] = x / np.linalg.norm(x) if np.linalg.norm(x) > 1e-12 else normals[i]
    return out


def quadric_update(points, normals, idx, k_of, cos_rho, tau, max_step, sharpen=True):
    """Restricted quadric update with numpy least squares (lstsq, rcond relative)."""
    out = np.empty_like(points)
    klass = np.empty(len(points), dtype=int)
    for i in range(len(points)):
        nb = idx[i, : k_of[i]]
        t = normals[nb].T @ normals[nb]
        lam, vec = np.linalg.eigh(t)
        m = max(int((lam / lam[2] >= tau).sum()), 1) if lam[2] > 0 else 1
        klass[i] = m
        m = m if sharpen else 1
        d = normals[i][:, None] if m == 1 else vec[:, ::-1][:, :m]
        if m == 1:
            nb = nb[normals[nb] @ normals[i] >= cos_rho]
        else:
            nb = nb[(np.abs(normals[nb] @ d) >= cos_rho).any(axis=1)]
        g = normals[nb] @ d  # (n, m)
        off = ((points[i] - points[nb]) * normals[nb]).sum(axis=1)
        a = g.T @ g
        mu, w = np.linalg.eigh(a)
        s = np.zeros(m)
        for e in range(m):
            if mu[-1] > 0 and mu[e] > 1e-6 * mu[-1]:
                s += w[:, e] * (w[:, e] @ (-g.T @ off)) / mu[e]
        x = d @ s
        length = np.linalg.norm(x)
        if length > max_step:
            x *= max_step / length
        out[i] = points[i] + x
    return out, klass


def plane_lists(normals, idx, k_of, cos_rho):
    """Per point the first k_of[i] neighbours with n_i . n_j >= cos_rho, in table
    order, left-aligned in an (N, K) table (-1 after them), and their counts."""
    lists = np.full(idx.shape, -1, dtype=np.int64)
    counts = np.zeros(len(idx), dtype=np.int64)
    for i in range(len(idx)):
        nb = idx[i, : k_of[i]]
        nb = nb[normals[nb] @ normals[i] >= cos_rho]
        lists[i, : nb.size] = nb
        counts[i] = nb.size
    return lists, counts


def plane_update(points, normals, idx, k_of, cos_rho, max_step, sigma, beta=1.0):
    """Each point along its normal by the weighted least squares over the planes
    ((2 - beta) n_i + beta n_j) . (x - p_j) = 0 of its neighbours with
    n_i . n_j >= cos_rho."""
    out = points.copy()
    for i in range(len(points)):
        nb = idx[i, : k_of[i]]
        nb = nb[normals[nb] @ normals[i] >= cos_rho]
        d = points[nb] - points[i]
        w = np.exp(-(d**2).sum(axis=1) / sigma**2)
        m = (2 - beta) * normals[i] + beta * normals[nb]
        g = m @ normals[i]
        a = float((w * g * g).sum())
        s = float((w * g * (m * d).sum(axis=1)).sum()) / a if a > 0 else 0.0
        out[i] = points[i] + min(max(s, -max_step), max_step) * normals[i]
    return out


def lonely_normals(points, normals, idx, k_of, cos_rho, min_count, sigma):
    """Normals of points with fewer than min_count neighbours (itself included) within
    the cut-off: the Gaussian-weighted sum of the other neighbours' normals, each
    signed like the own one, normalised, when at least min_count of the neighbours'
    normals (itself included) are within the cut-off of it."""
    out = normals.copy()
    for i in range(len(points)):
        nb = idx[i, : k_of[i]]
        if (normals[nb] @ normals[i] >= cos_rho).sum() >= min_count:
            continue
        nb = nb[1:]
        w = np.exp(-((points[nb] - points[i]) ** 2).sum(axis=1) / sigma**2)
        w = np.where(normals[nb] @ normals[i] < 0, -w, w)
        v = (w[:, None] * normals[nb]).sum(axis=0)
        if np.linalg.norm(v) > 0:
            v = v / np.linalg.norm(v)
            if (normals[idx[i, : k_of[i]]] @ v >= cos_rho).sum() >= min_count:
                out[i] = v
    return out


def flatness_step(points, k, eta, eps, m1=8, m2=8):
    """Eq. 6.3 for every point with numpy eigh on the equal-weight covariance."""
    from scipy.spatial import cKDTree

    idx = cKDTree(points).query(points, k)[1]
    out = points.copy()
    for i in range(len(points)):
        nb = points[idx[i]]
        b = nb.mean(axis=0)
        y = nb - b
        lam, vec = np.linalg.eigh(y.T @ y)
        l1, l2, l3 = lam[2], lam[1], lam[0]
        e = (1 - l2 / l1) ** m1 + 1 - (1 - l3 / l1) ** m2
        v1, v3 = vec[:, 2], vec[:, 0]
        d = (points[i] - b) @ v3
        pbar = b + ((points[i] - b) @ v1) * v1
        out[i] = points[i] + eps * (eta * (2 - e) * (-d * v3) + (1 - eta) * e * (pbar - points[i]))
    return out


# --------------------------------------------------------------------------- previous pipeline


def neighbourhoods(pts, radius_factor=2.0):
    """k_i and l by brute force: l the mean distance to the 6 nearest others, k_i the
    number of points within radius_factor * l (itself included), clamped to [7, 48]."""
    n = len(pts)
    d = np.sqrt(((pts[:, None, :] - pts[None, :, :]) ** 2).sum(axis=-1))
    ell = float(np.sort(d, axis=1)[:, 1:7].mean())
    k = np.clip((d <= radius_factor * ell).sum(axis=1), min(7, n), min(48, n))
    return k.astype(np.int64), ell


def face_normals(points, normals, idx, k_of, cos_rho):
    """Per point: numpy eigh of the covariance of its neighbours with n_i . n_j >=
    cos_rho about their barycentre; least eigenvector signed like n_i (kept n_i when
    fewer than three or no plane)."""
    out = normals.copy()
    for i in range(len(points)):
        nb = idx[i, : k_of[i]]
        nb = nb[normals[nb] @ normals[i] >= cos_rho]
        if nb.size < 3:
            continue
        y = points[nb] - points[nb].mean(axis=0)
        lam, vec = np.linalg.eigh(y.T @ y / nb.size)
        if not lam[1] > lam[0]:
            continue
        v = vec[:, 0]
        out[i] = -v if v @ normals[i] < 0 else v
    return out

"""Slow, obvious plain-numpy references for the denoise kernels (STYLE section 7)."""

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


def previous_neighbourhoods(pts, radius_factor=2.0, extra=0):
    """`default_neighbourhoods` before the speed work: one full-width query."""
    from pointatlas.neighbors import mean_spacing, query_knn

    n = pts.shape[0]
    kcap = min(48, n)
    ncol = min(kcap + extra, n)
    idx, dist = query_knn(pts, ncol)
    ell = float(np.mean(dist[:, 1:7])) if ncol > 6 else mean_spacing(pts, 6)
    inside = (dist[:, :kcap] <= radius_factor * ell).sum(axis=1)
    k = np.clip(inside, min(7, n), kcap).astype(np.int64)
    return np.ascontiguousarray(idx[:, : min(int(k.max()) + extra, ncol)]), k, ell


def previous_normal_voting_denoise(points, normals=None, *, rho=0.9, tau=0.3, n_iter=2,
                                   n_filter_iter=10, adaptive=True, max_step=0.5,
                                   sharpen=False, radius_factor=2.0):  # fmt: skip
    """`normal_voting_denoise` before the speed work (checked kernels, fresh queries).

    Without normals: PCA normals (k = 20) oriented with `orient_normals` on one
    20-NN table, as the benchmark did. Returns (points, normals, k, feature_class).
    """
    from pointatlas.denoise._kernels import (
        adaptive_k_kernel,
        quadric_update_kernel,
        voting_filter_kernel,
    )
    from pointatlas.neighbors import query_knn
    from pointatlas.normals import estimate_normals, orient_normals

    pts = np.array(points, dtype=np.float64)
    n = len(pts)
    if normals is None:
        knn = query_knn(pts, min(20, n))
        nrm = orient_normals(pts, estimate_normals(pts, min(20, n), neighbors=knn), neighbors=knn)
    else:
        nrm = np.array(normals, dtype=np.float64)
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    ell = None
    cur = pts.copy()
    klass = np.ones(n, dtype=np.int64)
    k_of = np.zeros(n, dtype=np.int64)
    for _ in range(n_iter):
        idx, k_def, spacing = previous_neighbourhoods(cur, radius_factor, 10 if adaptive else 0)
        ell = spacing if ell is None else ell
        k_of = k_def.copy()
        use_cut = np.ones(n, dtype=bool)
        if adaptive:
            k_lo = np.maximum(k_def - 10, 1).astype(np.int64)
            k_hi = np.minimum(k_def + 10, idx.shape[1]).astype(np.int64)
            best_k = np.empty(n, dtype=np.int64)
            best_e = np.empty(n)
            masks = np.full(n, -1, dtype=np.int64)
        for _ in range(n_filter_iter):
            if adaptive:
                adaptive_k_kernel(cur, nrm, idx, k_lo, k_hi, rho, best_k, best_e, masks)
                fallback = best_k < 0
                k_of = np.where(fallback, k_def, best_k)
                use_cut = ~fallback
            out = np.empty_like(nrm)
            voting_filter_kernel(nrm, idx, k_of, use_cut, rho, tau, out)
            nrm = out
        nxt = np.empty_like(cur)
        quadric_update_kernel(cur, nrm, idx, k_def, rho, tau, max_step * ell, sharpen, nxt, klass)
        cur = nxt
    return cur, nrm, k_of, klass

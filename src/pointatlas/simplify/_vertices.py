"""Mesh vertices from proxy planes: guarded least squares and Eq. 4.12 (thesis 4.4.1)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.optimize import NonlinearConstraint

from .._core import readonly
from .._core.tolerances import SIMPLIFY_PLANE_SV_RTOL, SIMPLIFY_VERTEX_BOUND
from ._solver import newton_kkt, newton_solver, project_constraints, solve_constrained

__all__ = ["MeshVertices", "SimplifyWarning"]


class SimplifyWarning(UserWarning):
    """The Eq. 4.12 optimisation (or the constrained plane fit) failed and plane
    intersection was used instead."""


@dataclass(frozen=True, slots=True)
class MeshVertices:
    """Positions of the complex's vertices and how they were obtained.

    Attributes
    ----------
    positions : ndarray of shape (V, 3), float64
        One position per vertex of the surface-like complex.
    plane_normals : ndarray of shape (R, 3), float64
        Plane normals the faces lie in: the proxy normals (least squares), the
        corrected normals n~_i of Eq. 4.12 (optimisation) or the refitted normals.
    plane_offsets : ndarray of shape (R,), float64
        d_i with plane_normals[i] . x = d_i.
    rank : ndarray of shape (V,), int64
        Number of plane directions used per vertex (least squares; 3 = a point
        fixed by its planes, less = guarded or a two-region vertex; ``"fit"``:
        min(3, number of regions); ``"optimize"``: 3).
    guarded : ndarray of shape (V,), bool
        True where near-parallel planes or the distance bound reduced the rank.
    plane_residual : ndarray of shape (V,), float64
        max_i |n_i . x_j - d_i| over the vertex's regions (input units).
    method : str
        ``"lsq"``, ``"optimize"`` or ``"fit"`` (the method actually used).
    fallback : bool
        True when ``"optimize"`` or ``"fit"`` was asked for but failed and least
        squares was used.
    constraint_violation : float
        Largest violation of the Eq. 4.12 (or fit) constraints (scaled units; NaN
        for lsq).
    n_iter : int
        Optimiser iterations (0 for lsq).
    message : str
        Optimiser status message (empty for lsq).
    """

    positions: np.ndarray
    plane_normals: np.ndarray
    plane_offsets: np.ndarray
    rank: np.ndarray
    guarded: np.ndarray
    plane_residual: np.ndarray
    method: str
    fallback: bool
    constraint_violation: float
    n_iter: int
    message: str

    def __post_init__(self):
        for name in (
            "positions",
            "plane_normals",
            "plane_offsets",
            "rank",
            "guarded",
            "plane_residual",
        ):
            readonly(getattr(self, name))


def _residuals(positions, vregions, normals, offsets):
    out = np.zeros(len(vregions))
    for j, regs in enumerate(vregions):
        r = np.asarray(regs)
        out[j] = np.max(np.abs(normals[r] @ positions[j] - offsets[r])) if r.size else 0.0
    return out


def lsq_vertices(cplx, points, normals, centers, *, max_distance=None) -> MeshVertices:
    """Guarded least-squares intersection of each vertex's proxy planes (private).

    ``normals``/``centers`` are validated (R, 3) arrays. The solution is a truncated
    SVD about the vertex's witness anchor p0: directions with singular value below
    ``SIMPLIFY_PLANE_SV_RTOL * s_max`` are taken from p0; when the solution lies
    farther than the bound from p0, the weakest remaining direction is dropped.
    """
    nv = cplx.n_vertices
    offsets = np.einsum("ij,ij->i", normals, centers)
    pos = np.zeros((nv, 3))
    rank = np.zeros(nv, dtype=np.int64)
    guarded = np.zeros(nv, dtype=bool)
    for j, regs in enumerate(cplx.vertex_regions):
        r = np.asarray(regs, dtype=np.int64)
        p0 = cplx.vertex_anchor[j]
        a = normals[r]
        b = offsets[r] - a @ p0
        u, s, vt = np.linalg.svd(a, full_matrices=False)
        full = int(np.sum(s > SIMPLIFY_PLANE_SV_RTOL * s[0])) if s.size else 0
        if max_distance is None:
            wit = cplx.vertex_points[j]
            spread = 0.0
            if wit.size > 1:
                spread = float(np.max(np.linalg.norm(points[wit] - p0, axis=1)))
            bound = max(
                SIMPLIFY_VERTEX_BOUND * float(np.min(np.linalg.norm(centers[r] - p0, axis=1))),
                2.0 * spread,
            )
        else:
            bound = float(max_distance)
        best = 0
        x = p0.copy()
        for kk in range(full, -1, -1):
            coef = (u[:, :kk].T @ b) / s[:kk]
            cand = p0 + vt[:kk].T @ coef
            if np.linalg.norm(cand - p0) <= bound or kk == 0:
                x, best = cand, kk
                break
        pos[j] = x
        rank[j] = best
        guarded[j] = best < min(3, r.size)
    return MeshVertices(
        positions=pos,
        plane_normals=np.array(normals, dtype=np.float64),
        plane_offsets=offsets,
        rank=rank,
        guarded=guarded,
        plane_residual=_residuals(pos, cplx.vertex_regions, normals, offsets),
        method="lsq",
        fallback=False,
        constraint_violation=float("nan"),
        n_iter=0,
        message="",
    )


def _incidences(cplx, centers):
    """Incidence arrays (vertex J, region I) and targets T of Eq. 4.11."""
    jj, ii, tt = [], [], []
    for j, regs in enumerate(cplx.vertex_regions):
        for i in regs:
            jj.append(j)
            ii.append(i)
            # inserted (two-region) vertices are pulled to their witness point, not
            # to the centroids (several of them share the same two regions)
            tt.append(cplx.vertex_anchor[j] if cplx.vertex_is_inserted[j] else centers[i])
    return (
        np.asarray(jj, dtype=np.int64),
        np.asarray(ii, dtype=np.int64),
        np.asarray(tt, dtype=np.float64).reshape(-1, 3),
    )


def _fallback(base, what, violation, n_iter, message) -> MeshVertices:
    """Warn that ``what`` failed and return the plane-intersection vertices ``base``."""
    warnings.warn(
        f"{what} failed (constraint violation {violation:.2e}, {message}); "
        "using plane intersection instead",
        SimplifyWarning,
        stacklevel=4,
    )
    return MeshVertices(
        positions=np.array(base.positions),
        plane_normals=np.array(base.plane_normals),
        plane_offsets=np.array(base.plane_offsets),
        rank=np.array(base.rank),
        guarded=np.array(base.guarded),
        plane_residual=np.array(base.plane_residual),
        method="lsq",
        fallback=True,
        constraint_violation=violation,
        n_iter=n_iter,
        message=message,
    )


def optimize_vertices(
    cplx, points, normals, centers, *, weight=1.0, max_iter=3000, lsq=None, solver="newton"
) -> MeshVertices:
    """Eq. 4.12 by ``scipy.optimize.minimize(method="trust-constr")`` (private).

    Variables: the vertex positions x_j and corrected normals n~_i. Objective (4.11)
    sum_j sum_{i in I_j} |x_j - C_i|^2 / s^2 + w sum_i |N_i - n~_i|^2 with s the RMS
    radius of the points (so ``weight`` is scale free; s = 1 for the unit sphere of
    the thesis). Constraints n~_i . (x_j - C_i) = 0 and |n~_i|^2 = 1. Analytic sparse
    Jacobian and Hessians. Start: n~_i = N_i, x_j = barycentre of its C_i (thesis
    4.4.3). On failure: least squares (``lsq``) with ``fallback=True`` and a
    `SimplifyWarning`.
    """
    nv = cplx.n_vertices
    n_reg = normals.shape[0]
    mu = points.mean(axis=0)
    scale = float(np.sqrt(np.mean(np.sum((points - mu) ** 2, axis=1))))
    scale = scale if scale > 0 else 1.0
    c_s = (centers - mu) / scale
    jj, ii, tt = _incidences(cplx, centers)
    t_s = (tt - mu) / scale
    m = jj.size
    q = np.bincount(jj, minlength=nv).astype(np.float64)
    nx = 3 * nv
    w = float(weight)

    x0 = np.zeros((nv, 3))
    np.add.at(x0, jj, t_s)
    x0 /= np.maximum(q, 1.0)[:, None]
    z0 = np.concatenate([x0.ravel(), normals.ravel()])
    n_target = normals.ravel()

    def split(z):
        return z[:nx].reshape(nv, 3), z[nx:].reshape(n_reg, 3)

    def fun(z):
        x, nn = split(z)
        dx = x[jj] - t_s
        dn = z[nx:] - n_target
        f = float(np.sum(dx * dx) + w * np.dot(dn, dn))
        gx = np.zeros((nv, 3))
        np.add.at(gx, jj, 2.0 * dx)
        return f, np.concatenate([gx.ravel(), 2.0 * w * dn])

    hess_obj = sparse.diags(np.concatenate([np.repeat(2.0 * q, 3), np.full(3 * n_reg, 2.0 * w)]))

    def hess(z):
        return hess_obj

    def cons(z):
        x, nn = split(z)
        g = np.einsum("ij,ij->i", nn[ii], x[jj] - c_s[ii])
        h = np.einsum("ij,ij->i", nn, nn) - 1.0
        return np.concatenate([g, h])

    cols_g = np.stack(
        [(3 * jj[:, None] + np.arange(3)).ravel(), (nx + 3 * ii[:, None] + np.arange(3)).ravel()],
        axis=1,
    )

    def cjac(z):
        x, nn = split(z)
        vals_x = nn[ii]  # d g / d x_j
        vals_n = x[jj] - c_s[ii]  # d g / d n_i
        r = np.concatenate([np.repeat(np.arange(m), 3), np.repeat(np.arange(m), 3)])
        c = np.concatenate([cols_g[:, 0], cols_g[:, 1]])
        v = np.concatenate([vals_x.ravel(), vals_n.ravel()])
        r2 = m + np.repeat(np.arange(n_reg), 3)
        c2 = nx + np.arange(3 * n_reg)
        v2 = 2.0 * z[nx:]
        return sparse.csr_array(
            (np.concatenate([v, v2]), (np.concatenate([r, r2]), np.concatenate([c, c2]))),
            shape=(m + n_reg, nx + 3 * n_reg),
        )

    size = nx + 3 * n_reg

    def chess(z, lam):
        v = np.repeat(lam[:m], 3)
        r = np.concatenate([cols_g[:, 0], cols_g[:, 1], nx + np.arange(3 * n_reg)])
        c = np.concatenate([cols_g[:, 1], cols_g[:, 0], nx + np.arange(3 * n_reg)])
        vals = np.concatenate([v, v, np.repeat(2.0 * lam[m:], 3)])
        return sparse.csr_array((vals, (r, c)), shape=(size, size))

    constraint = NonlinearConstraint(cons, 0.0, 0.0, jac=cjac, hess=chess)
    z, ok, violation, n_iter, message = solve_constrained(
        fun,
        z0,
        hess,
        constraint,
        cons,
        max_iter,
        gtol=1e-12,
        xtol=1e-14,
        refine=lambda z: project_constraints(
            newton_kkt(z, fun, hess_obj, cons, cjac, chess), cons, cjac
        ),
        newton=newton_solver(solver, fun, hess_obj, cons, cjac, chess),
    )
    if not ok:
        base = lsq if lsq is not None else lsq_vertices(cplx, points, normals, centers)
        return _fallback(base, "Eq. 4.12 optimisation", violation, n_iter, message)
    x, nn = split(z)
    nn = nn / np.linalg.norm(nn, axis=1, keepdims=True)
    pos = x * scale + mu
    offsets = np.einsum("ij,ij->i", nn, centers)
    return MeshVertices(
        positions=pos,
        plane_normals=nn,
        plane_offsets=offsets,
        rank=np.full(nv, 3, dtype=np.int64),
        guarded=np.zeros(nv, dtype=bool),
        plane_residual=_residuals(pos, cplx.vertex_regions, nn, offsets),
        method="optimize",
        fallback=False,
        constraint_violation=violation,
        n_iter=n_iter,
        message=message,
    )


_FIT_GTOL = 1e-12
_FIT_XTOL = 1e-14
_FIT_MIN_ENERGY = 1e-6


def _plane_moments(points, labels, n_reg):
    """Centre mu and RMS radius s of the points, and the per-region moments M_i of
    (q, -1), q = (p - mu) / s: the plane energy of region i is y_i^T M_i y_i with
    y_i = (n_i, d_i) (divided by the number of points)."""
    n_pts = points.shape[0]
    mu = points.mean(axis=0)
    scale = float(np.sqrt(np.mean(np.sum((points - mu) ** 2, axis=1))))
    scale = scale if scale > 0 else 1.0
    q = (points - mu) / scale
    qh = np.concatenate([q, -np.ones((n_pts, 1))], axis=1)
    mom = np.zeros((n_reg, 4, 4))
    for a in range(4):
        for b in range(a, 4):
            col = np.bincount(labels, weights=qh[:, a] * qh[:, b], minlength=n_reg) / n_pts
            mom[:, a, b] = mom[:, b, a] = col
    return mu, scale, mom


def _incidence_constraints(jj, ii, nv, n_reg):
    """The plane fit's constraints n_i . x_j - d_i = 0 (incidence (j, i)) and
    |n_i|^2 - 1 = 0 on z = (x, n, d): the values, the sparse Jacobian and the
    Hessian of lam . c (functions of z)."""
    m = jj.size
    nx = 3 * nv
    nn_off = nx
    d_off = nx + 3 * n_reg
    size = d_off + n_reg

    def cons(z):
        x = z[:nx].reshape(nv, 3)
        nn = z[nn_off:d_off].reshape(n_reg, 3)
        d = z[d_off:]
        g = np.einsum("ij,ij->i", nn[ii], x[jj]) - d[ii]
        h = np.einsum("ij,ij->i", nn, nn) - 1.0
        return np.concatenate([g, h])

    col_x = (3 * jj[:, None] + np.arange(3)).ravel()
    col_n = (nn_off + 3 * ii[:, None] + np.arange(3)).ravel()
    r3 = np.repeat(np.arange(m), 3)
    jac_rows = np.concatenate([r3, r3, np.arange(m), m + np.repeat(np.arange(n_reg), 3)])
    jac_cols = np.concatenate([col_x, col_n, d_off + ii, nn_off + np.arange(3 * n_reg)])

    def cjac(z):
        x = z[:nx].reshape(nv, 3)
        nn = z[nn_off:d_off].reshape(n_reg, 3)
        v = np.concatenate([nn[ii].ravel(), x[jj].ravel(), -np.ones(m), 2.0 * z[nn_off:d_off]])
        return sparse.csr_array((v, (jac_rows, jac_cols)), shape=(m + n_reg, size))

    def chess(z, lam):
        v = np.repeat(lam[:m], 3)
        r = np.concatenate([col_x, col_n, nn_off + np.arange(3 * n_reg)])
        c = np.concatenate([col_n, col_x, nn_off + np.arange(3 * n_reg)])
        vals = np.concatenate([v, v, np.repeat(2.0 * lam[m:], 3)])
        return sparse.csr_array((vals, (r, c)), shape=(size, size))

    return cons, cjac, chess


def fit_vertices(
    cplx, points, labels, normals, centers, *, lsq, weight=1.0, max_iter=3000, solver="newton"
) -> MeshVertices:
    """Planes fitted to their points through common vertices (private; beyond the thesis).

    Variables: vertex positions x_j and planes (n_i, d_i). Objective: the mean squared
    distance of the points to their region's plane, (1/N) sum_i sum_{p in P_i}
    (n_i . p - d_i)^2, plus ``weight`` times the mean squared displacement of the
    vertices from the least-squares vertices ``lsq`` (which pins the vertices of two
    regions along their line). Constraints: n_i . x_j = d_i for every vertex j of
    region i and |n_i|^2 = 1 - Eq. 4.12's constraints with free plane offsets, so
    every face is planar. Coordinates are centred and divided by the RMS radius s.
    Start: the proxy planes and ``lsq``; trust-constr, then Gauss-Newton steps onto
    the constraints. On failure: ``lsq`` with ``fallback=True`` and a warning.
    """
    nv = cplx.n_vertices
    n_reg = normals.shape[0]
    mu, scale, mom = _plane_moments(points, labels, n_reg)
    jj, ii, _ = _incidences(cplx, centers)
    nx = 3 * nv
    nn_off = nx
    d_off = nx + 3 * n_reg
    size = d_off + n_reg
    alpha = float(weight) / max(nv, 1)
    x_ref = (np.asarray(lsq.positions) - mu) / scale
    d0 = np.einsum("ij,ij->i", normals, (centers - mu) / scale)
    z0 = np.concatenate([x_ref.ravel(), normals.ravel(), d0])
    # y_i = (n_i, d_i) as positions in z
    y_idx = np.concatenate(
        [nn_off + 3 * np.arange(n_reg)[:, None] + np.arange(3), d_off + np.arange(n_reg)[:, None]],
        axis=1,
    )

    # scale the objective to O(1) at the start (trust-constr's merit function and
    # tolerances are absolute; the plane energy is a tiny mean squared distance)
    y0 = z0[y_idx]
    e0 = float(np.einsum("ra,rab,rb->", y0, mom, y0))
    c_obj = 1.0 / max(e0, _FIT_MIN_ENERGY)
    mom = mom * c_obj
    alpha = alpha * c_obj

    def fun(z):
        y = z[y_idx]
        my = np.einsum("rab,rb->ra", mom, y)
        dx = z[:nx] - x_ref.ravel()
        f = float(np.einsum("ra,ra->", y, my) + alpha * np.dot(dx, dx))
        g = np.zeros(size)
        g[:nx] = 2.0 * alpha * dx
        g[y_idx.ravel()] = 2.0 * my.ravel()
        return f, g

    rows_h = np.concatenate([np.arange(nx), np.repeat(y_idx, 4, axis=1).ravel()])
    cols_h = np.concatenate([np.arange(nx), np.tile(y_idx, (1, 4)).ravel()])
    vals_h = np.concatenate([np.full(nx, 2.0 * alpha), 2.0 * mom.ravel()])
    hess_obj = sparse.csr_array((vals_h, (rows_h, cols_h)), shape=(size, size))

    def hess(z):
        return hess_obj

    cons, cjac, chess = _incidence_constraints(jj, ii, nv, n_reg)
    constraint = NonlinearConstraint(cons, 0.0, 0.0, jac=cjac, hess=chess)
    z, ok, violation, n_iter, message = solve_constrained(
        fun,
        z0,
        hess,
        constraint,
        cons,
        max_iter,
        gtol=_FIT_GTOL,
        xtol=_FIT_XTOL,
        refine=lambda z: newton_kkt(z, fun, hess_obj, cons, cjac, chess),
        polish=lambda z: project_constraints(z, cons, cjac),
        newton=newton_solver(solver, fun, hess_obj, cons, cjac, chess),
    )
    if not ok:
        return _fallback(lsq, "plane fit through common vertices", violation, n_iter, message)
    x = z[:nx].reshape(nv, 3)
    nn = z[nn_off:d_off].reshape(n_reg, 3)
    norm = np.linalg.norm(nn, axis=1)
    nn = nn / norm[:, None]
    pos = x * scale + mu
    offsets = z[d_off:] / norm * scale + nn @ mu
    return MeshVertices(
        positions=pos,
        plane_normals=nn,
        plane_offsets=offsets,
        rank=np.minimum(np.bincount(jj, minlength=nv), 3).astype(np.int64),
        guarded=np.zeros(nv, dtype=bool),
        plane_residual=_residuals(pos, cplx.vertex_regions, nn, offsets),
        method="fit",
        fallback=False,
        constraint_violation=violation,
        n_iter=n_iter,
        message=message,
    )

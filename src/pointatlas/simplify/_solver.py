"""Solvers of the constrained vertex problems: Newton on the KKT system first, scipy's
trust-constr as the reference (thesis Eq. 4.12 and the plane fit through common
vertices; docs/decisions/simplify.md, "Vertex fitting")."""

from __future__ import annotations

import warnings

import numpy as np
from scipy import sparse
from scipy.optimize import minimize

from .._core.tolerances import SIMPLIFY_CONSTRAINT_TOL

__all__ = ["newton_kkt", "newton_solver", "project_constraints", "solve_constrained", "sqp"]


def solve_constrained(
    fun,
    z0,
    hess,
    constraint,
    cons,
    max_iter,
    *,
    gtol,
    xtol,
    refine=None,
    polish=None,
    newton=None,
):
    """Solve min ``fun`` (value, gradient) under ``constraint`` (= 0).

    ``newton`` (when given): Newton's method on the KKT system from ``z0`` (`sqp`),
    kept when it converges to a feasible local minimum. Otherwise (the reference
    solver) trust-constr, then the optional ``refine`` (only when trust-constr
    converged, not at its iteration limit); then ``polish``. Returns (z, ok,
    constraint violation, iterations, message).
    """
    if newton is not None:
        with one_blas_thread():
            z, converged, steps = newton(z0)
            if converged and polish is not None:
                z = polish(z)
        c = cons(z)
        violation = float(np.max(np.abs(c))) if c.size else 0.0
        if converged and np.all(np.isfinite(z)) and violation <= SIMPLIFY_CONSTRAINT_TOL:
            return z, True, violation, steps, f"Newton-KKT converged in {steps} steps"
    z, message, n_iter, violation, ok = z0, "", 0, float("inf"), False
    try:
        with warnings.catch_warnings(), one_blas_thread():
            warnings.simplefilter("ignore")  # scipy's own progress warnings
            res = minimize(
                fun,
                z0,
                jac=True,
                hess=hess,
                method="trust-constr",
                constraints=[constraint],
                options={"maxiter": int(max_iter), "gtol": gtol, "xtol": xtol},
            )
        z = res.x
        if refine is not None and res.status != 0:  # 0: iteration limit reached
            z = refine(z)
        if polish is not None:
            z = polish(z)
        c = cons(z)
        violation = float(np.max(np.abs(c))) if c.size else 0.0
        n_iter = int(res.nit)
        message = str(res.message)
        ok = bool(np.all(np.isfinite(z))) and violation <= SIMPLIFY_CONSTRAINT_TOL
    except (ValueError, np.linalg.LinAlgError, ArithmeticError) as exc:
        message = f"optimizer error: {exc}"
    return z, ok, violation, n_iter, message


def newton_solver(solver, fun, hess_obj, cons, cjac, chess):
    """``solver="newton"``: `sqp` first (trust-constr only when it does not converge);
    ``"trust-constr"``: the reference solver alone (None)."""
    if solver == "trust-constr":
        return None
    if solver != "newton":
        raise ValueError(f"solver must be 'newton' or 'trust-constr'; got {solver!r}")
    return lambda z: sqp(z, fun, hess_obj, cons, cjac, chess)


def project_constraints(z, cons, cjac, n_steps=8, tol=1e-15):
    """Gauss-Newton min-norm steps z <- z - J^+ c(z) onto {c = 0} (a feasibility polish)."""
    for _ in range(n_steps):
        c = cons(z)
        if not c.size or np.max(np.abs(c)) <= tol:
            break
        step = min_norm_step(cjac(z), c)
        z_new = z - step
        if not np.all(np.isfinite(z_new)):
            break
        if np.max(np.abs(cons(z_new))) >= np.max(np.abs(c)):
            break
        z = z_new
    return z


def one_blas_thread():
    """Limit BLAS to one thread around the many small dense solves (on a busy 2-core
    box the threads cost more than they give)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


#: Newton steps of `sqp` at most, and its KKT residual tolerance (scaled problem)
_SQP_MAX_STEPS = 50
_SQP_TOL = 1e-11
#: size up to which `sqp` checks that its stationary point is a minimum
_SQP_CHECK_SIZE = 1500


def sqp(z, fun, hess_obj, cons, cjac, chess):
    """Newton's method on the KKT conditions of min f(z) s.t. c(z) = 0 from ``z``
    (private): the fast solver of Eq. 4.12 and of the plane fit.

    The problem's structure makes this cheap: the objective is quadratic (constant
    sparse Hessian) and the constraints bilinear (plane . vertex) or quadratic
    (|n|^2 = 1), so the Lagrangian's Hessian and the constraint Jacobian are known in
    closed form and sparse, and the start (least-squares vertices, proxy planes) is
    near the optimum. Steps [[W, J^T], [J, 0]] [dz, lam] = -[grad f, c], halved
    until the squared KKT residual |grad f + J^T lam|^2 + |c|^2 drops. Returns (z,
    converged, steps); converged means a KKT residual (largest entry) of at most
    ``_SQP_TOL`` and, up to ``_SQP_CHECK_SIZE`` unknowns, a Hessian of the
    Lagrangian positive definite on the constraints' tangent space (a minimum, not
    a saddle).
    """
    size = z.size

    def kkt(z, lam):
        g, jac, c = fun(z)[1], cjac(z), cons(z)
        return np.concatenate([g + jac.T @ lam, c]), g, jac, c

    g = fun(z)[1]
    jac = cjac(z)
    lam = _solve_kkt(sparse.csr_array(jac.T), -g)
    if lam is None or not np.all(np.isfinite(lam)):  # pragma: no cover - defensive
        return z, False, 0
    resid, g, jac, c = kkt(z, lam)
    merit = float(resid @ resid)
    steps = 0
    while steps < _SQP_MAX_STEPS and np.max(np.abs(resid)) > _SQP_TOL * 1e-3:
        w = sparse.csr_array(hess_obj + chess(z, lam))
        system = sparse.bmat([[w, jac.T], [jac, None]], format="csr")
        sol = _solve_kkt(system, -np.concatenate([g, c]))
        if sol is None or not np.all(np.isfinite(sol)):
            break
        dz, dlam = sol[:size], sol[size:] - lam
        alpha, taken = 1.0, False
        while alpha >= 1.0 / 64.0:
            z_new, lam_new = z + alpha * dz, lam + alpha * dlam
            out = kkt(z_new, lam_new)
            m_new = float(out[0] @ out[0])
            if np.isfinite(m_new) and m_new < merit:
                taken = True
                break
            alpha *= 0.5
        if not taken:
            break
        z, lam, merit = z_new, lam_new, m_new
        resid, g, jac, c = out
        steps += 1
    res = float(np.max(np.abs(resid)))
    if not res <= _SQP_TOL:
        return z, False, steps
    if size <= _SQP_CHECK_SIZE:
        dense = jac.toarray()
        _, sv, vt = np.linalg.svd(dense)
        rank = int((sv > 1e-10 * max(sv.max(initial=0.0), 1e-300)).sum())
        basis = vt[rank:].T  # tangent space of the constraints
        if basis.shape[1]:
            w = sparse.csr_array(hess_obj + chess(z, lam)).toarray()
            reduced = basis.T @ w @ basis
            eig = np.linalg.eigvalsh(0.5 * (reduced + reduced.T))
            if eig.min() < -1e-9 * max(float(np.abs(eig).max()), 1.0):
                return z, False, steps
    return z, True, steps


#: Newton steps on the KKT system after trust-constr (dense solves up to this size)
_KKT_MAX_STEPS = 10
_KKT_DENSE_SIZE = 2000
#: a sparse LU solution of a square KKT system is kept when its residual is at most
#: this share of the right-hand side (else the system is taken for singular)
_KKT_RESIDUAL = 1e-10


def _solve_kkt(mat, rhs):
    """Solution of a KKT system (least squares where it is singular); None on failure.

    The systems are sparse (a few entries per row), so a square one (the Newton
    step) goes to sparse LU (`spsolve`) first, kept when its residual is at round-off
    (`_KKT_RESIDUAL` of the right-hand side); a singular or inaccurate one, and the
    rectangular one (the multipliers' least squares, J^T lam = -g), to dense least
    squares up to `_KKT_DENSE_SIZE` rows and columns, else LSMR. Dense least squares
    on every step took 6.2 of torus_coarse's 39 profiled seconds (73 solves of
    up to 2,000 unknowns). The rectangular case once went to `spsolve` and stopped a
    134,345-point scan with "matrix must be square (has shape (2750, 1936))".
    """
    from scipy.sparse.linalg import lsmr, spsolve

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a singular system: MatrixRankWarning, NaNs
        if mat.shape[0] == mat.shape[1]:
            sol = spsolve(sparse.csc_array(mat), rhs)
            scale = float(np.max(np.abs(rhs))) if rhs.size else 0.0
            if np.all(np.isfinite(sol)) and np.max(
                np.abs(mat @ sol - rhs), initial=0.0
            ) <= _KKT_RESIDUAL * max(scale, 1e-300):
                return sol
        if max(mat.shape) <= _KKT_DENSE_SIZE:
            return np.linalg.lstsq(mat.toarray(), rhs, rcond=None)[0]
        sol = lsmr(mat, rhs, atol=1e-15, btol=1e-15, maxiter=20 * max(mat.shape))[0]
    return sol if np.all(np.isfinite(sol)) else None


def min_norm_step(jac, c) -> np.ndarray:
    """The least-norm step J^+ c: dense least squares up to 1,500 unknowns, else
    sparse LSQR."""
    if jac.shape[1] <= 1500:
        return np.linalg.lstsq(jac.toarray(), c, rcond=None)[0]
    from scipy.sparse.linalg import lsqr

    return lsqr(jac, c, atol=1e-16, btol=1e-16, iter_lim=10 * jac.shape[1])[0]


def newton_kkt(z, fun, hess_obj, cons, cjac, chess):
    """Newton steps on the first-order conditions of min f(z) s.t. c(z) = 0 from a
    near-optimal ``z`` (private).

    trust-constr stops where its tolerances say, which depends on the path it took
    (on round-off in the input); Newton's method on grad f + J^T lam = 0, c = 0
    converges quadratically to the nearby stationary point itself, so the result is
    the solution to round-off, whatever the path (translation and scale invariance,
    docs/decisions/simplify.md). Steps are kept while the KKT residual decreases.
    """
    size = z.size

    def residual(z, lam):
        g = fun(z)[1]
        jac = cjac(z)
        c = cons(z)
        return max(float(np.max(np.abs(g + jac.T @ lam))), float(np.max(np.abs(c)))), g, jac, c

    g = fun(z)[1]
    jac = cjac(z)
    lam = _solve_kkt(sparse.csr_array(jac.T), -g)
    if lam is None or not np.all(np.isfinite(lam)):  # pragma: no cover - defensive
        return z
    res, g, jac, c = residual(z, lam)
    for _ in range(_KKT_MAX_STEPS):
        w = sparse.csr_array(hess_obj + chess(z, lam))
        kkt = sparse.bmat([[w, jac.T], [jac, None]], format="csr")
        sol = _solve_kkt(kkt, -np.concatenate([g, c]))
        if sol is None or not np.all(np.isfinite(sol)):
            break
        z_new, lam_new = z + sol[:size], sol[size:]
        res_new, g_new, jac_new, c_new = residual(z_new, lam_new)
        if not res_new < res:
            break
        z, lam, res, g, jac, c = z_new, lam_new, res_new, g_new, jac_new, c_new
    return z

"""The fast vertex solver (Newton on the KKT system of Eq. 4.12 and of the plane fit)
gives the reference solver's optimum (scipy trust-constr, kept as ``solver=
"trust-constr"``) where both converge, and reports its constraint violation."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import pointatlas.simplify._solver as solver_module
import pointatlas.simplify._vertices as vertices_module
from pointatlas import synth
from pointatlas.simplify import simplify_points

CASES = {
    "cube": (synth.cube(6), {"max_angle": 0.3}),
    "dodecahedron": (synth.dodecahedron(), {}),
    "octahedron": (synth.octahedron(), {}),
}


def _run(monkeypatch, model, options, method, solver):
    real = solver_module.newton_solver
    calls = []
    real_sqp = solver_module.sqp

    def spy(*args):
        out = real_sqp(*args)
        calls.append(out[1])
        return out

    monkeypatch.setattr(solver_module, "sqp", spy)
    monkeypatch.setattr(
        vertices_module, "newton_solver", lambda _solver, *rest: real(solver, *rest)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no fallback to plane intersection
        r = simplify_points(
            model.vertices, model.normals, vertices=method, path="thesis", **options
        )
    monkeypatch.undo()
    return r.mesh, calls


@pytest.mark.parametrize("method", ["fit", "optimize"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_newton_solver_equals_the_reference_solver(monkeypatch, name, method):
    model, options = CASES[name]
    fast, calls = _run(monkeypatch, model, options, method, "newton")
    ref, ref_calls = _run(monkeypatch, model, options, method, "trust-constr")
    assert ref_calls == [] and len(calls) >= 1
    if method == "fit":
        # from the least-squares vertices and the proxy planes Newton converges here:
        # trust-constr was not needed
        assert all(calls)
    # (Eq. 4.12 starts from the regions' barycentres, farther away: where Newton does
    # not converge to a minimum, the reference solver takes over)
    assert fast.vertex_method == ref.vertex_method == method
    scale = float(np.linalg.norm(np.ptp(model.vertices, axis=0)))
    np.testing.assert_allclose(fast.vertices, ref.vertices, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(fast.plane_normals, ref.plane_normals, rtol=0, atol=1e-9)
    # the constraint violation is reported (and tiny)
    assert 0.0 <= fast.constraint_violation <= 1e-12
    assert fast.summary()["constraint_violation"] == fast.constraint_violation


def test_unknown_solver_is_rejected():
    with pytest.raises(ValueError, match="solver must be"):
        solver_module.newton_solver("fast", None, None, None, None, None)


@pytest.mark.parametrize("shape", [(2750, 1936), (1936, 2750), (2400, 2400)])
def test_large_kkt_systems_are_solved_sparse_as_their_least_squares_solution(shape):
    """The sparse branch (systems over 2,000 rows or columns) of both shapes: the
    rectangular one stopped a 134,345-point scan with "matrix must be square"."""
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    from pointatlas.simplify._solver import _solve_kkt, min_norm_step

    rng = np.random.default_rng(0)
    mat = sparse.random(*shape, density=0.003, random_state=1, format="csc")
    mat = mat + sparse.eye(*shape, format="csc")  # full rank
    rhs = rng.normal(size=shape[0])
    # the unique least-squares (more rows) or least-norm (more columns) solution, by
    # the normal equations (a dense lstsq of 2,750 x 1,936 took 24 CPU-s of the suite)
    if shape[0] == shape[1]:
        want = spsolve(mat, rhs)
    elif shape[0] > shape[1]:
        want = spsolve((mat.T @ mat).tocsc(), mat.T @ rhs)
    else:
        want = mat.T @ spsolve((mat @ mat.T).tocsc(), rhs)
    np.testing.assert_allclose(_solve_kkt(mat, rhs), want, rtol=1e-6, atol=1e-9)
    if shape[0] < shape[1]:  # a Jacobian with more unknowns than constraints
        np.testing.assert_allclose(min_norm_step(mat, rhs), want, rtol=1e-6, atol=1e-9)


def test_square_kkt_systems_go_to_sparse_lu_and_singular_ones_to_least_squares():
    """Every square KKT system is tried by sparse LU first (dense least squares on
    every Newton step was a third of a 2,304-point run); a singular one (a constraint
    given twice: J has a zero singular value) gets the least-squares solution."""
    from scipy import sparse

    from pointatlas.simplify._solver import _solve_kkt

    rng = np.random.default_rng(3)
    n, m = 40, 12
    w = sparse.random(n, n, density=0.1, random_state=2, format="csr")
    w = w @ w.T + sparse.eye(n)  # positive definite Hessian
    jac = sparse.random(m, n, density=0.2, random_state=4, format="csr") + sparse.eye(m, n)
    kkt = sparse.bmat([[w, jac.T], [jac, None]], format="csr")
    rhs = rng.normal(size=n + m)
    np.testing.assert_allclose(
        _solve_kkt(kkt, rhs), np.linalg.solve(kkt.toarray(), rhs), atol=1e-10
    )
    twice = sparse.vstack([jac, jac[:1]], format="csr")
    singular = sparse.bmat([[w, twice.T], [twice, None]], format="csr")
    rhs = np.concatenate([rhs, rhs[n : n + 1]])  # consistent: the repeated row's value
    got = _solve_kkt(singular, rhs)
    want = np.linalg.lstsq(singular.toarray(), rhs, rcond=None)[0]
    np.testing.assert_allclose(got, want, atol=1e-9)
    np.testing.assert_allclose(singular @ got, rhs, atol=1e-9)

"""Newton on the natural map and on Fischer–Burmeister's equation: the same solver-level
properties as on Alart–Curnier's (tests/test_newton.py) — manufactured exact solutions under
every policy, asymmetric and frictionless W, global native = condensed, dense = SuperLU."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.problem import FrictionContactProblem, GlobalFrictionContactProblem

EQUATIONS = ["natural_map", "fischer_burmeister"]
#: (policy, structure): plain steps have no proximal term, so on a rank-deficient W
#: (``redundant``) their matrix is singular where contacts stick and only the shift of
#: PLAIN_REGULARIZATION is left (formulations/newton.md §13); the proximal policies are held
#: to both structures
CASES = [(policy, structure) for policy in ("prox", "plain", "hybrid", "prox_error")
         for structure in ("tree", "redundant") if (policy, structure) != ("plain", "redundant")]


@pytest.mark.parametrize("equation", EQUATIONS)
@pytest.mark.parametrize("policy,structure", CASES)
@pytest.mark.parametrize("dim", [2, 3])
def test_manufactured_exact_solutions(dim, structure, policy, equation):
    p = manufactured(30, dim, 0.5, structure=structure, seed=11)
    res = socp_cd.solve(p, "newton", tol=1e-10, equation=equation, policy=policy)
    assert res.converged and socp_cd.error(p, res.r) <= 1e-10
    assert res.info["equation"] == equation
    if structure == "tree":                    # u is unique: the exact one
        u_star = p.solution.u
        assert np.linalg.norm(res.u - u_star) <= 1e-6 * max(1.0, np.linalg.norm(u_star))


@pytest.mark.parametrize("equation", EQUATIONS)
@pytest.mark.parametrize("dim", [2, 3])
def test_asymmetric_and_frictionless_w(dim, equation):
    base = manufactured(20, dim, 0.5, seed=4)
    rng = np.random.default_rng(4)
    S = rng.normal(size=(base.m, base.m))
    W = base.W.toarray() + 0.05 * np.abs(base.W).max() * (S - S.T)
    p = FrictionContactProblem(W, base.solution.u - W @ base.solution.r, base.mu, dim)
    assert p.asymmetry > 1e-3
    res = socp_cd.solve(p, "newton", tol=1e-10, equation=equation)
    assert res.converged and socp_cd.error(p, res.r) <= 1e-10
    f = manufactured(20, dim, 0.0, seed=6)
    res = socp_cd.solve(f, "newton", tol=1e-10, equation=equation)
    assert res.converged and socp_cd.error(f, res.r) <= 1e-10


@pytest.mark.parametrize("equation", EQUATIONS)
@pytest.mark.parametrize("dim", [2, 3])
def test_global_native_and_condensed_agree(dim, equation):
    rng = np.random.default_rng(2)
    n, nc = 12, 5
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n)
    H = rng.normal(size=(n, nc * dim))
    w = np.tile(np.r_[0.1, np.zeros(dim - 1)], nc)
    g = GlobalFrictionContactProblem(sp.csr_matrix(M), sp.csr_matrix(H), rng.normal(size=n), w,
                                     0.4, dim)
    native = socp_cd.solve(g, "newton", tol=1e-10, global_mode="native", equation=equation)
    cond = socp_cd.solve(g, "newton", tol=1e-10, global_mode="condense", equation=equation)
    assert native.converged and cond.converged
    assert native.info["linear_solver"] == "splu-global"
    np.testing.assert_allclose(native.u, cond.u, atol=1e-7 * max(1.0, np.linalg.norm(cond.u)))


@pytest.mark.parametrize("equation", EQUATIONS)
def test_the_same_run_on_the_dense_and_sparse_matrices(equation):
    p = manufactured(40, 3, 0.5, seed=8)
    a = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="dense", equation=equation)
    b = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="splu", equation=equation)
    assert a.converged and b.converged
    np.testing.assert_allclose(a.u, b.u, atol=1e-8)

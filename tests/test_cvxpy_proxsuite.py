"""cvxpy reference models, ProxQP polyhedral laws and the faceted cone.

Expectations come from hand-derived solutions, an independent enumeration of
the frictionless LCP, NNLS projections (Moreau's decomposition) and the
direct Clarabel path — never from the code under test.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest
import scipy.optimize as so

from socp_cd import read_problem
from socp_cd.data import shared_problems_dir
from socp_cd.errors import InvalidProblemError, UnsupportedError
from socp_cd.problem import FrictionContactProblem
from socp_cd.faceted import (cone_matrix, faceted_error, project_faceted_cone)
from socp_cd.solvers.registry import solve, solvers

pytest.importorskip("cvxpy")
pytest.importorskip("proxsuite")

HAS_CLARABEL = "clarabel" in solvers()
needs_clarabel = pytest.mark.skipif(not HAS_CLARABEL, reason="clarabel_backend not available yet")


# ----------------------------------------------------------------- fixtures
def synthetic(nc, dim, seed=0, rank_deficient=False, mu_zero=True):
    """Random Delassus ``W = HᵀH/n`` (singular when ``rank_deficient``)."""
    rng = np.random.default_rng(seed)
    m = nc * dim
    n = m // 2 if rank_deficient else m + 3
    H = rng.standard_normal((n, m))
    q = rng.standard_normal(m)
    q[::dim] -= 1.0                      # mostly approaching contacts
    mu = rng.uniform(0.1, 0.6, nc)
    if mu_zero:
        mu[0] = 0.0
    return FrictionContactProblem(H.T @ H / n, q, mu, dim, name=f"synthetic{nc}x{dim}")


def objective(problem, r):
    """½ rᵀ W_s r + qᵀ r (= ½ rᵀ W r + qᵀ r), computed independently."""
    return 0.5 * r @ (problem.W @ r) + problem.q @ r


def rel(a, b):
    return np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300)


def real_problem(name):
    d = shared_problems_dir()
    if d is None or not (d / name).exists():
        pytest.skip(f"shared data not found: {name}")
    return read_problem(d / name)


# ------------------------------------------- cvxpy == direct Clarabel path
@needs_clarabel
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("nc,rank_deficient", [(5, False), (40, True)])
@pytest.mark.parametrize("formulation", ["associated", "tresca", "frictionless"])
def test_cvxpy_matches_direct_clarabel_single_programs(formulation, nc, rank_deficient, dim):
    P = synthetic(nc, dim, seed=nc + dim, rank_deficient=rank_deficient)
    kw = {"threshold": np.linspace(0.05, 0.5, nc)} if formulation == "tresca" else {}
    a = solve(P, "cvxpy", formulation, tol=1e-8, **kw)
    b = solve(P, "clarabel", formulation, tol=1e-8, polish=None, **kw)   # same algorithm
    fa, fb = objective(P, a.r), objective(P, b.r)
    assert abs(fa - fb) <= 1e-8 * max(1.0, abs(fb))
    assert rel(a.u, b.u) <= 1e-5          # u is unique even when W is singular
    assert a.error <= 1e-5 and b.error <= 1e-5
    retry = a.info.get("retry")
    if retry is None or retry["kept"] == "first":
        assert a.info["cvxpy_status"] == "optimal"
    else:   # the dispatcher refuted cvxpy's claim and kept its better retry at a tighter tol
        assert a.info["cvxpy_status"] in ("optimal", "optimal_inaccurate")
        assert retry["retry_error"] < retry["first_error"]


@needs_clarabel
@pytest.mark.parametrize("dim,tol", [(2, 1e-7), (3, 1e-5)])
def test_cvxpy_matches_direct_clarabel_coulomb(dim, tol):
    P = synthetic(12, dim, seed=3)
    a = solve(P, "cvxpy", "coulomb", tol=tol, polish=None)
    b = solve(P, "clarabel", "coulomb", tol=tol, polish=None)
    assert a.error <= 10 * tol and b.error <= 10 * tol
    assert rel(a.u, b.u) <= 1e-4
    assert a.iterations >= 1 and a.info["inner_iterations"] >= a.iterations


@needs_clarabel
@pytest.mark.parametrize("name", ["FC3D_Example1.dat", "Rover1039.dat"])
@pytest.mark.parametrize("formulation", ["associated", "coulomb", "frictionless"])
def test_cvxpy_matches_direct_clarabel_real(name, formulation):
    P = real_problem(name)
    same = {"polish": None} if formulation == "coulomb" else {}     # same algorithm, no polish
    a = solve(P, "cvxpy", formulation, tol=1e-7, **same)
    b = solve(P, "clarabel", formulation, tol=1e-7, polish=None)
    assert rel(a.u, b.u) <= 1e-5
    assert abs(objective(P, a.r) - objective(P, b.r)) <= 1e-7 * max(1.0, abs(objective(P, b.r)))
    assert a.error <= 1e-5


@needs_clarabel
@pytest.mark.parametrize("dim", [2, 3])
def test_cvxpy_coulomb_default_reaches_tolerance(dim):
    # with its default Newton polish the cvxpy path reaches the exact law, as the direct path does
    P = synthetic(12, dim, seed=3)
    a = solve(P, "cvxpy", "coulomb", tol=1e-8)
    b = solve(P, "clarabel", "coulomb", tol=1e-8)
    assert a.converged and a.error <= 1e-8
    assert rel(a.u, b.u) <= 1e-6


def test_cvxpy_hand_solution_single_contact():
    # W = I, q = (-1, 3, 4), mu = 0.5: sliding, r_N = 1, r_T = -0.5 * (3, 4)/5
    P = FrictionContactProblem(np.eye(3), [-1.0, 3.0, 4.0], 0.5, 3)
    res = solve(P, "cvxpy", "coulomb", tol=1e-8, polish=None)
    assert np.allclose(res.r, [1.0, -0.3, -0.4], atol=1e-6)
    res = solve(P, "cvxpy", "tresca", tol=1e-8, threshold=0.2)
    assert np.allclose(res.r, [1.0, -0.12, -0.16], atol=1e-7)


def test_cvxpy_status_mapping_iteration_cap():
    P = synthetic(20, 3, seed=1)
    res = solve(P, "cvxpy", "associated", tol=1e-8, inner_settings={"max_iter": 1})
    assert res.info["cvxpy_status"] == "user_limit"
    assert res.status == "max_iter" and not res.converged


# ------------------------------------------------ proxsuite: frictionless
def lcp_by_enumeration(M, q):
    """All solutions of ``0 <= z ⊥ Mz + q >= 0`` by active-set enumeration."""
    n = len(q)
    sols = []
    for k in range(n + 1):
        for S in itertools.combinations(range(n), k):
            S = list(S)
            z = np.zeros(n)
            if S:
                z[S] = np.linalg.solve(M[np.ix_(S, S)], -q[S])
            w = M @ z + q
            if np.all(z >= -1e-12) and np.all(w >= -1e-12):
                sols.append(z)
    return sols


@pytest.mark.parametrize("case", ["one_2d", "two_3d_one_active", "two_3d_both_active", "skew_3d"])
def test_proxsuite_frictionless_equals_exact_lcp(case):
    if case == "one_2d":
        W = np.array([[2.0, 0.5], [0.5, 1.0]])
        q = np.array([-1.0, 0.3])
        P = FrictionContactProblem(W, q, 0.3, 2)
        expected_rN = np.array([0.5])            # r_N = -q_N / W_NN
    else:
        rng = np.random.default_rng(7)
        B = rng.standard_normal((6, 6))
        W = B @ B.T / 6 + np.eye(6)
        W[0, 0], W[3, 3], W[0, 3], W[3, 0] = 2.0, 2.0, 1.0, 1.0
        if case == "skew_3d":
            S = rng.standard_normal((6, 6)) * 0.05
            W = W + (S - S.T)
        q = rng.standard_normal(6)
        q[[0, 3]] = {"two_3d_one_active": (-1.0, 1.0), "two_3d_both_active": (-1.0, -1.0),
                     "skew_3d": (-1.0, -0.5)}[case]
        P = FrictionContactProblem(W, q, 0.4, 3)
        sols = lcp_by_enumeration(W[np.ix_([0, 3], [0, 3])], q[[0, 3]])
        assert len(sols) == 1                    # W_NN is a P-matrix here
        expected_rN = sols[0]
        if case == "two_3d_one_active":
            assert np.allclose(expected_rN, [0.5, 0.0])
        if case == "two_3d_both_active":
            assert np.allclose(expected_rN, [1 / 3, 1 / 3])
    res = solve(P, "proxsuite", "frictionless", tol=1e-10)
    R = P.reshape(res.r)
    assert np.allclose(R[:, 0], expected_rN, atol=1e-8)
    assert np.all(R[:, 1:] == 0.0)
    assert res.converged
    if case == "skew_3d":
        assert res.info["skew_splitting"] and res.iterations > 1


@needs_clarabel
@pytest.mark.parametrize("dim", [2, 3])
def test_proxsuite_frictionless_equals_clarabel_and_cvxpy(dim):
    P = synthetic(30, dim, seed=11, rank_deficient=True)
    px = solve(P, "proxsuite", "frictionless", tol=1e-9)
    cl = solve(P, "clarabel", "frictionless", tol=1e-9)
    cv = solve(P, "cvxpy", "frictionless", tol=1e-9)
    assert px.converged
    assert rel(px.u, cl.u) <= 1e-6 and rel(px.u, cv.u) <= 1e-6
    assert abs(objective(P, px.r) - objective(P, cl.r)) <= 1e-9 * max(1, abs(objective(P, cl.r)))


def test_proxsuite_status_mapping_iteration_cap():
    P = synthetic(30, 3, seed=2)
    res = solve(P, "proxsuite", "faceted", tol=1e-10, inner_settings={"max_iter": 1})
    assert res.info["proxqp_status"] == "PROXQP_MAX_ITER_REACHED"
    assert res.status == "max_iter" and not res.converged


# ----------------------------------------------------- proxsuite: 2D laws
@pytest.mark.parametrize("q,expected", [
    # W = [[1, .2], [.2, 1]], mu = 0.5.  Sliding: u_N = 0, r_T = -mu r_N
    # -> 0.9 r_N = 1, u_T = 2 - 1/3 > 0.  Sticking: u = 0 -> r = W^-1 (1, -0.1), |r_T| <= mu r_N
    ((-1.0, 2.0), (1 / 0.9, -0.5 / 0.9)),
    ((-1.0, 0.1), tuple(np.linalg.solve([[1.0, 0.2], [0.2, 1.0]], [1.0, -0.1]))),
])
def test_proxsuite_coulomb_2d_hand_solution(q, expected):
    P = FrictionContactProblem([[1.0, 0.2], [0.2, 1.0]], q, 0.5, 2)
    res = solve(P, "proxsuite", "coulomb", tol=1e-10)
    assert res.converged
    assert np.allclose(res.r, expected, atol=1e-8)


def test_proxsuite_coulomb_2d_matches_reference():
    P = synthetic(40, 2, seed=5)
    px = solve(P, "proxsuite", "coulomb", tol=1e-8)
    assert px.converged
    ref_name = "nsgs" if "nsgs" in solvers() and "coulomb" in solvers()["nsgs"]["formulations"] \
        else ("clarabel" if HAS_CLARABEL else None)
    if ref_name is None:
        pytest.skip("no reference Coulomb solver registered")
    ref = solve(P, ref_name, "coulomb", tol=1e-8)
    assert ref.converged
    assert rel(px.u, ref.u) <= 1e-5


@needs_clarabel
@pytest.mark.parametrize("formulation", ["associated", "tresca"])
def test_proxsuite_2d_single_qps_match_clarabel(formulation):
    P = synthetic(40, 2, seed=8)
    kw = {"threshold": 0.3} if formulation == "tresca" else {}
    px = solve(P, "proxsuite", formulation, tol=1e-9, **kw)
    cl = solve(P, "clarabel", formulation, tol=1e-9, **kw)
    assert px.converged
    assert rel(px.u, cl.u) <= 1e-5
    assert abs(objective(P, px.r) - objective(P, cl.r)) <= 1e-8 * max(1, abs(objective(P, cl.r)))


# ------------------------------------------------------------ faceted cone
def nnls_projection(x, C_rows):
    """P_K(x) for K = {C r <= 0}: x minus its projection on the polar cone cone(C_rows)."""
    lam, _ = so.nnls(C_rows.T, x)
    return x - C_rows.T @ lam


@pytest.mark.parametrize("placement", ["inscribed", "circumscribed"])
@pytest.mark.parametrize("nf", [3, 5, 8, 16])
def test_faceted_projection_matches_nnls(nf, placement):
    rng = np.random.default_rng(nf)
    nc = 40
    mu = rng.uniform(0.0, 1.5, nc)
    mu[:3] = 0.0
    X = rng.standard_normal((nc, 3)) * rng.uniform(0.1, 5.0, (nc, 1))
    P = project_faceted_cone(X, mu, 3, nf, placement)
    C = cone_matrix(mu, 3, nf, placement).toarray()
    rows = 1 + nf
    for i in range(nc):
        Ci = C[i * rows:(i + 1) * rows, 3 * i:3 * i + 3]
        assert np.allclose(P[i], nnls_projection(X[i], Ci), atol=1e-9 * (1 + np.abs(X[i]).max()))


def test_faceted_cone_geometry():
    mu, nf = np.array([0.7]), 8
    C = cone_matrix(mu, 3, nf, "inscribed").toarray()
    # inscribed: vertices (1, mu cos phi_k, mu sin phi_k), phi_k = 2 pi k / nf, on two facets
    phi = 2 * np.pi * np.arange(nf) / nf
    V = np.column_stack([np.ones(nf), 0.7 * np.cos(phi), 0.7 * np.sin(phi)])
    S = C @ V.T
    assert np.allclose(S.max(axis=0), 0.0, atol=1e-14)
    assert np.all((np.abs(S) < 1e-14).sum(axis=0) == 2)
    # circumscribed: the friction circle touches each facet at its midpoint
    C = cone_matrix(mu, 3, nf, "circumscribed").toarray()
    th = phi + np.pi / nf
    M = np.column_stack([np.ones(nf), 0.7 * np.cos(th), 0.7 * np.sin(th)])
    assert np.allclose((C @ M.T).max(axis=0), 0.0, atol=1e-14)
    # 2D: exactly the Coulomb wedge |r_T| <= mu r_N (facet count ignored)
    C2 = cone_matrix([0.5], 2, 8).toarray()
    assert np.allclose(C2, [[-1, 0], [-0.5, 1], [-0.5, -1]])


def test_faceted_2d_is_associated():
    P = synthetic(30, 2, seed=4)
    f = solve(P, "proxsuite", "faceted", tol=1e-9, facets=5)
    a = solve(P, "proxsuite", "associated", tol=1e-9)
    assert f.converged and np.allclose(f.r, a.r, atol=1e-9)
    # the faceted residual in 2D is the associated residual
    from socp_cd.laws import associated_error
    # the backend's residual is in the balanced units it saw (socp_cd.solvers.scaling)
    from socp_cd.solvers.scaling import balance
    sc = balance(P)
    assert f.info["law_residual"] == pytest.approx(
        associated_error(sc.problem(P), f.r / sc.a), rel=1e-9, abs=1e-15)
    assert f.error == pytest.approx(associated_error(P, f.r), rel=1e-12, abs=1e-15)


@needs_clarabel
def test_faceted_converges_to_associated_as_facets_increase():
    P = synthetic(15, 3, seed=9, mu_zero=False)
    assoc = solve(P, "clarabel", "associated", tol=1e-9)
    f_assoc = objective(P, assoc.r)
    nfs = [4, 8, 16, 32, 64]
    f_in, err_u = [], []
    for nf in nfs:
        ins = solve(P, "proxsuite", "faceted", tol=1e-10, facets=nf)
        cir = solve(P, "proxsuite", "faceted", tol=1e-10, facets=nf, placement="circumscribed")
        assert ins.converged and cir.converged
        assert ins.info["law_residual"] <= 1e-10
        # K_circ ⊃ K ⊃ K_in: the optimal values are sandwiched
        assert objective(P, cir.r) <= f_assoc + 1e-8 and f_assoc <= objective(P, ins.r) + 1e-8
        f_in.append(objective(P, ins.r))
        err_u.append(rel(ins.u, assoc.u))
    # nested inscribed polygons (vertices at 2 pi k / nf): optimal value nonincreasing
    assert all(b <= a + 1e-10 for a, b in zip(f_in, f_in[1:]))
    # on this fixed case the velocity error decreases with nf, about like 1/nf (the
    # sliding directions snap to facet normals), the objective gap about like 1/nf^2
    assert all(b < a for a, b in zip(err_u, err_u[1:])), err_u
    assert err_u[-1] < 0.1 * err_u[0]
    assert f_in[-1] - f_assoc < 1e-2 * (f_in[0] - f_assoc)
    # inscribed reactions are admissible for the exact cone
    assert faceted_error(P, ins.r, None, 64) <= 1e-10


# --------------------------------------------------------- unsupported
@pytest.mark.parametrize("solver,formulation,dim", [
    ("proxsuite", "coulomb", 3), ("proxsuite", "associated", 3), ("proxsuite", "tresca", 3),
    ("cvxpy", "faceted", 3),
])
def test_unsupported_combinations(solver, formulation, dim):
    P = synthetic(3, dim)
    kw = {"threshold": 0.1} if formulation == "tresca" else {}
    with pytest.raises(UnsupportedError, match=formulation):
        solve(P, solver, formulation, **kw)


def test_proxsuite_3d_coulomb_message_points_to_alternatives():
    with pytest.raises(UnsupportedError, match="faceted"):
        solve(synthetic(2, 3), "proxsuite", "coulomb")


@pytest.mark.parametrize("bad", [{"facets": 2}, {"facets": 4.5}, {"placement": "middle"}])
def test_faceted_invalid_options(bad):
    with pytest.raises(InvalidProblemError):
        solve(synthetic(2, 3), "proxsuite", "faceted", **bad)

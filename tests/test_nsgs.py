"""Tests of the reference NSGS backend (``solver="nsgs"``).

Single-contact problems are built backwards from a hand-chosen solution
(``q = u* - W r*``), so the expected ``r*`` and ``u*`` are known exactly.
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla

import socp_cd
from socp_cd import FrictionContactProblem, fenchel_young_gap, solve
from socp_cd.data import shared_problems_dir
from socp_cd.residuals import feasibility

from _cases import coupled_pair

TOL = 1e-10


def _check_law(problem, r, atol=1e-9):
    """Feasibility and a vanishing Fenchel–Young gap (independent of the solver)."""
    u = problem.velocity(r)
    feas = feasibility(problem, r, u)
    assert feas["cone"] <= atol
    assert feas["normal_velocity"] <= atol
    gap = fenchel_young_gap(r, u, problem.mu, problem.dim)
    assert np.max(np.abs(gap)) <= atol


# ----------------------------------------------------------------------------- 2D cases
W2 = np.array([[2.0, 0.5], [0.5, 1.0]])
MU2 = 0.5
CASES_2D = {
    # name: (r*, u*) with q = u* - W r*
    "separation": (np.array([0.0, 0.0]), np.array([1.0, 3.0])),
    "stick": (np.array([1.0, 0.2]), np.array([0.0, 0.0])),
    "slide_forward": (np.array([1.0, -0.5]), np.array([0.0, 1.0])),     # u_T > 0, r_T = -mu r_N
    "slide_backward": (np.array([1.0, 0.5]), np.array([0.0, -2.0])),    # u_T < 0, r_T = +mu r_N
}


@pytest.mark.parametrize("local_solver", ["exact", "ac_newton", "projection"])
@pytest.mark.parametrize("case", sorted(CASES_2D))
def test_single_contact_2d_cases(case, local_solver):
    r_star, u_star = CASES_2D[case]
    q = u_star - W2 @ r_star
    p = FrictionContactProblem(W2, q, MU2, dim=2)
    res = solve(p, "nsgs", tol=TOL, max_iter=50, local_solver=local_solver)
    assert res.converged, res
    np.testing.assert_allclose(res.r, r_star, atol=1e-9)
    np.testing.assert_allclose(res.u, u_star, atol=1e-9)
    _check_law(p, res.r)


@pytest.mark.parametrize("case", ["stick", "slide_forward", "slide_backward"])
def test_single_contact_2d_nonsymmetric_block(case):
    # nonsymmetric diagonal block: the case analysis must still pick the consistent case
    W = np.array([[2.0, 0.8], [-0.3, 1.0]])
    r_star, u_star = CASES_2D[case]
    q = u_star - W @ r_star
    p = FrictionContactProblem(W, q, MU2, dim=2)
    res = solve(p, "nsgs", tol=TOL, max_iter=50, local_solver="exact")
    assert res.converged, res
    _check_law(p, res.r)
    np.testing.assert_allclose(res.u, u_star, atol=1e-9)


# ----------------------------------------------------------------------------- 3D cases
W3 = np.array([[1.0, 0.1, 0.05], [0.1, 1.2, 0.1], [0.05, 0.1, 0.9]])
MU3 = 0.5
CASES_3D = {
    "separation": (np.zeros(3), np.array([1.0, 2.0, -1.0])),
    "stick": (np.array([1.0, 0.1, -0.2]), np.zeros(3)),
    # slide: u_T = (0.6, 0.8) (unit), r_T = -mu r_N u_T/|u_T|
    "slide": (np.array([1.0, -0.3, -0.4]), np.array([0.0, 0.6, 0.8])),
}


@pytest.mark.parametrize("local_solver", ["ac_newton", "projection"])
@pytest.mark.parametrize("case", sorted(CASES_3D))
def test_single_contact_3d_cases(case, local_solver):
    r_star, u_star = CASES_3D[case]
    q = u_star - W3 @ r_star
    p = FrictionContactProblem(W3, q, MU3, dim=3)
    res = solve(p, "nsgs", tol=TOL, max_iter=50, local_solver=local_solver)
    assert res.converged, res
    np.testing.assert_allclose(res.r, r_star, atol=1e-8)
    np.testing.assert_allclose(res.u, u_star, atol=1e-8)
    _check_law(p, res.r, atol=1e-8)


# ----------------------------------------------------------------------------- multi-contact
def _random_problem(nc, dim, seed, mu=0.3, dofs_per_body=6, n_bodies=None, duplicate=0):
    """``W = H^T M^{-1} H`` with a random H and a block-diagonal SPD mass matrix."""
    rng = np.random.default_rng(seed)
    n_bodies = n_bodies or max(2, nc // 2)
    blocks = []
    for _ in range(n_bodies):
        A = rng.normal(size=(dofs_per_body, dofs_per_body))
        blocks.append(A @ A.T + dofs_per_body * np.eye(dofs_per_body))
    M = sla.block_diag(*blocks)
    n = M.shape[0]
    H = rng.normal(size=(n, dim * nc)) * (rng.random((n, dim * nc)) < 0.3)
    H[:, ::dim] += 0.5 * rng.normal(size=(n, nc))
    if duplicate:
        # the last `duplicate` contacts repeat the first ones: W singular
        H[:, dim * (nc - duplicate):] = H[:, :dim * duplicate]
    W = H.T @ np.linalg.solve(M, H)
    q = rng.normal(size=dim * nc)
    q[::dim] -= 1.0            # mostly approaching contacts
    return FrictionContactProblem(W, q, mu, dim=dim)


@pytest.mark.parametrize("dim", [2, 3])
def test_random_spd_problems_converge(dim):
    p = _random_problem(30, dim, seed=dim)
    res = solve(p, "nsgs", tol=1e-9, max_iter=20000)
    assert res.converged and res.error <= 1e-9, res
    assert socp_cd.error(p, res.r) <= 1e-9
    _check_law(p, res.r, atol=1e-6 * max(1.0, np.linalg.norm(res.r)))


def test_asymmetric_W():
    p = _random_problem(20, 3, seed=11)
    rng = np.random.default_rng(5)
    S = rng.normal(size=(p.m, p.m)) * 0.02
    p2 = p.with_(W=p.W.toarray() + (S - S.T))
    assert not p2.is_symmetric
    res = solve(p2, "nsgs", tol=1e-9, max_iter=20000)
    assert res.converged, res


def test_rank_deficient_W_u_unique():
    p = _random_problem(16, 3, seed=3, duplicate=4)
    assert p.is_rank_deficient
    a = solve(p, "nsgs", tol=1e-10, max_iter=50000)
    b = solve(p, "nsgs", tol=1e-10, max_iter=50000, ordering="shuffled", seed=7)
    assert a.converged and b.converged, (a, b)
    # u is unique, r need not be
    assert np.linalg.norm(a.u - b.u) <= 1e-6 * max(1.0, np.linalg.norm(a.u))


def test_mu_zero_is_frictionless():
    p = _random_problem(20, 3, seed=4, mu=0.0)
    res = solve(p, "nsgs", tol=1e-10, max_iter=20000)
    assert res.converged, res
    R = res.r.reshape(-1, 3)
    assert np.max(np.abs(R[:, 1:])) == 0.0
    f = solve(p.with_(mu=0.7), "nsgs", formulation="frictionless", tol=1e-10, max_iter=20000)
    assert f.converged
    np.testing.assert_allclose(f.u, res.u, atol=1e-7)


def test_tresca_single_contact_slide():
    # 2D, threshold g = 0.25: r_T = -g sign(u_T), u_N = 0
    r_star, u_star = np.array([1.0, -0.25]), np.array([0.0, 2.0])
    q = u_star - W2 @ r_star
    p = FrictionContactProblem(W2, q, MU2, dim=2)
    res = solve(p, "nsgs", formulation="tresca", threshold=0.25, tol=TOL, max_iter=50)
    assert res.converged, res
    np.testing.assert_allclose(res.r, r_star, atol=1e-9)


def test_tresca_and_associated_multi_contact():
    p = _random_problem(20, 3, seed=8)
    t = solve(p, "nsgs", formulation="tresca", threshold=np.linspace(0.0, 0.5, 20), tol=1e-9,
              max_iter=20000)
    assert t.converged, t
    a = solve(p, "nsgs", formulation="associated", tol=1e-9, max_iter=20000)
    assert a.converged, a


def test_singular_diagonal_block_numerical_error():
    W = np.eye(6)
    W[3:, 3:] = 0.0                     # contact 1 has a zero diagonal block
    p = FrictionContactProblem(W, -np.ones(6), 0.3, dim=3)
    res = solve(p, "nsgs", tol=1e-8)
    assert res.status == "numerical_error" and not res.converged
    assert np.all(np.isfinite(res.r))
    assert 1 in res.info["singular_contacts"]


def test_max_iter_status():
    p = _random_problem(30, 3, seed=1)
    res = solve(p, "nsgs", tol=1e-12, max_iter=1)
    assert res.status == "max_iter" and res.iterations == 1 and not res.converged


def test_warm_start_from_solution_one_sweep():
    p = _random_problem(25, 3, seed=2)
    ref = solve(p, "nsgs", tol=1e-12, max_iter=50000)
    assert ref.converged
    res = solve(p, "nsgs", tol=1e-8, r0=ref.r, max_iter=100)
    assert res.converged and res.iterations == 1


def test_shuffled_reproducible_and_history():
    p = _random_problem(25, 3, seed=6)
    kw = dict(tol=1e-9, max_iter=20000, ordering="shuffled", seed=3)
    a = solve(p, "nsgs", **kw)
    b = solve(p, "nsgs", **kw)
    assert a.converged and b.converged
    np.testing.assert_array_equal(a.r, b.r)
    assert a.iterations == b.iterations
    h = solve(p, "nsgs", history=True, **kw)     # full error at every sweep
    assert h.converged and h.iterations == len(h.history) <= a.iterations
    assert h.history[-1] <= 1e-9 < h.history[0]
    # the backend ran on the balanced problem (socp_cd.solvers.scaling): its history is
    # Siconos' error in those units, which the dispatcher's guard recomputes from r
    assert h.history[-1] == pytest.approx(h.info["guard"]["error"], rel=1e-6)


def test_relaxation_converges():
    p = _random_problem(20, 2, seed=9)
    res = solve(p, "nsgs", tol=1e-9, max_iter=20000, omega=0.8)
    assert res.converged, res


def test_bad_options():
    p = _random_problem(4, 3, seed=0)
    with pytest.raises(socp_cd.UnsupportedError):
        solve(p, "nsgs", local_solver="exact")          # 2D only
    with pytest.raises(socp_cd.UnsupportedError):
        solve(p, "nsgs", not_an_option=1)
    with pytest.raises(socp_cd.InvalidProblemError):
        solve(p, "nsgs", omega=2.5)


# ----------------------------------------------------------------------------- real data
def _data_dir() -> Path:
    return shared_problems_dir() or Path("/nonexistent-shared-data")


@pytest.mark.parametrize("name", ["Rover1039.dat", "FC3D_Example1_SBM.dat",
                                  "Confeti-ex13-4contact-Fc3D-SBM.dat",
                                  "FC2D_SliderCrankLagrangian00000.dat",
                                  "FrictionContactProblem00071.dat"])
def test_real_problems_converge(name):
    path = _data_dir() / name
    if not path.exists():
        pytest.skip(f"shared data absent: {path}")
    p = socp_cd.read_problem(path)
    res = solve(p, "nsgs", tol=1e-8, max_iter=100000)
    assert res.converged and socp_cd.error(p, res.r) <= 1e-8, res


@pytest.mark.parametrize("name", ["FC2D_SliderCrankLagrangian00000.dat",
                                  "FrictionContactProblem00071.dat",
                                  "LMGC_100_PR_PerioBox-i00361-60-03000.hdf5"])
def test_nsgs_stops_where_the_dispatcher_accepts(name):
    """On these, ||r~|| dominates Siconos' normalization: NSGS used to stop within tol by
    Siconos' measure, the units guard refused, and the dispatcher ran NSGS again."""
    path = _data_dir() / name
    if not path.exists():
        pytest.skip(f"shared data absent: {path}")
    p = socp_cd.read_problem(path)
    res = solve(p, "nsgs", tol=1e-8)
    assert res.converged and "retry" not in res.info, res
    assert res.info["guard"]["value"] <= 1e-8 and socp_cd.error(p, res.r) <= 1e-8


def test_stopping_measure_is_the_guard_error_of_the_balanced_problem():
    from socp_cd import residuals
    from socp_cd.solvers.block_storage import block_csr
    from socp_cd.solvers.nsgs_kernels import full_errors
    from socp_cd.solvers.scaling import balanced
    for seed, (dim, law) in enumerate([(2, 0), (3, 0), (3, 1)]):
        p = _random_problem(6, dim, seed, mu=0.4)
        bal = balanced(p).problem
        B = block_csr(bal.W, dim)
        rng = np.random.default_rng(seed)
        for scale in (1e-6, 1.0, 1e4):            # ||r~|| below and above ||q~||, ||u~||
            r = scale * rng.standard_normal(p.m)
            u = np.empty(p.m)
            err, stop = full_errors(dim, p.n_contacts, B.indptr, B.indices, B.blocks, bal.q, r,
                                    bal.mu, np.zeros(p.n_contacts), law,
                                    float(np.linalg.norm(bal.q)), u)
            assert np.allclose(u, bal.velocity(r), rtol=1e-12, atol=1e-12 * np.abs(u).max())
            ref = (residuals.error if law == 0 else socp_cd.laws.LAW_RESIDUALS["associated"])
            measured = ref(bal, r, u)
            assert err == pytest.approx(measured, rel=1e-12)
            # guard_values' "error" of the balanced pair (unit factors 1 on the balanced problem)
            g = residuals.guard_values(measured, np.linalg.norm(r), np.linalg.norm(u),
                                       np.linalg.norm(bal.q))
            assert stop == pytest.approx(g["error"], rel=1e-12)
            assert stop >= err * (1 - 1e-14)


def test_block_storage_reproduces_W():
    import scipy.sparse as sp
    from socp_cd.solvers.block_storage import block_csr
    d, nc = 3, 7
    A = sp.random(d * nc, d * nc, density=0.2, random_state=2).tocsr()
    # unsorted column indices and a duplicate entry, as real files may have
    coo = A.tocoo()
    rows = np.r_[coo.row[::-1], 0]
    cols = np.r_[coo.col[::-1], 0]
    vals = np.r_[coo.data[::-1], 1.5]
    W = sp.csr_matrix((vals, (rows, cols)), shape=A.shape)
    W.has_sorted_indices = False
    S = block_csr(W, d)
    dense = np.zeros((d * nc, d * nc))
    for i in range(nc):
        for p in range(S.indptr[i], S.indptr[i + 1]):
            j = S.indices[p]
            dense[i * d:(i + 1) * d, j * d:(j + 1) * d] += S.blocks[p]
    np.testing.assert_allclose(dense, W.toarray())
    expected_diag = np.stack([W.toarray()[i * d:(i + 1) * d, i * d:(i + 1) * d] for i in range(nc)])
    np.testing.assert_allclose(S.diag, expected_diag)


# ------------------------------------------------------- the one-contact Alart–Curnier kernel
def _ac_local(A, b, r, mu, rho_n, rho_t, d, law=0, g=0.0):
    """``(||F||, F, J)`` of :func:`socp_cd.solvers.local_solvers.ac_function` as arrays."""
    from socp_cd.solvers.local_solvers import ac_function
    b2, r2 = (b[2], r[2]) if d == 3 else (0.0, 0.0)
    out = ac_function(A[None], 0, b[0], b[1], b2, mu, g, law, rho_n, rho_t, r[0], r[1], r2, d)
    F = np.array(out[1:1 + d])
    J = np.array(out[4:]).reshape(3, 3)[:d, :d]
    return out[0], F, J


@pytest.mark.parametrize("d", [2, 3])
def test_local_ac_function_equals_the_newton_kernels_reference(d):
    """NSGS's one-contact F and J (scalar kernel) equal the Newton method's NumPy reference
    ``F``, ``Dr + Du A`` (:func:`~socp_cd.solvers.kernels.newton_ac.ac_blocks_reference`),
    in all four branches (open/closed normal x stick/slide), symmetric or not."""
    from socp_cd.solvers.kernels.newton_ac import ac_blocks_reference
    rng = np.random.default_rng(d)
    branches = set()
    for k in range(400):
        B = rng.standard_normal((d, d))
        A = B @ B.T + 0.5 * np.eye(d) if k % 2 else B + d * np.eye(d)      # asymmetric half
        b, r = rng.standard_normal(d), rng.standard_normal(d) * rng.choice([1e-3, 1.0, 1e3])
        mu = float(rng.choice([0.0, 0.3, 1.0, 4.0]))
        rho_n, rho_t = rng.uniform(0.1, 3.0, 2)
        if k % 10 == 0:     # x_T = r_T - rho_t u_T = 0 exactly: the stick test passes with R = 0
            A[1:, 0] = 0.0
            b[1:] = r[1:] = 0.0
        nF, F, J = _ac_local(A, b, r, mu, rho_n, rho_t, d)
        F_ref, Dr, Du, branch = ac_blocks_reference(r, A @ r + b, [mu], [rho_n], [rho_t], d)
        branches.add(int(branch[0]))
        np.testing.assert_allclose(F, F_ref.ravel(), rtol=1e-13, atol=1e-13 * np.abs(r).max())
        assert nF == pytest.approx(np.linalg.norm(F_ref), rel=1e-13, abs=1e-300)
        np.testing.assert_allclose(J, Dr[0] + Du[0] @ A, rtol=1e-12, atol=1e-12)
    assert len(branches) == 4, branches


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("law", ["coulomb", "tresca"])
def test_local_ac_jacobian_matches_finite_differences(d, law):
    """Away from the kinks, J of the one-contact kernel is the derivative of F (both laws)."""
    rng = np.random.default_rng(10 * d + len(law))
    code = 0 if law == "coulomb" else 2
    checked = 0
    for _ in range(200):
        B = rng.standard_normal((d, d))
        A = B @ B.T + np.eye(d)
        b, r = rng.standard_normal(d), rng.standard_normal(d)
        mu, g = 0.7, 0.4
        h = 1e-7
        cols, smooth = [], True
        nF, F, J = _ac_local(A, b, r, mu, 1.0, 0.8, d, code, g)
        for e in np.eye(d):
            Fp = _ac_local(A, b, r + h * e, mu, 1.0, 0.8, d, code, g)[1]
            Fm = _ac_local(A, b, r - h * e, mu, 1.0, 0.8, d, code, g)[1]
            # a kink between r - h e and r + h e: one-sided differences disagree
            smooth &= np.allclose(Fp - F, F - Fm, atol=1e-9)
            cols.append((Fp - Fm) / (2 * h))
        if smooth:
            np.testing.assert_allclose(J, np.column_stack(cols), atol=1e-6)
            checked += 1
    assert checked >= 150


# ------------------------------------------- the one-contact solves NSGS runs (scalar kernels)
@pytest.mark.parametrize("d", [2, 3])
def test_solve_small_equals_lapack_with_row_swaps(d):
    """The augmented-buffer solve of the local Newton step: the right-hand side moves with
    its row when the pivot search swaps rows; a singular matrix is refused."""
    from socp_cd.solvers.local_solvers import solve_small
    rng = np.random.default_rng(40 + d)
    swapped = 0
    for _ in range(50):
        J = rng.standard_normal((d, d))
        J[1, 0] = 3.0 * max(abs(J[0, 0]), 1.0) * np.sign(J[1, 0] or 1.0)   # a row swap at k = 0
        rhs = rng.standard_normal(d)
        M = np.zeros((d, d + 1))
        M[:, :d], M[:, d] = J, rhs
        assert solve_small(M, d)
        np.testing.assert_allclose(M[:, d], np.linalg.solve(J, rhs), rtol=1e-10, atol=1e-12)
        swapped += 1
    assert swapped == 50
    M = np.zeros((d, d + 1))
    M[:, :d] = np.outer(np.arange(1.0, d + 1), np.ones(d))                    # rank 1
    assert not solve_small(M, d)


def _sliding_contact_3d(mu=0.6, seed=3):
    """A 3D contact with a known sliding solution: ``(A (1, 3, 3), b, r*)``."""
    rng = np.random.default_rng(seed)
    B = rng.standard_normal((3, 3))
    A = B @ B.T + np.eye(3)
    t = np.array([0.6, 0.8])                          # direction of r_T
    r_star = np.r_[2.0, mu * 2.0 * t]                 # on the cone's boundary
    u_star = np.r_[0.0, -1.5 * t]                     # u_N = 0, u_T opposite to r_T
    return A[None], u_star - A @ r_star, r_star, mu


def test_ac_newton_3d_slide_converges_fast_in_every_component():
    """Semismooth Newton near a smooth sliding solution: a few steps, all three components
    of r exact (a step that drops a component stalls or fails)."""
    from socp_cd.solvers.kernels.cone import LAW_COULOMB
    from socp_cd.solvers.local_solvers import ac_newton
    A, b, r_star, mu = _sliding_contact_3d()
    x0 = r_star + np.array([0.05, -0.04, 0.03])
    M = np.zeros((3, 4))
    it, *r = ac_newton(A, 0, *b, mu, 0.0, LAW_COULOMB, 1.0, 1.0, *x0, 3, 50, 1e-14, M)
    assert 1 <= it <= 5
    np.testing.assert_allclose(r, r_star, rtol=0, atol=1e-12)


def test_local_solve_falls_back_to_the_projection_then_newton():
    """With one Newton step allowed, Newton alone fails from r = 0 on a sliding contact; the
    chain's projection fixed point, then Newton again, solves it."""
    from socp_cd.solvers.kernels.cone import LAW_COULOMB
    from socp_cd.solvers.local_solvers import (KIND_AC_NEWTON, LOCAL_OK, ac_newton,
                                               local_solve)
    A, b, r_star, mu = _sliding_contact_3d()
    M = np.zeros((3, 4))
    rho = 1.0 / np.trace(A[0]) * 3
    it = ac_newton(A, 0, *b, mu, 0.0, LAW_COULOMB, rho, rho, 0.0, 0.0, 0.0, 3, 1, 1e-12, M)[0]
    assert it < 0                                     # Newton alone: not within one step
    r = np.zeros(3)
    status = local_solve(KIND_AC_NEWTON, A, 0, b, mu, 0.0, LAW_COULOMB, rho, rho, rho, r, 3,
                         1e-12, 1, 5000, np.zeros((8, 3)), M)
    assert status == LOCAL_OK
    np.testing.assert_allclose(r, r_star, rtol=0, atol=1e-9)


def test_tresca_projection_clamps_the_normal_part():
    """Tresca's set R+ x B(0, g): a negative normal part goes to 0, the tangential part to
    the disc; and a separated, tangentially still Tresca contact gets r = 0 from NSGS."""
    from socp_cd.solvers.kernels.cone import LAW_TRESCA, law_projection
    p = law_projection(-1.0, 3.0, 4.0, 3, 0.5, 2.0, LAW_TRESCA)
    np.testing.assert_allclose(p, (0.0, 1.2, 1.6), rtol=0, atol=1e-15)
    p = law_projection(2.0, 0.3, 0.0, 2, 0.5, 2.0, LAW_TRESCA)
    np.testing.assert_allclose(p, (2.0, 0.3, 0.0), rtol=0, atol=0)
    W = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, 0.2], [0.1, 0.2, 1.2]])
    sep = FrictionContactProblem(W, np.array([0.5, 0.0, 0.0]), np.array([0.4]), 3)   # u = q
    res = solve(sep, "nsgs", formulation="tresca", threshold=np.array([0.3]), tol=TOL)
    assert res.converged
    np.testing.assert_allclose(res.r, 0.0, atol=1e-14)


def test_predicted_sweeps_by_hand():
    from socp_cd.solvers.nsgs_kernels import predicted_sweeps
    # rate c = (1e-4 / 1e-2)^(1/20) = 10^(-0.1): 1e-4 -> 1e-8 takes 4 decades = 40 sweeps
    assert predicted_sweeps(40, 20, 1e-2, 1e-4, 1e-8) == pytest.approx(80.0, rel=1e-12)
    assert predicted_sweeps(40, 20, 1e-4, 1e-4, 1e-8) == np.inf         # no progress
    assert predicted_sweeps(40, 20, 1e-4, 2e-4, 1e-8) == np.inf         # growing
    assert predicted_sweeps(40, 20, 1e-2, 1e-9, 1e-8) == 40.0           # already there
    assert predicted_sweeps(40, 20, 0.0, 1e-4, 1e-8) == np.inf          # nothing to compare


@pytest.mark.parametrize("time_limit", [None, 10.0])
def test_predict_window_stops_a_slow_run_early(time_limit):
    p = coupled_pair()
    full = solve(p, "nsgs", tol=1e-10, max_iter=300, time_limit=time_limit)
    assert full.status == "max_iter" and full.iterations == 300
    res = solve(p, "nsgs", tol=1e-10, max_iter=300, predict_window=20, time_limit=time_limit)
    assert res.status == "max_iter" and res.iterations < 300
    assert "predicts more than 300" in res.message
    if time_limit is None:
        assert res.iterations % 20 == 0
    # the prediction was right: the error NSGS had then cannot reach tol in the cap's sweeps
    assert full.error > 1e-10
    # with a budget large enough for the predicted rate, no early stop
    long = solve(p, "nsgs", tol=1e-10, max_iter=200_000, predict_window=20)
    assert long.status == "converged"


def test_predict_window_leaves_a_fast_run_converged():
    p = _random_problem(20, 3, seed=4)
    a = solve(p, "nsgs", tol=1e-8)
    b = solve(p, "nsgs", tol=1e-8, predict_window=20)
    assert a.converged and b.converged and b.iterations <= a.iterations
    with pytest.raises(socp_cd.InvalidProblemError, match="predict_window"):
        solve(p, "nsgs", predict_window=-1)


def test_next_block_rule():
    from socp_cd.solvers.nsgs_kernels import STATUS_CONVERGED, STATUS_MAX_ITER, next_block
    # a full block, sweeps left: twice the block (capped), the window's error carried when
    # the block ended on a window's end
    assert next_block(STATUS_MAX_ITER, 20, 20, 40, 1000, 1e-3, 20) == (40, 1e-3)
    assert next_block(STATUS_MAX_ITER, 20, 20, 30, 1000, 1e-3, 20) == (40, -1.0)
    assert next_block(STATUS_MAX_ITER, 20, 20, 990, 1000, 1e-3, 0) == (10, -1.0)
    # over: converged, out of sweeps, or fewer sweeps than the block (the prediction stopped)
    assert next_block(STATUS_CONVERGED, 5, 20, 25, 1000, 1e-9, 20) == (0, -1.0)
    assert next_block(STATUS_MAX_ITER, 20, 20, 1000, 1000, 1e-3, 20) == (0, -1.0)
    assert next_block(STATUS_MAX_ITER, 7, 20, 27, 1000, 1e-3, 20) == (0, -1.0)
    # ... or stopped by the prediction on the block's last sweep (session 45)
    from socp_cd.solvers.nsgs_kernels import STATUS_NAMES, STATUS_PREDICTED
    assert next_block(STATUS_PREDICTED, 20, 20, 40, 1000, 1e-3, 20) == (0, -1.0)
    assert STATUS_NAMES[STATUS_PREDICTED] == "max_iter"


@pytest.mark.parametrize("solver,name,tol,stop", [
    ("nsgs", "BoxesStack1-i100000-32.hdf5.dat", 1e-6, 45),
    ("nsgs", "OneObject-i1028-138.hdf5.dat", 1e-5, 105),
    ("projection", "BoxesStack1-i100000-32.hdf5.dat", 1e-6, 45)])
def test_rate_prediction_stops_at_the_same_sweep_in_blocks_as_in_one_run(solver, name, tol,
                                                                        stop):
    # under a time limit the sweeps run in blocks of whole windows (15, 30, 60, ...: blocks
    # end at 45, 105, 225); a verdict due on a block's last sweep was skipped until session 45
    # (the block's own cap hid it), so a timed run stopped a window later than an untimed one
    from pathlib import Path
    from socp_cd.data import shared_problems_dir
    p = socp_cd.read_problem(Path(shared_problems_dir()) / name)
    one = solve(p, solver, tol=tol, max_iter=300, predict_window=15)
    blocks = solve(p, solver, tol=tol, max_iter=300, predict_window=15, time_limit=100.0)
    assert one.status == blocks.status == "max_iter"
    assert one.iterations == blocks.iterations == stop     # (a block's last sweep)
    assert np.array_equal(blocks.r, one.r)


# --------------------------------------------------------------------------- the sweep's code
@functools.cache
def _reference_sweeps():
    """(Compiled once per session.)  The sweep loop before session 16 (one loop, ``local_solve`` per contact), compiled:
    what :func:`~socp_cd.solvers.nsgs_kernels.nsgs_loop`'s split loop must reproduce bit for
    bit (iterates, local failures, the light error)."""
    from numba import njit
    from socp_cd.solvers.local_solvers import local_solve
    from socp_cd.solvers.nsgs_kernels import local_free_velocity

    @njit
    def sweeps(d, indptr, indices, blocks, diag, q, mu, g, law, kind, rhoN, rhoT, rhoP, tol,
               newton_maxit, proj_maxit, omega, order, n_sweeps, r):
        nc = diag.shape[0]
        work = np.zeros((4, d))
        M = np.zeros((d, d + 1))
        b = np.zeros(d)
        rl = np.zeros(d)
        rold = np.zeros(d)
        n_fail = 0
        dsums = np.zeros(n_sweeps)
        for it in range(n_sweeps):
            dsum = 0.0
            for kk in range(nc):
                i = order[it, kk]
                o = i * d
                local_free_velocity(i, d, indptr, indices, blocks, q, r, b)
                for a in range(d):
                    rold[a] = r[o + a]
                    rl[a] = r[o + a]
                if local_solve(kind, diag, i, b, mu[i], g[i], law, rhoN[i], rhoT[i], rhoP[i],
                               rl, d, tol, newton_maxit, proj_maxit, work, M) != 0:
                    n_fail += 1
                for a in range(d):
                    v = omega * rl[a] + (1.0 - omega) * rold[a]
                    e = v - rold[a]
                    dsum += e * e
                    r[o + a] = v
            dsums[it] = dsum
        return n_fail, dsums
    return sweeps


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("law_name", ["coulomb", "tresca", "associated"])
@pytest.mark.parametrize("kind_name", ["exact", "ac_newton", "projection"])
@pytest.mark.parametrize("omega, newton_maxit", [(1.0, 10), (0.7, 10), (1.0, 1)])
def test_split_sweep_equals_the_single_loop(dim, law_name, kind_name, omega, newton_maxit):
    """``nsgs_loop`` (``sweep_span`` with the first local attempt inlined, the rest of the
    chain on the contacts it stops at) gives the single loop's iterates, local failures and
    light errors bit for bit: every local solver and law, relaxation, and Newton capped at
    one step so that the fallback chain runs mid-sweep."""
    from socp_cd.bench.generators import manufactured
    from socp_cd.solvers.block_storage import block_csr
    from socp_cd.solvers.kernels.cone import LAW_ASSOCIATED, LAW_COULOMB, LAW_TRESCA
    from socp_cd.solvers.local_solvers import KIND_AC_NEWTON, KIND_EXACT, KIND_PROJECTION
    from socp_cd.solvers.nsgs_kernels import (BlockW, Law, LocalSolver, Sweeps,
                                              local_parameters, no_origin, nsgs_loop)
    if kind_name == "exact" and dim == 3:
        pytest.skip("the exact local solver is 2D only")
    law = {"coulomb": LAW_COULOMB, "tresca": LAW_TRESCA, "associated": LAW_ASSOCIATED}[law_name]
    kind = {"exact": KIND_EXACT, "ac_newton": KIND_AC_NEWTON, "projection": KIND_PROJECTION}[kind_name]
    p = manufactured(12, dim, 0.6, structure="redundant", seed=dim)
    S = block_csr(p.W, dim)
    rhoN, rhoT, rhoP, bad = local_parameters(S.diag, S.blocks)
    assert not bad.any()
    g = np.full(p.n_contacts, 0.05)
    n_sweeps = 6
    for shuffle in (False, True):
        r_new = np.zeros(p.m)
        sweeps = Sweeps(1e-300, n_sweeps, omega, shuffle, 3, 0, 0, False, 0, n_sweeps, -1.0, np.inf)
        status, its, err, n_full, n_fail, light, _ = nsgs_loop(
            dim, BlockW(S.indptr, S.indices, S.blocks, S.diag), p.q, Law(p.mu, g, law),
            LocalSolver(kind, rhoN, rhoT, rhoP, 1e-13, newton_maxit, 50), sweeps, r_new,
            np.full(1, np.nan), no_origin())
        assert its == n_sweeps
        # the orders the kernel drew (numba's generator, seeded as the kernel seeds it)
        order = np.tile(np.arange(p.n_contacts), (n_sweeps, 1))
        if shuffle:
            order = _shuffled_orders(3, p.n_contacts, n_sweeps)
        r_ref = np.zeros(p.m)
        ref_fail, dsums = _reference_sweeps()(
            dim, S.indptr, S.indices, S.blocks, S.diag, p.q, p.mu, g, law, kind, rhoN, rhoT,
            rhoP, 1e-13, newton_maxit, 50, omega, order, n_sweeps, r_ref)
        assert np.array_equal(r_new, r_ref)
        assert n_fail == ref_fail
        nr2 = 0.0
        for x in r_ref:                      # (the kernel's order of summation)
            nr2 += x * x
        assert light == np.sqrt(dsums[-1]) / np.sqrt(nr2)


@functools.cache
def _order_drawer():
    """numba's generator drawing the contact orders of shuffled sweeps, seeded as
    ``nsgs_loop`` seeds it (compiled once per session)."""
    from numba import njit

    @njit
    def draw(seed, nc, n_sweeps):
        np.random.seed(seed)
        order = np.arange(nc)
        out = np.empty((n_sweeps, nc), dtype=np.int64)
        for k in range(n_sweeps):
            np.random.shuffle(order)
            out[k] = order
        return out
    return draw


def _shuffled_orders(seed, nc, n_sweeps):
    """The contact orders of ``n_sweeps`` shuffled sweeps."""
    return _order_drawer()(seed, nc, n_sweeps)


def test_a_non_finite_local_iterate_stops_the_sweeps_with_a_numerical_error():
    """A contact whose free velocity is not finite: ``nsgs_loop`` returns STATUS_NUMERICAL
    (its full error, of the last finite ``r``, not finite) instead of sweeping on."""
    from socp_cd.bench.generators import manufactured
    from socp_cd.solvers.block_storage import block_csr
    from socp_cd.solvers.kernels.cone import LAW_COULOMB
    from socp_cd.solvers.local_solvers import KIND_AC_NEWTON
    from socp_cd.solvers.nsgs_kernels import (STATUS_NUMERICAL, BlockW, Law, LocalSolver,
                                              Sweeps, local_parameters, no_origin, nsgs_loop)
    p = manufactured(6, 3, 0.5, seed=1)
    S = block_csr(p.W, 3)
    rhoN, rhoT, rhoP, _ = local_parameters(S.diag, S.blocks)
    q = p.q.copy()
    q[3 * 4] = -np.inf                       # contact 4
    r = np.zeros(p.m)
    status, its, err, n_full, n_fail, light, _ = nsgs_loop(
        3, BlockW(S.indptr, S.indices, S.blocks, S.diag), q, Law(p.mu, np.zeros(6), LAW_COULOMB),
        LocalSolver(KIND_AC_NEWTON, rhoN, rhoT, rhoP, 1e-13, 10, 50),
        Sweeps(1e-10, 20, 1.0, False, 0, 0, 0, False, 0, 20, -1.0, np.inf), r, np.full(1, np.nan),
        no_origin())
    assert status == STATUS_NUMERICAL and its <= 20 and n_full == 1
    assert np.all(np.isfinite(r)) and not np.isfinite(err)


@pytest.mark.parametrize("options", [{}, {"omega": 1.0}])   # the compiled route; the backend
def test_a_deadline_stops_the_sweeps_at_the_first_check(options):
    # the sweeps read the compiled clock every max(1, CHECK_BLOCKS // nnzb) sweeps (here
    # every other sweep: 669 blocks), not only between blocks of 10, 20, ... sweeps
    from socp_cd.bench.generators import manufactured
    from socp_cd.solvers import nsgs_kernels
    from socp_cd.solvers.kernels import clock
    if not clock.AVAILABLE:
        pytest.skip("no compiled clock: the sweeps stop between blocks only")
    p = manufactured(400, 3, 0.5, seed=1)
    nnzb = p.W.nnz // 9
    every = max(1, nsgs_kernels.CHECK_BLOCKS // nnzb)
    assert every < 10               # (a first block holds 10 sweeps)
    res = solve(p, "nsgs", tol=1e-300, time_limit=1e-9, **options)
    assert res.status == "time_limit" and res.iterations == every
    free = solve(p, "nsgs", tol=1e-300, max_iter=25, **options)    # no deadline: no stop
    assert free.status == "max_iter" and free.iterations == 25

"""Proximal-point semismooth Newton backend (``solver="newton"``)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.data import shared_problems
from socp_cd.errors import SocpCdError
from socp_cd.problem import FrictionContactProblem, GlobalFrictionContactProblem
from socp_cd.solvers import newton
from socp_cd.solvers.kernels.newton_ac import ac_blocks, ac_blocks_reference

MU = 0.5
RHO = 0.7
#: (rho_N, rho_T) pairs: one scalar per contact ("block") and split parameters
#: differing by 40x both ways (as on elongated bodies: W_NN and W_TT far apart)
RHO_PAIRS = [(RHO, RHO), (2.0, 0.05), (0.05, 2.0)]


def _branch_point(branch, dim, rng):
    """``(r, u)`` of one contact strictly inside an AC branch (away from kinks).

    branch: 'separated' (a_N < 0), 'stick' (a_N > 0, ||x_T|| < R),
    'slide' (a_N > 0, ||x_T|| > R), 'open-slide' is 'separated'.
    """
    t = rng.normal(size=dim - 1)
    t /= np.linalg.norm(t)
    if branch == "separated":          # a_N = r_N - rho u_N < 0, x_T != 0
        r = np.concatenate([[0.2], 0.3 * t])
        u = np.concatenate([[1.0], 0.5 * rng.normal(size=dim - 1)])
    elif branch == "stick":            # a_N > 0, ||x_T|| < mu a_N
        r = np.concatenate([[1.0], 0.1 * t])
        u = np.concatenate([[0.1], 0.05 * rng.normal(size=dim - 1)])
    elif branch == "slide":            # a_N > 0, ||x_T|| > mu a_N
        r = np.concatenate([[1.0], 0.3 * t])
        u = np.concatenate([[0.1], -2.0 * t + 0.1 * rng.normal(size=dim - 1)])
    else:                              # 'polar': a_N < 0 and x_T = 0 is a kink; use x_T small
        r = np.concatenate([[-0.5], 1e-1 * t])
        u = np.concatenate([[0.5], np.zeros(dim - 1)])
    return r, u


def _F(r, u, dim, rho_n=RHO, rho_t=RHO):
    F = np.empty(dim)
    z = np.empty((1, dim, dim))
    ac_blocks(r, u, np.array([MU]), np.array([rho_n]), np.array([rho_t]), dim, False, F, z, z,
              np.empty(1, np.int64))
    return F


def _in_branch(branch, rho_n, rho_t, dim, rng):
    """A branch point for the given parameters: ``u`` rescaled so that ``rho u`` is as
    in :func:`_branch_point` (the branch depends on ``rho_N u_N`` and ``rho_T u_T``)."""
    r, u = _branch_point(branch, dim, rng)
    u = u * (RHO / np.r_[rho_n, np.full(dim - 1, rho_t)])
    return r, u


@pytest.mark.parametrize("rho_n,rho_t", RHO_PAIRS)
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("branch,code", [("separated", 1), ("stick", 2), ("slide", 3),
                                         ("polar", 1)])
def test_jacobian_matches_finite_differences_in_every_branch(dim, branch, code, rho_n, rho_t):
    rng = np.random.default_rng(3)
    r, u = _in_branch(branch, rho_n, rho_t, dim, rng)
    F = np.empty(dim)
    Dr, Du = np.empty((1, dim, dim)), np.empty((1, dim, dim))
    br = np.empty(1, np.int64)
    ac_blocks(r, u, np.array([MU]), np.array([rho_n]), np.array([rho_t]), dim, True,
              F, Dr, Du, br)
    assert br[0] == code                       # the point is in the intended branch
    h = 1e-7
    for j in range(dim):
        e = np.zeros(dim)
        e[j] = h
        fd_r = (_F(r + e, u, dim, rho_n, rho_t) - _F(r - e, u, dim, rho_n, rho_t)) / (2 * h)
        fd_u = (_F(r, u + e, dim, rho_n, rho_t) - _F(r, u - e, dim, rho_n, rho_t)) / (2 * h)
        np.testing.assert_allclose(Dr[0, :, j], fd_r, atol=1e-7)
        np.testing.assert_allclose(Du[0, :, j], fd_u, atol=1e-7)


@pytest.mark.parametrize("dim", [2, 3])
def test_split_parameters_enter_their_own_rows(dim):
    """F_N depends on rho_N only and, when sticking, F_T on rho_T only."""
    rng = np.random.default_rng(7)
    r, u = _branch_point("stick", dim, rng)
    F_block = _F(r, u, dim, RHO, RHO)
    F_n = _F(r, u, dim, 2 * RHO, RHO)
    F_t = _F(r, u, dim, RHO, 1.1 * RHO)
    assert F_n[0] == pytest.approx(2 * F_block[0]) and np.array_equal(F_n[1:], F_block[1:])
    assert F_t[0] == F_block[0]
    np.testing.assert_allclose(F_t[1:], 1.1 * F_block[1:])


@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_equals_numpy_reference(dim):
    rng = np.random.default_rng(5)
    nc = 200
    r, u = rng.normal(size=nc * dim), rng.normal(size=nc * dim)
    mu, rho_n, rho_t = rng.uniform(0, 2, nc), rng.uniform(0.1, 2, nc), rng.uniform(0.1, 2, nc)
    for X in (r, u):                   # x_T = 0 at the first contacts: the apex branch
        X.reshape(nc, dim)[:20, 1:] = 0.0
    F = np.empty(nc * dim)
    Dr, Du = np.empty((nc, dim, dim)), np.empty((nc, dim, dim))
    br = np.empty(nc, np.int64)
    ac_blocks(r, u, mu, rho_n, rho_t, dim, True, F, Dr, Du, br)
    F0, Dr0, Du0, br0 = ac_blocks_reference(r, u, mu, rho_n, rho_t, dim)
    assert len(set(br0.tolist())) == 4         # every branch visited
    np.testing.assert_allclose(F, F0, atol=1e-14)
    np.testing.assert_allclose(Dr, Dr0, atol=1e-14)
    np.testing.assert_allclose(Du, Du0, atol=1e-14)
    np.testing.assert_array_equal(br, br0)


def _check_exact(p, res, tol, unique_u=True):
    assert res.status == "converged" and res.error <= tol
    assert socp_cd.error(p, res.r) <= tol      # independent recomputation
    if not unique_u:
        return
    u_star = p.solution.u
    assert np.linalg.norm(res.u - u_star) <= 1e-6 * max(1.0, np.linalg.norm(u_star))


@pytest.mark.parametrize("rho", ["block", "split"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("structure", ["tree", "redundant"])
@pytest.mark.parametrize("mu", [0.1, 1.0])
def test_manufactured_exact_solutions_to_1e_10(dim, structure, mu, rho):
    p = manufactured(30, dim, mu, structure=structure, seed=11)
    assert (structure == "redundant") == bool(p.is_rank_deficient)
    res = socp_cd.solve(p, "newton", tol=1e-10, rho=rho)
    assert res.info["rho"] == rho
    # with a rank-deficient W the non-associated law may have several u
    _check_exact(p, res, 1e-10, unique_u=structure == "tree")


@pytest.mark.parametrize("dim", [2, 3])
def test_split_equals_block_when_diagonal_blocks_are_isotropic(dim):
    """W_ii = c_i I: W_NN = ||W_TT||_2 = ||W_ii||_F/sqrt(d), so both strategies give
    the same parameters and the same iterates; on an anisotropic W they differ."""
    base = manufactured(20, dim, 0.5, seed=6)
    W = base.W.toarray()
    nc = base.m // dim
    c = np.random.default_rng(6).uniform(0.5, 5.0, nc)
    for i in range(nc):
        W[i * dim:(i + 1) * dim, i * dim:(i + 1) * dim] = c[i] * np.eye(dim)
    r_star, u_star = base.solution.r, base.solution.u
    runs = {}
    for scale_t in (1.0, 30.0):
        Ws = W.copy()
        for i in range(nc):
            Ws[i * dim + 1:(i + 1) * dim, i * dim + 1:(i + 1) * dim] *= scale_t
        p = FrictionContactProblem(Ws, u_star - Ws @ r_star, base.mu, dim)
        for rho in ("block", "split"):
            runs[scale_t, rho] = socp_cd.solve(p, "newton", tol=1e-10, max_iter=3, history=True,
                                               rho=rho)
    assert runs[1.0, "block"].history == runs[1.0, "split"].history
    assert runs[30.0, "block"].history != runs[30.0, "split"].history


@pytest.mark.parametrize("rho", ["block", "split"])
@pytest.mark.parametrize("dim", [2, 3])
def test_asymmetric_w(dim, rho):
    base = manufactured(20, dim, 0.5, seed=4)
    rng = np.random.default_rng(4)
    S = rng.normal(size=(base.m, base.m))
    W = base.W.toarray() + 0.05 * np.abs(base.W).max() * (S - S.T)   # PD symmetric part, skew
    r_star, u_star = base.solution.r, base.solution.u
    p = FrictionContactProblem(W, u_star - W @ r_star, base.mu, dim,
                               solution=type(base.solution)(r=r_star, u=u_star))
    assert p.asymmetry > 1e-3
    res = socp_cd.solve(p, "newton", tol=1e-10, rho=rho)
    _check_exact(p, res, 1e-10)


def _shared(name):
    hits = [s for s in shared_problems() if s.file == name]
    if not hits:
        pytest.skip("shared data not available")
    return socp_cd.read_problem(hits[0].path)


@pytest.mark.parametrize("name", ["OneObject-i1028-138.hdf5.dat",      # asymmetric, rank deficient
                                  "FC2D_SliderCrankLagrangian00000.dat",  # 2D, asymmetric, rank def.
                                  "Rover3865.dat", "BoxesStack1-i100000-32.hdf5.dat"])
def test_real_asymmetric_or_rank_deficient_problems(name):
    p = _shared(name)
    assert p.is_rank_deficient or p.asymmetry > 1e-8
    res = socp_cd.solve(p, "newton", tol=1e-8)
    assert res.converged and socp_cd.error(p, res.r) <= 1e-8


def _small_global(dim, seed):
    rng = np.random.default_rng(seed)
    n, nc = 12, 5
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n)
    H = rng.normal(size=(n, nc * dim))
    f = rng.normal(size=n)
    w = np.tile(np.r_[0.1, np.zeros(dim - 1)], nc)
    return GlobalFrictionContactProblem(sp.csr_matrix(M), sp.csr_matrix(H), f, w, 0.4, dim)


@pytest.mark.parametrize("dim", [2, 3])
def test_global_and_local_agree(dim):
    g = _small_global(dim, 2)
    rg = socp_cd.solve(g, "newton", tol=1e-10, global_mode="native")
    rl = socp_cd.solve(g.to_local(), "newton", tol=1e-10)
    rc = socp_cd.solve(g, "newton", tol=1e-10)            # auto: condensed (small m)
    assert rg.converged and rl.converged and rc.converged
    assert "condensed_to_local" not in rg.info            # the registry did not condense
    assert rg.info["linear_solver"] == "splu-global" and rc.info["global_mode"] == "condense"
    np.testing.assert_allclose(rc.v, g.global_velocity(rc.r), atol=1e-8)
    np.testing.assert_allclose(rg.u, rl.u, atol=1e-7 * max(1.0, np.linalg.norm(rl.u)))
    np.testing.assert_allclose(rg.v, g.global_velocity(rg.r), atol=1e-8)


def test_dense_and_sparse_paths_agree():
    p = manufactured(40, 3, 0.5, seed=8)
    a = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="dense")
    b = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="splu")
    assert a.converged and b.converged
    np.testing.assert_allclose(a.u, b.u, atol=1e-8)


def test_never_converged_above_tol_and_history():
    p = _shared("Capsules-i125-1213.hdf5")
    for max_iter in (1, 2, 3):
        res = socp_cd.solve(p, "newton", tol=1e-12, max_iter=max_iter, history=True)
        recomputed = socp_cd.error(p, res.r)
        assert res.converged == (recomputed <= 1e-12)
        assert res.status in ("max_iter", "converged")
        assert len(res.history) == res.iterations + 1
        assert res.info["factorizations"] >= res.iterations


def test_warm_start_from_solution_is_immediate():
    p = manufactured(10, 3, 0.5, seed=1)
    res = socp_cd.solve(p, "newton", tol=1e-10, r0=p.solution.r)
    assert res.converged and res.iterations == 0


@pytest.mark.parametrize("opts", [dict(alpha0=-1.0), dict(linear_solver="qr"),
                                  dict(inner_max_iter=0), dict(bogus=1), dict(rho="spectral")])
def test_bad_options_raise_socp_cd_errors(opts):
    p = manufactured(3, 3, 0.5, seed=1)
    with pytest.raises(SocpCdError):
        socp_cd.solve(p, "newton", **opts)


@pytest.mark.parametrize("dim", [2, 3])
def test_internal_error_equals_socp_cd_error(dim):
    from socp_cd.solvers.kernels.cone import siconos_error
    p = manufactured(15, dim, 0.7, seed=2)
    r = np.random.default_rng(0).normal(size=p.m)
    u = p.velocity(r)
    e = siconos_error(r, u, p.mu, dim, float(np.linalg.norm(p.q)))
    assert e > 1e-3
    assert e == pytest.approx(socp_cd.error(p, r), rel=1e-12)


def _rank_deficient_asymmetric(seed, mu=2.0, nc=20, n_dofs=36, skew=0.1):
    """Manufactured problem on ``W = HᵀH + skew`` with ``H`` of ``n_dofs < 3 nc`` rows
    (rank-deficient symmetric part, asymmetric: as capsule piles)."""
    base = manufactured(nc, 3, mu, seed=seed)
    rng = np.random.default_rng(seed)
    H = rng.normal(size=(n_dofs, base.m)) / np.sqrt(n_dofs)
    S = rng.normal(size=(base.m, base.m))
    W = H.T @ H + skew * (S - S.T) / np.sqrt(base.m)
    r_star, u_star = base.solution.r, base.solution.u
    return FrictionContactProblem(W, u_star - W @ r_star, base.mu, 3)


def test_hybrid_converges_where_the_proximal_loop_stalls(monkeypatch):
    # one of the random draws (seeds 0-39, mu 2, skew 0.1) on which the proximal loop
    # alone stalls near 2e-3; the reverse happens too (seed 3): see newton.md §7
    p = _rank_deficient_asymmetric(24)
    W = p.W.toarray() if sp.issparse(p.W) else np.asarray(p.W)
    assert np.linalg.matrix_rank(W + W.T) == 36 < p.m and p.asymmetry > 1e-3
    # (with session 13's cold proximal parameter, alpha0 = 1; the default 0.1 of session 14
    # solves this draw with the proximal loop too)
    a = socp_cd.solve(p, "newton", tol=1e-8, policy="prox", alpha0=1.0)
    b = socp_cd.solve(p, "newton", tol=1e-8, policy="hybrid", alpha0=1.0)
    assert not a.converged and socp_cd.error(p, a.r) > 1e-6
    assert b.converged and socp_cd.error(p, b.r) <= 1e-8
    assert b.info["plain_steps"] > 0
    assert socp_cd.solve(p, "newton", tol=1e-8, policy="prox").converged
    # session 20's looser subproblem test (a full step that halves ||F_alpha||, not
    # adopted: newton.md §4) solves this draw with the proximal loop alone from alpha0 = 1
    monkeypatch.setattr(newton, "INNER_GATE", 0.5)
    monkeypatch.setattr(newton, "INNER_DECREASE", 0.5)
    assert socp_cd.solve(p, "newton", tol=1e-8, policy="prox", alpha0=1.0).converged


@pytest.mark.parametrize("seed", [3, 24])
def test_hybrid_plain_steps_keep_alpha_and_stop_when_the_error_does_not_follow(seed):
    p = _rank_deficient_asymmetric(seed)
    res = socp_cd.solve(p, "newton", tol=1e-12, max_iter=60, history=True, policy="hybrid")
    trace, hist = res.info["trace"], res.history
    plain = [row[7] for row in trace]
    assert any(plain) and not all(plain)
    for k in range(len(trace) - 1):
        if plain[k]:
            assert trace[k + 1][0] == trace[k][0]          # alpha unchanged by a plain step
            if plain[k + 1]:
                assert hist[k + 1] < hist[k]                # a plain step continues only on progress


def _scipy_jacobian(Dr, Du, W, alpha):
    """The reference of the sparse local Newton matrix: scipy's ``Dr + alpha Du + Du W``."""
    nc, d = Dr.shape[0], Dr.shape[1]
    ind, ptr = np.arange(nc), np.arange(nc + 1)
    Dr_s = sp.bsr_matrix((Dr + alpha * Du, ind, ptr), shape=W.shape).tocsr()
    Du_s = sp.bsr_matrix((Du, ind, ptr), shape=W.shape).tocsr()
    return (Dr_s + Du_s @ W).toarray()


@pytest.mark.parametrize("name", ["Capsules-i125-1213.hdf5", "fc2d_granularflowonwall_00667_00000.dat"])
def test_block_jacobian_equals_the_scipy_product_call_after_call(name):
    from socp_cd.solvers.newton import BlockJacobian
    path = next((p for p in shared_problems() if p.file == name), None)
    if path is None:
        pytest.skip("shared data not available")
    p = socp_cd.read_problem(path)
    W, d, nc = sp.csr_matrix(p.W), p.dim, p.n_contacts
    bj = BlockJacobian(W, d)
    rng = np.random.default_rng(3)
    for call in range(3):       # the stored pattern must survive each call's zero elimination
        Dr, Du = rng.standard_normal((nc, d, d)), rng.standard_normal((nc, d, d))
        separated = rng.random(nc) < 0.4          # Du_i = 0, Dr_i = I: zero rows off the diagonal
        Du[separated] = 0.0
        Dr[separated] = np.eye(d)
        J = bj.matrix(Dr, Du, 0.1 * call)
        assert sp.isspmatrix_csc(J)
        np.testing.assert_array_equal(J.toarray(), _scipy_jacobian(Dr, Du, W, 0.1 * call))
        assert J.nnz == np.count_nonzero(J.toarray())      # no stored zeros reach SuperLU


def test_block_jacobian_stores_a_structurally_zero_diagonal_block():
    from socp_cd.solvers.newton import BlockJacobian
    d, nc = 3, 3
    A = np.arange(1.0, 82.0).reshape(9, 9)
    A[3:6, 3:6] = 0.0                    # contact 1 has no diagonal block in W
    W = sp.csr_matrix(A)
    bj = BlockJacobian(W, d)
    rng = np.random.default_rng(0)
    Dr, Du = rng.standard_normal((nc, d, d)), rng.standard_normal((nc, d, d))
    J = bj.matrix(Dr, Du, 0.5)
    np.testing.assert_allclose(J.toarray(), _scipy_jacobian(Dr, Du, W, 0.5), rtol=1e-14, atol=0)
    np.testing.assert_allclose(J.toarray()[3:6, 3:6], Dr[1] + 0.5 * Du[1], rtol=1e-14)


@pytest.mark.parametrize("seed", [3, 24])
def test_trace_records_each_outer_step(seed):
    # the trace's last three entries: ||r - r_k||, ||u - u_k|| (u - u_k = W~ (r - r_k) in the
    # balanced units the backend runs in, so at most ||W~||_2 times the first; both 0 for a
    # rejected outer step) and the cosine with the last nonzero step (nan when none)
    from socp_cd.solvers.scaling import balanced
    p = _rank_deficient_asymmetric(seed)
    res = socp_cd.solve(p, "newton", tol=1e-12, max_iter=40, history=True, policy="prox")
    trace = res.info["trace"]
    # (one row per outer iteration but the converging one, which stops before its row)
    assert 0 < len(trace) <= res.iterations and all(len(row) == 11 for row in trace)
    norm_w = np.linalg.norm(np.asarray(balanced(p).problem.W.todense()), 2)
    steps = [row[8] for row in trace]
    assert any(s > 0 for s in steps)
    assert sum(s == 0 for s in steps) >= res.info["rejected_outer"]
    assert seed != 3 or res.info["rejected_outer"] > 0      # (a draw with rejected steps)
    for k, (*_, step, ustep, turn) in enumerate(trace):
        assert (ustep == 0) == (step == 0)
        assert ustep <= norm_w * step * (1 + 1e-9)
        assert np.isnan(turn) == (step == 0 or not any(s > 0 for s in steps[:k]))


def test_sparse_system_diag_blocks_equal_the_problem_reference_with_a_zero_block():
    # LocalSystem reads W_ii from the Jacobian's block pattern; FrictionContactProblem's
    # diagonal_blocks is the NumPy reference (a structurally zero W_ii included)
    from socp_cd.solvers.newton import LocalSystem
    d = 3
    A = np.arange(1.0, 82.0).reshape(9, 9)
    A = A + A.T
    A[3:6, 3:6] = 0.0
    p = socp_cd.FrictionContactProblem(W=sp.csr_matrix(A), q=np.ones(9), mu=np.full(3, 0.5), dim=d)
    blocks = LocalSystem(p, "splu").diag_blocks()
    np.testing.assert_array_equal(blocks, p.diagonal_blocks())
    assert not blocks[1].any()


def test_newton_systems_of_one_problem_share_its_pattern_and_column_order(monkeypatch):
    # the pattern and the LU's column order are computed once per problem object (auto's
    # stages each build a system); a new problem computes its own
    from socp_cd.solvers import sparse_lu
    from socp_cd.solvers.newton import LocalSystem
    p = manufactured(60, 3, 0.5, seed=5)
    calls = []
    real = sparse_lu.column_order

    def counting(*args):
        calls.append(1)
        return real(*args)
    monkeypatch.setattr(sparse_lu, "column_order", counting)
    s1 = LocalSystem(p, "left_looking")
    s2 = LocalSystem(p, "left_looking")
    assert len(calls) == 1
    assert s1.jacobian.perm is s2.jacobian.perm and s1.jacobian.out is not s2.jacobian.out
    fresh = LocalSystem(p.with_(), "left_looking")
    assert len(calls) == 2 and fresh.jacobian.perm is not s1.jacobian.perm
    r = np.random.default_rng(0).random(p.m)
    for s in (s1, s2, fresh):     # the same Newton direction from each
        Dr = np.broadcast_to(np.eye(3), (60, 3, 3)).copy()
        Du = 0.5 * Dr
        F = s.start(r)
        np.testing.assert_array_equal(s.direction(r, Dr, Du, 0.1, F)[0],
                                      s1.direction(r, Dr, Du, 0.1, F)[0])

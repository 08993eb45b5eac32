"""The compiled left-looking sparse LU (kernels.sparse_lu) and NewtonLU's choice (sparse_lu).

The reference is SuperLU: every solve is checked by its residual and against scipy's.
"""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.solvers import newton
from socp_cd.solvers import sparse_lu
from socp_cd.solvers.kernels import sparse_lu as kernel


def _lu(A, choice="left_looking"):
    A = sp.csc_matrix(A)
    A.sort_indices()
    return A, sparse_lu.NewtonLU(A.indptr, A.indices, A.shape[0], newton.SPLU_OPTIONS, choice)


def _solve(lu, A, b):
    ident = np.arange(A.nnz, dtype=np.int64)
    return lu.solve(np.ascontiguousarray(A.data), ident, b)


def _random(n, density, seed, diag=1.0):
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=density, random_state=rng, format="csc")
    return (A + diag * sp.identity(n)).tocsc()


@pytest.mark.parametrize("seed", range(6))
def test_matches_superlu_on_random_matrices(seed):
    n = 60 + 20 * seed
    A, lu = _lu(_random(n, 0.05, seed))
    b = np.random.default_rng(seed).standard_normal(n)
    x = _solve(lu, A, b)
    assert lu.kind == "left_looking"
    np.testing.assert_allclose(A @ x, b, atol=1e-10 * np.linalg.norm(b))
    np.testing.assert_allclose(x, spla.spsolve(A, b), rtol=1e-8, atol=1e-10)


def test_off_diagonal_pivots():
    """No diagonal at all (a cyclic shift, slightly perturbed off the diagonal): every pivot
    is off it."""
    n = 50
    rng = np.random.default_rng(3)
    shift = sp.csc_matrix((rng.uniform(1, 2, n), ((np.arange(n) + 1) % n, np.arange(n))),
                          shape=(n, n))
    noise = sp.random(n, n, density=0.04, random_state=rng, format="lil")
    noise.setdiag(0.0)
    A = sp.csc_matrix(shift + 1e-3 * sp.csc_matrix(noise))
    A.eliminate_zeros()
    assert A.diagonal().max() == 0.0
    _, lu = _lu(A)
    b = rng.standard_normal(n)
    x = _solve(lu, A, b)
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert np.all(lu.pinv[lu.q] != np.arange(n))


def test_singular_matrices_raise():
    n = 20
    A = _random(n, 0.1, 1).tolil()
    A[:, 7] = 0.0                        # a zero column: no pivot
    A = sp.csc_matrix(A)
    A.eliminate_zeros()
    _, lu = _lu(A)
    with pytest.raises(sparse_lu.SingularMatrix):
        _solve(lu, A, np.ones(n))
    B = (_random(n, 0.1, 2) + sp.identity(n)).tolil()
    B[:, 3] = 0.0
    B[:, 5] = 0.0
    B[0, 3], B[0, 5] = 1.0, 2.0          # two columns with one row between them: no pivot
    B = sp.csc_matrix(B)
    B.eliminate_zeros()
    _, lu = _lu(B)
    with pytest.raises(sparse_lu.SingularMatrix):
        _solve(lu, B, np.ones(n))
    assert not np.any(lu.x) and not lu.valid     # the work vector is left zero


def test_subnormal_column_is_singular_not_a_crash():
    """A stored zero on the diagonal beside a subnormal entry: ``0.1 * 5e-324`` rounds to 0,
    which must not make the zero diagonal a pivot (a division by zero)."""
    A = sp.csc_matrix((np.array([0.0, 5e-324, 1.0, 1.0]), np.array([0, 1, 0, 1]),
                       np.array([0, 2, 4])), shape=(2, 2))
    lu = sparse_lu.NewtonLU(A.indptr, A.indices, 2, newton.SPLU_OPTIONS, "left_looking")
    x = _solve(lu, A, np.ones(2))         # the subnormal entry is the pivot
    np.testing.assert_array_equal(x, [0.0, 1.0])      # (exact: x1 = 1 from row 0, x0 = 0)


def test_infinite_pivot_is_refused_by_both_paths():
    A = sp.csc_matrix(np.array([[4.0, 1, 0], [1, 3, 1], [0, 1, 2]]))
    _, lu = _lu(A)
    _solve(lu, A, np.ones(3))
    B = A.copy()
    B.data[B.data == 3.0] = np.inf
    with pytest.raises(sparse_lu.SingularMatrix):       # after a factorization (refactor)
        _solve(lu, B, np.ones(3))
    _, fresh = _lu(B)
    with pytest.raises(sparse_lu.SingularMatrix):       # from scratch
        _solve(fresh, B, np.ones(3))


def test_factors_grow_when_full():
    A, lu = _lu(_random(120, 0.08, 5))
    lu._allocate(130)                    # far too small: FULL_L / FULL_U, then doubled
    b = np.ones(120)
    x = _solve(lu, A, b)
    assert lu.kind == "left_looking" and lu.Li.shape[0] > 130
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)


def test_hands_over_to_superlu_beyond_max_growth():
    A, lu = _lu(_random(120, 0.08, 6))
    lu._allocate(130)
    lu.max_capacity = 200                # no room to grow: SuperLU takes the solves
    b = np.ones(120)
    x = _solve(lu, A, b)
    # (SuperLU then orders each matrix itself: the solve's order no longer fits these
    # matrices, and in it SuperLU would fill as badly)
    assert lu.kind == "splu" and lu.used_left_looking and lu.reorder_each
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)


def test_newton_reports_the_hand_over_to_superlu(monkeypatch):
    monkeypatch.setattr(sparse_lu, "MAX_GROWTH", 0)     # the first growth hands over
    p = manufactured(45, 3, 0.5, seed=3)
    orig = sparse_lu.NewtonLU._allocate

    def small(self, capacity):
        orig(self, min(capacity, self.n + 1))
    monkeypatch.setattr(sparse_lu.NewtonLU, "_allocate", small)
    res = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="left_looking")
    assert res.converged and res.info["linear_solver"] == "left_looking->splu"


def test_factor_flops_counts_updates():
    # a 2x2 full matrix: one update of column 1 by column 0 (one entry below the diagonal)
    A = sp.csc_matrix(np.array([[4.0, 1.0], [1.0, 3.0]]))
    lu = spla.splu(A, permc_spec="NATURAL", diag_pivot_thresh=0.0)
    assert sparse_lu.factor_flops(lu.L, lu.U) == 1
    D = sp.csc_matrix(np.diag([1.0, 2.0, 3.0]))
    lu = spla.splu(D, permc_spec="NATURAL")
    assert sparse_lu.factor_flops(lu.L, lu.U) == 0


def test_choice_follows_the_fill():
    # a block-diagonal pattern: no fill, left-looking
    n = 300
    A = sp.block_diag([np.ones((3, 3)) + 3 * np.eye(3)] * (n // 3), format="csc")
    _, lu = _lu(A, "auto")
    assert lu.kind == "left_looking" and lu.flops <= sparse_lu.LEFT_LOOKING_MAX_FLOPS_PER_ROW * n
    # the same with its block size: uncoupled contacts, natural order, no ordering computed
    lu = sparse_lu.NewtonLU(A.indptr, A.indices, n, newton.SPLU_OPTIONS, "auto", block=3)
    assert lu.kind == "left_looking" and lu.flops == 0
    np.testing.assert_array_equal(lu.q, np.arange(n))
    x = _solve(lu, A, np.ones(n))
    np.testing.assert_allclose(A @ x, np.ones(n), atol=1e-12)
    # a full pattern: many entries per row, SuperLU whatever the flop count (the ordering
    # computed all the same: SuperLU factorizes in it)
    F = sp.csc_matrix(np.ones((60, 60)) + 60 * np.eye(60))
    _, lu = _lu(F, "auto")
    assert lu.kind == "splu" and lu.flops > 0 and sorted(lu.q) == list(range(60))
    # an arrow-and-band pattern of few entries per row but heavy fill: SuperLU by the flops
    m = 400
    rng = np.random.default_rng(0)
    rows = rng.integers(0, m, 8 * m)
    cols = rng.integers(0, m, 8 * m)
    R = sp.csc_matrix((np.ones(rows.size), (rows, cols)), shape=(m, m)) + m * sp.identity(m)
    R = sp.csc_matrix(R)
    _, lu = _lu(R, "auto")
    assert R.nnz <= sparse_lu.SPLU_ROW_ENTRIES * m
    assert lu.flops > sparse_lu.LEFT_LOOKING_MAX_FLOPS_PER_ROW * m and lu.kind == "splu"


def _manufactured_paths(p, tol):
    a = socp_cd.solve(p, "newton", tol=tol, linear_solver="left_looking")
    b = socp_cd.solve(p, "newton", tol=tol, linear_solver="splu")
    assert a.info["linear_solver"] == "left_looking" and b.info["linear_solver"] == "splu"
    for res in (a, b):
        assert res.converged and socp_cd.error(p, res.r) <= tol
    return a, b


@pytest.mark.parametrize("structure", ["tree", "redundant"])
def test_newton_left_looking_agrees_with_superlu(structure):
    """Same Newton iterates up to rounding (same ordering rule, same pivot threshold), on an
    SPD and on a rank-deficient W (the proximal term makes J nonsingular)."""
    kw = {"bodies_per_contact": 0.5} if structure == "redundant" else {}
    p = manufactured(45, 3, 0.5, structure=structure, seed=11, **kw)
    a, b = _manufactured_paths(p, 1e-10)
    np.testing.assert_allclose(a.u, b.u, atol=1e-8 * max(1.0, np.linalg.norm(b.u)))


def test_newton_left_looking_on_an_asymmetric_w():
    p = manufactured(40, 3, 0.3, seed=5)
    rng = np.random.default_rng(5)
    W = p.W.toarray()
    W = W + 0.05 * np.abs(W).max() * np.triu(rng.standard_normal(W.shape), 1) * (W != 0)
    r_star = socp_cd.solve(p, "newton", tol=1e-12).r
    u_star = p.W @ r_star + p.q        # the same solution on the asymmetric operator
    q = u_star - W @ r_star
    asym = socp_cd.FrictionContactProblem(sp.csr_matrix(W), q, p.mu, 3)
    _manufactured_paths(asym, 1e-9)


def test_default_sparse_path_is_the_left_looking_lu_on_low_fill():
    p = manufactured(60, 3, 0.5, seed=2)         # m = 180 > DENSE_ALWAYS_M, a tree: no fill
    assert p.m > newton.DENSE_ALWAYS_M
    res = socp_cd.solve(p, "newton", tol=1e-10)
    assert res.converged and res.info["linear_solver"] == "left_looking"
    assert 0 <= res.info["lu_refactorizations"] < res.info["factorizations"]


def test_kernel_solve_matches_dense_inverse():
    """lu_factor / lu_solve directly: P A Q = L U reproduces A on a small full matrix."""
    rng = np.random.default_rng(9)
    n = 12
    M = rng.standard_normal((n, n)) + n * np.eye(n)
    A = sp.csc_matrix(M)
    q = rng.permutation(n).astype(np.int64)
    cap = n * n + n
    Lp, Up = np.empty(n + 1, np.int64), np.empty(n + 1, np.int64)
    Li, Lx, Ui, Ux = (np.empty(cap, np.int64), np.empty(cap), np.empty(cap, np.int64),
                      np.empty(cap))
    pinv, xi, ps, mark = (np.empty(n, np.int64) for _ in range(4))
    x = np.zeros(n)
    st, lnz, unz = kernel.lu_factor(n, A.indptr.astype(np.int64), A.indices.astype(np.int64),
                                    A.data, q, 0.1, Lp, Li, Lx, Up, Ui, Ux, pinv, xi, ps, x, mark)
    assert st == kernel.OK
    L = sp.csc_matrix((Lx[:lnz], Li[:lnz], Lp), shape=(n, n)).toarray()
    U = sp.csc_matrix((Ux[:unz], Ui[:unz], Up), shape=(n, n)).toarray()
    P = np.zeros((n, n))
    P[pinv, np.arange(n)] = 1.0         # row i of A is row pinv[i] of P A
    np.testing.assert_allclose(P @ M[:, q], L @ U, atol=1e-12 * np.abs(M).max())
    b = rng.standard_normal(n)
    out, work = np.empty(n), np.empty(n)
    kernel.lu_solve(n, pinv, q, Lp, Li, Lx, Up, Ui, Ux, b, work, out)
    np.testing.assert_allclose(out, np.linalg.solve(M, b), rtol=1e-10)


def test_refactorization_reuses_the_pivots():
    # (a dominant diagonal: the pivots pass the threshold again after the values change,
    # whatever the column order; with diag=1 they did in COLAMD's order, not in MMD's)
    A, lu = _lu(_random(90, 0.06, 7, diag=5.0))
    b = np.random.default_rng(7).standard_normal(90)
    _solve(lu, A, b)
    B = A.copy()
    B.data = B.data * np.random.default_rng(8).uniform(0.8, 1.25, B.nnz)     # same pattern
    x = _solve(lu, B, b)
    assert (lu.factorizations, lu.refactorizations) == (1, 1)
    np.testing.assert_allclose(x, spla.spsolve(B, b), rtol=1e-9, atol=1e-11)


def test_refactorization_falls_back_on_a_bad_pivot():
    """The second matrix has a zero where the first one's pivot was (same pattern, a stored
    zero): the refactorization refuses it and the pivot search runs again."""
    n = 40
    band = sp.diags([np.ones(n - 1), np.ones(n - 1)], [-1, 1])    # entries off the diagonal
    A, lu = _lu(_random(n, 0.1, 9, diag=5.0) + band)
    b = np.ones(n)
    _solve(lu, A, b)
    k0 = int(lu.q[0])                    # the first column: its pivot was its diagonal
    assert lu.pinv[k0] == 0
    B = A.copy()
    col = slice(B.indptr[k0], B.indptr[k0 + 1])
    rows = B.indices[col]
    vals = B.data[col].copy()
    vals[rows == k0] = 0.0
    B.data[col] = vals
    x = _solve(lu, B, b)
    assert (lu.factorizations, lu.refactorizations) == (2, 0)
    assert np.linalg.norm(B @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert not np.any(lu.x)


def _symmetric_pattern(n, seed, diag=4.0):
    """A random matrix of symmetric pattern (values unsymmetric), ``diag`` on its diagonal."""
    rng = np.random.default_rng(seed)
    S = sp.random(n, n, density=0.04, random_state=rng, format="csc")
    P = (S + S.T).tocsc()
    P.data = rng.uniform(-1.0, 1.0, P.nnz)
    return (P + diag * sp.identity(n)).tocsc()


def _spy_splu(monkeypatch):
    calls = []
    original = spla.splu

    def spy(A, **kw):
        calls.append((A.copy(), kw))
        return original(A, **kw)

    monkeypatch.setattr(sparse_lu.spla, "splu", spy)
    return calls


def test_superlu_factorizes_in_the_solve_order(monkeypatch):
    """Kind "splu": each matrix goes to SuperLU permuted into the order computed once
    (``A[q][:, q]``, ``permc_spec="NATURAL"``, stored zeros dropped), and the solution is
    mapped back."""
    A, lu = _lu(_symmetric_pattern(120, 3), "splu")
    assert lu.kind == "splu" and sorted(lu.q) == list(range(120))
    A.data[::7] = 0.0           # stored zeros (a separated contact's rows)
    A.setdiag(4.0)
    calls = _spy_splu(monkeypatch)
    b = np.random.default_rng(3).standard_normal(120)
    for _ in range(2):
        x = _solve(lu, A, b)
        np.testing.assert_allclose(A @ x, b, atol=1e-12 * np.abs(b).max())
    assert len(calls) == 2
    for M, kw in calls:
        assert kw["permc_spec"] == "NATURAL" and M.nnz == np.count_nonzero(A.data)
        np.testing.assert_array_equal(M.toarray(), A.toarray()[lu.q][:, lu.q])
    assert not lu.reorder_each


def test_superlu_orders_each_matrix_after_fill_growth(monkeypatch):
    """When an ordered factorization stores more than SPLU_FILL_GROWTH times the ordering's
    own, the later matrices go to SuperLU as they are, with its per-call ordering (COLAMD)."""
    A, lu = _lu(_symmetric_pattern(120, 4), "splu")
    monkeypatch.setattr(sparse_lu, "SPLU_FILL_GROWTH", 1e-3)
    calls = _spy_splu(monkeypatch)
    b = np.ones(120)
    x1 = _solve(lu, A, b)
    assert lu.reorder_each                  # (the first step's factors still used)
    x2 = _solve(lu, A, b)
    for x in (x1, x2):
        np.testing.assert_allclose(A @ x, b, atol=1e-12)
    assert [kw["permc_spec"] for _, kw in calls] == ["NATURAL", newton.SPLU_OPTIONS["permc_spec"]]


def test_superlu_orders_each_matrix_without_the_knob(monkeypatch):
    """SPLU_ORDER_ONCE = False: session 38's path (no ordering computed, SuperLU orders)."""
    monkeypatch.setattr(sparse_lu, "SPLU_ORDER_ONCE", False)
    A, lu = _lu(_symmetric_pattern(80, 5), "splu")
    assert lu.q is None and lu.flops is None
    calls = _spy_splu(monkeypatch)
    x = _solve(lu, A, np.ones(80))
    np.testing.assert_allclose(A @ x, np.ones(80), atol=1e-12)
    assert calls[0][1]["permc_spec"] == newton.SPLU_OPTIONS["permc_spec"]


def test_the_ordering_is_minimum_degree_on_a_plus_at():
    """The order of a symmetric pattern (a 2D grid: the contact network of a deposit) fills
    less than COLAMD's order of AᵀA, the reason for :data:`sparse_lu.ORDERING`."""
    g = 40
    T = sp.diags([-np.ones(g - 1), 4 * np.ones(g), -np.ones(g - 1)], [-1, 0, 1])
    A = (sp.kron(sp.identity(g), T) + sp.kron(sp.diags([np.ones(g - 1)] * 2, [-1, 1]),
                                               -sp.identity(g))).tocsc()
    A.sort_indices()
    n = g * g
    q, flops, nnz, stored = sparse_lu.column_order(A.indptr, A.indices, n, newton.SPLU_OPTIONS)
    assert sorted(q) == list(range(n)) and stored > 0
    # the matrix permuted into q and factorized in its natural order fills as the ordering said
    ordered = spla.splu(A[q][:, q].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.1,
                       options={"SymmetricMode": True})
    assert ordered.nnz == stored
    colamd = spla.splu(A, permc_spec="COLAMD", diag_pivot_thresh=0.1,
                       options={"SymmetricMode": True})
    assert nnz < 0.8 * (colamd.L.nnz + colamd.U.nnz)


def test_newton_reports_the_reordering(monkeypatch):
    """Newton with SuperLU: the solution as with the left-looking LU, and ``info`` says when
    SuperLU went back to ordering each matrix."""
    p = manufactured(60, 3, 0.4, seed=6)
    a = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="splu")
    assert a.converged and "splu_reordered" not in a.info
    monkeypatch.setattr(sparse_lu, "SPLU_FILL_GROWTH", 1e-3)
    b = socp_cd.solve(p, "newton", tol=1e-10, linear_solver="splu")
    assert b.converged and b.info["splu_reordered"] is True
    np.testing.assert_allclose(a.r, b.r, rtol=1e-6, atol=1e-9 * np.abs(a.r).max())


def test_the_polish_counts_its_set_up_in_its_time_limit(monkeypatch):
    """``newton_polish``'s ``time_limit`` bounds the whole call: the system's set-up (here an
    ordering made slow) leaves the Newton loop only what remains."""
    import time
    p = manufactured(150, 3, 0.4, seed=6)
    real_order, seen = sparse_lu.column_order, []

    def slow_order(*args):
        time.sleep(0.3)
        return real_order(*args)

    real_loop = newton.prox_newton

    def spy(*args, **kw):
        seen.append(kw["time_limit"])
        return real_loop(*args, **kw)

    monkeypatch.setattr(sparse_lu, "column_order", slow_order)
    monkeypatch.setattr(newton, "prox_newton", spy)
    r, info = newton.newton_polish(p, np.zeros(p.m), 1e-8,
                                   {"max_iter": 30, "law": "coulomb", "time_limit": 0.2})
    assert seen == [1e-9]                    # the set-up took the whole budget
    q = p.with_()                            # a new problem: its own ordering, 0.3 s again
    newton.newton_polish(q, np.zeros(q.m), 1e-8, {"max_iter": 30, "law": "coulomb",
                                                  "time_limit": 5.0})
    assert 4.0 < seen[-1] < 4.71              # 5 s minus the 0.3 s set-up (and some)
    newton.newton_polish(q, np.zeros(q.m), 1e-8, {"max_iter": 30, "law": "coulomb",
                                                  "time_limit": 5.0})
    assert seen[-1] > 4.75                    # the ordering is kept on the problem

"""The dispatcher's compiled checks equal the NumPy references; per-problem caches are exact."""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd import residuals
from socp_cd.problem import FrictionContactProblem, GlobalFrictionContactProblem, Solution
from socp_cd.solvers import checks
from socp_cd.solvers.kernels import cone as kc
from socp_cd.solvers.scaling import balanced


def _problem(nc, dim, seed, mu=0.5):
    """A random local problem with unbalanced units (contacts of very different stiffness)."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((nc * dim, nc * dim))
    S = np.repeat(10.0 ** rng.uniform(-3, 3, nc), dim)
    W = S[:, None] * (A @ A.T + nc * dim * np.eye(nc * dim)) * S[None, :]
    return FrictionContactProblem(W, 1e4 * rng.standard_normal(nc * dim), mu, dim)


def _candidates(p, seed):
    """Random reactions at several scales, r = 0, and a solver's answer."""
    rng = np.random.default_rng(seed)
    out = [np.zeros(p.m), socp_cd.solve(p, "nsgs", tol=1e-10, max_iter=500).r]
    out += [s * rng.standard_normal(p.m) for s in (1e-20, 1e-3, 1.0, 1e6)]
    return out


@pytest.mark.parametrize("dim,nc", [(2, 1), (3, 1), (2, 6), (3, 7)])
def test_compiled_checks_equal_reference(dim, nc):
    p = _problem(nc, dim, seed=10 * dim + nc)
    for r in _candidates(p, nc):
        u = p.velocity(r)
        assert checks.coulomb_error(p, r, u) == pytest.approx(residuals.error(p, r, u),
                                                               rel=1e-12, abs=1e-14)
        fast, ref = checks.coulomb_guard(p, r, u), residuals.guard(p, r, u)
        assert fast.keys() == ref.keys()
        for key in ref:
            assert fast[key] == pytest.approx(ref[key], rel=1e-12, abs=1e-14), key


def test_violation_kernel_equals_reference_parts():
    p = _problem(9, 3, seed=3, mu=np.linspace(0.0, 2.0, 9))
    rng = np.random.default_rng(0)
    r, u = rng.standard_normal(p.m), rng.standard_normal(p.m)
    cone, normal, gap = kc.coulomb_violations(r, u, p.mu, p.dim)
    ref = residuals.coulomb_parts(r, u, p, 2.0)
    assert cone / 2.0 == pytest.approx(ref["cone"], rel=1e-13)
    assert normal / 2.0 == pytest.approx(ref["normal_velocity"], rel=1e-13)
    assert gap / 4.0 == pytest.approx(ref["complementarity"], rel=1e-13)


def test_cached_problem_quantities_are_the_computed_ones():
    p = _problem(5, 3, seed=1)
    assert p.zero_error == residuals.error(p, np.zeros(p.m)) == p.trivial_error()
    a, b = residuals.contact_scales(p)
    rec = balanced(p)
    assert np.allclose(rec.a, a, rtol=1e-14, atol=0) and np.allclose(rec.b, b, rtol=1e-14, atol=0)
    assert p.q_norm == float(np.linalg.norm(p.q))
    assert rec.q_norm == pytest.approx(float(np.linalg.norm(p.q / b)), rel=1e-14)
    assert balanced(p) is rec and rec.problem is balanced(p).problem     # built once
    with pytest.raises(ValueError):
        rec.a[0] = 1.0                                     # the cache cannot be altered by a caller
    with pytest.raises(ValueError):
        rec.problem.q[0] = 1.0


def _awkward_problems():
    """Local problems the balancing must get right: unbalanced, missing or zero or
    negative diagonal entries, q = 0, 2D and 3D, mu = 0."""
    out = [_problem(6, 3, seed=4), _problem(5, 2, seed=5, mu=0.0), _problem(1, 3, seed=6)]
    rng = np.random.default_rng(7)
    W = rng.standard_normal((9, 9))
    W[0, 0] = W[1, 1] = W[2, 2] = 0.0            # a contact with no diagonal of its own
    W[4, 4] = -3.0                                # a negative diagonal entry (|.| is taken)
    out.append(FrictionContactProblem(W, rng.standard_normal(9), 0.3, 3))
    out.append(FrictionContactProblem(np.zeros((6, 6)), rng.standard_normal(6), 0.5, 3))   # W = 0
    out.append(FrictionContactProblem(np.eye(6) * 1e8, np.zeros(6), 1.0, 2))                # q = 0
    return out


@pytest.mark.parametrize("k", range(6))
def test_compiled_balancing_equals_the_references(k):
    """scaling.balanced (one compiled pass) = contact_scales + rescaled + error(r = 0)."""
    p = _awkward_problems()[k]
    a, b = residuals.contact_scales(p)
    rec = balanced(p)
    assert np.allclose(rec.a, a, rtol=1e-14, atol=0) and np.allclose(rec.b, b, rtol=1e-14, atol=0)
    ref = p.rescaled(a, b)
    assert np.array_equal(rec.problem.W.indices, ref.W.indices)
    assert np.array_equal(rec.problem.W.indptr, ref.W.indptr)
    assert np.allclose(rec.problem.W.data, ref.W.data, rtol=1e-13, atol=0)
    assert np.allclose(rec.problem.q, ref.q, rtol=1e-13, atol=0)
    assert rec.q_norm == pytest.approx(float(np.linalg.norm(ref.q)), rel=1e-13)
    assert rec.raw_q_norm == pytest.approx(float(np.linalg.norm(p.q)), rel=1e-14)
    assert rec.zero_error == pytest.approx(residuals.error(p, np.zeros(p.m)), rel=1e-13, abs=1e-300)
    assert checks.zero_error(p) == rec.zero_error


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_zero_error_is_the_reference(dim):
    """checks.zero_error (compiled, local problems) = the cached NumPy reference, mu = 0 included."""
    for seed, mu in enumerate((0.0, 0.5, np.array([0.0, 0.3, 0.0, 1.0, 2.0]))):
        p = _problem(5, dim, seed=seed, mu=mu)
        for q in (p.q, np.abs(p.q), -np.abs(p.q), np.zeros(p.m)):   # separated / closing / none
            pq = FrictionContactProblem(p.W, q, p.mu, dim)
            assert checks.zero_error(pq) == pytest.approx(pq.zero_error, rel=1e-13, abs=1e-300)


def test_rescaled_equals_the_validated_construction():
    p = _problem(4, 3, seed=2)
    p.solution = Solution(r=np.arange(p.m, dtype=float), u=np.ones(p.m))
    a, b = balanced(p).a, balanced(p).b
    s = np.sqrt(a / b)
    fast = p.rescaled(a, b)
    ref = FrictionContactProblem(s[:, None] * p.W.toarray() * s[None, :], p.q / b, p.mu, p.dim)
    assert np.allclose(fast.W.toarray(), ref.W.toarray(), rtol=1e-15, atol=0)
    assert np.array_equal(fast.q, ref.q) and np.array_equal(fast.mu, ref.mu)
    assert np.array_equal(fast.solution.r, p.solution.r / a)
    assert np.array_equal(fast.solution.u, p.solution.u / b)
    # a solution of the balanced problem maps back to one of the original
    res = socp_cd.solve(fast, "nsgs", tol=1e-12, max_iter=1000)
    assert residuals.error(p, a * res.r) < 1e-9


def test_global_problem_condensed_once():
    rng = np.random.default_rng(5)
    n, m = 12, 9
    A = rng.standard_normal((n, n))
    p = GlobalFrictionContactProblem(A @ A.T + n * np.eye(n), rng.standard_normal((n, m)),
                                     rng.standard_normal(n), rng.standard_normal(m), 0.3, 3)
    assert p.local is p.local
    ref = p.to_local()
    assert np.array_equal(p.local.W.toarray(), ref.W.toarray())
    assert np.array_equal(p.local.q, ref.q)


@pytest.mark.parametrize("seed", range(3))
def test_compiled_global_scales_equal_the_reference(seed):
    """scaling.balanced of a global problem (compiled Jacobi estimate) = contact_scales."""
    rng = np.random.default_rng(40 + seed)
    n, m = 10, 9
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    if seed == 1:
        M[0, 0] = 0.0                 # a zero mass entry: no Jacobi weight for that dof
    H = rng.standard_normal((n, m))
    if seed == 2:
        H[:, :3] = 0.0                # a contact with no coupling: filled by the geometric mean
    p = GlobalFrictionContactProblem(M, H, rng.standard_normal(n), 1e3 * rng.standard_normal(m),
                                     0.4, 3)
    a, b = residuals.contact_scales(p)
    rec = balanced(p)
    assert rec.problem is None
    assert np.allclose(rec.a, a, rtol=1e-14, atol=0) and np.allclose(rec.b, b, rtol=1e-14, atol=0)
    assert rec.q_norm == pytest.approx(float(np.linalg.norm(p.q_local / b)), rel=1e-13)
    assert rec.raw_q_norm == pytest.approx(p.q_norm, rel=1e-14)
    # the compiled error of r = 0 (u = q_local) is the NumPy reference's
    assert rec.zero_error == pytest.approx(residuals.error(p, np.zeros(p.m)), rel=1e-13, abs=1e-300)
    assert checks.zero_error(p) == rec.zero_error == pytest.approx(p.zero_error, rel=1e-13)


def test_problem_from_csr_arrays_builds_its_matrix_only_when_asked():
    """from_checked with CSR arrays: csr_parts without scipy, W built once and equal."""
    p = _problem(4, 3, seed=11)
    rec = balanced(p)
    bp = rec.problem
    assert bp._W is None                      # NSGS / Newton / Clarabel's small path need no scipy W
    indptr, indices, data = bp.csr_parts
    assert indptr is p.W.indptr and indices is p.W.indices        # same sparsity, shared
    W = bp.W
    assert bp.W is W and bp._W is W                               # built once
    assert np.array_equal(W.toarray(), p.rescaled(rec.a, rec.b).W.toarray())
    # the arrays the problem was made with, kept (made once: the compiled calls read them),
    # the matrix's entries
    assert all(x is y for x, y in zip(bp.csr_parts, (indptr, indices, data)))
    assert all(np.array_equal(x, y) for x, y in zip(bp.csr_parts, (W.indptr, W.indices, W.data)))
    # a problem made from a matrix: its arrays, the tuple made with the problem
    assert p.csr_parts is p.csr_parts and all(
        x is y for x, y in zip(p.csr_parts, (p.W.indptr, p.W.indices, p.W.data)))


def test_block_storage_from_arrays_equals_block_csr():
    """problem_blocks (from the problem's CSR arrays, kept on it) = block_csr of its matrix."""
    from socp_cd.solvers.block_storage import block_csr, problem_blocks
    for p in _awkward_problems()[:4]:
        bp = balanced(p).problem
        S = problem_blocks(bp)
        assert problem_blocks(bp) is S
        ref = block_csr(bp.W, bp.dim)
        for name in ("indptr", "indices", "blocks", "diag_pos", "diag"):
            assert np.array_equal(getattr(S, name), getattr(ref, name)), name


@pytest.mark.parametrize("seed", range(3))
def test_condensation_in_one_block_equals_the_chunked_product(seed):
    """to_local's one-block path (m <= chunk) = the chunked sparse product, bit for bit,
    with structural zeros (an uncoupled contact) and exact cancellations dropped."""
    rng = np.random.default_rng(60 + seed)
    n, m = 10, 9
    A = rng.standard_normal((n, n))
    H = rng.standard_normal((n, m))
    H[:, 3:6] = 0.0                             # contact 1 sees no dof: zero rows and columns of W
    if seed == 1:
        H[:5, :] = 0.0                         # some dofs carry no contact
    p = GlobalFrictionContactProblem(np.diag(rng.uniform(1, 3, n)) if seed == 2 else
                                     A @ A.T + n * np.eye(n), H, rng.standard_normal(n),
                                     rng.standard_normal(m), 0.3, 3)
    one, chunked = p.to_local(), p.to_local(chunk=2)
    for name in ("indptr", "indices", "data"):
        assert np.array_equal(getattr(one.W, name), getattr(chunked.W, name)), name
    assert np.array_equal(one.q, chunked.q)
    assert 0.0 not in one.W.data


@pytest.mark.parametrize("seed", range(4))
def test_compiled_velocity_is_scipys_bit_for_bit(seed):
    """checks.velocity (compiled CSR mat-vec) = problem.velocity = W @ r + q exactly:
    empty rows, unsorted column indices and a read-only q included."""
    import scipy.sparse as sp
    from socp_cd.solvers.kernels.dense import csr_matvec_add
    rng = np.random.default_rng(80 + seed)
    m = 3 * (1 + seed * 7)
    A = sp.random(m, m, density=0.3, random_state=seed, format="csr") * 1e3
    A = A.tocsr()
    A.data[:] = rng.standard_normal(A.nnz) * 10.0 ** rng.uniform(-8, 8, A.nnz)
    if seed == 3 and A.nnz > 1:                       # unsorted columns within rows
        for i in range(m):
            lo, hi = A.indptr[i], A.indptr[i + 1]
            A.indices[lo:hi] = A.indices[lo:hi][::-1].copy()
            A.data[lo:hi] = A.data[lo:hi][::-1].copy()
        A.has_sorted_indices = False
    p = FrictionContactProblem(A, rng.standard_normal(m), 0.4, 3)
    r = rng.standard_normal(m) * 1e4
    assert np.array_equal(checks.velocity(p, r), p.velocity(r))
    bp = balanced(p).problem                          # CSR arrays, read-only q
    assert np.array_equal(checks.velocity(bp, r), bp.W @ r + bp.q)
    assert np.array_equal(csr_matvec_add(A.indptr, A.indices, A.data, r, np.zeros(m)), A @ r)


def _claiming_solver(deltas, calls):
    """A solver that claims convergence and returns the balanced problem's solution
    perturbed by ``deltas[k]`` on its k-th call (recording the tolerances it is given)."""
    def func(problem, formulation, *, tol, max_iter=None, r0=None, **kw):
        ref = socp_cd.solve(problem, "nsgs", tol=1e-14, max_iter=20000).r
        calls.append(tol)
        r = ref * (1.0 + deltas[len(calls) - 1])
        return socp_cd.SolverResult(r=r, status="converged", iterations=1,
                                    info={"work": 10 * len(calls), "flag": True})
    return func


@pytest.mark.parametrize("second, kept", [(1e-13, "retry"), (1e-3, "first"), (1e-6, "retry")])
def test_retry_after_a_refuted_claim_keeps_the_better_answer(second, kept):
    """A refuted claim of convergence is retried once with a tighter tol; the retry is kept
    when it converges, or when it fails by less than the first answer (its larger measure)."""
    p = _problem(4, 3, seed=21)
    calls = []
    res = socp_cd.solve(p, _claiming_solver([1e-4, second], calls), tol=1e-8)
    assert len(calls) == 2 and calls[1] < calls[0] == 1e-8
    rec = res.info["retry"]
    assert rec["kept"] == kept and res.iterations == 2
    worse = max(res.error, res.info["guard"]["value"])
    if kept == "retry":
        assert res.error == rec["retry_error"] < rec["first_error"]
        assert res.converged == (second == 1e-13)
    else:
        assert res.error == rec["first_error"] < rec["retry_error"] and not res.converged
    assert worse <= max(rec["first_error"], rec["first_guard"])
    # each run's own counters (the kept run's stay in info; booleans are not counters)
    assert rec["first_counts"] == {"work": 10} and rec["retry_counts"] == {"work": 20}
    assert res.info["work"] == (20 if kept == "retry" else 10)


def test_factor_kernels_equal_numpy():
    from socp_cd.solvers.kernels.scaling import factor_summary, times_factors
    for dim, nc in ((2, 5), (3, 9)):
        p = _problem(nc, dim, seed=dim)
        rec = balanced(p)
        a, b = rec.a, rec.b
        d = b[::dim] / a[::dim]
        assert factor_summary(a, b, dim) == (np.sqrt(a[0] * b[0]), d.min(), d.max())
        r = np.random.default_rng(dim).standard_normal(p.m)
        np.testing.assert_array_equal(times_factors(r, a), r * a)
    huge = np.full(3, 1e300)
    assert np.isinf(times_factors(huge, huge)).all()    # overflow: inf, no warning raised


@pytest.mark.parametrize("solver", ["auto", "nsgs", "newton"])
def test_public_guard_is_what_solve_judged(solver):
    # socp_cd.guard (public, used by validation/newton_vs_siconos.py to judge Siconos' answers)
    # gives the value solve() accepted or refused, for routed and general-path calls alike
    for dim, nc, seed in ((3, 1, 1), (2, 4, 2), (3, 7, 3)):
        p = _problem(nc, dim, seed)
        res = socp_cd.solve(p, solver, tol=1e-9)
        value = socp_cd.guard(p, res.r)["value"]
        assert value == pytest.approx(res.info["guard"]["value"], rel=1e-9, abs=1e-15)
        assert res.converged == (res.error <= 1e-9 and value <= 1e-9)

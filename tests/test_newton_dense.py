"""The compiled Newton loops (kernels/newton_dense.py: proximal and plain) equal their Python reference.

``prox_newton(..., compiled=False)`` is the Python loop, ``compiled=None`` (the
default) runs the twin on small dense local systems: same status, same number
of outer iterations, same counters and the same ``r`` on cold and warm starts,
real and manufactured problems (stick, slide, separated, grazing contacts,
rank-deficient and asymmetric ``W``, ``mu = 0``), budgets that run out, stalls,
non-finite starts and the time-limit chunking.
"""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd import cones
from socp_cd.bench.evalset import manufacture_local
from socp_cd.bench.generators import manufactured
from socp_cd.data import shared_problems
from socp_cd.errors import UnsupportedError
from socp_cd.problem import FrictionContactProblem
from socp_cd.solvers import newton as nt
from socp_cd.solvers import nsgs_route
from socp_cd.solvers.kernels.cone import project_cone_stacked, siconos_error
from socp_cd.solvers.kernels.dense import LAPACK_LU, WRITTEN_OUT, envelope_fraction

#: settings of a cold solve (newton_backend's defaults) and of the polish (newton_polish)
COLD = dict(alpha0=nt.COLD_ALPHA0, alpha_min=1e-10, inner_max_iter=10, stall_window=50)
#: session 13's cold start (alpha0 = 1): the twins held equal there too
COLD_1 = dict(COLD, alpha0=1.0)
WARM = dict(COLD, alpha0=nt.WARM_ALPHA0)
#: shared problems with m <= COMPILED_LOOP_MAX_M (1-23 contacts; global ones condensed)
SMALL_SHARED = ["FrictionContact3D_1c.dat", "FrictionContact3D_RR_1c.dat", "Rover11035.dat",
                "FC2D_SliderCrankLagrangian00000.dat", "FC3D_Example1.dat", "Rover1039.dat",
                "Confeti-ex13-4contact-Fc3D-SBM.dat", "Rover3865.dat", "NESpheres_10_1.dat",
                "GFC3D_Example1.dat", "LMGC_GlobalFrictionContactProblem00046.hdf5",
                "OneObject-i1028-138.hdf5.dat"]


def _both(p, r0, tol, max_iter=200, time_limit=None, rho="block", policy="prox",
          equation="alart_curnier", **settings):
    """``(python, compiled)`` results of ``prox_newton`` on ``p`` from ``r0``."""
    settings = settings or COLD
    out = []
    for compiled in (False, True):       # True: the twin, or UnsupportedError
        system = nt.LocalSystem(p, "auto")
        mu = np.ascontiguousarray(p.mu, dtype=np.float64)
        out.append(nt.prox_newton(system, mu, np.array(r0, dtype=np.float64), tol=tol,
                                  max_iter=max_iter, time_limit=time_limit, history=False,
                                  rho=rho, policy=policy, compiled=compiled,
                                  equation=equation, **settings))
    return out


def _assert_equal(a, b):
    sa, ra, ia, _, infa = a
    sb, rb, ib, _, infb = b
    assert (sa, ia) == (sb, ib)
    np.testing.assert_equal(infa, infb)          # every counter, alpha, the internal error
    np.testing.assert_allclose(rb, ra, rtol=1e-12, atol=1e-300)   # bit-identical here


def _shared(name):
    hits = [s for s in shared_problems() if s.file == name]
    if not hits:
        pytest.skip("shared data not available")
    p = socp_cd.read_problem(hits[0].path)
    return p.to_local() if p.is_global else p


def test_dispatch_rules():
    p = manufactured(3, 3, 0.5, seed=0)
    system = nt.LocalSystem(p, "auto")
    assert system.compiled and p.m <= nt.COMPILED_LOOP_MAX_M
    mu = np.ascontiguousarray(p.mu)
    with pytest.raises(UnsupportedError):      # the twin keeps no history
        nt.prox_newton(system, mu, np.zeros(p.m), tol=1e-10, max_iter=5, time_limit=None,
                       history=True, compiled=True, **COLD)
    assert system.lapack == WRITTEN_OUT            # the written-out LU
    # m = 75 > COMPILED_LU_MAX_M: the written-out LU on a contact graph's pattern (a small
    # envelope), LAPACK's on a full W
    big = manufactured(25, 3, 0.5, seed=0)
    indptr, indices, _ = big.csr_parts
    assert envelope_fraction(indptr, indices, big.m) < 0.3
    system = nt.LocalSystem(big, "auto")
    assert system.compiled and system.lapack == WRITTEN_OUT
    rng = np.random.default_rng(0)
    A = rng.standard_normal((big.m, big.m))
    full = FrictionContactProblem(A @ A.T + np.eye(big.m), big.q, big.mu, 3)
    system = nt.LocalSystem(full, "auto")
    assert system.compiled and system.lapack == LAPACK_LU
    assert not nt.LocalSystem(p, "splu").compiled
    huge = manufactured(210, 3, 0.5, seed=0)       # m = 630 > DENSE_MAX_M
    assert not nt.LocalSystem(huge, "dense").compiled


@pytest.mark.parametrize("name", SMALL_SHARED)
def test_twin_equals_python_loop_on_shared_problems(name):
    p = _shared(name)
    assert p.m <= nt.COMPILED_LOOP_MAX_M
    a, b = _both(p, np.zeros(p.m), 1e-10)
    _assert_equal(a, b)
    assert a[0] == "converged"
    # warm start near the solution with the polish's settings, and a short budget
    rng = np.random.default_rng(0)
    r1 = a[1] * (1.0 + 1e-3 * rng.standard_normal(p.m))
    _assert_equal(*_both(p, r1, 1e-12, max_iter=15, **WARM))
    _assert_equal(*_both(p, np.zeros(p.m), 1e-14, max_iter=2, rho="split"))
    _assert_equal(*_both(p, np.zeros(p.m), 1e-10, **COLD_1))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("structure", ["tree", "redundant"])
@pytest.mark.parametrize("mu", [0.0, 0.3, 2.0])
@pytest.mark.parametrize("m, lapack", [(72, False), (90, False), (90, True)])
def test_twin_equals_python_loop_on_manufactured_problems(dim, structure, mu, m, lapack,
                                                          monkeypatch):
    """Mixes of separated/stick/slide/grazing contacts; "redundant": rank-deficient W;
    m = 72 = COMPILED_LU_MAX_M (written-out LU), 90 (the envelope rule's choice: written-out
    on "tree", LAPACK's on "redundant", whose envelope is ~0.75; or LAPACK's with the rule
    switched off)."""
    if lapack:
        monkeypatch.setattr(nt, "COMPILED_LU_MAX_ENVELOPE", -1.0)
    nc = m // dim
    for seed, mix in enumerate([(0.25, 0.35, 0.3, 0.1), (0.0, 0.0, 0.0, 1.0),
                                (0.0, 0.0, 1.0, 0.0), (0.5, 0.0, 0.0, 0.5)]):
        p = manufactured(nc, dim, mu, structure=structure, mix=mix, seed=seed)
        assert bool(p.is_rank_deficient) == (structure == "redundant")
        if lapack or m > nt.COMPILED_LU_MAX_M:
            assert (nt.LocalSystem(p, "auto").lapack == LAPACK_LU) == (
                lapack or structure == "redundant")
        a, b = _both(p, np.zeros(p.m), 1e-10)
        _assert_equal(a, b)
        a, b = _both(p, p.solution.r + 1e-4 * np.abs(p.solution.r).max(), 1e-12, **WARM)
        _assert_equal(a, b)


def test_twin_equals_python_loop_on_asymmetric_w_and_real_w():
    base = manufactured(8, 3, 0.5, seed=4)
    rng = np.random.default_rng(4)
    S = rng.normal(size=(base.m, base.m))
    W = base.W.toarray() + 0.05 * np.abs(base.W).max() * (S - S.T)
    p = FrictionContactProblem(W, base.solution.u - W @ base.solution.r, base.mu, 3)
    assert p.asymmetry > 1e-3
    _assert_equal(*_both(p, np.zeros(p.m), 1e-10))
    # manufactured exact solutions on a real (asymmetric, rank-deficient) W
    real = _shared("FC2D_SliderCrankLagrangian00000.dat")
    for seed in range(3):
        q = manufacture_local(real, 0.4, (0.25, 0.35, 0.3, 0.1), seed)
        _assert_equal(*_both(q, np.zeros(q.m), 1e-10))


@pytest.mark.parametrize("gate, decrease", [(0.5, 0.5), (0.3, 1e-2)])
def test_twin_equals_python_loop_with_another_subproblem_test(gate, decrease, monkeypatch):
    """The subproblem test's constants (newton.INNER_GATE, INNER_DECREASE) are read by both
    loops at call time: a study that sets them gets the same iterates from both, and they
    change the run (another count of factorizations than the default's)."""
    cases = [manufactured(12, 3, 0.5, structure="redundant", seed=3),
             manufactured(20, 2, 2.0, seed=5), _shared("OneObject-i1028-138.hdf5.dat")]
    default = [_both(p, np.zeros(p.m), 1e-10)[0] for p in cases]
    monkeypatch.setattr(nt, "INNER_GATE", gate)
    monkeypatch.setattr(nt, "INNER_DECREASE", decrease)
    changed = 0
    for p, d in zip(cases, default):
        a, b = _both(p, np.zeros(p.m), 1e-10)
        _assert_equal(a, b)
        assert a[0] == "converged"
        changed += a[4]["factorizations"] != d[4]["factorizations"]
    assert changed >= 1          # (the constants reach both loops)
    c = nt.trial_constants()
    assert (c[nsgs_route.C_INNER_GATE], c[nsgs_route.C_INNER_DECREASE]) == (gate, decrease)


def test_twin_equals_python_loop_when_it_stalls_runs_out_or_overflows():
    p = manufactured(9, 3, 1.0, structure="redundant", seed=2)
    a, b = _both(p, np.zeros(p.m), 1e-16, max_iter=40, **dict(COLD, stall_window=3))
    _assert_equal(a, b)
    assert a[0] in ("stalled", "converged")
    a, b = _both(p, np.zeros(p.m), 1e-16, max_iter=3)
    _assert_equal(a, b)
    assert a[0] == "max_iter" and a[2] == 3
    # a start of 1e300: its error is finite (measured scaled: kernels.cone.law_error), so
    # both loops iterate from it, equally; a start whose u = W r + q overflows: the error is
    # not finite -> numerical_error in both
    a, b = _both(p, np.full(p.m, 1e300), 1e-10, max_iter=5)
    _assert_equal(a, b)
    assert a[0] == "max_iter" and np.all(np.isfinite(a[1])) and np.max(np.abs(a[1])) < 1e300
    a, b = _both(p, np.full(p.m, 1.7e308), 1e-10, max_iter=5)
    _assert_equal(a, b)
    assert a[0] == "numerical_error"


def test_time_limit_stops_the_twin_where_it_stops_the_python_loop():
    p = manufactured(9, 3, 0.5, seed=5)
    a, b = _both(p, np.zeros(p.m), 1e-10)
    c = _both(p, np.zeros(p.m), 1e-10, time_limit=1e9)      # a deadline far away
    _assert_equal(a, c[0])
    _assert_equal(b, c[1])
    # a spent budget: both loops stop after one outer iteration (the twin reads the
    # compiled clock where the Python loop reads its own)
    py, tw = _both(p, np.zeros(p.m), 1e-10, time_limit=0.0)
    _assert_equal(py, tw)
    assert py[0] == "time_limit" and py[2] == 1


def test_time_limit_chunks_without_the_compiled_clock(monkeypatch):
    from socp_cd.solvers.kernels import clock
    p = manufactured(9, 3, 0.5, seed=5)
    a = _both(p, np.zeros(p.m), 1e-10)[1]
    monkeypatch.setattr(clock, "AVAILABLE", False)
    c = _both(p, np.zeros(p.m), 1e-10, time_limit=1e9)[1]     # chunks of outer iterations
    _assert_equal(a, c)
    # a spent budget: the twin stops after one chunk (newton.CHUNK_WORK: here
    # 3e6 / (10 * 27^3 / 3) = 45 iterations, capped at CHUNK_MAX = 64: enough to converge)
    tw = _both(p, np.zeros(p.m), 1e-10, time_limit=0.0)[1]
    assert tw[0] == "converged" and tw[2] == a[2]
    monkeypatch.setattr(nt, "CHUNK_WORK", 1.0)                 # one iteration per chunk
    d = _both(p, np.zeros(p.m), 1e-10, time_limit=0.0)
    assert [x[0] for x in d] == ["time_limit"] * 2 and [x[2] for x in d] == [1, 1]
    # the Python loop cuts the subproblem at its deadline (after its first Newton step); the
    # twin, without the compiled clock, runs whole outer iterations between chunks
    assert d[0][4]["newton_steps"] == 1 < d[1][4]["newton_steps"]
    monkeypatch.setattr(nt, "CHUNK_WORK", 2 * 10 * 27 ** 3 / 3)  # two per chunk
    tw2 = _both(p, np.zeros(p.m), 1e-10, time_limit=0.0)[1]
    assert tw2[0] == "time_limit" and tw2[2] == 2


def test_a_spent_deadline_cuts_the_subproblem_in_both_loops():
    # a deadline passed before the subproblem's second factorization: the Python loop and
    # the twin (the compiled clock) both stop after one outer iteration of one Newton step,
    # with the same iterate and counters; without a limit the same run takes more steps
    p = manufactured(9, 3, 0.5, seed=5)
    free = _both(p, np.zeros(p.m), 1e-10)
    assert free[0][4]["newton_steps"] > free[0][2] >= 2      # several steps per subproblem
    cut = _both(p, np.zeros(p.m), 1e-10, time_limit=0.0)
    _assert_equal(*cut)
    status, r, its, _, info = cut[0]
    assert status == "time_limit" and its == 1 and info["newton_steps"] == 1
    assert info["factorizations"] == 1


def test_project_cone_stacked_equals_reference():
    rng = np.random.default_rng(1)
    for dim in (2, 3):
        nc = 300
        x = rng.standard_normal(nc * dim) * np.repeat(rng.choice([1e-3, 1.0, 1e3], nc), dim)
        mu = rng.choice([0.0, 0.1, 0.7, 3.0], size=nc)
        x.reshape(nc, dim)[::7, 1:] = 0.0
        x.reshape(nc, dim)[::11] = 0.0
        np.testing.assert_allclose(project_cone_stacked(x, mu, dim, np.empty_like(x)),
                                   cones.project_cone(x, mu, dim), rtol=1e-14, atol=1e-300)


def test_diag_blocks_of_dense_and_sparse_w_agree():
    p = manufactured(7, 3, 0.5, seed=3)
    dense = nt.LocalSystem(p, "dense").diag_blocks()
    sparse = nt.LocalSystem(p, "splu").diag_blocks()
    W = p.W.toarray()
    np.testing.assert_array_equal(dense, sparse)
    np.testing.assert_array_equal(dense[4], W[12:15, 12:15])


def test_block_rho_kernel_equals_numpy_reference():
    from socp_cd.solvers.kernels.newton_ac import block_rho_dense
    for dim in (2, 3):
        p = manufactured(11, dim, 0.5, contact_scale=1e6, seed=dim)
        W = p.W.toarray()
        W[:dim, :dim] = 0.0                        # a contact with a zero block: the floor
        system = nt.LocalSystem(FrictionContactProblem(W, p.q, p.mu, dim), "dense")
        rho_n, rho_t, ref = nt._rho(system.diag_blocks(), dim, "block")
        rho = np.empty(11)
        assert block_rho_dense(system.W, dim, rho) == pytest.approx(ref, rel=1e-14)
        np.testing.assert_allclose(rho, rho_n, rtol=1e-14)
        assert rho[0] == pytest.approx(1e8 / ref, rel=1e-14)
        assert nt._system_rho(system, "block")[0] is nt._system_rho(system, "block")[1]


def test_projected_error_kernel_equals_the_three_calls():
    from socp_cd.solvers.kernels.newton_dense import projected_error
    for dim in (2, 3):
        p = manufactured(6, dim, 0.7, contact_scale=1e3, seed=10 + dim)
        system = nt.LocalSystem(p, "dense")
        rng = np.random.default_rng(dim)
        mu = np.ascontiguousarray(p.mu, dtype=np.float64)
        for r in (np.zeros(p.m), rng.standard_normal(p.m), 1e6 * rng.standard_normal(p.m)):
            ref_r = project_cone_stacked(r, mu, dim, np.empty_like(r))
            ref = nt.siconos_error(ref_r, system.start(ref_r), mu, dim, system.norm_q)
            out = np.empty_like(r)
            assert projected_error(system.W, system.q, system.norm_q, mu, dim, r, out) == ref
            np.testing.assert_array_equal(out, ref_r)


def test_polish_given_the_dense_arrays_equals_the_polish_that_forms_them():
    """The De Saxcé loop hands its dense W and q to the polish (cache["dense"])."""
    for name in ("FrictionContact3D_1c.dat", "Rover1039.dat", "NESpheres_10_1.dat"):
        p = _shared(name)
        r0 = socp_cd.solve(p, "clarabel", tol=1e-8, polish=None, max_iter=1).r
        W = np.ascontiguousarray(p.W.toarray())
        q = np.array(p.q, dtype=np.float64)
        cache = {"dense": (W, q)}
        a = nt.newton_polish(p, r0, 1e-8, {"max_iter": 15, "cache": cache})
        b = nt.newton_polish(p, r0, 1e-8, {"max_iter": 15})
        assert cache["newton_system"].W is W           # used as given, not copied
        np.testing.assert_array_equal(a[0], b[0])
        assert a[1] == b[1]


# --------------------------------------------------------------------------- plain policy
#: settings of the plain stages of solver="auto" (newton_plain: stall 50; newton_trial: 2)
PLAIN = dict(COLD, stall_window=50)


@pytest.mark.parametrize("name", SMALL_SHARED)
def test_plain_twin_equals_python_loop_on_shared_problems(name):
    p = _shared(name)
    a, b = _both(p, np.zeros(p.m), 1e-10, policy="plain", **PLAIN)
    _assert_equal(a, b)
    assert a[4]["policy"] == "plain" and a[4]["plain_steps"] == a[4]["newton_steps"]
    # from a perturbed prox answer (the trial's start), and a stall window of 2
    ref = _both(p, np.zeros(p.m), 1e-10)[0][1]
    rng = np.random.default_rng(1)
    r1 = ref * (1.0 + 1e-2 * rng.standard_normal(p.m))
    _assert_equal(*_both(p, r1, 1e-12, max_iter=6, policy="plain", **dict(PLAIN, stall_window=2)))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("structure", ["tree", "redundant"])
@pytest.mark.parametrize("mu", [0.0, 0.3, 2.0])
@pytest.mark.parametrize("m", [72, 90])
def test_plain_twin_equals_python_loop_on_manufactured_problems(dim, structure, mu, m):
    """Stick / slide / separated / grazing mixes; "redundant": rank-deficient W, where plain
    steps meet singular Newton matrices (the regularized retry) and failing line searches;
    the written-out LU (m = 72) and LAPACK's (90)."""
    nc = m // dim
    for seed, mix in enumerate([(0.25, 0.35, 0.3, 0.1), (0.0, 0.0, 0.0, 1.0),
                                (0.0, 0.0, 1.0, 0.0), (0.5, 0.0, 0.0, 0.5)]):
        p = manufactured(nc, dim, mu, structure=structure, mix=mix, seed=seed)
        a, b = _both(p, np.zeros(p.m), 1e-10, max_iter=60, policy="plain", **PLAIN)
        _assert_equal(a, b)
        a, b = _both(p, p.solution.r + 1e-4 * np.abs(p.solution.r).max(), 1e-12,
                     policy="plain", **PLAIN)
        _assert_equal(a, b)


OTHER_EQUATIONS = ["natural_map", "fischer_burmeister"]


def test_law_codes_are_the_backend_equations_and_an_unknown_code_is_nan():
    from socp_cd.solvers.kernels import newton_dense as nd
    assert set(nd.LAW_CODES) == set(nt.EQUATIONS) == set(nt._LAW_BLOCKS)
    assert sorted(nd.LAW_CODES.values()) == list(range(len(nt.EQUATIONS)))
    p = manufactured(3, 3, 0.5, seed=1)
    nc, m = p.n_contacts, p.m
    F, Dr, Du = np.zeros(m), np.zeros((nc, 3, 3)), np.zeros((nc, 3, 3))
    branch = np.zeros(nc, dtype=np.int64)
    r, u, rho = p.solution.r, p.solution.u, np.ones(nc)
    for name, code in nd.LAW_CODES.items():
        # each code runs its own kernel: F = 0 at the exact solution, F != 0 away from it
        assert nd.law_blocks(code, r, u, p.mu, rho, rho, 3, True, F, Dr, Du, branch) < 1e-12
        assert nd.law_blocks(code, r + 1.0, u, p.mu, rho, rho, 3, True, F, Dr, Du, branch) > 0
    assert np.isnan(nd.law_blocks(99, r, u, p.mu, rho, rho, 3, True, F, Dr, Du, branch))
    assert np.isnan(F).all()


@pytest.mark.parametrize("equation", OTHER_EQUATIONS)
@pytest.mark.parametrize("name", SMALL_SHARED)
def test_twins_equal_python_loop_on_the_other_equations_shared(name, equation):
    # since session 36 the compiled loops take the equation (law_blocks): the natural
    # map's and Fischer–Burmeister's runs are the Python loop's, bit for bit
    p = _shared(name)
    a, b = _both(p, np.zeros(p.m), 1e-10, equation=equation)
    _assert_equal(a, b)
    assert a[4]["equation"] == b[4]["equation"] == equation
    _assert_equal(*_both(p, np.zeros(p.m), 1e-10, policy="plain", equation=equation, **PLAIN))


@pytest.mark.parametrize("equation", OTHER_EQUATIONS)
@pytest.mark.parametrize("policy", ["prox", "plain"])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("structure", ["tree", "redundant"])
@pytest.mark.parametrize("m", [72, 90])
def test_twins_equal_python_loop_on_the_other_equations_manufactured(m, structure, dim, policy,
                                                                     equation):
    """Separated/stick/slide/grazing mixes, mu = 0 (FB's scalar branch) to 2, rank-deficient
    W, both LUs; cold and from a perturbed exact solution."""
    nc = m // dim
    settings = PLAIN if policy == "plain" else COLD
    for seed, (mu, mix) in enumerate([(0.3, (0.25, 0.35, 0.3, 0.1)), (2.0, (0.0, 0.0, 1.0, 0.0)),
                                      (0.0, (0.5, 0.0, 0.0, 0.5))]):
        p = manufactured(nc, dim, mu, structure=structure, mix=mix, seed=seed)
        _assert_equal(*_both(p, np.zeros(p.m), 1e-10, max_iter=60, policy=policy,
                             equation=equation, **settings))
        _assert_equal(*_both(p, p.solution.r + 1e-4 * np.abs(p.solution.r).max(), 1e-12,
                             policy=policy, equation=equation, **settings))


def test_plain_twin_counts_failed_line_searches_like_the_python_loop():
    # rank-deficient W and a mass ratio of 1e6: plain steps whose 30 halvings all fail
    # (then the full step is taken) occur, and the twin counts them as the reference does
    seen_ls = seen_retry = 0
    for seed in range(6):
        p = manufactured(20, 3, 1.0, structure="redundant", mass_ratio=1e6, seed=seed)
        a, b = _both(p, np.zeros(p.m), 1e-14, max_iter=40, policy="plain", **PLAIN)
        _assert_equal(a, b)
        seen_ls += a[4]["line_search_failures"]
        # a singular Newton matrix is retried regularized once; the run's later steps are
        # regularized at once (no second factorization per step)
        assert a[4]["factorizations"] <= a[4]["newton_steps"] + 1
        seen_retry += a[4]["factorizations"] > a[4]["newton_steps"]
    assert seen_ls > 0 and seen_retry > 0


def test_plain_twin_time_limit_chunks_like_the_python_loop(monkeypatch):
    # re-entry of the compiled loop between chunks: one step per call, then 7; the state
    # "regularized first" (I_REGULARIZED) carried from chunk to chunk (mass ratio 1e6 and
    # redundant W: singular Newton matrices, the regularized retry)
    retried = 0
    for p in (manufactured(20, 3, 0.5, structure="redundant", seed=2),
              *(manufactured(20, 3, 1.0, structure="redundant", mass_ratio=1e6, seed=s)
                for s in range(3))):
        for work in (1.0, 7 * 60 ** 3 / 3):
            monkeypatch.setattr(nt, "CHUNK_WORK", work)
            a, b = _both(p, np.zeros(p.m), 1e-14, max_iter=30, time_limit=1e3, policy="plain",
                         **PLAIN)
            _assert_equal(a, b)
            retried += a[4]["factorizations"] > a[4]["newton_steps"]
    assert retried > 0


def test_velocity_error_is_the_guard_error():
    from socp_cd.residuals import guard_values
    from socp_cd.solvers.kernels.newton_dense import velocity_error
    rng = np.random.default_rng(0)
    for scale_r, scale_u, nq in [(1.0, 1.0, 1.0), (1e6, 1e-3, 1.0), (0.0, 0.0, 0.0),
                                 (1e-20, 1e-20, 1e-20), (3.0, 1e5, 2.0)]:
        r, u = scale_r * rng.standard_normal(12), scale_u * rng.standard_normal(12)
        want = guard_values(1e-7, np.linalg.norm(r), np.linalg.norm(u), nq)["error"]
        assert velocity_error(1e-7, r, u, nq) == pytest.approx(want, rel=1e-14)


def test_warmup_runs_both_twins(monkeypatch):
    # newton.warmup (called by the benchmarks before timing) reaches both compiled loops, in
    # 2D and 3D, with and without a time limit
    from socp_cd.solvers.kernels import newton_dense as nd
    nt.warmup()     # (compiled kernels that call the loops are typed before the spies go in)
    calls = []
    for name in ("prox_newton_dense", "plain_newton_dense"):
        original = getattr(nd, name)

        def spy(*args, _name=name, _original=original):
            calls.append((_name, args[6]))            # (loop, dim)
            return _original(*args)
        monkeypatch.setattr(nd, name, spy)
    assert nt.warmup() > 0.0
    assert {(n, d) for n, d in calls} == {(n, d) for n in ("prox_newton_dense",
                                                          "plain_newton_dense") for d in (2, 3)}


def test_no_kernel_reads_the_lapack_addresses_as_a_global():
    # dense.LAPACK_LU holds this process's addresses of getrf/getrs; a cached kernel that
    # named it as a global would keep them as constants and call them in a later process
    # (another address space), so the kernels take it as an argument only (session 47)
    import importlib
    import pkgutil
    from numba.core.registry import CPUDispatcher
    import socp_cd as pkg
    seen = 0
    for info in pkgutil.walk_packages(pkg.__path__, "socp_cd."):
        mod = importlib.import_module(info.name)
        for obj in vars(mod).values():
            if isinstance(obj, CPUDispatcher):
                seen += 1
                names = obj.py_func.__code__.co_names
                assert "LAPACK_LU" not in names, obj.py_func.__qualname__
    assert seen > 50


# --------------------------------------------------------------------------- dense solves
@pytest.mark.parametrize("n", [5, 40, 90, 150])
def test_both_lus_of_dense_solve_agree_and_report_singular_matrices(n):
    """The written-out LU and LAPACK's (kernels/dense.py: dense_solve) give the same
    solution.  Singular: the written-out LU on a pivot below PIVOT_TOL of the largest
    entry; LAPACK with ``strict`` the same (its verdict is scipy's LU's pivot against
    PIVOT_TOL: the same getrf), without it an exact zero pivot only (scipy's test)."""
    import scipy.linalg as sla
    from socp_cd.solvers.kernels.dense import PIVOT_TOL, dense_solve
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n)) + n * np.eye(n)
    b = rng.standard_normal(n)
    x1, ok1 = dense_solve(A.copy(), b.copy(), WRITTEN_OUT, True)
    x2, ok2 = dense_solve(A, b, LAPACK_LU, True)
    assert ok1 and ok2
    np.testing.assert_allclose(x2, np.linalg.solve(A, b), rtol=1e-10)
    np.testing.assert_allclose(x1, x2, rtol=1e-10)
    Z = A.copy()
    Z[:, 0] = 0.0                                # an exact zero column: singular for all
    assert not dense_solve(Z.copy(), b.copy(), WRITTEN_OUT, False)[1]
    for strict in (True, False):
        assert not dense_solve(Z, b, LAPACK_LU, strict)[1]
    # rank n - 1 in floating point: rounding leaves a tiny, non-zero pivot
    S = rng.standard_normal((n, n - 1)) @ rng.standard_normal((n - 1, n))
    pivot = np.min(np.abs(np.diag(sla.lu_factor(S)[0]))) / np.abs(S).max()
    assert 0.0 < pivot < 1e-12
    assert dense_solve(S, b, LAPACK_LU, True)[1] == (pivot > PIVOT_TOL)
    assert dense_solve(S, b, LAPACK_LU, False)[1]      # a huge, finite "solution"
    if n <= 5:
        assert pivot <= PIVOT_TOL
        assert not dense_solve(S.copy(), b.copy(), WRITTEN_OUT, False)[1]
    bad = A.copy()
    bad[1, 2] = np.nan
    assert not dense_solve(bad.copy(), b.copy(), WRITTEN_OUT, True)[1]
    assert not dense_solve(bad, b, LAPACK_LU, False)[1]


@pytest.mark.parametrize("n", [1, 3, 7, 42, 73])
def test_vector_lu_is_the_many_rhs_lu_bit_for_bit(n):
    """``lu_solve`` (one right-hand side) is ``lu_solve_many``'s first column, pivoting and
    sparse rows included, and solves the system; the scale ``abs_max`` (four running
    maxima) is the largest |entry|, NaN ignored."""
    from socp_cd.solvers.kernels.dense import abs_max, lu_solve, lu_solve_many
    rng = np.random.default_rng(n)
    for trial in range(4):
        A = rng.standard_normal((n, n))
        A[rng.random((n, n)) < 0.5] = 0.0          # zero multipliers (skipped) and pivoting
        A += 0.1 * np.eye(n)
        b = rng.standard_normal(n)
        x, ok = lu_solve(A.copy(), b)
        X, ok_many = lu_solve_many(A.copy(), b.reshape(n, 1).copy())
        assert ok == ok_many
        assert np.array_equal(x, X[:, 0])
        if ok:
            np.testing.assert_allclose(A @ x, b, atol=1e-8 * max(1.0, np.abs(x).max()))
        assert abs_max(A) == np.abs(A).max()
    if n == 1:
        return
    A = rng.standard_normal((n, n))
    A[0, n - 1] = np.nan
    A[n - 1, 0] = -1e3
    assert abs_max(A) == np.nanmax(np.abs(A)) == 1e3
    assert not lu_solve(A, rng.standard_normal(n))[1]


def test_twin_on_a_rank_deficient_w_ordered_to_a_small_envelope():
    """A redundant (rank-deficient) W of 90 unknowns with its contacts in reverse
    Cuthill-McKee order: the envelope rule takes the written-out LU above 72 unknowns on a
    singular pattern; the twin still equals the Python loop, and Newton solves it."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    from socp_cd.bench.transforms import permuted
    for seed in range(3):
        base = manufactured(30, 3, 0.5, structure="redundant", seed=seed)
        graph = sp.csr_matrix(np.abs(base.W.toarray()).reshape(30, 3, 30, 3).sum(axis=(1, 3)))
        p, _ = permuted(base, reverse_cuthill_mckee(graph, symmetric_mode=True))
        indptr, indices, _ = p.csr_parts
        assert p.is_rank_deficient and p.m > nt.COMPILED_LU_MAX_M
        assert envelope_fraction(indptr, indices, p.m) <= nt.COMPILED_LU_MAX_ENVELOPE
        assert nt.LocalSystem(p, "auto").lapack == WRITTEN_OUT
        _assert_equal(*_both(p, np.zeros(p.m), 1e-10))
        _assert_equal(*_both(p, np.zeros(p.m), 1e-10, policy="plain"))
        res = socp_cd.solve(p, "newton", tol=1e-8)
        assert res.converged


def test_envelope_fraction_of_simple_patterns():
    """0 for a diagonal pattern, (m - 1) / m for a full one; an entry above the diagonal
    counts as its transpose; int32 or int64 indices; a NumPy reference on random patterns."""
    import scipy.sparse as sp
    m = 7
    for A, expected in ((np.eye(m), 0.0), (np.ones((m, m)), (m - 1) / m)):
        S = sp.csr_matrix(A)
        assert envelope_fraction(S.indptr, S.indices, m) == pytest.approx(expected, abs=1e-15)
    A = np.eye(m)
    A[0, m - 1] = 1.0                              # row m - 1's envelope reaches column 0
    S = sp.csr_matrix(A)
    assert envelope_fraction(S.indptr.astype(np.int32), S.indices.astype(np.int32), m) == \
        pytest.approx((m - 1) / (m * m / 2))
    rng = np.random.default_rng(0)
    for _ in range(5):
        A = (rng.random((20, 20)) < 0.1) + np.eye(20)
        nz = (A != 0) | (A.T != 0)
        first = np.argmax(nz, axis=1)
        ref = (np.arange(20) - first).sum() / 200.0
        S = sp.csr_matrix(A)
        assert envelope_fraction(S.indptr, S.indices, 20) == pytest.approx(ref, abs=1e-15)


@pytest.mark.parametrize("d", [2, 3])
def test_dense_jacobian_equals_the_entrywise_products(d):
    # kernels/newton_ac.dense_jacobian builds J = Dr + Du (W + alpha I) row by row (its rows
    # vectorize): bit for bit the entry-by-entry dot products sum_b Du[i,a,b] W[o+b,c] summed
    # from 0 in b's order (the former kernel), zeros of either sign, and the NumPy product to
    # rounding
    from socp_cd.solvers.kernels.newton_ac import dense_jacobian
    rng = np.random.default_rng(d)
    for nc in (1, 4, 17):
        m = nc * d
        W = rng.standard_normal((m, m))
        W[0, -1] = -0.0
        Dr, Du = rng.standard_normal((nc, d, d)), rng.standard_normal((nc, d, d))
        Du[0, 0, :] = 0.0           # a zero row of Du (a separated contact's)
        Du[-1, -1, 0] = -0.0
        alpha = 0.37
        J = np.empty((m, m))
        dense_jacobian(Dr, Du, W, alpha, d, J)
        ref = np.empty((m, m))
        for i in range(nc):
            o = i * d
            for a in range(d):
                for c in range(m):
                    s = 0.0
                    for b in range(d):
                        s += Du[i, a, b] * W[o + b, c]
                    ref[o + a, c] = s
                for c in range(d):
                    ref[o + a, o + c] += Dr[i, a, c] + alpha * Du[i, a, c]
        assert np.array_equal(J.view(np.int64), ref.view(np.int64))
        block = np.zeros((m, m)), np.zeros((m, m))
        for i in range(nc):
            block[0][i * d:(i + 1) * d, i * d:(i + 1) * d] = Dr[i]
            block[1][i * d:(i + 1) * d, i * d:(i + 1) * d] = Du[i]
        np.testing.assert_allclose(J, block[0] + block[1] @ (W + alpha * np.eye(m)),
                                   rtol=1e-13, atol=1e-13)


def test_velocity_error_of_an_overflowing_pair_is_its_scaled_value():
    # the guard's error part re-normalizes err by max(||q||, ||u||): a ratio of norms, the same
    # for the pair times c (its squared norms overflowed to inf / inf = NaN before)
    from socp_cd.solvers.kernels import newton_dense as nd
    rng = np.random.default_rng(3)
    r, u = rng.standard_normal(12), rng.standard_normal(12)
    expected = nd.velocity_error(1e-3, r, 2.0 * u, 0.5)
    c = 1e200
    assert nd.velocity_error(1e-3, c * r, 2.0 * c * u, c * 0.5) == pytest.approx(expected, rel=1e-12)
    assert nd.velocity_error(1e-3, r, np.full(12, np.inf), 0.5) == np.inf


def _measure(p, r, mu, policy):
    """The loop's own measure of ``r``: Siconos' error, re-normalized by the velocity scale
    under the plain policy (:func:`~socp_cd.solvers.newton.velocity_relative_error`)."""
    u = p.W @ r + p.q
    nq = float(np.linalg.norm(p.q))
    e = siconos_error(r, u, p.mu, p.dim, nq)
    return e if policy == "prox" else nt.velocity_relative_error(e, r, u, nq)


@pytest.mark.parametrize("policy", ["prox", "plain"])
def test_accepted_stops_both_loops_at_the_first_lower_iterate_it_takes(policy):
    """``accepted`` (auto's judge, as a hook): with a ``tol`` no run meets, both loops stop
    ``converged`` at the same outer iteration -- the first whose error is a new best that the
    test takes -- with the same ``r``, asking the test at new bests only; a test that takes
    nothing leaves the run as it is without the hook."""
    p = manufactured(6, 3, 0.5, seed=3)
    mu = np.ascontiguousarray(p.mu, dtype=np.float64)

    def run(compiled, accepted=None, history=False):
        return nt.prox_newton(nt.LocalSystem(p, "auto"), mu, np.zeros(p.m), tol=1e-300,
                              max_iter=60, time_limit=None, history=history, policy=policy,
                              compiled=compiled, accepted=accepted, **COLD)

    hist = run(False, history=True)[3]
    lower, best = [], hist[0]                # (iteration, error) of each new best
    for k, e in enumerate(hist[1:], start=1):
        if e < best:
            lower.append((k, e))
            best = e
    assert len(lower) >= 4
    # an error the run reaches after a few iterations, halfway (geometrically) between two
    # successive bests: the hook's own measure of an iterate differs from the loop's by
    # rounding, which a bar equal to one of them would make decide the stop (it did, on
    # another CPU)
    mid = len(lower) // 2
    bar = float(np.sqrt(lower[mid - 1][1] * lower[mid][1]))
    first = lower[mid][0]
    asked = []

    def accepted(r):
        asked.append(1)
        return bool(_measure(p, r, mu, policy) <= bar)

    runs = []
    for compiled in (False, True):
        asked.clear()
        runs.append(run(compiled, accepted))
        assert runs[-1][0] == "converged" and runs[-1][2] == first
        assert _measure(p, runs[-1][1], mu, policy) <= bar
        assert len(asked) == sum(1 for k, _ in lower if k <= first)
    _assert_equal(*runs)
    _assert_equal(run(True), run(True, lambda r: False))


@pytest.mark.parametrize("policy", ["prox", "prox_error"])
def test_the_backend_stops_at_the_answer_its_hook_takes_and_does_not_continue_it(policy):
    """newton_backend passes ``accepted`` to its runs (auto's stages), and a run it stopped is
    the answer: not continued towards ``tol`` as written (``continued_runs``)."""
    from socp_cd.solvers.scaling import balanced
    # contact scales spanning 1e-3 ... 1e3: the balanced copy's errors are not those as written
    p = manufactured(8, 3, 0.5, seed=1, contact_scale=1e6)
    bp = balanced(p).problem                          # the dispatcher's balanced copy
    asked = []

    def hook(r):
        asked.append(r.copy())
        u = bp.W @ r + bp.q
        return bool(siconos_error(r, u, bp.mu, 3, float(np.linalg.norm(bp.q))) <= 1e-7)
    res = nt.newton_backend(bp, "coulomb", tol=1e-300, max_iter=200, policy=policy,
                            accepted=hook)
    assert asked and res.status == "converged" and hook(res.r)
    assert res.info["continued"] == []
    without = nt.newton_backend(bp, "coulomb", tol=1e-300, max_iter=200, policy=policy)
    assert without.status != "converged"           # tol 1e-300: only the hook ends a run


def test_accepted_on_the_iteration_that_spends_the_time_limit_wins_on_both_loops():
    """An iterate the hook takes on the outer iteration whose end also spends the time limit:
    both loops end ``converged`` there with the same record (the twin's kernel had made its
    time test, and updated alpha, before it was asked)."""
    p = manufactured(6, 3, 0.5, seed=3)
    mu = np.ascontiguousarray(p.mu, dtype=np.float64)
    runs = [nt.prox_newton(nt.LocalSystem(p, "auto"), mu, np.zeros(p.m), tol=1e-300,
                           max_iter=60, time_limit=1e-9, history=False, compiled=compiled,
                           accepted=lambda r: True, **COLD) for compiled in (False, True)]
    for status, _, its, _, _ in runs:
        assert status == "converged" and its == 1
    _assert_equal(*runs)


def _drift_toy():
    """One contact whose tangential block of ``W`` is zero, sticking at ``r = (1, 0, 0)`` with
    a tangential velocity of 1e-4 that no force can cancel: the proximal step moves ``r_T``
    by ``-u_T / alpha`` with ``u`` unchanged (a drift along the null space of ``W``), and the
    law is met only once ``r_T`` reaches the cone's edge (sliding, ``r = (1, -0.5, 0)``)."""
    W = np.diag([1.0, 0.0, 0.0])
    return FrictionContactProblem(W=W, q=np.array([-1.0, 1e-4, 0.0]), mu=np.array([0.5]), dim=3)


def test_the_drift_stop_ends_both_loops_after_the_window():
    """``alpha_min = alpha0`` holds the proximal parameter, so the drift keeps its pace: 29
    outer iterations to the edge without the test; with ``drift_window=5`` both loops stop
    after the 5th, ``"stalled"`` with ``info["stop"] = "null_drift"``, and agree."""
    p = _drift_toy()
    held = dict(WARM, alpha_min=nt.WARM_ALPHA0)
    start = np.array([1.0, 0.0, 0.0])
    a, b = _both(p, start, 1e-10, **held)
    _assert_equal(a, b)
    assert a[0] == "converged" and a[2] > 20 and a[4]["stop"] == ""
    np.testing.assert_allclose(a[1], [1.0, -0.5, 0.0], atol=1e-12)
    a, b = _both(p, start, 1e-10, drift_window=5, **held)
    _assert_equal(a, b)
    assert (a[0], a[2], a[4]["stop"]) == ("stalled", 5, "null_drift")
    assert a[1][0] == 1.0 and -0.5 < a[1][1] < 0.0      # drifted, not at the edge
    res = socp_cd.solve(p, solver="newton", tol=1e-10, r0=start, drift_window=5,
                        alpha0=nt.WARM_ALPHA0, alpha_min=nt.WARM_ALPHA0)
    assert res.status == "stalled" and "null space" in res.message


@pytest.mark.parametrize("structure", ["tree", "redundant"])
def test_twin_equals_python_loop_with_a_drift_test_that_fires_on_any_solved_step(
        structure, monkeypatch):
    """With DRIFT_CHANGE and DRIFT_NULL so wide that every solved subproblem that moves the
    error by less than 100 % counts, the two loops still stop at the same iteration (the
    count skips the same neutral iterations and resets on the same ones)."""
    monkeypatch.setattr(nt, "DRIFT_CHANGE", 0.99)
    monkeypatch.setattr(nt, "DRIFT_NULL", 1e6)
    stops = 0
    for seed, mix in enumerate([(0.25, 0.35, 0.3, 0.1), (0.0, 0.0, 1.0, 0.0)]):
        p = manufactured(12, 3, 0.3, structure=structure, mix=mix, seed=seed)
        for start, settings in ((np.zeros(p.m), COLD), (p.solution.r * 1.01, WARM)):
            a, b = _both(p, start, 1e-12, drift_window=2, **settings)
            _assert_equal(a, b)
            stops += a[4]["stop"] == "null_drift"
    assert stops > 0


def test_drift_step_verdicts():
    from socp_cd.solvers.kernels.newton_dense import drift_step
    rk, uk = np.zeros(3), np.zeros(3)
    r = np.array([0.0, 1.0, 0.0])
    still, moved = np.array([0.0, 1e-4, 0.0]), np.array([0.0, 0.5, 0.0])
    # solved, error flat, u moved by 1e-4 per unit of r (wscale 1): a drift step
    assert drift_step(True, 1.0, 1.0, r, rk, still, uk, 1.0, 1e-2, 1e-2) == 1
    # ... but not when u moved as much as r, or the error fell by 5 %, or r did not move
    assert drift_step(True, 1.0, 1.0, r, rk, moved, uk, 1.0, 1e-2, 1e-2) == -1
    assert drift_step(True, 0.95, 1.0, r, rk, still, uk, 1.0, 1e-2, 1e-2) == -1
    assert drift_step(True, 1.0, 1.0, rk, rk, uk, uk, 1.0, 1e-2, 1e-2) == -1
    # the block scale scales the test: W 100x smaller, u moves 100x less for the same r
    assert drift_step(True, 1.0, 1.0, r, rk, still, uk, 1e-3, 1e-2, 1e-2) == -1
    # unsolved: neutral while the error did not fall by more than the change, else a reset
    assert drift_step(False, 1.2, 1.0, r, rk, moved, uk, 1.0, 1e-2, 1e-2) == 0
    assert drift_step(False, 0.5, 1.0, r, rk, moved, uk, 1.0, 1e-2, 1e-2) == -1


@pytest.mark.parametrize("bad", [-1, "x", 2.5, float("nan")])
def test_a_bad_drift_window_is_named(bad):
    from socp_cd.errors import InvalidProblemError
    p = manufactured(3, 3, 0.5, seed=0)
    with pytest.raises(InvalidProblemError, match="drift_window"):
        socp_cd.solve(p, solver="newton", drift_window=bad)

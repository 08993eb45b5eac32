"""Lemke's method (``socp_cd.lcp``, ``solvers/kernels/lemke.py``) and ``solver="lemke"``."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import socp_cd
from socp_cd import lcp
from socp_cd.bench.generators import manufactured
from socp_cd.data import shared_problems
from socp_cd.errors import UnsupportedError
from socp_cd.problem import FrictionContactProblem
from socp_cd.solvers import lemke as lemke_backend
from socp_cd.solvers.kernels import lemke as kern


def _coulomb_lcp(rng, nc, rank_deficient=False):
    A = rng.standard_normal((2 * nc, 2 * nc - (1 if rank_deficient else 0)))
    W = A @ A.T
    q = rng.standard_normal(2 * nc)
    mu = rng.uniform(0.0, 2.0, nc)
    return W, q, mu


def _check_solution(M, q, z, scale=1.0):
    w = M @ z + q
    tol = 1e-9 * max(scale, np.abs(q).max(), 1.0)
    assert z.min() >= 0.0
    assert w.min() >= -tol
    assert np.abs(w * z).max() <= tol * max(1.0, np.abs(z).max())


def test_constants_match_the_reference():
    """The compiled layer keeps its own copies of socp_cd.lcp's constants (it imports nothing
    from socp_cd outside it): they must be the same values."""
    assert (kern.SOLVED, kern.RAY, kern.MAX_PIVOTS, kern.TIME_LIMIT) == (
        lcp.LEMKE_SOLVED, lcp.LEMKE_RAY, lcp.LEMKE_MAX_PIVOTS, lcp.LEMKE_TIME_LIMIT)
    assert (kern.PIVOT_TOL, kern.TIE_TOL) == (lcp.PIVOT_TOL, lcp.TIE_TOL)
    from socp_cd.solvers.kernels.dense import PIVOT_TOL
    assert lcp.LU_PIVOT_TOL == PIVOT_TOL
    # the compiled route reports Lemke's outcomes as NSGS status codes: the same names
    from socp_cd.solvers.nsgs_route import LEMKE_CODES, STATUS_NAMES
    assert tuple(STATUS_NAMES[c] for c in LEMKE_CODES) == lcp.LEMKE_STATUS


@pytest.mark.parametrize("rank_deficient", [False, True])
def test_kernel_equals_reference_on_coulomb_lcps(rank_deficient):
    """Same outcome, same number of pivots and the same z on random 2D Coulomb LCPs (PSD W,
    full rank and rank one short); every solved one is a solution of the LCP."""
    rng = np.random.default_rng(3 if rank_deficient else 4)
    solved = 0
    for _ in range(60):
        nc = int(rng.integers(1, 9))
        M, q = lcp.coulomb_lcp_2d(*_coulomb_lcp(rng, nc, rank_deficient))
        z_ref, code_ref, piv_ref = lcp.lemke_reference(M, q, 500)
        z = np.empty(q.shape[0])
        code, piv = kern.lemke(M, q, 500, np.inf, z)
        assert (code, piv) == (code_ref, piv_ref)
        np.testing.assert_allclose(z, z_ref, rtol=1e-10, atol=1e-12)
        if code == lcp.LEMKE_SOLVED:
            solved += 1
            _check_solution(M, q, z)
    # full rank: a positive definite W has a solution, which Lemke's method found on all of
    # these (it is not guaranteed: M is copositive, not copositive-plus); rank-deficient W
    # with a random q may have none
    assert solved == 60 if not rank_deficient else solved >= 40


def test_positive_definite_lcps_are_solved():
    """An LCP whose M is positive definite has one solution; Lemke's method reaches it
    (both implementations), also when q has ties (degenerate first pivot)."""
    rng = np.random.default_rng(5)
    for k in range(40):
        n = int(rng.integers(1, 15))
        A = rng.standard_normal((n, n))
        M = A @ A.T + 0.1 * np.eye(n) + 0.5 * (A - A.T)
        q = rng.standard_normal(n) if k % 2 else -np.ones(n)         # all tied
        for z, code, _ in (lcp.lemke_reference(M, q, 10 * n + 10),
                           _kernel(M, q, 10 * n + 10)):
            assert code == lcp.LEMKE_SOLVED
            _check_solution(M, q, z)


def _kernel(M, q, cap, deadline=np.inf):
    z = np.empty(q.shape[0])
    code, piv = kern.lemke(M, q, cap, deadline, z)
    return z, code, piv


def test_trivial_and_infeasible_lcps():
    """q >= 0: z = 0 without a pivot; w = -z - 1 >= 0 has no solution: a secondary ray."""
    for impl in (lcp.lemke_reference, _kernel):
        z, code, piv = impl(np.eye(3), np.array([1.0, 0.0, 2.0]), 10)
        assert code == lcp.LEMKE_SOLVED and piv == 0 and not z.any()
        z, code, piv = impl(-np.eye(1), np.array([-1.0]), 10)
        assert code == lcp.LEMKE_RAY
        z, code, piv = impl(np.zeros((0, 0)), np.zeros(0), 10)
        assert code == lcp.LEMKE_SOLVED and z.shape == (0,)


def test_compiled_lcp_matches_the_reference_builder():
    """kernels.lemke.coulomb_lcp_2d (from CSR) builds the same M, q as socp_cd.lcp's (dense)."""
    rng = np.random.default_rng(6)
    for nc in (1, 3, 7):
        W, q, mu = _coulomb_lcp(rng, nc)
        W[np.abs(W) < 0.5] = 0.0            # a sparse pattern, zeros not stored
        Wc = sp.csr_matrix(W)
        M, ql = kern.coulomb_lcp_2d(Wc.indptr, Wc.indices, Wc.data, q, mu)
        M_ref, ql_ref = lcp.coulomb_lcp_2d(W, q, mu)
        np.testing.assert_array_equal(M, M_ref)
        np.testing.assert_array_equal(ql, ql_ref)
        z = rng.uniform(0.0, 1.0, 4 * nc)
        r = lcp.coulomb_impulses(z, nc)
        np.testing.assert_array_equal(r[0::2], z[:nc])
        np.testing.assert_array_equal(r[1::2], z[nc:2 * nc] - z[2 * nc:3 * nc])


def test_lcp_solution_is_the_coulomb_law():
    """The impulses of an LCP solution solve the 2D Coulomb law (Siconos' error at rounding)."""
    rng = np.random.default_rng(7)
    for nc in (1, 2, 5, 12):
        W, q, mu = _coulomb_lcp(rng, nc)
        M, ql = lcp.coulomb_lcp_2d(W, q, mu)
        z, code, _ = lcp.lemke_reference(M, ql, 1000)
        assert code == lcp.LEMKE_SOLVED
        p = FrictionContactProblem(W, q, mu, dim=2)
        assert socp_cd.error(p, lcp.coulomb_impulses(z, nc)) < 1e-12


@pytest.mark.parametrize("structure", ["tree", "redundant"])
@pytest.mark.parametrize("mix", [(1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1),
                                 (0.25, 0.25, 0.25, 0.25)])
def test_solver_solves_manufactured_2d_problems(structure, mix):
    """Every contact state (separated, sticking, sliding, grazing), tree and redundant
    (rank-deficient) W: solve(solver="lemke") converges with Siconos' error at rounding."""
    for seed in range(3):
        p = manufactured(8, dim=2, mu=0.6, structure=structure, mix=mix, seed=seed)
        res = socp_cd.solve(p, solver="lemke", tol=1e-10)
        assert res.converged, (res.status, res.error, res.message)
        assert res.error < 1e-12
        assert res.info["lcp_unknowns"] == 32 and res.iterations == res.info["pivots"]


def test_slider_crank_is_solved_to_rounding():
    """The shared slider crank (asymmetric, rank-deficient W), where NSGS takes 367 sweeps."""
    hits = [s for s in shared_problems() if s.file == "FC2D_SliderCrankLagrangian00000.dat"]
    if not hits:
        pytest.skip("shared data not available")
    p = socp_cd.read_problem(hits[0].path)
    res = socp_cd.solve(p, solver="lemke")
    assert res.converged and res.error < 1e-14 and res.info["lemke"] == "solved"


def test_extremes():
    """mu = 0 and mu = 100, W and q scaled by 1e+-6, duplicated (redundant) contacts; at
    mu = 1e6 rounding may end the pivots on a false secondary ray (formulations/lemke.md):
    then the outcome says so, and auto's chain solves the problem all the same."""
    rng = np.random.default_rng(8)
    W, q, _ = _coulomb_lcp(rng, 5)
    for mu in (0.0, 100.0):
        res = socp_cd.solve(FrictionContactProblem(W, q, np.full(5, mu), dim=2), solver="lemke")
        assert res.converged and res.error < 1e-12, (mu, res.error)
    huge = FrictionContactProblem(W, q, np.full(5, 1e6), dim=2)
    res = socp_cd.solve(huge, solver="lemke")
    assert res.converged or (res.status == "numerical_error"
                             and res.info["lemke"] == "secondary ray")
    assert socp_cd.solve(huge).converged
    for f in (1e-6, 1e6):
        res = socp_cd.solve(FrictionContactProblem(W * f, q * f, np.full(5, 0.4), dim=2),
                            solver="lemke")
        assert res.converged and res.error < 1e-12, (f, res.error)
    # each contact twice: W = [[A, A], [A, A]] (per contact pairs), q repeated: degenerate ties
    A = W[:4, :4]
    Wd = np.block([[A, A], [A, A]])
    qd = np.concatenate([q[:4], q[:4]])
    res = socp_cd.solve(FrictionContactProblem(Wd, qd, np.full(4, 0.5), dim=2), solver="lemke")
    assert res.converged and res.error < 1e-12


def test_frictionless_law_in_2d_and_3d():
    for dim in (2, 3):
        p = manufactured(6, dim=dim, mu=0.5, seed=1)
        res = socp_cd.solve(p, solver="lemke", formulation="frictionless")
        assert res.converged and res.error < 1e-12
        assert not res.r.reshape(-1, dim)[:, 1:].any()      # r_T = 0
        ref = socp_cd.solve(p, solver="nsgs", formulation="frictionless", tol=1e-12)
        np.testing.assert_allclose(res.u[0::dim], ref.u[0::dim], atol=1e-8 * (1 + abs(ref.u).max()))


def test_outcomes_other_than_solved_are_reported():
    """No solution (u_N = q_N < 0 whatever r: W = 0): numerical_error, not converged;
    max_iter = 1: max_iter; a deadline already past: time_limit."""
    p = FrictionContactProblem(sp.csr_matrix((4, 4)), np.array([-1.0, 0.3, 2.0, 0.0]),
                               np.array([0.5, 0.5]), dim=2)
    res = socp_cd.solve(p, solver="lemke")
    assert not res.converged and res.status == "numerical_error"
    assert res.info["lemke"] == "secondary ray"
    q = manufactured(30, dim=2, mu=0.5, mix=(0, 0, 1, 0), seed=2)
    res = socp_cd.solve(q, solver="lemke", max_iter=1)
    assert not res.converged and res.status == "max_iter" and res.iterations == 1
    M, ql = lcp.coulomb_lcp_2d(q.W.toarray(), q.q, q.mu)
    z, code, piv = _kernel(M, ql, 10000, deadline=-np.inf)
    assert code == lcp.LEMKE_TIME_LIMIT and piv == kern.CLOCK_EVERY - 1


def test_refused_problems_and_options():
    p3 = manufactured(2, dim=3, mu=0.5, seed=0)
    with pytest.raises(UnsupportedError, match="2D only"):
        socp_cd.solve(p3, solver="lemke")
    with pytest.raises(UnsupportedError, match="inner_settings"):
        socp_cd.solve(p3, solver="lemke", formulation="frictionless", inner_settings={"a": 1})
    with pytest.raises(UnsupportedError):
        socp_cd.solve(p3, solver="lemke", formulation="frictionless", rho=1.0)
    nc = lemke_backend.MAX_UNKNOWNS // 4 + 1
    big = FrictionContactProblem(sp.identity(2 * nc, format="csr"), -np.ones(2 * nc),
                                 np.full(nc, 0.3), dim=2)
    with pytest.raises(UnsupportedError, match="beyond its bound"):
        socp_cd.solve(big, solver="lemke")


@pytest.fixture(autouse=True)
def _table_loaded():
    """The dispatcher finds a plain call's compiled route in a table made when the solver table
    is first loaded (a process's first solve takes the general path): load it."""
    socp_cd.solvers()


def _general(monkeypatch, p, **kw):
    """``socp_cd.solve(p, **kw)`` on the general path (the compiled routes off, as
    tests/test_route.py does: ``nsgs_route.MAX_CONTACTS = 0``)."""
    from socp_cd.solvers import nsgs_route
    with monkeypatch.context() as m:
        m.setattr(nsgs_route, "MAX_CONTACTS", 0)
        res = socp_cd.solve(p, **kw)
    assert "route" not in res.info
    return res


def _auto_cases():
    """2D problems of at most auto.LEMKE_MAX_NC contacts: manufactured (tree, redundant), mu
    0.1 and 1, every state mixed, and one with mu = 0 on some contacts."""
    from socp_cd.solvers import auto
    cases = [manufactured(nc, dim=2, mu=mu, structure=st, seed=seed)
             for nc, mu, st, seed in ((1, 0.3, "tree", 0), (3, 0.1, "tree", 1),
                                      (auto.LEMKE_MAX_NC, 1.0, "redundant", 2),
                                      (5, 0.5, "redundant", 3))]
    p = manufactured(4, dim=2, mu=0.5, seed=4)
    mu = p.mu.copy()
    mu[:2] = 0.0
    cases.append(FrictionContactProblem(p.W, p.q, mu, dim=2))
    return cases


@pytest.mark.parametrize("k", range(5))
@pytest.mark.parametrize("time_limit", [None, 1.0])
def test_auto_starts_small_2d_problems_with_lemke_compiled_as_the_general_path(monkeypatch, k,
                                                                               time_limit):
    """A plain auto call on a small 2D problem (auto.plain's compiled Lemke stage) gives the
    general path's answer bit for bit (its chain starts with the "lemke" stage; history=True
    takes it too), and the path says so."""
    p = _auto_cases()[k]
    plain = socp_cd.solve(p, time_limit=time_limit)
    general = _general(monkeypatch, p, time_limit=time_limit)
    assert np.array_equal(socp_cd.solve(p, time_limit=time_limit, history=True).r, plain.r)
    assert plain.converged and general.converged
    np.testing.assert_array_equal(plain.r, general.r)
    np.testing.assert_array_equal(plain.u, general.u)
    assert plain.error == general.error and plain.message == general.message == "lemke met tol"
    assert plain.info["guard"]["value"] == general.info["guard"]["value"]
    for a, b in zip(plain.info["path"], general.info["path"], strict=True):
        assert (a["method"], a["iterations"], a["status"], a["error"]) == (
            b["method"], b["iterations"], b["status"], b["error"]) == (
            "lemke", plain.iterations, "converged", a["error"])
    assert plain.info["route"] == "compiled"


def test_auto_chain_goes_on_after_a_failed_lemke_stage(monkeypatch):
    """mu = 1e6 (Lemke's pivots may end on a false ray, test_extremes): the plain call takes
    the general path, whose chain goes on after the stage and converges; with the knob off or
    above its bound the chain starts with NSGS, as in 3D."""
    from socp_cd.solvers import auto
    rng = np.random.default_rng(8)
    W, q, _ = _coulomb_lcp(rng, 5)
    huge = FrictionContactProblem(W, q, np.full(5, 1e6), dim=2)
    alone = socp_cd.solve(huge, solver="lemke")
    res = socp_cd.solve(huge)
    assert res.converged and res.info["path"][0]["method"] == "lemke"
    if not alone.converged:
        assert len(res.info["path"]) > 1 and res.info["path"][0]["status"] == "numerical_error"
    p = manufactured(auto.LEMKE_MAX_NC + 1, dim=2, mu=0.5, seed=5)
    assert socp_cd.solve(p).info["path"][0]["method"] == "nsgs"
    assert socp_cd.solve(manufactured(3, dim=3, mu=0.5, seed=5)).info["path"][0]["method"] == "nsgs"
    monkeypatch.setattr(auto, "LEMKE_MAX_NC", None)
    p = manufactured(3, dim=2, mu=0.5, seed=5)
    for kw in ({}, {"history": True}):
        assert socp_cd.solve(p, **kw).info["path"][0]["method"] == "nsgs"


def test_warm_calls_start_with_nsgs_on_the_compiled_route(monkeypatch):
    """Pivoting has no warm start: with r0 the chain starts with NSGS, through auto's compiled
    route as before the Lemke stage (the Moreau–Jean stepper's warm-started calls), and the
    general path agrees."""
    p = manufactured(5, dim=2, mu=0.5, structure="redundant", seed=6)
    r0 = socp_cd.solve(p).r * 0.9
    warm = socp_cd.solve(p, r0=r0)
    general = _general(monkeypatch, p, r0=r0)
    assert warm.converged and warm.info["path"][0]["method"] == "nsgs"
    assert warm.info.get("route") == "compiled"
    assert general.info["path"][0]["method"] == "nsgs"
    np.testing.assert_array_equal(warm.r, general.r)


def test_a_failed_lemke_stage_is_handed_on_not_run_again(monkeypatch):
    """A pivot cap of 2 (monkeypatched): the plain call's compiled stage misses tol and hands
    it to the chain as its first stage (one "lemke" record, not two), whose iterate is not
    the seed (NSGS starts from zero: the general path, which runs the stage itself, takes the
    same path to the same answer)."""
    from socp_cd.solvers import lemke as backend
    monkeypatch.setattr(backend, "pivot_cap", lambda n, max_iter: 2)
    p = manufactured(6, dim=2, mu=0.5, mix=(0, 0, 1, 0), seed=7)
    plain = socp_cd.solve(p, time_limit=1.0)
    general = _general(monkeypatch, p, time_limit=1.0)
    methods = [s["method"] for s in plain.info["path"]]
    assert plain.converged and methods[0] == "lemke" and methods.count("lemke") == 1
    first = plain.info["path"][0]
    assert first["status"] == "max_iter" and first["iterations"] == 2
    assert methods == [s["method"] for s in general.info["path"]]
    np.testing.assert_array_equal(plain.r, general.r)
    assert plain.time >= plain.info["path"][0]["time"]      # the stage's time counts


def test_frictionless_and_bounds_of_the_lemke_rule(monkeypatch):
    """All mu = 0: the QP first (the compiled stage declines); LEMKE_MAX_NC within SMALL_NC
    (one test for plain, route and stage_order); a bad value is named."""
    from socp_cd.errors import InvalidProblemError
    from socp_cd.solvers import auto
    p = manufactured(3, dim=2, mu=0.0, seed=8)
    res = socp_cd.solve(p)
    assert res.converged and res.info["path"][0]["method"] == "clarabel_qp"
    q = manufactured(4, dim=2, mu=0.5, seed=9)
    monkeypatch.setattr(auto, "SMALL_NC", 2)
    for kw in ({}, {"history": True}):
        assert socp_cd.solve(q, **kw).info["path"][0]["method"] == "nsgs_probe"
    monkeypatch.setattr(auto, "SMALL_NC", 100)
    monkeypatch.setattr(auto, "LEMKE_MAX_NC", "8")
    with pytest.raises(InvalidProblemError, match="LEMKE_MAX_NC"):
        socp_cd.solve(q)

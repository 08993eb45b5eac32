"""The compiled route (``SolverSpec.route``) gives the general path's answer, bit for bit.

A plain call (local problem, exact Coulomb law, no solver options) of ``nsgs``
or ``auto`` on a small problem runs balancing, NSGS and the dispatcher's
checks in one compiled call (:mod:`socp_cd.solvers.nsgs_route`).  Setting
``nsgs_route.MAX_CONTACTS = 0`` sends the same call down the general path;
the two must agree, including when ``auto``'s route hands its NSGS stage on
(``resume``) and when a time limit makes NSGS sweep in blocks.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import pytest

import socp_cd
from socp_cd import residuals
from socp_cd.bench.generators import manufactured
from socp_cd.problem import FrictionContactProblem
from socp_cd.solvers import newton, nsgs_route
from socp_cd.solvers.result import STATUSES, LazyInfo
from socp_cd.solvers.kernels.cone import LAW_COULOMB, error_parts, relative_error
from socp_cd.solvers.kernels.scaling import GUARD_KEYS, balanced_guard

from _cases import coupled_pair


@pytest.fixture(autouse=True)
def _nsgs_first_in_2d(monkeypatch):
    """This module tests the NSGS and Newton routes, on 2D problems too: ``auto``'s chain on
    small 2D problems starts with Lemke's method (``auto.LEMKE_MAX_NC``), whose route
    ``tests/test_lemke.py`` tests; off here."""
    from socp_cd.solvers import auto
    monkeypatch.setattr(auto, "LEMKE_MAX_NC", None)


def _random(nc, dim, seed, mu=0.5, spread=3.0):
    """A random SPD local problem with contacts of very different stiffness."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((nc * dim, nc * dim))
    S = np.repeat(10.0 ** rng.uniform(-spread, spread, nc), dim)
    W = S[:, None] * (A @ A.T + nc * dim * np.eye(nc * dim)) * S[None, :]
    return FrictionContactProblem(W, 1e2 * rng.standard_normal(nc * dim), mu, dim)


def _cases():
    out = []
    for dim in (2, 3):
        for nc, seed in ((1, 0), (1, 1), (3, 2), (7, 3), (20, 4)):
            out.append((f"random-{dim}d-{nc}c-{seed}", _random(nc, dim, seed,
                                                               mu=0.1 + 0.4 * seed)))
        for nc, seed, structure in ((4, 5, "tree"), (12, 6, "redundant"), (140, 7, "tree")):
            p = manufactured(nc, dim, mu=0.6, structure=structure, mass_ratio=1e6,
                             contact_scale=1e4, seed=seed)
            out.append((f"manufactured-{structure}-{dim}d-{nc}c", p))
    return out


CASES = _cases()



def _general(monkeypatch, p, **kw):
    with monkeypatch.context() as m:
        m.setattr(nsgs_route, "MAX_CONTACTS", 0)
        res = socp_cd.solve(p, **kw)
    assert "route" not in res.info
    return res


def _same(a, b):
    assert np.array_equal(a.r, b.r)
    assert np.array_equal(a.u, b.u)
    assert (a.status, a.converged, a.iterations, a.trivial) == (b.status, b.converged,
                                                                 b.iterations, b.trivial)
    assert a.error == b.error and a.coulomb_error == b.coulomb_error
    assert a.info["guard"] == b.info["guard"]
    assert a.info["scaling"] == b.info["scaling"]


def _newton_general(monkeypatch, p, **kw):
    with monkeypatch.context() as m:
        m.setattr(newton, "ROUTE_MAX_M", 0)           # (newton.route declines)
        res = socp_cd.solve(p, "newton", **kw)
    assert "route" not in res.info
    return res


@pytest.mark.parametrize("name,p", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("time_limit", [None, 5.0])
def test_newton_route_equals_general_path(monkeypatch, name, p, time_limit):
    # solver="newton"'s compiled route (newton.route: the backend's run and the checks in
    # one compiled call, nsgs_route.newton_checked, and a run that goes on through
    # nsgs_route.trial_runner in newton.continued_runs) gives the general path's result: r, u,
    # status, iterations, the residuals, the guard and every entry of the backend's info
    from socp_cd.solvers import newton
    socp_cd.solvers()
    routed = expected = 0
    for kw in (dict(), dict(max_iter=3), dict(tol=1e-12),
               dict(r0=np.random.default_rng(1).random(p.m))):
        if time_limit is not None:
            # (a first call compiles the timed kernels: on a fresh cache, inside the 5 s, the
            # two paths stopped at different points)
            socp_cd.solve(p, "newton", time_limit=time_limit, **kw)
            _newton_general(monkeypatch, p, time_limit=time_limit, **kw)
        a = socp_cd.solve(p, "newton", time_limit=time_limit, **kw)
        b = _newton_general(monkeypatch, p, time_limit=time_limit, **kw)
        _same(a, b)
        assert a.message == b.message
        # the route takes a call within its bounds (unless the checks refute a claim)
        takes = p.m <= newton.ROUTE_MAX_M and newton.compiled_written_out(p)
        expected += takes
        if "route" in a.info:
            assert takes
            routed += 1
            assert {k: v for k, v in a.info.items() if k != "route"} == b.info
    assert (routed > 0) is (expected > 0)


def test_a_refuted_route_claim_runs_only_the_retry(monkeypatch):
    # a route's claimed convergence that the checks refute is the general path's first
    # answer: the general path goes on with its retry, without running the backend's first
    # run again (a Newton run of up to 150 unknowns cost twice before); same result
    from socp_cd.solvers import registry
    socp_cd.solvers()
    p = dict(CASES)["random-3d-3c-2"]
    calls = []
    real = registry._run_backend

    def counting(*args, **kwargs):
        calls.append(args[0].name)
        return real(*args, **kwargs)
    monkeypatch.setattr(registry, "_run_backend", counting)
    a = socp_cd.solve(p, "newton")
    assert "retry" in a.info and "route" not in a.info and calls == ["newton"]
    calls.clear()
    b = _newton_general(monkeypatch, p)
    assert calls == ["newton", "newton"]        # its first run, then the retry
    _same(a, b)
    assert a.info == b.info and a.message == b.message


def test_newton_route_under_a_time_limit(monkeypatch):
    # with a time limit the route runs to a deadline on the compiled clock (kernels.clock):
    # it takes time-limited calls of any size it takes, and one whose deadline has passed
    # stops after one outer iteration, "time_limit", as the general path does
    from socp_cd.solvers import newton
    from socp_cd.solvers.kernels import clock
    socp_cd.solvers()
    assert clock.AVAILABLE          # (Linux, macOS: the platforms the suite runs on)
    big = _random(20, 3, 4)         # (m = 60: beyond the work bound of the clockless route)
    assert newton._route_work(big.m, 200) > newton.ROUTE_TIMED_WORK
    for lim in (10.0, 1e-3):
        assert socp_cd.solve(big, "newton", time_limit=lim).info["route"] == "compiled"
    a = socp_cd.solve(big, "newton", time_limit=1e-300)
    b = _newton_general(monkeypatch, big, time_limit=1e-300)
    assert a.info["route"] == "compiled"
    assert a.status == b.status == "time_limit" and a.iterations == b.iterations == 1
    assert np.array_equal(a.r, b.r)
    # without the compiled clock: the bounds on the work of a time-limited call
    monkeypatch.setattr(clock, "AVAILABLE", False)
    p = _random(3, 3, 0)
    assert newton._route_work(p.m, 200) <= newton.ROUTE_TIMED_WORK
    lim = newton.ROUTE_MIN_TIME_LIMIT
    assert "route" in socp_cd.solve(p, "newton", time_limit=lim).info
    assert "route" not in socp_cd.solve(p, "newton", time_limit=lim * 0.99).info
    assert "route" in socp_cd.solve(big, "newton").info
    assert "route" not in socp_cd.solve(big, "newton", time_limit=10.0).info
    assert "route" in socp_cd.solve(big, "newton", time_limit=10.0, max_iter=2).info


@pytest.mark.parametrize("name,p", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("time_limit", [None, 5.0])
def test_nsgs_route_equals_general_path(monkeypatch, name, p, time_limit):
    for kw in (dict(), dict(max_iter=7), dict(tol=1e-12),
               dict(r0=np.random.default_rng(1).random(p.m))):
        a = socp_cd.solve(p, "nsgs", time_limit=time_limit, **kw)
        b = _general(monkeypatch, p, solver="nsgs", time_limit=time_limit, **kw)
        _same(a, b)
        for key in ("local_solver", "full_error_evaluations", "local_failures", "light_error",
                    "internal_error"):
            if "route" in a.info:
                assert a.info[key] == b.info[key], key


@pytest.mark.parametrize("name,p", CASES, ids=[c[0] for c in CASES])
def test_auto_route_equals_general_path_and_resumes(monkeypatch, name, p):
    # max_iter=5 leaves most NSGS stages short of tol: the route hands them on (resume);
    # on more than auto.SMALL_NC contacts the routed stage is the NSGS probe
    for kw in (dict(), dict(max_iter=5), dict(time_limit=5.0, max_iter=5),
               dict(r0=np.random.default_rng(2).random(p.m))):
        a = socp_cd.solve(p, **kw)
        b = _general(monkeypatch, p, **kw)
        _same(a, b)
        pa, pb = a.info["path"], b.info["path"]
        assert [(s["method"], s["iterations"], s["status"]) for s in pa] == \
               [(s["method"], s["iterations"], s["status"]) for s in pb]
        for sa, sb in zip(pa, pb):
            # to rounding: the route reads NSGS's own final error (block order of the sums)
            assert sa["error"] == pytest.approx(sb["error"], rel=1e-9, abs=1e-13)
        assert a.info["best_stage"] == b.info["best_stage"]
        assert a.info["features"] == b.info["features"]


def test_route_runs_for_plain_calls_only():
    p = _random(3, 3, seed=7)
    assert socp_cd.solve(p).info.get("route") == "compiled"
    assert socp_cd.solve(p, "nsgs").info.get("route") == "compiled"
    assert socp_cd.solve(p, "nsgs", time_limit=1.0).info.get("route") == "compiled"
    assert socp_cd.solve(p, time_limit=0.1).info.get("route") == "compiled"    # (< 0.5 s)
    for kw in (dict(solver="nsgs", omega=1.0), dict(history=True),
               dict(solver="nsgs", inner_settings={"local_tol": 1e-12}),
               dict(formulation="associated"), dict(crosscheck="nsgs")):
        assert "route" not in socp_cd.solve(p, **kw).info, kw
    with pytest.MonkeyPatch.context() as m:
        m.setattr(nsgs_route, "MAX_CONTACTS", 2)
        assert "route" not in socp_cd.solve(p, "nsgs").info
    # under a time limit the route runs to its deadline, whatever the sweeps' work (nsgs:
    # 1000 sweeps of 150 dense contacts; test_timed_work_bound_without_the_compiled_clock)
    big = _random(150, 2, seed=8, spread=0.5)
    assert socp_cd.solve(big, "nsgs", max_iter=1000, time_limit=5.0).info["route"] == "compiled"
    assert socp_cd.solve(big, "nsgs", max_iter=3).info.get("route") == "compiled"
    # auto on a frictionless problem models Signorini's QP first: no NSGS stage to route
    frictionless = _random(3, 3, seed=9, mu=0.0)
    res = socp_cd.solve(frictionless)
    assert "route" not in res.info and res.info["path"][0]["method"] == "clarabel_qp"


def test_route_never_claims_convergence_the_references_refute():
    tol = 1e-8
    routed = 0
    for seed in range(60):
        rng = np.random.default_rng(seed)
        dim = 2 + seed % 2
        p = _random(1 + seed % 9, dim, seed, mu=rng.uniform(0.0, 3.0), spread=6.0)
        for solver in ("auto", "nsgs"):
            res = socp_cd.solve(p, solver, tol=tol)
            routed += res.info.get("route") == "compiled"
            if res.converged:
                assert residuals.error(p, res.r) <= tol
                assert residuals.guard(p, res.r)["value"] <= tol
            assert math.isfinite(res.error) or res.status == "numerical_error"
    assert routed > 60


def test_balanced_guard_kernel_equals_reference():
    """The compiled guard formulas equal residuals.guard_values + finite_guard + coulomb_parts."""
    rng = np.random.default_rng(0)
    for trial in range(300):
        dim, nc = 2 + trial % 2, 1 + trial % 5
        m = dim * nc
        mu = rng.uniform(0.0, 2.0, nc)
        # balanced entries up to 1e140: their squares stay finite (beyond, the NumPy
        # reference's ||u_T|| overflows where the kernel's |u_T| in 2D does not)
        r = 10.0 ** rng.uniform(-90, 90) * rng.standard_normal(m)
        u = 10.0 ** rng.uniform(-90, 90) * rng.standard_normal(m)
        if trial % 7 == 0:
            r[:] = 0.0
        a = 10.0 ** np.repeat(rng.uniform(-50, 50, nc), dim)
        b = 10.0 ** np.repeat(rng.uniform(-50, 50, nc), dim)
        q_norm = [0.0, 1e-300, 1.0, 1e300][trial % 4]
        finite, out = balanced_guard(r, u, a, b, mu, dim, q_norm)
        rs, us = r / a, u / b
        assert finite
        view = type("View", (), {"mu": mu, "dim": dim})
        # the reference formulas on the same measured value
        f2, r2, u2 = error_parts(rs, us, mu, np.zeros(nc), dim, LAW_COULOMB)
        ref = residuals.guard_values(relative_error(f2, r2, u2, q_norm), math.sqrt(r2),
                                     math.sqrt(u2), q_norm)
        with np.errstate(all="ignore"):
            ref.update(residuals.coulomb_parts(rs, us, view, ref["velocity_scale"]))
        ref = residuals.finite_guard(ref)
        assert tuple(ref) == GUARD_KEYS
        for k, key in enumerate(GUARD_KEYS):
            assert out[k] == pytest.approx(ref[key], rel=1e-12, abs=0.0), (trial, key)
    # a pair that is not finite in balanced units: the guard fails, every entry inf
    finite, out = balanced_guard(np.array([1e300, 0.0]), np.ones(2), np.full(2, 1e-300),
                                 np.ones(2), np.array([0.5]), 2, 1.0)
    assert not finite and np.isinf(out).all()


def test_small_sweeps_cap_route_equals_general_path(monkeypatch):
    # auto.SMALL_SWEEPS (the study knob of validation/auto_small_sweeps.py): the first NSGS
    # stage of a small problem stops at the cap on both paths, and NSGS runs again, uncapped,
    # as the chain's last stage
    from socp_cd.solvers import auto
    p = manufactured(12, 3, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=6)
    monkeypatch.setattr(auto, "SMALL_SWEEPS", 3)
    order = [m for m, _ in auto.stage_order(p, "coulomb", auto.features(p, "coulomb"))]
    assert order[0] == "nsgs" and order[-1] == "nsgs" and order.count("nsgs") == 2
    a = socp_cd.solve(p, tol=1e-14)
    b = _general(monkeypatch, p, tol=1e-14)
    _same(a, b)
    first = a.info["path"][0]
    assert first["method"] == "nsgs" and first["iterations"] == 3
    assert [s["method"] for s in a.info["path"]] == [s["method"] for s in b.info["path"]]
    monkeypatch.setattr(auto, "SMALL_SWEEPS", None)      # the default: no cap, no second NSGS
    order = [m for m, _ in auto.stage_order(p, "coulomb", auto.features(p, "coulomb"))]
    assert order.count("nsgs") == 1
    assert socp_cd.solve(p, tol=1e-14, max_iter=40).info["path"][0]["iterations"] == 40
    monkeypatch.setattr(auto, "SMALL_SWEEPS", 3)         # the caller's smaller max_iter wins
    for kw in (dict(), dict(time_limit=5.0)):
        assert socp_cd.solve(p, tol=1e-14, max_iter=2, **kw).info["path"][0]["iterations"] == 2
        assert _general(monkeypatch, p, tol=1e-14, max_iter=2,
                        **kw).info["path"][0]["iterations"] == 2


@pytest.mark.parametrize("knob,value", [("SMALL_SWEEPS", 0), ("SMALL_SWEEPS", 2.5),
                                        ("SMALL_STALL", -1), ("SMALL_STALL", True)])
def test_small_stage_knobs_are_checked(monkeypatch, knob, value):
    from socp_cd.solvers import auto
    p = manufactured(12, 3, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=6)
    monkeypatch.setattr(auto, knob, value)
    with pytest.raises(ValueError, match=knob):
        socp_cd.solve(p, tol=1e-14)


def test_last_nsgs_stage_runs_after_a_first_stage_that_did_not_improve_r0(monkeypatch):
    # the capped first NSGS stage and the appended NSGS with its defaults are different runs:
    # the second is not skipped as "the same method from the same start" (review, session 8)
    from socp_cd.solvers import auto
    p = manufactured(6, 2, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=10)
    r0 = socp_cd.solve(p, "nsgs", max_iter=50, tol=1e-18).r
    monkeypatch.setattr(auto, "SMALL_SWEEPS", 1)
    # (without the cold alternative, which meets 1e-18 by the stages' measure here and ends
    # the chain: the order's last stage would not be reached)
    monkeypatch.setattr(auto, "ALT_ALPHA0", None)
    monkeypatch.setattr(auto, "LAST_RESORT", False)     # (the order's own last stage)
    methods = [s["method"] for s in socp_cd.solve(p, tol=1e-18, r0=r0).info["path"]]
    assert methods[0] == "nsgs" and methods[-1] == "nsgs"


def test_small_stall_window_reaches_the_first_nsgs_stage_on_both_paths(monkeypatch):
    # auto.SMALL_STALL (a study knob of validation/auto_small_sweeps.py): the first NSGS stage
    # of a small problem runs with that stall window on the route and on the general path;
    # the appended last NSGS stage runs with NSGS's defaults
    import dataclasses
    from socp_cd.solvers import auto, nsgs
    p = manufactured(12, 3, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=6)
    seen, calls = [], []
    original = nsgs.compiled_run

    def spy(*args):
        seen.append(args[6] if len(args) > 6 else None)
        return original(*args)

    def recording(problem, formulation, **kw):
        calls.append(kw.get("stall_window"))
        return nsgs.nsgs_backend(problem, formulation, **kw)
    monkeypatch.setattr(nsgs, "compiled_run", spy)
    monkeypatch.setitem(auto._STAGES, "nsgs",
                        (dataclasses.replace(nsgs.SPEC, func=recording), {}))
    monkeypatch.setattr(auto, "SMALL_STALL", 7)
    # (without the cold fixed point after the warm one: at this unreachable tol it cuts the
    # error a little, and the rounds that follow run NSGS again)
    monkeypatch.setattr(auto, "FP_COLD_AFTER_WARM", False)
    order = [m for m, _ in auto.stage_order(p, "coulomb", auto.features(p, "coulomb"))]
    assert order[0] == "nsgs" and order[-1] == "nsgs"
    a = socp_cd.solve(p, tol=1e-17)
    assert seen == [7] and "route" not in a.info        # routed first stage, then resumed
    assert calls == [None]                               # the last NSGS stage: defaults
    calls.clear()
    b = _general(monkeypatch, p, tol=1e-17)
    assert calls == [7, None]
    _same(a, b)
    assert [(s["method"], s["iterations"]) for s in a.info["path"]] == \
           [(s["method"], s["iterations"]) for s in b.info["path"]]


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_run_stall_window_is_the_option(dim):
    # nsgs.compiled_run(..., stall_window=w) stops where solve(p, "nsgs", stall_window=w) does
    from socp_cd.solvers import nsgs
    p = dict(CASES)[f"manufactured-tree-{dim}d-140c"]
    stops = set()
    for w in (1, 30):
        ref = socp_cd.solve(p, "nsgs", tol=1e-17, stall_window=w)
        out = nsgs.compiled_run(p, 1e-17, None, None, None, True, w)
        assert (out.status, int(out.stats[nsgs_route.SWEEPS])) == (ref.status, ref.iterations)
        assert np.array_equal(out.vectors[1], ref.r)
        stops.add(ref.status)
    assert stops == {"stalled", "max_iter"}         # the window changed where NSGS stopped


def test_stats_layout_of_the_route():
    # the layout of nsgs_checked's stats tuple (RouteOutcome.stats), which the routes of
    # nsgs and auto read through the named constants, and the guard's keys after it
    assert (nsgs_route.SWEEPS, nsgs_route.INTERNAL_ERROR, nsgs_route.ERROR, nsgs_route.ZERO_ERROR,
            nsgs_route.START_ERROR, nsgs_route.MU_MAX) == (0, 1, 5, 6, 7, 8)
    assert nsgs_route.STATS[9:13] == ("velocity_scale", "diag_min", "diag_max", "guard_finite")
    assert len(nsgs_route.STATS) == 13 and len(GUARD_KEYS) == 7
    assert GUARD_KEYS == ("error", "balanced_siconos", "rounding", "value", "cone",
                          "normal_velocity", "complementarity")
    # the records built from the tuple by literal index
    x = tuple(float(k) for k in range(20))
    assert nsgs_route.guard_record(x) == {k: 13.0 + j for j, k in enumerate(GUARD_KEYS)}
    assert nsgs_route.scaling_record(x) == {name: x[nsgs_route.STATS.index(name)]
                                            for name in ("velocity_scale", "diag_min", "diag_max")}


def test_flat_kernel_is_the_tuple_kernel():
    # nsgs_checked_flat (auto.plain's call) is nsgs_checked with its outputs in one
    # vector: the same code, vectors and stats, bit for bit, cold and warm, with and without a
    # time limit, the hand-off on or off; its five numbers are the stats' entries
    from socp_cd.solvers import nsgs
    for nc, dim, seed in ((1, 3, 1), (3, 3, 2), (4, 2, 3), (30, 3, 4)):
        p = _random(nc, dim, seed, mu=0.4)
        r0 = np.random.default_rng(seed).random(p.m)
        settings = nsgs.route_settings(dim)
        for r0_, limit, handoff, window in ((None, None, (0, 0), 0), (r0, 1.0, (0, 0), 0),
                                            (None, 1.0, (2, 10), 3), (r0, None, (200, 32000), 20)):
            tail = nsgs_route.prepared(settings, True, handoff, window)
            for tol in (1e-8, 1e-14):
                ref = nsgs_route.run_prepared(p, tail, tol, 50, r0_, limit)
                indptr, indices, data = p.csr_parts
                flat = np.empty((nsgs_route.flat_rows(p.m), p.m))
                if r0_ is not None:
                    flat[0] = r0_
                flat_settings = nsgs_route.flat_settings(dim, 50, nsgs_route.TIME_CHECK_SWEEPS,
                                                         tail)
                got = (nsgs_route.flat_entry(indptr, indices)(
                    indptr, indices, data, p.q, p.mu, flat_settings, r0_ is not None, tol,
                    limit is not None, np.inf if limit is None else limit, flat), flat)
                out = nsgs_route.flat_outcome(*got)
                assert out.status == ref.status and out.stats == ref.stats
                assert np.array_equal(out.vectors, ref.vectors) and out.vectors.shape == (3, p.m)
                x = ref.stats
                assert got[0][1:] == (int(x[nsgs_route.SWEEPS]), x[nsgs_route.INTERNAL_ERROR],
                                      x[nsgs_route.ERROR], x[nsgs_route.GUARD_VALUE],
                                      x[nsgs_route.ZERO_ERROR])
                assert type(got[0][1]) is int and all(type(v) is float for v in got[0][2:])


def test_flat_kernel_declines_an_output_array_too_short():
    # numba does not check bounds: an out with fewer than 3 m + N_OUT entries would have the
    # stats written past its end; the kernel declines it instead, before any work
    from socp_cd.solvers import nsgs
    p = _random(2, 3, 5, mu=0.4)
    tail = nsgs_route.prepared(nsgs.route_settings(3), True, (0, 0), 0)
    settings = nsgs_route.flat_settings(3, 50, nsgs_route.TIME_CHECK_SWEEPS, tail)
    indptr, indices, data = p.csr_parts
    for rows in (3, nsgs_route.flat_rows(p.m)):
        out = np.zeros((rows, p.m))
        x = nsgs_route.nsgs_checked_flat(indptr, indices, data, p.q, p.mu, settings, False,
                                         1e-8, False, np.inf, out)
        assert (x[0] == nsgs_route.DECLINED_SHORT_OUT) is (rows == 3)
        assert (rows == 3) is not out.any()         # (declined: nothing written)
    # a settings vector too short declines too, before any work
    out = np.zeros((nsgs_route.flat_rows(p.m), p.m))
    x = nsgs_route.nsgs_checked_flat(indptr, indices, data, p.q, p.mu, settings[:-1], False,
                                     1e-8, False, np.inf, out)
    assert x[0] == nsgs_route.DECLINED_SHORT_OUT and not out.any()
    # flat_settings takes the names' count of values, each exact in float64
    with pytest.raises(ValueError):
        nsgs_route.flat_settings(3, 50, 10, tail[:-1])
    with pytest.raises(ValueError):
        nsgs_route.flat_settings(3, 2 ** 53 + 1, 10, tail)


def test_of_local_fills_the_fields_it_names():
    from dataclasses import fields
    from socp_cd.solvers.result import SolverResult
    r, u, info = np.ones(3), np.zeros(3), {"k": 1}
    res = SolverResult.of_local(r, u, "stalled", 0.25, 7, info, "why", True)
    assert [f.name for f in fields(SolverResult)][:16] == [
        "r", "u", "v", "converged", "status", "error", "coulomb_error", "iterations", "time",
        "solver", "formulation", "tol", "history", "info", "message", "trivial"]
    assert (res.r is r and res.u is u and res.v is None and res.converged is False
            and res.status == "stalled" and res.error == res.coulomb_error == 0.25
            and res.iterations == 7 and res.info is info and res.message == "why"
            and res.trivial is True and res.history is None)
    # the same object as the dataclass's constructor makes: every field, in order
    ref = SolverResult(r, u, None, False, "stalled", 0.25, 0.25, 7, 0.0, "", "", 0.0, None,
                       info, "why", True)
    assert list(vars(res)) == list(vars(ref))
    assert all(vars(res)[k] is vars(ref)[k] or vars(res)[k] == vars(ref)[k] for k in vars(ref))
    assert res == ref and repr(res) == repr(ref)
    # with the dispatcher's verdict fields (SolverSpec.plain's finished result)
    res = SolverResult.of_local(r, u, "converged", 0.25, 7, info, "why", False, True, "auto",
                                "coulomb", 1e-8, 0.5)
    ref = SolverResult(r, u, None, True, "converged", 0.25, 0.25, 7, 0.5, "auto", "coulomb",
                       1e-8, None, info, "why", False)
    assert list(vars(res)) == list(vars(ref)) and res == ref and repr(res) == repr(ref)


def test_handoff_route_equals_general_path(monkeypatch):
    # the hand-off (auto.HANDOFF_SWEEPS): the first NSGS stage stops at the same sweep on the
    # compiled route and on the general path, and the chain goes on identically
    from socp_cd.solvers import auto
    p = manufactured(12, 3, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=6)
    monkeypatch.setattr(auto, "HANDOFF_SWEEPS", 3)
    monkeypatch.setattr(auto, "HANDOFF_WORK", 1)
    a = socp_cd.solve(p, tol=1e-14)
    b = _general(monkeypatch, p, tol=1e-14)
    _same(a, b)
    assert a.info["path"][0]["method"] == "nsgs" and a.info["path"][0]["iterations"] == 3
    assert [s["method"] for s in a.info["path"]] == [s["method"] for s in b.info["path"]]
    assert a.info["path"][1]["method"] == "newton_trial"
    assert a.info["path"][1]["iterations"] <= auto.TRIAL_STEPS


def test_handoff_work_term_route_equals_general_path(monkeypatch):
    # two strongly coupled contacts: nnz(W) = 36, so HANDOFF_WORK (not HANDOFF_SWEEPS) sets the
    # cap (ceil(32 000 / 36) = 889 sweeps); the compiled route and the general path must stop
    # the first NSGS stage at the same sweep, with the module's constants, a warm start, a
    # time limit and a max_iter above NSGS's default
    from socp_cd.solvers import auto
    p = coupled_pair()
    m = p.m
    cap = auto._handoff_cap(p, None)
    assert cap == -(-auto.HANDOFF_WORK // int(p.csr_parts[0][-1])) > auto.HANDOFF_SWEEPS
    stops = set()
    for predict in (0, auto.HANDOFF_PREDICT):       # the rate prediction off, and the default
        monkeypatch.setattr(auto, "HANDOFF_PREDICT", predict)
        for kw in (dict(), dict(r0=np.full(m, 0.1)), dict(time_limit=5.0), dict(max_iter=2000)):
            a = socp_cd.solve(p, tol=1e-10, **kw)
            b = _general(monkeypatch, p, tol=1e-10, **kw)
            _same(a, b)
            assert [s["method"] for s in a.info["path"]] == [s["method"] for s in b.info["path"]]
            first = a.info["path"][0]
            assert first["iterations"] <= cap
            if first["status"] == "max_iter":
                stops.add((predict, first["iterations"] == cap))
                assert first["iterations"] == cap or predict
    # slow NSGS here: without the prediction it runs to the cap, with it it hands over earlier
    assert stops == {(0, True), (auto.HANDOFF_PREDICT, False)}


def test_plain_call_fast_dispatch_equals_the_full_checks():
    # solve(p) with common options only takes registry._plain; verbose=0 (an int, not the
    # bool False) sends the same call through every check of solve(): the same answer
    for name, p in CASES[:6]:
        for kw in (dict(), dict(time_limit=2.0), dict(max_iter=4), dict(tol=1e-12),
                   dict(r0=np.random.default_rng(3).random(p.m))):
            for solver in ("auto", "nsgs"):
                a = socp_cd.solve(p, solver, **kw)
                b = socp_cd.solve(p, solver, verbose=0, **kw)
                _same(a, b)
                assert (a.solver, a.formulation, a.tol, a.message) == (b.solver, b.formulation,
                                                                       b.tol, b.message)


def _info_same(a, b):
    """The routed results' ``info`` equal but for the stages' times (and their errors to
    rounding, as the route reads NSGS's own final error)."""
    ia, ib = a.info, b.info
    assert set(ia) == set(ib)
    for key in ia:
        if key != "path":
            assert ia[key] == ib[key], key
    assert len(ia["path"]) == len(ib["path"])
    for sa, sb in zip(ia["path"], ib["path"]):
        assert {k: v for k, v in sa.items() if k != "time"} == \
               {k: v for k, v in sb.items() if k != "time"}


@pytest.mark.parametrize("name,p", CASES, ids=[c[0] for c in CASES])
def test_auto_plain_equals_the_route_and_the_verdict(monkeypatch, name, p):
    # SolverSpec.plain (auto.plain): solve(p) with max_iter and r0 None returns the route's
    # answer judged; verbose=0 (an int) takes every check, auto.route and registry._routed.
    # Both answers are the same, field by field; on small problems whose NSGS stage meets
    # tol clear of the margin, plain builds the result itself (no route, no stage outcome)
    from socp_cd.solvers import auto
    socp_cd.solvers()       # (the solver table loaded: a process's first solve takes every check)
    calls = []
    for fn in ("route", "_stage_outcome"):
        original = getattr(auto, fn)
        monkeypatch.setattr(auto, fn, lambda *a, _f=original, _n=fn, **k:
                            calls.append(_n) or _f(*a, **k))
    for kw in (dict(), dict(time_limit=5.0), dict(tol=1e-12), dict(tol=1e-3)):
        calls.clear()
        a = socp_cd.solve(p, **kw)
        took = list(calls)
        b = socp_cd.solve(p, verbose=0, **kw)
        _same(a, b)
        assert (a.solver, a.formulation, a.tol, a.message, a.history) == \
               (b.solver, b.formulation, b.tol, b.message, b.history)
        _info_same(a, b)
        assert 0 <= a.time < 10.0 and type(a.time) is float
        small = p.n_contacts <= auto.SMALL_NC
        assert ("route" in took) == (not small)
        lo = a.tol * auto._JUDGE_LO
        clear = (len(a.info["path"]) == 1 and a.info["path"][0]["error"] <= lo
                 and a.error <= lo and a.info["guard"]["value"] <= lo)
        if small:       # judged in plain itself, or handed to the route's remainder
            assert took == ([] if clear else ["_stage_outcome"])


def test_auto_plain_takes_both_branches(monkeypatch):
    # the same small problem: clear of tol = 1e-3 (plain judges it), short of tol = 1e-17
    # (the route's remainder: the hand-off's trials and the chain)
    from socp_cd.solvers import auto
    socp_cd.solvers()       # (the solver table loaded: a process's first solve takes every check)
    calls = []
    original = auto._stage_outcome
    monkeypatch.setattr(auto, "_stage_outcome", lambda *a, **k: calls.append(1) or original(*a, **k))
    p = _random(3, 3, seed=7)
    for tol, took in ((1e-3, []), (1e-17, [1])):
        calls.clear()
        a = socp_cd.solve(p, tol=tol)
        assert calls == took and a.converged == (tol == 1e-3)
        _same(a, socp_cd.solve(p, tol=tol, verbose=0))


def test_auto_plain_takes_the_route_under_a_study_knob(monkeypatch):
    # a study's knob (auto.SMALL_SWEEPS, SMALL_STALL, HANDOFF_SWEEPS None) sends plain through
    # auto.route, which applies or checks it (HANDOFF_PREDICT = 0, a valid window, does not):
    # the same answer as the full checks give
    from socp_cd.solvers import auto
    p = coupled_pair()
    calls = []
    original = auto.route
    monkeypatch.setattr(auto, "route", lambda *a, **k: calls.append(1) or original(*a, **k))
    for knob, value in (("SMALL_SWEEPS", 3), ("SMALL_STALL", 7), ("HANDOFF_SWEEPS", None),
                        ("HANDOFF_PREDICT", 0)):
        with monkeypatch.context() as m:
            m.setattr(auto, knob, value)
            calls.clear()
            a = socp_cd.solve(p, tol=1e-10)
            assert calls == ([1] if knob != "HANDOFF_PREDICT" else [])
            b = socp_cd.solve(p, tol=1e-10, verbose=0)
            _same(a, b)
            _info_same(a, b)
    with monkeypatch.context() as m:
        m.setattr(auto, "HANDOFF_SWEEPS", 0)        # a bad value: route names it
        with pytest.raises(ValueError, match="HANDOFF_SWEEPS"):
            socp_cd.solve(p)


@pytest.mark.parametrize("kw", [dict(tol=0.0), dict(tol=float("nan")), dict(tol=-1e-8),
                                dict(tol="1e-8"), dict(max_iter=0), dict(max_iter=2.5),
                                dict(max_iter=2 ** 62 + 1),
                                dict(time_limit=-1.0), dict(time_limit=float("inf")),
                                dict(r0=np.zeros(2)), dict(r0=np.full(9, np.nan))])
def test_plain_call_rejects_what_the_full_checks_reject(kw):
    p = _random(3, 3, seed=11)
    errors = []
    for extra in (dict(), dict(verbose=0)):
        with pytest.raises(socp_cd.SocpCdError) as exc:
            socp_cd.solve(p, **kw, **extra)
        errors.append((type(exc.value), str(exc.value)))
    assert errors[0] == errors[1]



def test_no_early_stop_when_the_handoff_cap_does_not_bind(monkeypatch):
    # max_iter below the hand-off's cap: no hand-off, and no rate prediction either, on both
    # paths (NSGS runs its max_iter sweeps, as without the hand-off)
    from socp_cd.solvers import auto
    p = coupled_pair()
    assert auto._handoff_cap(p, 100) is None and auto._predict_window(p) > 0
    for kw in (dict(), dict(time_limit=5.0)):
        a = socp_cd.solve(p, tol=1e-10, max_iter=100, **kw)
        b = _general(monkeypatch, p, tol=1e-10, max_iter=100, **kw)
        _same(a, b)
        assert a.info["path"][0]["iterations"] == 100


def test_routed_auto_result_builds_its_info_on_first_read_only(monkeypatch):
    # a converged routed auto call returns info as a LazyInfo: the verdict read the guard
    # value from the route, not from info; the dict built on first read is the one the
    # general path reports (path, features, guard, scaling), and it is built once; a copy
    # or a pickle carries the built dict (never the route's private builder)
    import copy
    import dataclasses
    import pickle
    from socp_cd.solvers import auto
    from socp_cd.solvers.result import LazyInfo
    p = _random(3, 3, seed=11)
    calls = []
    original = auto._route_info
    monkeypatch.setattr(auto, "_route_info", lambda *a: calls.append(1) or original(*a))
    res = socp_cd.solve(p)
    assert res.converged and type(res._info) is LazyInfo and not calls
    info = res.info
    assert res.info is info and type(res._info) is dict and len(calls) == 1
    assert info["route"] == "compiled" and info["guard"]["value"] <= 1e-8
    b = _general(monkeypatch, p)
    assert info["features"] == b.info["features"] and info["guard"] == b.info["guard"]
    assert [s["method"] for s in info["path"]] == [s["method"] for s in b.info["path"]]
    assert dataclasses.replace(res, status="stalled").info is info
    for make in (lambda x: pickle.loads(pickle.dumps(x)), copy.copy):
        fresh = socp_cd.solve(p)
        assert type(fresh._info) is LazyInfo
        twin = make(fresh)      # (pickling the patched builder would fail: it is built first)
        assert type(fresh._info) is dict and twin.info == fresh.info
    assert copy.copy(fresh).info is fresh.info      # a shallow copy shares it, as any field


def test_a_lazy_info_reads_as_the_dict_everywhere():
    import dataclasses
    from socp_cd.solvers.result import LazyInfo, SolverResult
    built = {"k": 1}
    res = SolverResult.of_local(np.ones(3), np.zeros(3), "converged", 0.0, 1,
                                LazyInfo((dict, built)), "", False)
    assert res.info == built and res.info is res.info
    assert dataclasses.asdict(res)["info"] == built
    res.info = {"other": 2}                 # assignment replaces it, as for any field
    assert res.info == {"other": 2}
    assert SolverResult(np.ones(1)).info == {}


@pytest.mark.parametrize("dim", [2, 3])
def test_one_contact_nsgs_checks_its_first_sweep(dim):
    # with one contact the local solve is the whole problem: NSGS checks the full error
    # after the first sweep and stops there (it used to run a second, confirming sweep)
    for seed in range(5):
        p = _random(1, dim, seed, mu=0.2 + 0.3 * seed)
        res = socp_cd.solve(p, "nsgs")
        assert res.converged and res.iterations == 1, (seed, res)
        assert socp_cd.error(p, res.r) <= 1e-8


def _decoupled(nc, dim, seed, coupled=False):
    """``nc`` one-contact problems of :func:`_random` side by side (W block diagonal); with
    ``coupled``, contacts 0 and 1 share a small off-diagonal block (W stays SPD)."""
    ps = [_random(1, dim, seed * 100 + i, mu=0.2 + 0.1 * i) for i in range(nc)]
    W = np.zeros((nc * dim, nc * dim))
    for i, p in enumerate(ps):
        W[i * dim:(i + 1) * dim, i * dim:(i + 1) * dim] = p.W.toarray()
    if coupled:
        c = 1e-3 * min(W[0, 0], W[dim, dim])
        W[0, dim] = W[dim, 0] = c
    q = np.concatenate([p.q for p in ps])
    return FrictionContactProblem(W, q, np.array([p.mu[0] for p in ps]), dim)


@pytest.mark.parametrize("dim", [2, 3])
def test_block_diagonal_w_nsgs_checks_its_first_sweep(monkeypatch, dim):
    # W block diagonal: every local solve is its own whole problem, so the first sweep is the
    # answer and NSGS checks it (session 29; one contact was the only such case before), on
    # the compiled route, the general path and auto alike; a coupled W, or relaxation, still
    # confirms it by a second sweep, whose light error is the first one that can be small
    for seed in range(3):
        p = _decoupled(12, dim, seed)
        for res in (socp_cd.solve(p, "nsgs"), _general(monkeypatch, p, solver="nsgs"),
                    socp_cd.solve(p)):
            assert res.converged and res.iterations == 1, (seed, res)
            assert socp_cd.error(p, res.r) <= 1e-8
        _same(socp_cd.solve(p, "nsgs"), _general(monkeypatch, p, solver="nsgs"))
        # coupled: the first sweep already meets a loose tol, yet it is not checked
        c = _decoupled(12, dim, seed, coupled=True)
        assert socp_cd.solve(c, "nsgs", tol=1e-2, max_iter=1).error <= 1e-2
        res = socp_cd.solve(c, "nsgs", tol=1e-2)
        assert res.converged and res.iterations >= 2, (seed, res)
        # with relaxation one sweep is not the answer: its sweeps are not all checked
        res = socp_cd.solve(p, "nsgs", tol=1e-10, omega=0.5, error_every=0)
        assert res.converged and res.iterations >= 3, (seed, res)
        assert res.info["full_error_evaluations"] < res.iterations, (seed, res.info)


def _heavy_and_light(nc, dim, structure, seed, mass_ratio, scale):
    """A manufactured problem (mu 0.6) with bodies of very different masses / contact scales."""
    return manufactured(nc, dim, mu=0.6, structure=structure, mass_ratio=mass_ratio,
                        contact_scale=scale, seed=seed)


@pytest.mark.parametrize("args", [(8, 2, "tree", 1, 1e6, 1.0), (4, 2, "tree", 3, 1e6, 1e4),
                                  (8, 3, "redundant", 5, 1.0, 1e4)])
def test_nsgs_stops_on_the_dispatchers_measure_not_only_the_balanced_one(monkeypatch, args):
    # problems whose balanced-units error meets tol before Siconos' error of the problem as
    # written does: NSGS used to stop there, the dispatcher refused and ran it again (a
    # retry from the Python path); the sweeps now also check the measure the dispatcher
    # judges by (kernels.scaling.origin_error), on the compiled route and the general path
    from socp_cd.solvers import nsgs as nsgs_module
    p = _heavy_and_light(*args)
    routed = socp_cd.solve(p, "nsgs")
    general = _general(monkeypatch, p, solver="nsgs")
    _same(routed, general)
    assert routed.converged and "retry" not in routed.info and routed.info["route"] == "compiled"
    assert routed.error <= 1e-8 and socp_cd.error(p, routed.r) <= 1e-8
    with monkeypatch.context() as m:        # without the origin: the refused claim, the retry
        m.setattr(nsgs_module, "origin", lambda problem: None)
        m.setattr(nsgs_route, "MAX_CONTACTS", 0)
        before = socp_cd.solve(p, "nsgs")
    assert before.info["retry"]["first_error"] > 1e-8 >= before.info["retry"]["retry_error"]


@pytest.mark.parametrize("args", [(8, 3, "redundant", 1, 1e6, 1.0), (8, 3, "redundant", 2, 1e6, 1.0),
                                  (4, 2, "tree", 1, 1e6, 1e4)])
def test_auto_judges_its_stages_by_the_dispatchers_measure(monkeypatch, args):
    # auto's stages (NSGS, Newton trials) used to end the chain on an answer within tol in
    # balanced units only; the dispatcher refused it and ran the whole chain again. The
    # judge's guard value now includes Siconos' error of the problem as written
    from socp_cd.solvers import auto, newton
    from socp_cd.solvers import nsgs as nsgs_module
    p = _heavy_and_light(*args)
    res = socp_cd.solve(p)
    assert res.converged and "retry" not in res.info and socp_cd.error(p, res.r) <= 1e-8
    with monkeypatch.context() as m:        # without the origin: the chain's answer refused
        m.setattr(auto, "origin", lambda problem: None)
        m.setattr(nsgs_module, "origin", lambda problem: None)
        m.setattr(newton, "origin", lambda problem: None)
        m.setattr(nsgs_route, "MAX_CONTACTS", 0)
        before = socp_cd.solve(p)
    assert before.info["retry"]["first_error"] > 1e-8


@pytest.mark.parametrize("args", [(4, 3, "tree", 1, 1e6, 1.0), (4, 3, "redundant", 2, 1e6, 1.0)])
def test_newton_goes_on_when_only_the_balanced_error_met_tol(monkeypatch, args):
    # the Newton backend on the dispatcher's balanced copy: a run that met tol in balanced
    # units only goes on from its answer with the dispatcher's tightened tolerance (one call,
    # the system kept), instead of the dispatcher's refusal and retry
    from socp_cd.solvers import newton
    p = _heavy_and_light(*args)
    res = socp_cd.solve(p, "newton")
    assert res.converged and "retry" not in res.info and socp_cd.error(p, res.r) <= 1e-8
    runs = res.info["continued"]
    assert 1 <= len(runs) <= newton.MAX_CONTINUED and runs[0]["error_as_written"] > 1e-8
    assert res.iterations > sum(run["iterations"] for run in runs)
    with monkeypatch.context() as m:
        m.setattr(newton, "origin", lambda problem: None)
        m.setattr(newton, "ROUTE_MAX_M", 0)           # (the general path: newton.route off)
        before = socp_cd.solve(p, "newton")
    assert before.info["continued"] == [] and before.info["retry"]["first_error"] > 1e-8
    assert before.info["retry"]["first_iterations"] == runs[0]["iterations"]


def test_newton_continuation_keeps_its_contracts(monkeypatch):
    # history: one entry per outer iteration plus the start, across the continued runs;
    # counters summed; max_iter bounds all runs; a continued run that fails leaves the claim
    # (the dispatcher then retries it, as before the continuation existed)
    from socp_cd.solvers import newton
    p = _heavy_and_light(4, 3, "redundant", 2, 1e6, 1.0)
    res = socp_cd.solve(p, "newton", history=True)
    assert res.info["continued"] and res.converged
    assert len(res.history) == res.iterations + 1
    assert res.info["newton_steps"] >= res.iterations
    first = res.info["continued"][0]["iterations"]
    capped = socp_cd.solve(p, "newton", max_iter=first)     # no iteration left to go on with
    assert capped.iterations <= first + capped.info.get("retry", {}).get("retry_iterations", 0)
    real = newton.prox_newton
    runs = []

    def failing(system, mu, r, **kw):     # every continued run fails, far off
        runs.append(kw["alpha0"])
        out = real(system, mu, r, **kw)
        if len(runs) > 1:
            return ("stalled", np.full_like(out[1], 1e3)) + out[2:]
        return out
    monkeypatch.setattr(newton, "prox_newton", failing)
    monkeypatch.setattr(newton, "ROUTE_MAX_M", 0)         # (the general path: newton.route off)
    kept = socp_cd.solve(p, "newton")
    assert len(runs) >= 3 and runs[1] == max(min(newton.COLD_ALPHA0, newton.WARM_ALPHA0), 1e-10)
    # the claim stood, the dispatcher refused it and its retry (a new backend call) ran
    assert kept.info["retry"]["first_error"] > 1e-8



def test_origin_error_is_the_error_of_the_problem_as_written():
    # kernels.scaling.origin_error on a pair of the balanced copy = socp_cd.error of the
    # problem as written (to the rounding of u = W r + q); only the copy has an origin
    from socp_cd.solvers.kernels.scaling import origin_error
    from socp_cd.solvers.scaling import balanced, origin
    p = _heavy_and_light(8, 3, "redundant", 4, 1e6, 1.0)
    copy = balanced(p).problem
    a, b, q_norm = origin(copy)
    assert origin(p) is None and a.flags.writeable and b.flags.writeable
    rng = np.random.default_rng(3)
    for scale in (1e-3, 1.0, 1e3):
        r = scale * rng.random(p.m) * np.repeat(rng.uniform(0.1, 10.0, p.n_contacts), 3)
        rs = r / a
        e = origin_error(rs, copy.velocity(rs), a, b, p.mu, 3, q_norm)
        assert e == pytest.approx(socp_cd.error(p, r), rel=1e-9)
    huge = origin_error(np.full(p.m, 1e300), np.full(p.m, 1e300), a, b, p.mu, 3, q_norm)
    assert not huge <= 1e-8         # an overflow never passes (inf or NaN, not a small number)


@pytest.mark.parametrize("dim", [2, 3])
def test_scaled_error_parts_is_error_parts_of_the_products(dim):
    from socp_cd.solvers.kernels.cone import LAW_ASSOCIATED, LAW_TRESCA, scaled_error_parts
    rng = np.random.default_rng(dim)
    m = 7 * dim
    r, u, a, b = rng.standard_normal(m), rng.standard_normal(m), rng.random(m), rng.random(m)
    mu, g = rng.random(7), rng.random(7)
    for law in (LAW_COULOMB, LAW_ASSOCIATED, LAW_TRESCA):
        assert scaled_error_parts(r, u, a, b, mu, g, dim, law) == \
            error_parts(a * r, b * u, mu, g, dim, law)          # the same bits


def test_auto_route_gives_its_stages_the_general_paths_shares(monkeypatch):
    # under a time limit the route's NSGS stage gets STAGE_SHARE of the budget and each
    # compiled trial PLAIN_SHARE of what is left, as auto_backend gives its stages (the
    # deadlines on the compiled clock; before session 24 the route read no clock)
    from socp_cd.solvers import auto
    socp_cd.solvers()       # (the solver table loaded: a process's first solve takes every check)
    budgets, trials = [], []
    real_runs = newton.compiled_runs

    def run_spy(*a):            # (auto.plain's NSGS kernel call: the stage's time limit)
        budgets.append(a[9] if a[8] else None)
        return nsgs_route.flat_entry(a[0], a[1])(*a)

    def runs_spy(*a, time_left=None, **kw):
        trials.append(time_left)
        return real_runs(*a, time_left=time_left, **kw)
    monkeypatch.setattr(auto, "_FLAT_ENTRIES", {np.dtype(np.int32): run_spy,
                                                np.dtype(np.int64): run_spy})
    monkeypatch.setattr(newton, "compiled_runs", runs_spy)
    p = manufactured(12, 3, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=6)
    for limit in (None, 10.0):
        budgets.clear(), trials.clear()
        res = socp_cd.solve(p, time_limit=limit)
        assert budgets == [None if limit is None else auto.STAGE_SHARE * limit]
        assert trials and all((t is None) if limit is None else
                              0 < t <= auto.PLAIN_SHARE * limit for t in trials)
        # the trials' shares are of what the stage left of the whole budget, not of the
        # stage's own share (a small problem's plain call once handed the chain the latter)
        assert limit is None or trials[0] > 0.9 * auto.PLAIN_SHARE * limit
        assert res.converged


@pytest.mark.parametrize("prox_first", [False, True])
def test_compiled_trials_equal_general_path_and_resume(monkeypatch, prox_first):
    # after the route's NSGS stage misses tol, the hand-off's Newton trials (plain from NSGS's
    # iterate, plain and proximal from r = 0) run compiled too (auto._compiled_trials): a trial
    # that meets tol ends the call on the route; a failed one is handed on (resume) and the
    # chain goes on as on the general path, which runs every trial itself; in either order of
    # the cold trials (auto.COLD_PROX_FIRST, a study knob)
    from socp_cd.solvers import auto
    monkeypatch.setattr(auto, "COLD_PROX_FIRST", prox_first)
    cold = ["newton_trial_prox", "newton_trial_cold"] if prox_first else \
        ["newton_trial_cold", "newton_trial_prox"]
    seen = []
    real = newton.compiled_runs

    def spy(problem, norm_q, start, tol, max_iter, *, prox, **kw):
        seen.append(prox)
        return real(problem, norm_q, start, tol, max_iter, prox=prox, **kw)

    monkeypatch.setattr(newton, "compiled_runs", spy)
    def case(dim, seed):
        return manufactured(12, dim, mu=0.6, structure="redundant", mass_ratio=1e6,
                            contact_scale=1e4, seed=seed)
    plain = (dict(), dict(tol=1e-12), dict(time_limit=5.0))
    # (the last: a cold trial meets tol in balanced units, is refused, the chain goes on)
    # (90 unknowns, above the written-out LU's NAIVE_LU_MAX_N: a tree's envelope keeps it)
    tree = manufactured(30, 3, mu=0.6, structure="tree", mass_ratio=1e6, contact_scale=1e4,
                        seed=0)
    # (tol=1e-18: no trial can meet it, so a hand-on occurs whatever the rounding of the
    # machine and library versions; at 1e-14 one did on one machine and not on another)
    cases = [(case(2, 6), plain), (case(3, 6), plain),
             (case(3, 7), (dict(tol=1e-14), dict(tol=1e-18))),
             (tree, plain[:1])]
    if prox_first:      # (the proximal trial meets the tolerances above: one it misses)
        cases.append((case(3, 10), (dict(tol=1e-12),)))
    outcomes = set()
    for p, kws in cases:
        for kw in kws:
            seen.clear()
            a = socp_cd.solve(p, **kw)
            b = _general(monkeypatch, p, **kw)
            _same(a, b)
            assert [(s["method"], s["iterations"], s["status"]) for s in a.info["path"]] == \
                   [(s["method"], s["iterations"], s["status"]) for s in b.info["path"]]
            for sa, sb in zip(a.info["path"], b.info["path"]):
                assert sa["error"] == pytest.approx(sb["error"], rel=1e-9, abs=1e-13)
            assert a.info["best_stage"] == b.info["best_stage"]
            # the route ran the chain's trials, in its order: plain, then the cold ones
            assert seen and seen == [False] + [c == "newton_trial_prox"
                                               for c in cold][:len(seen) - 1]
            methods = [s["method"] for s in a.info["path"]]
            assert methods[1:1 + len(seen)] == ["newton_trial"] + cold[:len(seen) - 1]
            if "route" in a.info:
                assert a.converged and len(methods) == 1 + len(seen)    # met tol on the route
                outcomes.add("route")
            else:
                outcomes.add("handed on")
    # both outcomes occur: a trial met tol on the route, and one was handed on
    assert outcomes == {"route", "handed on"}


def test_trial_runs_equal_newton_backend_on_the_balanced_copy():
    # nsgs_route.trial_runner in newton.continued_runs is the Newton backend with its default
    # settings on the dispatcher's balanced copy: the same answer, status and iterations
    # (policy plain / prox, from r = 0 and from a start), also where a run that met tol in
    # balanced units goes on (heavy and light contacts side by side)
    from socp_cd.solvers import auto, newton
    from socp_cd.solvers.scaling import balanced
    compared, went_on = 0, 0
    for dim, seed, scale in ((3, 1, 1.0), (2, 2, 1.0), (3, 3, 1e4), (2, 4, 1e4), (3, 5, 1e4)):
        p = manufactured(6, dim, mu=0.5, structure="redundant", mass_ratio=1e6,
                         contact_scale=scale, seed=seed)
        copy = balanced(p).problem
        settings = {"kind": 1, "loc_tol": 1e-13, "newton_maxit": 10, "proj_maxit": 100,
                    "omega": 1.0, "error_every": 10, "stall_window": 5000}
        out = nsgs_route.run(p, tuple(settings[k] for k in nsgs_route.ROUTE_SETTINGS), 1e-10,
                             3, None, None, True)
        assert out is not None
        c = newton.trial_constants()
        for warm in (False, True):
            start = out.vectors[0].copy() if warm else np.zeros(p.m)
            for prox, steps in ((False, 6), (True, 4)):
                run = nsgs_route.trial_runner(p, nsgs_route.judge_norm(p), prox, 2, c)
                st, r, its, _, info = newton.continued_runs(
                    run, lambda r, i: i["error_as_written"], start, 1e-10, steps,
                    c[nsgs_route.C_ALPHA0], c[nsgs_route.C_ALPHA_MIN], None)
                ref = newton.newton_backend(copy, "coulomb", tol=1e-10, max_iter=steps,
                                            r0=start if warm else None,
                                            policy="prox" if prox else "plain",
                                            stall_window=2)
                assert np.array_equal(r, ref.r)
                assert (st, its) == (ref.status, ref.iterations)
                assert len(info["continued"]) == len(ref.info["continued"])
                t, judge_guard = nsgs_route.trial_outcome(p, nsgs_route.judge_norm(p), st, r)
                assert np.array_equal(t.vectors[1], r * balanced(p).a)
                judge = auto._Judge(copy, "coulomb", {}, 1e-10)
                assert t.stats[nsgs_route.INTERNAL_ERROR] == judge(r)   # the judge's, exactly
                assert judge_guard == judge.guard_value(r)
                # newton.compiled_runs: the first run and the checks in one compiled call
                # (nsgs_route.newton_checked), the runs above when one goes on; ||q~|| given
                # or computed in the call
                for norm_q in (nsgs_route.judge_norm(p), -1.0):
                    for full in (False, True, "lazy"):
                        fst, fits, finfo, (fout, fguard) = newton.compiled_runs(
                            p, norm_q, start, 1e-10, steps, prox=prox, stall_window=2,
                            constants=c, full_info=full)
                        assert (fst, fits, fguard) == (st, its, judge_guard)
                        assert np.array_equal(fout.vectors, t.vectors)
                        assert fout.stats == t.stats and fout.status == t.status
                        if type(finfo) is LazyInfo:     # (one run: built on first read)
                            assert not info["continued"]
                            finfo = finfo[0](*finfo[1:])
                        assert finfo["continued"] == info["continued"]
                        assert finfo["internal_error"] == info["internal_error"]
                        if full:        # the backend's info, its keys in the same order
                            assert list(finfo.items()) == list(
                                run_info_of(p, prox, start, steps, c).items())
                compared += 1
                went_on += bool(info["continued"])
    assert compared == 20 and went_on >= 1


def run_info_of(p, prox, start, steps, c):
    """The backend's info of newton.continued_runs through nsgs_route.trial_runner with
    ``full_info`` (what newton.compiled_runs gives with ``full_info``)."""
    from socp_cd.solvers import newton
    run = nsgs_route.trial_runner(p, nsgs_route.judge_norm(p), prox, 2, c, True)
    return newton.continued_runs(run, lambda r, i: i["error_as_written"], start, 1e-10, steps,
                                 c[nsgs_route.C_ALPHA0], c[nsgs_route.C_ALPHA_MIN], None)[4]


@pytest.mark.parametrize("structure,seed,tol,setting", [
    # NSGS's own error above tol, the judge's at it: the chain does not hand over
    ("tree", 10, 0.0009899284903614493, None),
    # a trial within tol by the judge's error, refused by its guard value: the chain goes on
    ("redundant", 2, 8.345713059193823e-12, None),
    # a skipped cold trial: best_stage counts the stage order, skipped stages included
    ("redundant", 6, 1e-8, ("auto", "COLD_TRIAL_STEPS", 0)),
    # a study's Newton settings: the route leaves the trials to the general path
    ("redundant", 6, 1e-8, ("newton", "DEFAULT_RHO", "split")),
    ("redundant", 6, 1e-8, ("newton", "DEFAULT_POLICY", "hybrid")),
])
def test_compiled_trials_at_the_edges_equal_general_path(monkeypatch, structure, seed, tol,
                                                         setting):
    from socp_cd.solvers import auto, newton
    if setting is not None:
        monkeypatch.setattr({"auto": auto, "newton": newton}[setting[0]], setting[1], setting[2])
    dim, nc = (2, 6) if setting is None else (3, 12)
    p = manufactured(nc, dim, mu=0.5 if setting is None else 0.6, structure=structure,
                     mass_ratio=1e4 if setting is None else 1e6,
                     contact_scale=1.0 if setting is None else 1e4, seed=seed)
    a = socp_cd.solve(p, tol=tol)
    b = _general(monkeypatch, p, tol=tol)
    _same(a, b)
    assert [(s["method"], s["iterations"], s["status"]) for s in a.info["path"]] == \
           [(s["method"], s["iterations"], s["status"]) for s in b.info["path"]]
    assert a.info["best_stage"] == b.info["best_stage"]


def test_route_stop_test_at_tol_equals_general_path(monkeypatch):
    # tol within rounding of the NSGS stage's error or guard (the route's measures of them
    # differ from the chain judge's in the last digits): the route reads the judge's own
    # (auto.JUDGE_MARGIN), so it stops, or hands over, where the general path does
    p = manufactured(3, 2, mu=0.5, structure="tree", mass_ratio=100.0, contact_scale=1.0,
                     seed=9)
    for tol in (9.317857290759537e-12, 1e-8):
        a = socp_cd.solve(p, tol=tol)
        b = _general(monkeypatch, p, tol=tol)
        _same(a, b)
        assert [(s["method"], s["iterations"]) for s in a.info["path"]] == \
               [(s["method"], s["iterations"]) for s in b.info["path"]]


def test_route_kernel_entry_point_is_the_kernel_for_every_index_dtype(monkeypatch):
    # the route calls nsgs_checked's compiled entry point (kernels/entry.py), which checks no
    # argument type: CSR index arrays of int32 or int64 (one entry point each), read-only
    # arrays, strided arrays given to the constructor (made contiguous there), and index
    # arrays of two dtypes (the dispatcher then) give the general path's answers, warm
    # started and under a time limit too
    base = _random(3, 3, 11, mu=0.4)
    indptr, indices, data = base.csr_parts

    def read_only(x):
        x = x.copy()
        x.flags.writeable = False
        return x

    def strided(x):
        buf = np.zeros(2 * x.shape[0], dtype=x.dtype)
        buf[::2] = x
        return buf[::2]

    W_strided = sp.csr_matrix((strided(data), strided(indices), strided(indptr)),
                              shape=(base.m, base.m))
    assert not W_strided.data.flags.c_contiguous
    variants = {
        "int64": FrictionContactProblem.from_checked(
            (indptr.astype(np.int64), indices.astype(np.int64), data), base.q, base.mu, 3),
        "int32": FrictionContactProblem.from_checked(
            (indptr.astype(np.int32), indices.astype(np.int32), data), base.q, base.mu, 3),
        "read-only": FrictionContactProblem.from_checked(
            tuple(read_only(x) for x in (indptr, indices, data)), read_only(base.q),
            read_only(base.mu), 3),
        "strided": FrictionContactProblem(W_strided, strided(base.q), base.mu, 3),
        "mixed": FrictionContactProblem.from_checked(
            (indptr.astype(np.int64), indices.astype(np.int32), data), base.q, base.mu, 3),
    }
    r0 = np.random.default_rng(3).random(base.m)
    calls = (dict(solver="nsgs"), dict(), dict(solver="nsgs", r0=r0, time_limit=5.0),
             dict(r0=r0[::-1], max_iter=5))
    refs = [_general(monkeypatch, base, **kw) for kw in calls]
    for name, p in variants.items():
        with monkeypatch.context() as m:
            m.setattr(nsgs_route, "_CHECKED", {})
            for kw, ref in zip(calls, refs):
                a = socp_cd.solve(p, **kw)
                if kw.get("solver") == "nsgs":
                    assert a.info["route"] == "compiled", (name, kw)
                _same(a, ref)
            # one entry point per index dtype; the dispatcher for mixed ones
            assert set(nsgs_route._CHECKED) == (set() if name == "mixed" else {p.csr_parts[0].dtype})


def test_route_checks_a_start_it_is_handed_directly():
    # the kernel's entry point reads r0 as a contiguous float64 vector of length m: a start of
    # another length or shape, or a non-finite one, handed to the route directly (not through
    # solve()) is refused with the error solve() gives, a strided one is read as its values
    from socp_cd.errors import InvalidProblemError
    from socp_cd.solvers import nsgs
    p = _random(2, 3, 12, mu=0.3)
    for bad in (np.ones(p.m - 1), np.ones((p.m, 2)), np.full(p.m, np.nan)):
        with pytest.raises(InvalidProblemError, match="r0"):
            nsgs.compiled_run(p, 1e-8, None, bad, None)
    r0 = np.random.default_rng(4).random(2 * p.m)
    a = nsgs.compiled_run(p, 1e-8, None, r0[::2], None)
    b = nsgs.compiled_run(p, 1e-8, None, r0[::2].copy(), None)
    assert a.status == b.status and np.array_equal(a.vectors, b.vectors) and a.stats == b.stats


def test_nsgs_route_runs_to_a_deadline():
    # with a time limit the route's kernel stops at its deadline on the compiled clock, as
    # the NSGS backend stops on its own clock: the sweeps read it every
    # max(1, CHECK_BLOCKS // nnzb) sweeps (session 25; before, only between blocks of
    # sweeps, the first of TIME_CHECK_SWEEPS), status "time_limit"; any limit, any size
    from socp_cd.solvers import nsgs, nsgs_kernels
    from socp_cd.solvers.block_storage import csr_to_bsr
    p = _random(20, 3, 4, mu=0.8)
    nnzb = int(csr_to_bsr(*p.csr_parts, 3, 20)[0][-1])
    every = max(1, nsgs_kernels.CHECK_BLOCKS // nnzb)
    assert every < nsgs_route.TIME_CHECK_SWEEPS
    slow = dict(solver="nsgs", tol=1e-14, max_iter=10 ** 6)
    a = socp_cd.solve(p, time_limit=1e-300, **slow)
    b = _general(pytest.MonkeyPatch(), p, time_limit=1e-300, **slow)
    assert a.info["route"] == "compiled"
    assert a.status == b.status == "time_limit"
    assert a.iterations == b.iterations == every
    assert np.array_equal(a.r, b.r)
    st = nsgs.route_settings(3)
    ran = nsgs_route.run(p, st, 1e-8, 10 ** 9, None, 1e-3, True)     # (no work bound)
    assert ran is not None and ran.status in ("converged", "time_limit", "stalled")
    assert socp_cd.solve(p, "nsgs", time_limit=1e-4).info.get("route") == "compiled"


def test_timed_work_bound_without_the_compiled_clock(monkeypatch):
    # where the compiled clock is not available, the route takes a time-limited call only
    # when max_iter * nnz(W) <= MAX_TIMED_WORK and the limit is at least MIN_TIME_LIMIT;
    # without a time limit there is no bound
    from socp_cd.solvers import nsgs
    p = _random(1, 3, seed=0)
    nnz = int(p.csr_parts[0][-1])
    at = int(nsgs_route.MAX_TIMED_WORK) // nnz
    st = nsgs.route_settings(3)
    assert nsgs_route.run(p, st, 1e-8, at + 1, None, 1.0, True) is not None
    from socp_cd.solvers.kernels import clock
    monkeypatch.setattr(clock, "AVAILABLE", False)
    assert nsgs_route.run(p, st, 1e-8, at + 1, None, 1.0, True) is None
    ran = nsgs_route.run(p, st, 1e-8, at, None, 1.0, True)
    assert ran is not None and ran.status == "converged"
    assert nsgs_route.run(p, st, 1e-8, at + 1, None, None, True) is not None
    assert nsgs_route.run(p, st, 1e-8, 10, None, 0.5 * nsgs_route.MIN_TIME_LIMIT, True) is None
    # (2**62 * nnz wraps around in int64: the bound is compared in floats)
    assert nsgs_route.run(p, st, 1e-8, 2 ** 62, None, 1.0, True) is None
    monkeypatch.undo()
    # a cap beyond the kernel's int64 goes the general path, with or without a time limit
    assert nsgs_route.run(p, st, 1e-8, 2 ** 63, None, 1.0, True) is None
    assert nsgs_route.run(p, st, 1e-8, 2 ** 63, None, None, True) is None
    with pytest.raises(socp_cd.SocpCdError, match="max_iter"):
        socp_cd.solve(p, "nsgs", max_iter=2 ** 62 + 1, time_limit=1.0)     # (options.MAX_ITER)


def test_checked_answer_refuses_an_error_that_overflows():
    # the compiled checks both route kernels share (nsgs_route.checked_answer) judge only
    # answers whose checks are finite: a finite r and u whose squares overflow (Siconos' error
    # inf) is refused, the general path reports it; the same pair scaled down is judged
    W = sp.csr_matrix(np.eye(3))
    indptr, indices, data = (W.indptr.astype(np.int64), W.indices.astype(np.int64),
                             W.data.astype(np.float64))
    mu, q = np.array([0.5]), np.zeros(3)
    ones = np.ones(3)
    n_stats = len(nsgs_route.STATS) + 7
    for big, judged in ((1e200, False), (1.0, True)):
        r_s = np.array([big, 0.0, 0.0])
        vectors, stats = np.zeros((3, 3)), np.zeros(n_stats)
        ok = nsgs_route.checked_answer(indptr, indices, data, q, mu, 3, ones, ones, 0.0, 1.0,
                                       r_s, vectors, stats)
        assert ok is judged
        assert np.all(np.isfinite(vectors[1:])) and vectors[2][0] == big     # u = W r finite
        assert bool(np.isfinite(stats[nsgs_route.ERROR])) is judged     # (inf/inf: NaN)


def test_newton_checked_computes_judge_norm():
    # newton.route passes norm_q < 0 when there is no r0: nsgs_route.newton_checked computes
    # ||q~|| itself, and the route's answer equals the general path's only if that is
    # judge_norm's value to the last bit (both BLAS ddot on a contiguous vector; an install
    # whose two BLAS builds sum differently fails here)
    from socp_cd.solvers.kernels import newton_dense as nd
    c = newton.trial_constants()
    rng = np.random.default_rng(7)
    for nc in (2, 3, 5, 8, 13, 21, 34, 50):
        for dim in (2, 3):
            p = manufactured(nc, dim, mu=float(rng.uniform(0.1, 1.5)), structure="tree",
                             mass_ratio=float(10 ** rng.uniform(0, 6)),
                             contact_scale=float(10 ** rng.uniform(0, 8)),
                             q_scale=float(10 ** rng.uniform(-6, 6)), seed=nc)
            out = nsgs_route.newton_checked(
                *p.csr_parts, p.q, p.mu, p.dim, np.zeros(p.m), -1.0, 1e-8, 2, 5, True, c,
                c[nsgs_route.C_ALPHA0], np.empty((3, p.m)), np.full(nd.FSTATE, np.inf),
                np.empty(nd.ISTATE, dtype=np.int64))
            assert out[5] == nsgs_route.judge_norm(p)


def test_newton_default_settings_checked_once_per_value(monkeypatch):
    # SPEC.check validates the module's default settings once per set of values (and types:
    # True == 1, but a bool is not a stall window); a caller's options every call
    p = manufactured(2, 3, mu=0.5, structure="tree", seed=0)
    monkeypatch.setattr(newton, "DEFAULT_STALL_WINDOW", 1)
    assert socp_cd.solve(p, "newton").status in STATUSES
    monkeypatch.setattr(newton, "DEFAULT_STALL_WINDOW", True)
    with pytest.raises(socp_cd.InvalidProblemError, match="stall_window"):
        socp_cd.solve(p, "newton")
    monkeypatch.setattr(newton, "DEFAULT_STALL_WINDOW", 50)
    monkeypatch.setattr(newton, "COLD_ALPHA0", -1.0)
    for _ in range(2):          # (an invalid default is never recorded as checked)
        with pytest.raises(socp_cd.InvalidProblemError, match="alpha0"):
            socp_cd.solve(p, "newton")
    monkeypatch.setattr(newton, "COLD_ALPHA0", 0.1)
    with pytest.raises(socp_cd.InvalidProblemError, match="stall_window"):
        socp_cd.solve(p, "newton", stall_window=-1)


def test_plain_call_reads_the_hand_offs_knobs_as_they_are_set(monkeypatch):
    # auto.plain prepares its small call once per dimension; setting a knob it reads (a
    # study's setattr, monkeypatch) must reach the next call, and undoing it the one after
    from socp_cd.solvers import auto
    p = manufactured(12, 3, mu=0.6, structure="redundant", mass_ratio=1e6, contact_scale=1e4,
                     seed=6)

    def first_stage():
        res = socp_cd.solve(FrictionContactProblem(p.W, p.q, p.mu, 3))
        return res.info["path"][0]
    first_stage()           # (the first call in a process may load the table: no plan yet)
    default = first_stage()
    assert 3 in auto._PLANS         # the plan the knobs below must replace
    assert default["method"] == "nsgs" and default["iterations"] > 3
    with monkeypatch.context() as mp:
        mp.setattr(auto, "HANDOFF_SWEEPS", 3)
        mp.setattr(auto, "HANDOFF_WORK", 1)
        capped = first_stage()
        assert capped["method"] == "nsgs" and capped["iterations"] == 3
    again = first_stage()
    assert again["iterations"] == default["iterations"]
    with monkeypatch.context() as mp:
        mp.setattr(auto, "SMALL_NC", 0)        # the small chain off: the probe comes first
        assert first_stage()["method"] == "nsgs_probe"


def test_the_plain_calls_plan_reads_only_the_knobs_whose_setting_drops_it():
    # every module-level name in upper case that auto.small_plan reads is a knob whose
    # setting (and deletion) empties the plans: a knob missing from _PLAN_KNOBS would leave a
    # stale plan in use
    from socp_cd.solvers import auto
    read = {n for n in auto.small_plan.__code__.co_names if n.isupper() and n[0] != "_"}
    assert read and read <= auto._PLAN_KNOBS


@pytest.mark.parametrize("knob", sorted(["SMALL_NC", "SMALL_SWEEPS", "SMALL_STALL",
                                         "HANDOFF_SWEEPS", "HANDOFF_WORK", "HANDOFF_PREDICT",
                                         "PREDICT_MAX_M", "STAGE_SHARE"]))
def test_setting_or_deleting_a_knob_drops_the_plain_calls_plan(knob, monkeypatch):
    from socp_cd.solvers import auto
    p = manufactured(2, 3, mu=0.5, seed=1)
    for _ in range(2):
        socp_cd.solve(p)
    assert 3 in auto._PLANS
    monkeypatch.setattr(auto, knob, getattr(auto, knob))     # (the same value: still dropped)
    assert auto._PLANS == {}
    socp_cd.solve(p)
    assert 3 in auto._PLANS
    monkeypatch.delattr(auto, knob)
    assert auto._PLANS == {}
    monkeypatch.undo()              # (setattr again)
    assert auto._PLANS == {} and knob in vars(auto)

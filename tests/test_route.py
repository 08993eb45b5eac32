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
import pytest

import socp_cd
from socp_cd import residuals
from socp_cd.bench.generators import manufactured
from socp_cd.problem import FrictionContactProblem
from socp_cd.solvers import nsgs_route
from socp_cd.solvers.kernels.cone import LAW_COULOMB, error_parts, relative_error
from socp_cd.solvers.kernels.scaling import GUARD_KEYS, balanced_guard


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
    for kw in (dict(solver="nsgs", omega=1.0), dict(history=True),
               dict(solver="nsgs", inner_settings={"local_tol": 1e-12}),
               dict(time_limit=0.01),
               dict(formulation="associated"), dict(crosscheck="nsgs")):
        assert "route" not in socp_cd.solve(p, **kw).info, kw
    with pytest.MonkeyPatch.context() as m:
        m.setattr(nsgs_route, "MAX_CONTACTS", 2)
        assert "route" not in socp_cd.solve(p, "nsgs").info
    # under a time limit, the sweeps' work must fit (nsgs: 1000 sweeps of 150 dense contacts)
    big = _random(150, 2, seed=8, spread=0.5)
    assert "route" not in socp_cd.solve(big, "nsgs", max_iter=1000, time_limit=5.0).info
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

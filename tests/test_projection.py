"""The projection method (``solver="projection"``): kernel = NumPy reference, convergence,
options, blocks, rate prediction."""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd import FrictionContactProblem
from socp_cd.cones import desaxce_velocity, project_cone
from socp_cd.errors import InvalidProblemError, UnsupportedError
from socp_cd.residuals import error as siconos_error
from socp_cd.solvers import projection
from socp_cd.solvers.kernels.cone import LAW_COULOMB
from socp_cd.solvers.kernels.projection import Step, projection_loop

STEP = Step(0.9, 0.3, 0.6, 0.7, 20)


def _problem(nc, dim, seed, mu=0.5, asym=0.0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((nc * dim, nc * dim))
    W = A @ A.T / (nc * dim) + np.eye(nc * dim)
    W += asym * (A - A.T) / (nc * dim)
    q = rng.standard_normal(nc * dim)
    q[0::dim] -= 0.5
    return FrictionContactProblem(W, q, mu, dim)


def _reference(p, rho, steps, step=STEP):
    """The method in NumPy (formulations/projection.md), ``steps`` accepted steps from r = 0."""
    W = p.W.toarray() if hasattr(p.W, "toarray") else np.asarray(p.W)
    q, mu, d = p.q, p.mu, p.dim
    F = lambda r: desaxce_velocity(W @ r + q, mu, d)     # noqa: E731
    r = np.zeros(p.m)
    err = siconos_error(p, r)
    for _ in range(steps):
        Fr = F(r)
        for attempt in range(step.max_retries + 1):
            rn = project_cone(r - rho * Fr, mu, d)
            a1 = np.linalg.norm(F(rn) - Fr)
            a2 = np.linalg.norm(rn - r)
            if rho * a1 <= step.L * a2 or a2 == 0.0 or attempt == step.max_retries:
                break
            rho *= step.tau
        new_err = siconos_error(p, rn)
        if rho * a1 < step.L_min * a2 and new_err < err:
            rho /= step.tau_min
        r, err = rn, new_err
    return r, rho


def _kernel(p, rho, steps, tol=0.0, r=None, **kw):
    indptr, indices, data = p.csr_parts
    r = np.zeros(p.m) if r is None else r
    best = np.empty(p.m)
    args = dict(stall_window=0, predict_window=0, predict_budget=steps, predict_prev=-1.0,
                record=False, hist=np.zeros(1))
    args.update(kw)
    out = projection_loop(indptr, indices, data, p.q, np.asarray(p.mu, float),
                          np.zeros(p.n_contacts), p.dim, LAW_COULOMB, r, best, rho, tol, steps,
                          STEP, args["stall_window"], args["predict_window"],
                          args["predict_budget"], args["predict_prev"], args["record"],
                          args["hist"])
    return r, best, out


@pytest.mark.parametrize("dim,asym", [(2, 0.0), (3, 0.0), (3, 0.3)])
def test_kernel_equals_the_numpy_reference(dim, asym):
    p = _problem(6, dim, seed=dim, asym=asym)
    r_ref, rho_ref = _reference(p, 1.0, 25)
    r, _, out = _kernel(p, 1.0, 25)
    assert out[1] == 25
    np.testing.assert_allclose(r, r_ref, rtol=1e-10, atol=1e-12)
    assert out[3] == pytest.approx(rho_ref, rel=1e-12)


def test_a_step_shrinks_rho_when_the_test_fails():
    """A too long first step: the rule retries with rho * tau until rho ||dF|| <= L ||dr||."""
    p = _problem(4, 3, seed=1)
    _, _, out = _kernel(p, 1e3, 1)
    rho = out[3]
    assert rho < 1e3 * 0.6 and out[4] > 2          # retried: more products than steps + 1
    r_ref, rho_ref = _reference(p, 1e3, 1)
    assert rho == pytest.approx(rho_ref, rel=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("mu", [0.0, 0.3, 2.0])
def test_solves_random_problems_by_the_dispatchers_checks(dim, mu):
    p = _problem(8, dim, seed=10 + dim, mu=mu)
    res = socp_cd.solve(p, solver="projection", tol=1e-9)
    assert res.converged and res.error <= 1e-9
    assert siconos_error(p, res.r) <= 1e-9           # recomputed here too
    ref = socp_cd.solve(p, solver="nsgs", tol=1e-11)
    np.testing.assert_allclose(res.r, ref.r, atol=1e-6 * np.abs(ref.r).max())


@pytest.mark.parametrize("formulation", ["associated", "tresca", "frictionless"])
def test_other_laws(formulation):
    p = _problem(5, 3, seed=3)
    extra = {"threshold": np.full(5, 0.2)} if formulation == "tresca" else {}
    res = socp_cd.solve(p, solver="projection", formulation=formulation, tol=1e-9, **extra)
    ref = socp_cd.solve(p, solver="nsgs", formulation=formulation, tol=1e-11, **extra)
    assert res.converged and ref.converged
    np.testing.assert_allclose(res.r, ref.r, atol=1e-6 * max(np.abs(ref.r).max(), 1.0))


def test_asymmetric_and_rank_deficient_W():
    p = _problem(5, 3, seed=4, asym=0.5)
    assert socp_cd.solve(p, solver="projection", tol=1e-9).converged
    # rank deficient: W = J J^T with J of 9 columns for 15 unknowns; u is unique, r is not
    rng = np.random.default_rng(5)
    J = rng.standard_normal((15, 9))
    q = rng.standard_normal(15)
    q[0::3] = -np.abs(q[0::3]) - 0.5
    pr = FrictionContactProblem(J @ J.T, q, 0.5, 3)
    res = socp_cd.solve(pr, solver="projection", tol=1e-8, max_iter=200000)
    ref = socp_cd.solve(pr, solver="newton", tol=1e-11)
    assert res.converged
    np.testing.assert_allclose(pr.velocity(res.r), pr.velocity(ref.r), atol=1e-5)


def test_a_run_in_blocks_equals_one_run():
    """time_limit runs blocks of 10, 20, 40 ... steps going on from the last iterate, with rho
    carried: the same steps and iterate as one run."""
    p = _problem(10, 3, seed=6, mu=1.0)
    one = socp_cd.solve(p, solver="projection", tol=1e-10, stall_window=0)
    blocks = socp_cd.solve(p, solver="projection", tol=1e-10, stall_window=0, time_limit=1e6)
    assert one.iterations == blocks.iterations > 10
    np.testing.assert_array_equal(one.r, blocks.r)
    assert one.info["rho"] == blocks.info["rho"]


def _ill_conditioned():
    """Eigenvalues of W from 1 to 1e-3: the projection needs hundreds of steps (NSGS 59 sweeps)."""
    rng = np.random.default_rng(0)
    Q, _ = np.linalg.qr(rng.standard_normal((15, 15)))
    q = rng.standard_normal(15)
    q[0::3] = -1.0
    return FrictionContactProblem(Q @ np.diag(np.logspace(0, -3, 15)) @ Q.T, q, 0.3, 3)


def test_rate_prediction_stops_a_slow_run_early_and_history_has_every_step():
    p = _ill_conditioned()
    slow = socp_cd.solve(p, solver="projection", tol=1e-12, max_iter=100000, history=True)
    assert slow.iterations > 200                 # the projection crawls on this pair
    assert len(slow.history) == slow.iterations
    early = socp_cd.solve(p, solver="projection", tol=1e-12, max_iter=300, predict_window=20)
    assert early.status == "max_iter" and early.iterations < 300 and early.iterations % 20 == 0
    assert "predicts" in early.message
    # the result is the best iterate by Siconos' error (in the balanced units the solver sees)
    full = socp_cd.solve(p, solver="projection", tol=1e-12, max_iter=early.iterations,
                         history=True)
    assert early.info["internal_error"] == min(full.history)
    np.testing.assert_array_equal(early.r, full.r)


def test_max_iter_is_reported_not_converged():
    p = _ill_conditioned()
    res = socp_cd.solve(p, solver="projection", tol=1e-14, max_iter=5)
    assert res.status == "max_iter" and not res.converged and res.iterations == 5
    assert res.error > 1e-14


def test_warm_start_at_the_solution_takes_one_step():
    p = _problem(6, 3, seed=7)
    ref = socp_cd.solve(p, solver="newton", tol=1e-13)
    res = socp_cd.solve(p, solver="projection", tol=1e-9, r0=ref.r)
    assert res.converged and res.iterations <= 1


@pytest.mark.parametrize("opts", [{"L": 1.0}, {"L": 0.0}, {"tau": 1.5}, {"tau_min": 0.0},
                                  {"rho0": 0.0}, {"rho0": float("nan")}, {"L": 0.2, "L_min": 0.5},
                                  {"max_retries": -1}, {"predict_window": 1.5}])
def test_bad_options_name_the_option(opts):
    p = _problem(2, 3, seed=0)
    name = "L_min" if "L_min" in opts else next(iter(opts))
    with pytest.raises(InvalidProblemError, match=name):
        socp_cd.solve(p, solver="projection", **opts)


def test_inner_settings_rejected():
    p = _problem(2, 3, seed=0)
    with pytest.raises(UnsupportedError, match="inner_settings"):
        socp_cd.solve(p, solver="projection", inner_settings={"x": 1})


def test_mean_diagonal_of_an_all_zero_diagonal_is_one():
    import scipy.sparse as sp
    A = sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))
    assert projection.mean_diagonal(A.indptr, A.indices, A.data) == 1.0
    B = sp.csr_matrix(np.diag([2.0, 4.0]))
    assert projection.mean_diagonal(B.indptr, B.indices, B.data) == 3.0

"""Newton's second equation of the law: the natural map (``equation="natural_map"``).

Kernel against its NumPy reference and against finite differences in every branch; the
map is zero exactly at the law; the Newton runs on it (every policy, local and global,
2D and 3D, rank-deficient and asymmetric ``W``) meet ``tol`` by the recomputed error.
"""
from __future__ import annotations

import numpy as np
import pytest

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.cones import natural_map, natural_map_jacobian
from socp_cd.errors import InvalidProblemError, UnsupportedError
from socp_cd.solvers import newton
from socp_cd.solvers.kernels.newton_nm import NM_SEPARATED, NM_SLIDE, NM_STICK, nm_blocks

from _law_kernels import assert_blocks_are_central_differences, run_blocks

MU = 0.6


def _blocks(r, u, mu, rho, dim, jac=True):
    return run_blocks(nm_blocks, r, u, mu, rho, dim, jac)


def _branch_point(branch, dim, rng, rho):
    """``(r, u)`` of one contact strictly inside a branch of the projection at
    ``x = r - rho û`` (away from the cone's kinks), with ``u_T != 0``."""
    t = rng.normal(size=dim - 1)
    t /= np.linalg.norm(t)
    ut = 0.3 * rng.normal(size=dim - 1)
    if branch == "separated":          # x deep in the polar cone: r_N small, u_N large
        r = np.concatenate([[0.1], 0.02 * t])
        u = np.concatenate([[3.0 / rho], ut / rho])
    elif branch == "stick":            # x well inside K: large r_N, small û
        r = np.concatenate([[2.0], 0.1 * t])
        u = np.concatenate([[0.01 / rho], 0.05 * ut / rho])
    else:                              # 'slide': x outside K and outside the polar cone
        r = np.concatenate([[1.0], 0.2 * t])
        u = np.concatenate([[0.05 / rho], -2.0 * t / rho + 0.1 * ut / rho])
    return r, u


@pytest.mark.parametrize("rho", [0.7, 0.05, 20.0])
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("branch,code", [("separated", NM_SEPARATED), ("stick", NM_STICK),
                                         ("slide", NM_SLIDE)])
def test_jacobian_matches_finite_differences_in_every_branch(dim, branch, code, rho):
    rng = np.random.default_rng(11)
    r, u = _branch_point(branch, dim, rng, rho)
    mu, rh = np.array([MU]), np.array([rho])
    _, F, Dr, Du, br = _blocks(r, u, mu, rh, dim)
    assert br[0] == code                       # the point is in the intended branch
    assert_blocks_are_central_differences(nm_blocks, r, u, mu, rh, dim, Dr, Du)


@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_equals_numpy_reference(dim):
    rng = np.random.default_rng(5)
    nc = 300
    r, u = rng.normal(size=nc * dim), rng.normal(size=nc * dim)
    mu, rho = rng.uniform(0, 2, nc), rng.uniform(0.1, 2, nc)
    u.reshape(nc, dim)[:20, 1:] = 0.0          # u_T = 0: the norm's kink (w = 0)
    mu[20:25] = 0.0                            # frictionless contacts
    nF, F, Dr, Du, br = _blocks(r, u, mu, rho, dim)
    F0, Dr0, Du0, br0 = natural_map_jacobian(r, u, mu, dim, rho)
    assert set(br0.tolist()) == {NM_SEPARATED, NM_STICK, NM_SLIDE}
    assert set(br0[:20].tolist()) == {NM_SEPARATED, NM_STICK, NM_SLIDE}   # u_T = 0 in each
    np.testing.assert_allclose(F, F0, atol=1e-14)
    np.testing.assert_allclose(Dr, Dr0, atol=1e-14)
    np.testing.assert_allclose(Du, Du0, atol=1e-14)
    np.testing.assert_array_equal(br, br0)
    assert nF == pytest.approx(np.linalg.norm(F0), rel=1e-14)
    # the map itself is socp_cd.cones.natural_map's, one rho per contact
    np.testing.assert_allclose(F0, natural_map(r, u, mu, dim, rho[:, None]).reshape(-1),
                               atol=1e-14)


@pytest.mark.parametrize("dim", [2, 3])
def test_kernel_equals_reference_on_the_kinks(dim):
    """Points exactly on the projection's kinks (rho = 1, u = 0: x = r exactly): the
    surface of K, the surface of the polar cone, the apex, and mu = 0 with x_T = 0 — both
    implementations take the same branch and the same Jacobian."""
    t = np.zeros(dim - 1)
    t[0] = 1.0
    blocks = [np.r_[1.0, 0.5 * t], np.r_[-0.5, 1.0 * t], np.zeros(dim), np.r_[1.0, 0.0 * t],
              np.r_[1.0, 0.0 * t], np.r_[-1.0, 0.0 * t]]
    mu = np.array([0.5, 0.5, 0.5, 0.5, 0.0, 0.0])
    r = np.concatenate(blocks)
    u = np.zeros_like(r)
    rho = np.ones(len(blocks))
    _, F, Dr, Du, br = _blocks(r, u, mu, rho, dim)
    F0, Dr0, Du0, br0 = natural_map_jacobian(r, u, mu, dim, rho)
    np.testing.assert_array_equal(br, br0)
    np.testing.assert_array_equal(br, [NM_STICK, NM_SEPARATED, NM_SEPARATED, NM_STICK,
                                       NM_STICK, NM_SEPARATED])
    np.testing.assert_allclose(F, F0, atol=1e-15)
    np.testing.assert_allclose(Dr, Dr0, atol=1e-15)
    np.testing.assert_allclose(Du, Du0, atol=1e-15)
    # r in K (rows 0, 2, 3, 4) is its own projection; r on the polar cone projects to 0
    in_k = np.repeat([True, False, True, True, True, False], dim)
    np.testing.assert_array_equal(F[in_k], 0.0)
    np.testing.assert_array_equal(F[~in_k], r[~in_k])


@pytest.mark.parametrize("dim", [2, 3])
def test_zero_exactly_at_the_law(dim):
    """At a manufactured exact solution F = 0 for any rho; off it, F != 0."""
    p = manufactured(25, dim, 0.8, seed=3)
    r, u = p.solution.r, p.solution.u
    rho = np.random.default_rng(0).uniform(0.1, 10, p.n_contacts)
    nF = _blocks(r, u, p.mu, rho, dim, False)[0]
    assert nF <= 1e-12 * max(1.0, np.linalg.norm(r))
    assert _blocks(r + 0.01, u, p.mu, rho, dim, False)[0] > 1e-4


def test_the_two_equations_differ_and_the_default_is_alart_curnier():
    """Not the Alart–Curnier run under another name: other iterates, the same solution."""
    p = manufactured(30, 3, 1.0, seed=5)
    ac = socp_cd.solve(p, "newton", tol=1e-10, history=True, policy="plain")
    nm = socp_cd.solve(p, "newton", tol=1e-10, history=True, policy="plain",
                       equation="natural_map")
    assert ac.info["equation"] == "alart_curnier"
    assert ac.converged and nm.converged and ac.history != nm.history
    np.testing.assert_allclose(ac.u, nm.u, atol=1e-7 * max(1.0, np.linalg.norm(ac.u)))


def test_never_converged_above_tol():
    p = manufactured(40, 3, 2.0, structure="redundant", seed=9)
    for max_iter in (1, 2, 3):
        res = socp_cd.solve(p, "newton", tol=1e-12, max_iter=max_iter, policy="plain",
                            equation="natural_map")
        assert res.converged == (socp_cd.error(p, res.r) <= 1e-12)


@pytest.mark.parametrize("opts,field", [
    (dict(equation="fischer"), "equation"), (dict(equation=3), "equation"),
    (dict(equation=np.array("natural_map")), "equation"),     # (equal to a choice, unhashable)
    (dict(equation="natural_map", rho="split"), "rho")])
def test_bad_options_raise_socp_cd_errors(opts, field):
    p = manufactured(3, 3, 0.5, seed=1)
    with pytest.raises(InvalidProblemError) as exc:
        socp_cd.solve(p, "newton", **opts)
    assert exc.value.field == field


def _refuse(*args):
    raise AssertionError("the Alart–Curnier kernel ran in a natural-map solve")


@pytest.mark.parametrize("policy", ["prox", "plain", "hybrid", "prox_error"])
@pytest.mark.parametrize("history", [False, True])
def test_no_path_of_a_natural_map_solve_runs_the_alart_curnier_kernel(monkeypatch, policy,
                                                                     history):
    """Every Python call site takes the run's equation: with the Alart–Curnier kernel
    replaced by one that raises, natural-map solves under every policy still converge
    (prox_error's balanced second run forced by an unreachable tolerance and a stall window
    of one).  Since session 36, ``prox`` and ``plain`` without history run the compiled
    loops, which the patch does not reach; ``history=True`` holds those two policies to the
    Python loop, and tests/test_newton_dense.py holds the compiled loops to it."""
    monkeypatch.setattr(newton, "_LAW_BLOCKS",
                        dict(newton._LAW_BLOCKS, alart_curnier=_refuse))
    monkeypatch.setattr(newton, "ac_blocks", _refuse)
    p = manufactured(12, 3, 0.8, structure="redundant", seed=2)
    res = socp_cd.solve(p, "newton", tol=1e-10, equation="natural_map", policy=policy,
                        history=history, max_iter=400)
    assert res.converged
    if policy == "prox_error":
        from socp_cd.solvers.scaling import balanced
        rec = balanced(p)
        out = newton.prox_error_runs(newton.LocalSystem(rec.problem, "dense"), rec.problem.mu,
                                     np.zeros(p.m), tol=1e-30, max_iter=200, alpha_min=1e-10,
                                     stall_window=1, time_limit=None, history=history,
                                     written=newton.origin(rec.problem),
                                     equation="natural_map")
        assert [run[0] for run in out[4]["runs"]] == ["written", "balanced"]


def test_the_compiled_loop_takes_the_natural_map_not_given_rho_values():
    # (since session 36 the compiled loops take every equation; values of rho given per
    # contact run the Python loop)
    p = manufactured(4, 3, 0.5, seed=1)
    kw = dict(tol=1e-8, max_iter=5, alpha0=0.1, alpha_min=1e-10, inner_max_iter=10,
              stall_window=50, time_limit=None, history=False, compiled=True,
              equation="natural_map")
    out = newton.prox_newton(newton.LocalSystem(p, "dense"), p.mu, np.zeros(p.m), **kw)
    assert out[4]["equation"] == "natural_map"
    with pytest.raises(UnsupportedError):
        newton.prox_newton(newton.LocalSystem(p, "dense"), p.mu, np.zeros(p.m),
                           rho=np.ones(p.n_contacts), **kw)

"""``policy="plain"`` of the newton backend and the plain Newton stages of ``solver="auto"``
(issue #10: what Siconos NSN_AC solves; ``formulations/newton.md`` §8)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph

import socp_cd
from socp_cd.bench.evalset import MIXES, manufacture
from socp_cd.data import shared_problems
from socp_cd.problem import FrictionContactProblem
from socp_cd.solvers.checks import coulomb_guard
from socp_cd.solvers.kernels.cone import siconos_error
from socp_cd.solvers.newton import velocity_relative_error

TOL = 1e-8
#: the chain of ``auto`` for small local problems before the plain stages were added
PREVIOUS_SMALL_CHAIN = ("nsgs", "newton", "clarabel", "newton")


def _capsule_block(contact=7, mu=0.5, mix="mixed", seed=112):
    """Exact solution manufactured on one independent block of the real Capsules ``W``.

    The block of the contacts coupled to ``contact`` (34 contacts, m = 102,
    rank 66) of ``Capsules-i125-1213.hdf5``; ``mu``, ``mix`` and ``seed`` are
    those of a diagnosis case of ``validation/newton_siconos_gap.py`` (seed
    112: mixed, mu = 0.5) on which the proximal method stalls near 5e-7.
    """
    hits = [s for s in shared_problems() if s.file == "Capsules-i125-1213.hdf5"]
    if not hits:
        pytest.skip("shared data not available")
    base = socp_cd.read_problem(hits[0].path)
    W, d = sp.csr_matrix(base.W), base.dim
    rows, cols = W.nonzero()
    graph = sp.csr_matrix((np.ones(rows.size), (rows // d, cols // d)),
                          shape=(base.n_contacts, base.n_contacts))
    _, label = csgraph.connected_components(graph, directed=False)
    idx = np.flatnonzero(label == label[contact])
    dofs = (idx[:, None] * d + np.arange(d)).reshape(-1)
    block = FrictionContactProblem(W[dofs][:, dofs], np.zeros(dofs.size), np.full(idx.size, mu), d)
    return manufacture(block, mu, MIXES[mix], seed)


def _solved(p, res):
    err = socp_cd.error(p, res.r)
    guard = coulomb_guard(p, res.r, p.velocity(res.r))["value"]
    return err <= TOL and guard <= TOL


def test_plain_newton_solves_the_rank_deficient_block():
    p = _capsule_block()
    W = p.W.toarray() if sp.issparse(p.W) else np.asarray(p.W)
    assert np.linalg.matrix_rank(W) < p.m                     # the failure type: singular W
    res = socp_cd.solve(p, "newton", tol=TOL, policy="plain", history=True)
    assert res.converged and _solved(p, res)
    assert all(row[0] == 0.0 and row[7] for row in res.info["trace"])   # no proximal term
    assert res.info["plain_steps"] == res.iterations


@pytest.mark.parametrize("cold_max_m", [72, 150])
def test_auto_plain_stage_solves_what_the_previous_chain_did_not(monkeypatch, cold_max_m):
    # the plain policy solves it: as the stage after the first Newton stage when the cold
    # trials do not run on its size (session 13's bound, 72), else as the plain cold trial
    from socp_cd.solvers import auto
    monkeypatch.setattr(auto, "COLD_MAX_M", cold_max_m)
    p = _capsule_block()
    assert 72 < p.m <= 150
    # (the previous chain as it ran: since session 52 a warm fixed point that misses tol is
    # followed by one from r = 0, which solves this block too)
    with monkeypatch.context() as m:
        m.setattr(auto, "FP_COLD_AFTER_WARM", False)
        before = socp_cd.solve(p, "auto", tol=TOL, methods=PREVIOUS_SMALL_CHAIN)
    assert not before.converged and not _solved(p, before)
    res = socp_cd.solve(p, "auto", tol=TOL)
    assert res.converged and _solved(p, res)
    solver = "newton_plain" if cold_max_m < p.m else "newton_trial_cold"
    assert res.info["path"][-1]["method"] == solver
    # never worse than a stage it tried (stage errors in the dispatcher's balanced units)
    best = min(s["error"] for s in res.info["path"])
    assert res.info["guard"]["balanced_siconos"] <= best * (1 + 1e-3)


def test_velocity_relative_error_discounts_a_large_r():
    rng = np.random.default_rng(3)
    u, q = rng.normal(size=6), rng.normal(size=6)
    small = 0.1 * rng.normal(size=6)
    assert velocity_relative_error(2e-3, small, u, float(np.linalg.norm(q))) == 2e-3
    big = 1e4 * small
    vel = max(np.linalg.norm(q), np.linalg.norm(u))
    assert velocity_relative_error(2e-3, big, u, float(np.linalg.norm(q))) == \
        pytest.approx(2e-3 * np.linalg.norm(big) / vel)


def test_plain_iterates_running_off_along_the_null_space_are_not_reported():
    # a null-space direction of W added to a solution: Siconos' error shrinks with ||r||,
    # the error relative to the velocity scale does not
    p = _capsule_block()
    W = p.W.toarray()
    _, s, vt = np.linalg.svd(W)
    z = vt[-1]
    assert s[-1] < 1e-10 * s[0]
    r = p.solution.r + 1e6 * z
    u = W @ r + p.q
    nq = float(np.linalg.norm(p.q))
    e = siconos_error(r, u, np.asarray(p.mu, float), 3, nq)
    assert velocity_relative_error(e, r, u, nq) > 1e3 * e


# --------------------------------------------------------------- policy "prox_error" (PROX)
def test_shifted_system_is_the_proximal_subproblem():
    """The subproblem of ``policy="prox_error"``: ``u_s = W r + q + s (r - rk)``, Newton matrix
    ``Dr + Du (W + diag(s))``, diagonal blocks ``W_ii + diag(s_i)`` (a per-unknown shift)."""
    from socp_cd.solvers.newton import LocalSystem, _ShiftedSystem     # noqa: PLC2701
    rng = np.random.default_rng(3)
    nc, d = 4, 3
    m = nc * d
    A = rng.standard_normal((m, m))
    W = A @ A.T + np.eye(m)
    p = FrictionContactProblem(W, rng.standard_normal(m), 0.5, d)
    base = LocalSystem(p, "dense")
    s, rk, r = rng.uniform(0.1, 2.0, m), rng.standard_normal(m), rng.standard_normal(m)
    sub = _ShiftedSystem(base, s, rk, 1.0, base.diag_blocks())
    assert np.allclose(sub.start(r), W @ r + p.q + s * (r - rk))
    blocks = sub.diag_blocks()
    for i in range(nc):
        k = slice(i * d, (i + 1) * d)
        assert np.allclose(blocks[i], W[k, k] + np.diag(s[k]))
    Dr, Du = rng.standard_normal((nc, d, d)), rng.standard_normal((nc, d, d))
    F = rng.standard_normal(m)
    dr, wdr = sub.direction(r, Dr, Du, 0.0, F)
    J = sp.block_diag(list(Dr)).toarray() + sp.block_diag(list(Du)).toarray() @ (W + np.diag(s))
    assert np.allclose(J @ dr, -F) and np.allclose(wdr, (W + np.diag(s)) @ dr)


def test_prox_error_solves_the_rank_deficient_block():
    p = _capsule_block()
    res = socp_cd.solve(p, "newton", tol=TOL, policy="prox_error", history=True)
    assert res.converged and _solved(p, res)
    assert res.info["policy"] == "prox_error"
    assert len(res.history) == res.iterations + 1 and res.history[-1] <= TOL
    # the proximal parameter follows the error: at the end it is far below its start
    assert res.info["alpha_relative"] < 1e-3 * res.info["alpha_max_relative"]


def test_prox_error_runs_in_the_units_of_the_problem_as_written():
    """``solve`` hands the backend its balanced copy; PROX's loop runs there in the units of
    the problem as written (its proximal term on the written velocity, alpha from the written
    error and diagonal), so its first iterates are those of the same loop run directly on the
    problem as written (no balancing), and differ from a loop in the balanced units."""
    from socp_cd.solvers.newton import newton_backend
    from socp_cd.solvers.scaling import balanced
    p = _capsule_block(mu=0.5, mix="mixed", seed=3)
    # contacts in other units, one factor each: balancing undoes them, PROX's metric does not
    rng = np.random.default_rng(0)
    f = np.repeat(10.0 ** rng.uniform(-2, 2, p.n_contacts), p.dim)
    p = p.with_(W=sp.diags(f) @ p.W @ sp.diags(f), q=f * p.q)
    for its in (1, 2):
        via_solve = socp_cd.solve(p, "newton", tol=1e-14, policy="prox_error", max_iter=its).r
        direct = newton_backend(p, "coulomb", tol=1e-14, max_iter=its, policy="prox_error").r
        assert np.allclose(via_solve, direct, rtol=1e-7, atol=1e-9 * np.abs(direct).max())
    copy = balanced(p).problem
    own = newton_backend(copy.with_(), "coulomb", tol=1e-14, max_iter=2, policy="prox_error").r
    a = balanced(p).a
    assert not np.allclose(a * own, direct, rtol=1e-3)


@pytest.mark.parametrize("dim", [2, 3])
def test_prox_error_on_2d_and_global_problems(dim):
    """The policy on a 2D local problem and on a global problem solved natively (saddle-point
    steps, its shift through the local unknowns) and condensed: converged, the same answer."""
    from socp_cd.bench.generators import manufactured
    p = manufactured(12, dim, 0.8, structure="redundant", seed=3)
    res = socp_cd.solve(p, "newton", policy="prox_error", tol=1e-10)
    assert res.converged and res.info["policy"] == "prox_error"
    rng = np.random.default_rng(dim)
    g = socp_cd.GlobalFrictionContactProblem(np.eye(8), rng.standard_normal((8, 3 * dim)),
                                             rng.standard_normal(8),
                                             -np.abs(rng.standard_normal(3 * dim)), 0.4, dim)
    runs = [socp_cd.solve(g, "newton", policy="prox_error", tol=1e-10, global_mode=mode)
            for mode in ("native", "condense")]
    assert all(r.converged and r.info["policy"] == "prox_error" for r in runs)
    assert runs[0].info["global_mode"] == "native" and runs[1].info["global_mode"] == "condense"
    assert np.allclose(runs[0].r, runs[1].r, atol=1e-7 * np.abs(runs[1].r).max())


def test_prox_error_alpha_min_is_not_bounded_by_alpha0():
    """``alpha0`` does not apply to ``policy="prox_error"`` (alpha follows the error), so it
    does not bound ``alpha_min`` there as it does for the other policies."""
    from socp_cd.bench.generators import manufactured
    from socp_cd.errors import InvalidProblemError
    p = manufactured(4, 3, 0.5, structure="tree", seed=1)
    res = socp_cd.solve(p, "newton", policy="prox_error", alpha_min=0.5, max_iter=2)
    assert res.info["alpha_relative"] >= 0.5 * (1 - 1e-12)
    with pytest.raises(InvalidProblemError, match="alpha_min"):
        socp_cd.solve(p, "newton", policy="prox", alpha_min=0.5)

"""Clarabel backend, conic data and the De Saxcé fixed point.

Expected solutions are derived by hand (single contacts with W = I) or built
backwards: pick ``(r*, u*)`` obeying the law contact by contact, then set
``q = u* - W r*``.
"""
import clarabel
import numpy as np
import pytest
import scipy.sparse as sp

from socp_cd.condensation import condense_dense
from socp_cd.errors import InvalidProblemError, UnsupportedError
from socp_cd.cones import in_cone_violation, project_cone, project_dual_cone
from socp_cd.problem import FrictionContactProblem, GlobalFrictionContactProblem
from socp_cd.residuals import error
from socp_cd.solvers import solve
from socp_cd.solvers import clarabel_backend as cb
from socp_cd.solvers.conic_data import coulomb_cone_map, dual_cone_map, tresca_map
from socp_cd.solvers import conic_data as cd
from socp_cd.solvers.kernels import cone as kc, dense as kd
from socp_cd.solvers.desaxce import desaxce_fixed_point

TOL = 1e-8


def one_contact(q, mu=0.5, dim=3, W=None):
    W = np.eye(dim) if W is None else W
    return FrictionContactProblem(W, q, mu, dim)


# ---------------------------------------------------------------- cone maps
@pytest.mark.parametrize("dim", [2, 3])
def test_cone_maps_describe_the_cones(dim):
    rng = np.random.default_rng(0)
    mu = np.array([0.0, 0.3, 1.2, 0.0, 0.7])
    X = rng.normal(size=(400, 5 * dim))
    cm, dm = coulomb_cone_map(mu, dim), dual_cone_map(mu, dim)
    for cmap, proj in ((cm, project_cone), (dm, project_dual_cone)):
        for x in X:
            y = proj(x, mu, dim)          # a point of the set
            s = cmap.G @ y + cmap.g       # must land in the Clarabel cones
            z0 = cmap.n_zero
            n1 = z0 + cmap.n_nonneg
            assert np.allclose(s[:z0], 0.0, atol=1e-12)
            assert np.all(s[z0:n1] >= -1e-12)
            soc = s[n1:].reshape(-1, 3)
            assert np.all(np.linalg.norm(soc[:, 1:], axis=1) <= soc[:, 0] + 1e-12)
    # and a point outside K_mu violates some cone row
    x = np.zeros(5 * dim)
    x[dim:2 * dim] = [1.0, 1.0] + ([0.0] if dim == 3 else [])   # ||r_T|| = 1 > 0.3 * 1
    s = cm.G @ x
    n1 = cm.n_zero + cm.n_nonneg
    soc_bad = s[n1:].reshape(-1, 3) if cm.n_soc else np.zeros((0, 3))
    viol = np.any(s[cm.n_zero:n1] < -1e-12) or np.any(
        np.linalg.norm(soc_bad[:, 1:], axis=1) > soc_bad[:, 0] + 1e-12)
    assert viol
    assert len(cm.cones()) <= 2 + cm.n_soc


def test_tresca_map_is_the_ball():
    g = np.array([0.5, 0.0])
    tm = tresca_map(g, 3)
    r = np.array([1.0, 0.3, -0.39, 2.0, 0.0, 0.0])
    s = tm.G @ r + tm.g
    assert np.allclose(s[:2], [1.0, 2.0])                     # r_N >= 0 rows
    assert np.allclose(s[2:].reshape(2, 3), [[0.5, 0.3, -0.39], [0.0, 0.0, 0.0]])


# ------------------------------------------------- single contacts by hand
# W = I, mu = 0.5.  separate: r = 0; stick: r = -q; slide q = (-1, 2, 0):
# u_N = 0 -> r_N = 1, r_T = -mu r_N = -0.5, u_T = 1.5.
@pytest.mark.parametrize("q, r_exp", [
    ((1.0, 0.2, 0.0), (0.0, 0.0, 0.0)),
    ((-1.0, 0.1, -0.2), (1.0, -0.1, 0.2)),
    ((-1.0, 2.0, 0.0), (1.0, -0.5, 0.0)),
    ((-1.0, 0.0, -2.0), (1.0, 0.0, 0.5)),
])
def test_single_contact_coulomb(q, r_exp):
    res = solve(one_contact(q), "clarabel", "coulomb", tol=TOL)
    assert res.converged and res.status == "converged"
    assert np.allclose(res.r, r_exp, atol=1e-7)
    assert res.error <= TOL and res.coulomb_error == res.error


def test_associated_relaxation_dilates():
    # associated: r = P_K(-q) = P_K((1, -2, 0)) = (1.6, -0.8, 0), u = (0.6, 1.2, 0)
    p = one_contact((-1.0, 2.0, 0.0))
    res = solve(p, "clarabel", "associated", tol=TOL)
    assert res.converged
    assert np.allclose(res.r, [1.6, -0.8, 0.0], atol=1e-7)
    assert np.allclose(res.u, [0.6, 1.2, 0.0], atol=1e-7)
    # judged by the exact law it is wrong, and the result says so
    assert res.coulomb_error > 1e-2
    assert res.info["clarabel_status"] == "Solved"


def test_frictionless_and_tresca_by_hand():
    p = one_contact((-1.0, 2.0, 0.0))
    res = solve(p, "clarabel", "frictionless", tol=TOL)
    assert res.converged and np.allclose(res.r, [1.0, 0.0, 0.0], atol=1e-7)
    slide = solve(p, "clarabel", "tresca", tol=TOL, threshold=0.3)     # |q_T| > g: slides
    assert slide.converged and np.allclose(slide.r, [1.0, -0.3, 0.0], atol=1e-7)
    stick = solve(p, "clarabel", "tresca", tol=TOL, threshold=5.0)     # |q_T| < g: sticks
    assert stick.converged and np.allclose(stick.r, [1.0, -2.0, 0.0], atol=1e-7)


def test_2d_slide():
    p = one_contact((-1.0, 2.0), dim=2)
    res = solve(p, "clarabel", "coulomb", tol=TOL)
    assert res.converged and np.allclose(res.r, [1.0, -0.5], atol=1e-7)


# --------------------------------------------- multi-contact built backwards
def law_pair(kinds, mu, dim, rng):
    """(r*, u*) obeying the Coulomb law, contact kinds 'sep', 'stick', 'slide'."""
    r, u = [], []
    for k, m in zip(kinds, mu):
        t = rng.normal(size=dim - 1)
        t /= np.linalg.norm(t)
        if k == "sep":
            r.append(np.r_[0.0, 0.0 * t]); u.append(np.r_[rng.uniform(0.5, 1), 0.3 * t])
        elif k == "stick":
            r.append(np.r_[1.0, 0.5 * m * t]); u.append(np.zeros(dim))
        else:
            r.append(np.r_[1.0, -m * t]); u.append(np.r_[0.0, rng.uniform(0.5, 1) * t])
    return np.concatenate(r), np.concatenate(u)


def spd(m, rng, cond=10.0):
    Q, _ = np.linalg.qr(rng.normal(size=(m, m)))
    return Q @ np.diag(np.linspace(1.0, cond, m)) @ Q.T


def test_sticking_solution_associated_equals_coulomb():
    rng = np.random.default_rng(1)
    mu = np.full(3, 0.6)
    r_s, u_s = law_pair(["stick"] * 3, mu, 3, rng)
    W = spd(9, rng)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    a = solve(p, "clarabel", "associated", tol=TOL)
    c = solve(p, "clarabel", "coulomb", tol=TOL)
    assert a.converged and c.converged
    for res in (a, c):
        assert np.allclose(res.r, r_s, atol=1e-6)
        assert np.allclose(res.u, 0.0, atol=1e-6)
    assert a.coulomb_error <= 1e-7


def test_asymmetric_W_mixed_contacts():
    rng = np.random.default_rng(2)
    mu = np.array([0.3, 0.5, 0.2, 0.4])
    r_s, u_s = law_pair(["slide", "stick", "sep", "slide"], mu, 3, rng)
    S = rng.normal(size=(12, 12))
    W = spd(12, rng, 5.0) + 0.05 * (S - S.T)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    assert not p.is_symmetric
    res = solve(p, "clarabel", "coulomb", tol=TOL)
    assert res.converged and res.error <= TOL
    assert np.allclose(res.r, r_s, atol=1e-6) and np.allclose(res.u, u_s, atol=1e-6)
    # the associated relaxation also handles the skew part in the outer loop
    a = solve(p, "clarabel", "associated", tol=TOL)
    assert a.error <= 1e-6


def test_mu_zero_contacts():
    rng = np.random.default_rng(3)
    mu = np.array([0.0, 0.5, 0.0])
    # mu = 0: r_T = 0 and any tangential velocity is allowed
    r_s = np.array([1.0, 0.0, 0.0, 1.0, -0.5, 0.0, 0.0, 0.0, 0.0])
    u_s = np.array([0.0, 0.4, -0.3, 0.0, 0.8, 0.0, 0.7, 0.1, 0.2])
    W = spd(9, rng)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    res = solve(p, "clarabel", "coulomb", tol=TOL)
    assert res.converged
    assert np.allclose(res.r, r_s, atol=1e-6) and np.allclose(res.u, u_s, atol=1e-6)
    # associated law: the friction contact sticks, u = 0 there
    r_s[3:6], u_s[3:6] = [1.0, 0.2, -0.1], 0.0
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    res = solve(p, "clarabel", "associated", tol=TOL)
    assert res.converged
    assert np.allclose(res.r, r_s, atol=1e-6) and np.allclose(res.u, u_s, atol=1e-6)


def test_rank_deficient_u_unique_r_not():
    rng = np.random.default_rng(4)
    mu = np.full(3, 0.5)
    H = rng.normal(size=(5, 9))                     # 5 dofs, 9 contact unknowns
    W = H.T @ H                                     # rank 5 < 9
    r_s, u_s = law_pair(["stick", "stick", "sep"], mu, 3, rng)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    assert p.is_rank_deficient
    res = solve(p, "clarabel", "coulomb", tol=TOL)
    assert res.converged and error(p, res.r) <= TOL
    assert np.allclose(res.u, u_s, atol=1e-6)
    # impulses differing by a null-space direction of W are equally valid
    assert np.allclose(W @ (res.r - r_s), 0.0, atol=1e-6)


def small_global(rng, mu=0.4):
    n, nc = 8, 2
    M = spd(n, rng, 4.0)
    H = rng.normal(size=(n, 3 * nc))
    f = rng.normal(size=n)
    w = np.array([-0.5, 0.3, 0.1, 0.2, -0.1, 0.4])
    return GlobalFrictionContactProblem(M, H, f, w, mu, 3)


@pytest.mark.parametrize("native", [True, False])
@pytest.mark.parametrize("form", ["coulomb", "associated"])
def test_global_form_equals_condensed(form, native, monkeypatch):
    # native: the SOCP in v (W never formed); else the small-problem dense condensation
    monkeypatch.setattr(cb, "DENSE_CONDENSE_MAX", 0 if native else 10_000)
    g = small_global(np.random.default_rng(5))
    loc = g.to_local()
    rg = solve(g, "clarabel", form, tol=TOL)
    rl = solve(loc, "clarabel", form, tol=TOL)
    assert rg.converged and rl.converged
    assert "condensed_to_local" not in rg.info
    assert rg.info.get("condensed_dense", False) is (not native)
    assert np.allclose(rg.u, rl.u, atol=1e-6)
    assert np.allclose(rg.v, g.global_velocity(rl.r), atol=1e-6)
    if form == "associated":   # same convex program: same optimal value
        obj = lambda r: 0.5 * r @ (loc.W @ r) + loc.q @ r  # noqa: E731
        assert abs(obj(rg.r) - obj(rl.r)) <= 1e-7 * max(1.0, abs(obj(rl.r)))


# ---------------------------------------------------------- generic loop
class ExactInner:
    """Inner solver for W = I: the associated SOCP solution is P_K(-q_shift)."""

    def __init__(self, problem, W_sym):
        assert np.allclose(W_sym.toarray(), np.eye(problem.m))
        self.mu, self.dim, self.calls = problem.mu, problem.dim, 0

    def solve(self, q_shift, tol):
        self.calls += 1
        return project_cone(-q_shift, self.mu, self.dim), {"iterations": 0, "status": "exact", "ok": True}


def test_desaxce_generic_signature():
    p = one_contact((-1.0, 2.0, 0.0))
    res = desaxce_fixed_point(p, ExactInner, tol=1e-12, max_iter=200, polish=None)
    assert res.status == "converged"
    assert np.allclose(res.r, [1.0, -0.5, 0.0], atol=1e-10)


def test_a_polish_reporting_a_nan_error_is_not_trusted():
    # the loop takes a polish's reported Coulomb error, but recomputes a non-finite one
    # (a NaN taken as is would win every comparison's "not >=" and freeze the best iterate)
    p = one_contact((-1.0, 2.0, 0.0))
    calls = []

    def polish(problem, r, tol, options):
        calls.append(1)
        return np.zeros(problem.m), {"iterations": 1, "error": float("nan")}
    res = desaxce_fixed_point(p, ExactInner, tol=1e-12, max_iter=200, polish=polish,
                              history=True)
    assert calls and res.status == "converged"
    assert np.all(np.isfinite(res.history)) and np.isfinite(res.error)
    assert np.allclose(res.r, [1.0, -0.5, 0.0], atol=1e-10)


def test_keep_better_never_takes_a_nan_and_always_beats_a_nan_best():
    from socp_cd.solvers.desaxce import FixedPoint
    a, b = np.zeros(3), np.ones(3)
    nan = float("nan")
    assert FixedPoint.keep_better((b, nan), a, 0.5, None)[1] == 0.5        # NaN never wins
    assert FixedPoint.keep_better((b, 0.1), a, nan, None)[1] == 0.1        # beats a NaN best
    assert FixedPoint.keep_better((b, 0.7), a, 0.5, None)[0] is a          # worse: kept out
    hist = []
    assert FixedPoint.keep_better((b, 0.1), a, 0.5, hist)[0] is b and hist == [0.1]
    # an overflowing start (error NaN) then a polish that meets tol: converged, as before
    p = one_contact((-1.0, 2.0, 0.0))
    res = solve(p, "clarabel", "coulomb", tol=1e-8, r0=np.full(3, 1e300), max_iter=3)
    assert res.converged and res.iterations == 1


# ---------------------------------------------------------------- statuses
def test_max_iter_one_outer_iteration():
    p = one_contact((-1.0, 2.0, 0.0))
    res = solve(p, "clarabel", "coulomb", tol=TOL, max_iter=1, polish=None)
    assert not res.converged and res.status == "max_iter" and res.iterations == 1
    assert res.error > TOL


def test_clarabel_max_iterations_mapping():
    rng = np.random.default_rng(6)
    mu = np.full(4, 0.5)
    r_s, u_s = law_pair(["slide", "stick", "sep", "slide"], mu, 3, rng)
    W = spd(12, rng)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    res = solve(p, "clarabel", "associated", tol=TOL, max_iter=2, polish=None)
    assert res.info["clarabel_status"] == "MaxIterations"
    assert res.status == "max_iter" and not res.converged


def test_unbounded_relaxation_is_numerical_error():
    # W = 0 and q_N < 0: the associated SOCP min q.r over K is unbounded
    p = FrictionContactProblem(np.zeros((3, 3)), [-1.0, 0.0, 0.0], 0.5, 3)
    res = solve(p, "clarabel", "associated", tol=TOL)
    assert "Infeasible" in res.info["clarabel_status"]
    assert res.status == "numerical_error" and not res.converged


def test_converged_only_when_recomputed_error_small():
    rng = np.random.default_rng(7)
    mu = np.full(4, 0.5)
    r_s, u_s = law_pair(["slide", "stick", "sep", "slide"], mu, 3, rng)
    W = spd(12, rng)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    res = solve(p, "clarabel", "associated", tol=1e-14, inner_tol=1e-3, polish=None)
    assert res.info["clarabel_status"] == "Solved"     # Clarabel is happy at its loose tolerance
    assert res.error > 1e-14 and not res.converged and res.status == "stalled"
    # the Newton polish (default) repairs the loose interior-point iterate
    pol = solve(p, "clarabel", "associated", tol=1e-12, inner_tol=1e-3)
    assert pol.converged and pol.info["polish_iterations"] >= 1


def test_inner_failure_reported(monkeypatch):
    def broken(self, q_shift, tol):
        return np.full(self.problem.m, np.nan), {"iterations": 3, "status": "NumericalError", "ok": False}

    monkeypatch.setattr(cb.ClarabelInner, "solve", broken)
    res = solve(one_contact((-1.0, 2.0, 0.0)), "clarabel", "coulomb", tol=TOL, polish=None)
    assert res.status == "numerical_error" and not res.converged
    assert res.info["clarabel_status"] == "NumericalError"


def test_status_map_covers_clarabel():
    import clarabel
    names = [a for a in dir(clarabel.SolverStatus) if not a.startswith("_")]
    assert set(names) <= set(cb.STATUS_MAP)
    assert cb.map_status("Solved") == "converged"
    assert all(cb.map_status(n) in ("max_iter", "stalled", "numerical_error", "time_limit")
               for n in names if n != "Solved")


def test_unknown_option_rejected():
    with pytest.raises(UnsupportedError):
        solve(one_contact((-1.0, 2.0, 0.0)), "clarabel", "coulomb", bogus=1)
    with pytest.raises(UnsupportedError):
        solve(one_contact((-1.0, 2.0, 0.0)), "clarabel", "associated", inner_settings={"no_such": 1})


def test_settings_passthrough_changes_clarabel():
    p = one_contact((-1.0, 2.0, 0.0))
    res = solve(p, "clarabel", "associated", tol=TOL, inner_settings={"max_iter": 1}, polish=None)
    assert res.info["clarabel_status"] == "MaxIterations" and res.status == "max_iter"


# ---------------------------------------------------------------- real data
def test_real_problem_reaches_siconos_tolerance():
    from socp_cd.data import shared_problems_dir
    d = shared_problems_dir()
    if d is None or not (d / "Capsules-i125-1213.hdf5").exists():
        pytest.skip("shared data not available")
    from socp_cd.io import read_problem
    p = read_problem(d / "Capsules-i125-1213.hdf5")
    assert not p.is_symmetric
    res = solve(p, "clarabel", "coulomb", tol=1e-8)
    assert res.converged and error(p, res.r) <= 1e-8
    assert in_cone_violation(res.r, p.mu, 3).max() <= 1e-8 * max(1.0, np.abs(res.r).max())


# ------------------------------------------------- small-problem fast path
def test_upper_csc_arrays_is_the_upper_triangle():
    rng = np.random.default_rng(11)
    for n in (4, cd.DENSE_P_MAX + 5):
        S = rng.normal(size=(n, n))
        S = S + S.T
        S[0, 2] = S[2, 0] = 0.0
        for M in (S, sp.csr_matrix(S)):
            U = cd.upper_csc(M)
            assert U.has_sorted_indices
            assert np.array_equal(U.toarray(), np.triu(S))
            assert np.array_equal(cd.CscArrays.of(cd.upper_csc_arrays(M)).toarray(), np.triu(S))


def test_clarabel_reads_csc_arrays():
    # min 2 x0^2 + x1^2 + x0 - x1  s.t. x >= 0  ->  x = (0, 1/2) (by hand)
    P = cd.CscArrays(np.array([4.0, 2.0]), np.array([0, 1], dtype=np.int32),
                     np.array([0, 1, 2], dtype=np.int32), (2, 2))
    A = -cd.CscArrays(np.ones(2), np.array([0, 1], dtype=np.int32),
                      np.array([0, 1, 2], dtype=np.int32), (2, 2))
    sol = clarabel.DefaultSolver(P, np.array([1.0, -1.0]), A, np.zeros(2),
                                 [clarabel.NonnegativeConeT(2)], cb.make_settings(1e-10)).solve()
    assert np.allclose(sol.x, [0.0, 0.5], atol=1e-8)
    assert np.array_equal(A.tocsc().toarray(), -np.eye(2))


@pytest.mark.parametrize("law", ["coulomb", "associated"])
def test_dense_error_matches_residuals(law):
    from socp_cd.laws import associated_error
    rng = np.random.default_rng(12)
    mu = np.array([0.0, 0.4, 1.1, 0.3])
    S = rng.normal(size=(12, 12))
    p = FrictionContactProblem(spd(12, rng) + 0.1 * (S - S.T), rng.normal(size=12), mu, 3)
    code = kc.LAW_COULOMB if law == "coulomb" else kc.LAW_ASSOCIATED
    ref = error if law == "coulomb" else associated_error
    for r in (rng.normal(size=12), np.zeros(12), project_cone(rng.normal(size=12), mu, 3)):
        u = np.empty(12)
        e = kd.dense_error(p.W.toarray(), p.q, r, mu, 3, code, np.linalg.norm(p.q), u)
        assert np.isclose(e, ref(p, r), rtol=1e-12, atol=1e-15)
        assert np.allclose(u, p.velocity(r))


def test_dense_split_and_matvec():
    rng = np.random.default_rng(13)
    W = rng.normal(size=(6, 6))
    Wc = sp.csr_matrix(W)
    Wd, Ws, Wa, asym, scale, dsum = kd.dense_split(Wc.indptr, Wc.indices, Wc.data, 6)
    assert np.array_equal(Wd, W) and np.allclose(Ws + Wa, W) and np.allclose(Ws, Ws.T)
    assert np.isclose(asym, np.abs(W - W.T).max()) and np.isclose(scale, np.abs(W).max())
    assert np.isclose(dsum, np.abs(np.diag(W)).sum())
    x = rng.normal(size=6)
    assert np.allclose(kd.matvec(W, x), W @ x)


def test_dense_condense_matches_to_local():
    g = small_global(np.random.default_rng(14))
    loc = condense_dense(g)
    ref = g.to_local()
    assert np.allclose(loc.W.toarray(), ref.W.toarray(), atol=1e-12)
    assert np.allclose(loc.q, ref.q, atol=1e-12)
    # a singular M is not condensed densely: the sparse path reports it
    bad = GlobalFrictionContactProblem(np.zeros((8, 8)), g.H, g.f, g.w, g.mu, 3)
    with pytest.raises(InvalidProblemError):
        condense_dense(bad)


def test_newton_polish_converges_from_perturbed_solution():
    rng = np.random.default_rng(15)
    mu = np.array([0.3, 0.5, 0.2, 0.4])
    r_s, u_s = law_pair(["slide", "stick", "sep", "slide"], mu, 3, rng)
    W = spd(12, rng, 5.0)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    r0 = r_s + 1e-3 * rng.normal(size=12)
    from socp_cd.solvers.newton import newton_polish
    r, info = newton_polish(p, r0, 1e-12, {"max_iter": 30, "law": "coulomb"})
    assert info["error"] <= 1e-12 and np.isclose(info["error"], error(p, r), atol=1e-15)
    assert np.allclose(r, r_s, atol=1e-9) and 1 <= info["iterations"] <= 30


def test_small_problem_polish_from_first_iterate():
    # W = I: the first associated SOCP dilates (r_N too small); the compiled polish
    # reaches the Coulomb solution (by hand: slide, r = (1, -0.5, 0)) without a 2nd SOCP
    res = solve(one_contact((-1.0, 2.0, 0.0)), "clarabel", "coulomb", tol=1e-10)
    assert res.converged and res.iterations == 1 and res.info["polish_iterations"] >= 1
    assert np.allclose(res.r, [1.0, -0.5, 0.0], atol=1e-8)


def test_small_problem_with_default_and_explicit_outer_options_agree():
    rng = np.random.default_rng(16)
    mu = np.array([0.3, 0.5, 0.2, 0.4])
    r_s, u_s = law_pair(["slide", "stick", "sep", "slide"], mu, 3, rng)
    W = spd(12, rng, 5.0)
    p = FrictionContactProblem(W, u_s - W @ r_s, mu, 3)
    fast = solve(p, "clarabel", "coulomb", tol=1e-10, history=True)
    generic = solve(p, "clarabel", "coulomb", tol=1e-10, patience=8)   # an outer option: generic loop
    for res in (fast, generic):
        assert res.converged and np.allclose(res.r, r_s, atol=1e-8)
    assert fast.iterations == 1 and np.isclose(fast.history[-1], fast.error, rtol=1e-6)


def test_small_problem_loop_continues_when_first_polish_fails(monkeypatch):
    # the first polish is disabled: the loop must continue from its iterate
    from socp_cd.solvers import newton as nt
    calls = []
    real = nt.newton_polish

    def fails_first(problem, r, tol, options):
        calls.append(1)
        if len(calls) == 1:
            return r.copy(), {"iterations": 0, "error": np.inf}
        return real(problem, r, tol, options)

    monkeypatch.setattr(nt, "newton_polish", fails_first)
    p = one_contact((-1.0, 2.0, 0.0))
    res = solve(p, "clarabel", "coulomb", tol=1e-10, history=True)
    assert res.converged and res.iterations >= 2
    assert np.allclose(res.r, [1.0, -0.5, 0.0], atol=1e-8)
    assert res.history[0] > 1e-3              # the first (associated) iterate dilates
    assert res.info["inner_iterations"] > 0 and res.info["polish_iterations"] >= 1


@pytest.mark.parametrize("dim", [2, 3])
def test_coulomb_constraint_is_minus_cone_map(dim):
    for mu in (np.array([0.3, 1.2]), np.array([0.0, 0.7])):
        A, b, cones = cd.coulomb_constraint(mu, dim)
        cm = coulomb_cone_map(mu, dim)
        assert np.array_equal(cd.CscArrays.of(A).toarray(), -cm.G.toarray())
        assert np.array_equal(b, cm.g) and len(cones) == len(cm.cones())


# ------------------------------------------- regressions found by the extremes suite
def _extreme(case, dim):
    from socp_cd.bench.extremes import build
    return build(case, 50, dim)


def test_high_friction_does_not_stall():
    """mu = 10 (3D, 50 contacts): the outer loop stalls near 7e-4 and the final
    (dense) polish must finish; it used to stop at 9.5e-5 ("stalled")."""
    p = _extreme("mu=10", 3)
    res = solve(p, "clarabel", tol=1e-6)
    assert res.status == "converged" and error(p, res.r) <= 1e-6
    # feasible to tol in unit-free terms (the units guard's cone part)
    assert res.info["guard"]["cone"] <= 1e-6
    assert in_cone_violation(res.r, p.mu, 3).max() <= 1e-6 * max(1.0, np.abs(res.r).max())


def test_rank_deficient_w_unbounded_relaxation():
    """Redundant contacts (2D, rank(W) = 26 of 100): the first associated SOCP is
    unbounded (DualInfeasible); it used to end in numerical_error at 8e-6.  The
    velocities are unique, so they must match the manufactured ones."""
    p = _extreme("redundant", 2)
    assert p.is_rank_deficient
    res = solve(p, "clarabel", tol=1e-6)
    assert res.status == "converged" and error(p, res.r) <= 1e-6
    u_exact = p.solution.u
    assert np.linalg.norm(p.velocity(res.r) - u_exact) <= 1e-4 * max(1.0, np.linalg.norm(u_exact))


def test_inner_turns_refinement_back_on_after_a_failed_solve():
    """Iterative refinement (off on small problems for speed) comes back when a
    solve does not end "Solved", and stays on."""
    p = _extreme("redundant", 2)
    inner = cb.ClarabelInner(p, settings=dict(cb.SMALL_PROBLEM_SETTINGS), refine_on_failure=True)
    inner.solve(p.q, 1e-10)
    assert inner.statuses[0] != "Solved"          # the unrefined solve fails on this data
    assert len(inner.statuses) == 2               # ... and was redone once
    assert inner.user_settings["iterative_refinement_enable"] is True
    assert inner.refine_on_failure is False
    keep = cb.ClarabelInner(p, settings=dict(cb.SMALL_PROBLEM_SETTINGS))   # user choice kept
    keep.solve(p.q, 1e-10)
    assert len(keep.statuses) == 1


@pytest.mark.parametrize("structure", ["tree", "redundant"])
def test_time_limit_reaches_the_inner_solver(structure):
    # the De Saxcé loop's inner Clarabel solver gets the budget (session 25: it went to the
    # outer loop only, and an inner solve ran to its end): a budget spent before the first
    # interior-point iteration stops Clarabel there (its status MaxTime, no iteration)
    from socp_cd.bench.generators import manufactured
    p = manufactured(40, 3, 0.5, structure=structure, seed=2)
    res = solve(p, solver="clarabel", tol=1e-12, time_limit=1e-9, polish=None)
    assert res.status == "time_limit" and not res.converged
    assert res.info["inner_status"] == "MaxTime" and res.info["inner_iterations"] == 0
    free = solve(p, solver="clarabel", tol=1e-12, polish=None, max_iter=1)
    assert free.info["inner_iterations"] > 0 and free.info["inner_status"] != "MaxTime"

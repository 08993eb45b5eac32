"""Readable cvxpy reference models of the contact laws (backend ``"cvxpy"``).

Every law is the cone program ::

    minimize    ½ rᵀ W_s r + q̃ᵀ r          W_s = (W + Wᵀ)/2
    subject to  r ∈ S                       (one vectorized constraint per set)

with ``S`` the Coulomb cone ``K_mu`` (``"associated"``, ``"coulomb"``), Tresca's
set ``{r_N >= 0, ||r_T|| <= g}`` (``"tresca"``) or ``{r_N >= 0, r_T = 0}``
(``"frictionless"``).  ``q̃`` is a ``cp.Parameter`` so that the model is built
and canonicalized once and re-solved cheaply: ``q̃ = q`` for the associated
laws, ``q̃ = q + mu ||u_T|| e_N + W_a r`` inside the De Saxcé fixed point
for ``"coulomb"`` (:func:`socp_cd.solvers.desaxce.desaxce_fixed_point`;
``W_a`` the skew part of ``W``, also moved to that outer loop for
``"associated"`` when ``W`` is not symmetric).

The quadratic term is ``cp.quad_form(r, cp.psd_wrap(W_s))``: cvxpy hands
``W_s`` to Clarabel as its ``P`` matrix unchanged (no factorization, no extra
cone), and ``psd_wrap`` skips cvxpy's eigenvalue-based PSD check, which is
slow on large matrices and rejects singular ``W_s`` whose smallest
eigenvalues are ``-1e-16`` round-off (rank-deficient Delassus operators are
common).  A factor form ``sum_squares(L r)`` would need ``W_s = LᵀL`` — a
rank-revealing factorization of a singular matrix — and adds a second-order
cone of size ``m + 1``.  See ``formulations/cvxpy_models.md``.

The solver is Clarabel (through cvxpy).  This backend is the *reference*
model, not the fast path: use ``solver="clarabel"`` for speed.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import UnsupportedError
from .desaxce import desaxce_fixed_point
from .newton import resolve_polish
from .options import check_unknown, inner_tolerance
from .spec import SolverSpec
from .result import SolverResult

try:
    import cvxpy as cp
except ModuleNotFoundError:  # pragma: no cover - cvxpy is a declared dependency
    cp = None

DEFAULT_MAX_ITER = 50   #: outer De Saxcé iterations for "coulomb"

#: cvxpy status -> (provisional socp_cd status, explanation)
STATUS_MAP = {
    "optimal": ("converged", ""),
    "optimal_inaccurate": ("stalled", "Clarabel stopped at reduced accuracy (AlmostSolved)"),
    "user_limit": ("max_iter", "Clarabel hit its iteration/time limit"),
    "infeasible": ("numerical_error", "reported infeasible, impossible (r = 0 is feasible): "
                                      "numerical trouble"),
    "infeasible_inaccurate": ("numerical_error", "reported almost infeasible, impossible "
                                                 "(r = 0 is feasible): numerical trouble"),
    "unbounded": ("numerical_error", "reported unbounded: q has a descent direction inside "
                                     "the cone along ker W_s, the problem has no solution"),
    "unbounded_inaccurate": ("numerical_error", "reported almost unbounded (no solution or "
                                                "numerical trouble)"),
    "solver_error": ("numerical_error", "Clarabel failed (numerical error / insufficient "
                                        "progress)"),
}


def _require_cvxpy():
    if cp is None:  # pragma: no cover
        raise UnsupportedError("solver 'cvxpy' needs the cvxpy package (pip install cvxpy)")


def clarabel_tolerances(tol: float) -> dict:
    """Clarabel settings for an inner tolerance ``tol``.

    The same mapping as the direct path
    (:func:`socp_cd.solvers.clarabel_backend.make_settings`), so that the two
    paths are compared at equal accuracy: ``tol_gap_abs = tol_gap_rel =
    tol_feas = tol`` and ``tol_ktratio = min(1e-6, tol)``.
    """
    tol = float(tol)
    return {"tol_gap_abs": tol, "tol_gap_rel": tol, "tol_feas": tol,
            "tol_ktratio": min(1e-6, tol)}


def single_program_tol(tol: float) -> float:
    """Inner Clarabel tolerance of a single cone program, ``min(1e-10, tol/100)``.

    The natural-map residual of an interior-point solution behaves like the
    square root of its complementarity gap at contacts that are not strictly
    complementary, hence the margin (same default as the direct path).
    """
    return inner_tolerance(tol)


def law_constraints(r, problem, formulation: str, threshold=None) -> list:
    """cvxpy constraints ``r ∈ S`` for a law, vectorized over contacts.

    Parameters
    ----------
    r : cvxpy.Variable, shape (m,)
        Stacked impulses, normal first.
    problem : FrictionContactProblem
    formulation : {"coulomb", "associated", "tresca", "frictionless"}
    threshold : ndarray, optional
        Tresca thresholds ``g`` per contact.

    Returns
    -------
    list of cvxpy constraints
    """
    d, nc = problem.dim, problem.n_contacts
    N = d * np.arange(nc)                          # normal components
    Ts = [N + k for k in range(1, d)]              # tangential components

    def tangential(idx):                           # (d-1, len(idx)) block of r_T
        return cp.vstack([r[T[idx]] for T in Ts])

    if formulation == "frictionless":
        return [r[N] >= 0, r[np.concatenate(Ts)] == 0]
    if formulation == "tresca":
        g = np.asarray(threshold, dtype=np.float64)
        return [r[N] >= 0, cp.SOC(g, tangential(np.arange(nc)), axis=0)]
    # Coulomb cone K_mu; mu = 0 contacts are the ray r_T = 0, r_N >= 0
    mu = problem.mu
    fric, zero = np.flatnonzero(mu > 0), np.flatnonzero(mu == 0)
    cons = []
    if fric.size:
        cons.append(cp.SOC(cp.multiply(mu[fric], r[N[fric]]), tangential(fric), axis=0))
    if zero.size:
        cons += [r[N[zero]] >= 0, r[np.concatenate([T[zero] for T in Ts])] == 0]
    return cons


class CvxpyModel:
    """``min ½ rᵀ W_s r + q̃ᵀ r, r ∈ S`` built once, re-solved for new ``q̃``.

    Implements the inner-solver protocol of
    :func:`socp_cd.solvers.desaxce.desaxce_fixed_point`:
    ``solve(q_shift, tol) -> (r, info)``.

    Parameters
    ----------
    problem : FrictionContactProblem
    W_sym : sparse matrix, optional
        Symmetric matrix of the quadratic term (default ``problem.symmetric_part()``).
    formulation : str
        Feasible set (``"coulomb"`` and ``"associated"`` both use ``K_mu``).
    threshold : ndarray, optional
        Tresca thresholds.
    solver_options : dict, optional
        Extra Clarabel settings (override the tolerances derived from ``tol``).
    """

    def __init__(self, problem, W_sym=None, formulation: str = "associated", threshold=None,
                 solver_options=None):
        _require_cvxpy()
        Ws = problem.symmetric_part() if W_sym is None else W_sym
        self.r = cp.Variable(problem.m, name="r")
        self.q_shift = cp.Parameter(problem.m, name="q_shift")
        objective = 0.5 * cp.quad_form(self.r, cp.psd_wrap(Ws)) + self.q_shift @ self.r
        self.prob = cp.Problem(cp.Minimize(objective),
                               law_constraints(self.r, problem, formulation, threshold))
        self.solver_options = dict(solver_options or {})
        self.m = problem.m

    def compile(self) -> "CvxpyModel":
        """Canonicalize now (cvxpy caches it) instead of inside the first :meth:`solve`."""
        self.prob.get_problem_data(cp.CLARABEL)
        return self

    def apply(self, q_shift) -> None:
        """Step 1: put the data of this solve into the compiled model (the parameter ``q_shift``)."""
        self.q_shift.value = np.asarray(q_shift, dtype=np.float64)

    def run(self, tol: float) -> str:
        """Step 2: run Clarabel through cvxpy at tolerance ``tol``; returns cvxpy's status."""
        opts = {**clarabel_tolerances(tol), **self.solver_options}
        try:
            with warnings.catch_warnings():   # inaccuracy is reported through the status
                warnings.filterwarnings("ignore", message="Solution may be inaccurate")
                self.prob.solve(solver=cp.CLARABEL, warm_start=True, **opts)
            return self.prob.status
        except cp.error.SolverError:
            return "solver_error"

    def invert(self, status: str):
        """Step 3: the contact impulses and the ``info`` of the inner protocol from the solution."""
        r = self.r.value
        if r is None or status not in ("optimal", "optimal_inaccurate", "user_limit"):
            r = np.zeros(self.m)
        stats = self.prob.solver_stats
        iters = int(stats.num_iters) if stats is not None and stats.num_iters is not None else 0
        return np.asarray(r, dtype=np.float64), {
            "iterations": iters,
            "status": status,
            "ok": status == "optimal",
            "objective": self.prob.value,
            "socp_status": STATUS_MAP.get(status, ("numerical_error", ""))[0],
        }

    def solve(self, q_shift, tol: float):
        """Solve for the linear term ``q_shift``: :meth:`apply`, :meth:`run`, :meth:`invert`.

        Returns ``(r, info)``; ``info`` has ``iterations`` (Clarabel's),
        ``status`` (cvxpy's), ``ok`` (True for ``optimal``), ``objective`` and
        ``socp_status`` (the provisional socp_cd status from :data:`STATUS_MAP`).
        """
        self.apply(q_shift)
        return self.invert(self.run(tol))


def _result_from_inner(r, info) -> SolverResult:
    status, why = STATUS_MAP.get(info["status"], ("numerical_error", "unknown cvxpy status"))
    msg = f"cvxpy/Clarabel: {info['status']}" + (f" ({why})" if why else "")
    return SolverResult(r=r, status=status, iterations=info["iterations"],
                        info={"cvxpy_status": info["status"], "objective": info["objective"],
                              "inner_iterations": info["iterations"]},
                        message=msg)


#: solver-specific options: the De Saxcé outer options (coulomb) and the Tresca threshold
OPTIONS = {
    "threshold": "Tresca thresholds (formulation 'tresca')",
    "accel": "outer acceleration (default 'anderson')", "memory": "Anderson memory (default 5)",
    "adaptive_tol": "adaptive inner tolerance (default False)", "kappa": "(default 1e-2)",
    "inner_tol_max": "(default 1e-4)", "inner_tol_min": "(default min(1e-10, tol/100))",
    "polish": "'newton' (default), None or a callable",
    "polish_max_iter": "(default 15)", "polish_switch": "(default per problem size)",
    "patience": "(default 8)",
}


def solve_cvxpy(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                time_limit=None, verbose=False, inner_settings=None, **options):
    """Backend ``"cvxpy"``.

    Options
    -------
    threshold : array_like
        Tresca thresholds (``formulation="tresca"``, validated by :func:`socp_cd.solve`).
    inner_settings : dict
        Extra Clarabel settings passed through cvxpy (e.g. ``{"max_iter": 50}``).
    **outer_options
        For ``"coulomb"``: forwarded to the De Saxcé fixed point
        (:func:`socp_cd.solvers.desaxce.desaxce_fixed_point`), with the same
        defaults as the direct Clarabel path (Newton polish included; pass
        ``polish=None`` for the cone programs' answer alone).

    Notes
    -----
    ``tresca`` and ``frictionless`` are single cone programs with ``W_s``;
    when ``W`` is not symmetric they solve the law for ``W_s``, not ``W``, and
    :func:`socp_cd.solve`'s recomputed residual (with the true ``W``) tells
    how far that is. ``"associated"`` is one cone program when ``W`` is
    symmetric, otherwise the skew part goes to the outer fixed point
    (``law="associated"``, as the direct Clarabel path); ``"coulomb"`` always
    uses it. ``max_iter`` caps those outer iterations (default 50). As on the
    direct path, the outer loop ends with the Newton solver's local core as
    its polish (counted in ``info["polish_iterations"]``); without it the 3D
    fixed point stalls around 1e-6 on some problems.
    """
    _require_cvxpy()
    check_unknown("cvxpy", options, OPTIONS)
    solver_options = dict(inner_settings or {})
    if verbose:
        solver_options.setdefault("verbose", True)
    if time_limit is not None:
        solver_options.setdefault("time_limit", float(time_limit))
        if formulation == "coulomb":
            options.setdefault("time_limit", float(time_limit))
    threshold = options.pop("threshold", None)
    # "coulomb", and "associated" with a non-symmetric W (skew part in an outer loop)
    outer_law = formulation if formulation == "coulomb" or (
        formulation == "associated" and not problem.is_symmetric) else None
    if outer_law is not None:
        def factory(prob, W_sym):
            return CvxpyModel(prob, W_sym, "coulomb", solver_options=solver_options)

        if outer_law == "associated":
            options["law"] = "associated"
        options["polish"] = resolve_polish(options.get("polish", "newton"))
        return desaxce_fixed_point(problem, factory, tol=tol,
                                   max_iter=DEFAULT_MAX_ITER if max_iter is None else max_iter,
                                   r0=r0, history=history, **options)
    check_unknown(f"cvxpy ({formulation})", options, ())
    model = CvxpyModel(problem, None, formulation, threshold, solver_options)
    r, info = model.solve(problem.q, single_program_tol(tol))
    return _result_from_inner(r, info)


SPEC = SolverSpec(
    "cvxpy", solve_cvxpy, ("coulomb", "associated", "tresca", "frictionless"), dims=(2, 3),
    description="cvxpy reference models solved by Clarabel (readable, slower than 'clarabel')",
    default_max_iter=DEFAULT_MAX_ITER, options=OPTIONS,
    inner_settings="Clarabel settings passed through cvxpy's solve()")

__all__ = ["SPEC", "OPTIONS", "CvxpyModel", "law_constraints", "clarabel_tolerances", "single_program_tol", "solve_cvxpy", "STATUS_MAP"]

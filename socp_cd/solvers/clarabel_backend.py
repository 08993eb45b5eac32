"""Clarabel backend: contact laws as second-order cone programs.

Registered as solver ``"clarabel"`` with formulations

* ``"coulomb"`` (default) — the exact law by the De Saxcé fixed point
  (:mod:`socp_cd.solvers.desaxce`) over associated SOCPs solved by Clarabel;
* ``"associated"`` — the convex relaxation ``min ½ rᵀW r + qᵀr, r ∈ K_mu``
  (one SOCP when ``W`` is symmetric; with an asymmetric ``W`` the SOCP sees
  ``W_s`` and the skew part is iterated by the same outer loop as ``coulomb``,
  without the friction shift);
* ``"tresca"`` — ``min ½ rᵀW_s r + qᵀr, r_N >= 0, ||r_T|| <= g`` (one SOCP,
  thresholds ``options["threshold"]``);
* ``"frictionless"`` — ``r_T = 0, r_N >= 0`` (a QP).

Global problems are solved natively (for ``associated`` and ``coulomb``) in
the velocities ``v``: ``min ½ vᵀMv − fᵀv s.t. Hᵀv + w + shift ∈ K*_mu``; the
constraint multipliers are the impulses ``r`` and ``W`` is never formed.
Small ones (at most ``DENSE_CONDENSE_MAX`` dofs) are condensed instead by one
dense LU of ``M`` (:func:`socp_cd.condensation.condense_dense`, ``info["condensed_dense"]``): the
local path then runs the compiled residuals and the polish (the Newton solver's
local core, :func:`socp_cd.solvers.newton.newton_polish`).  Every problem,
tiny ones included, goes through the one De Saxcé loop.

Options (all keyword arguments of :func:`socp_cd.solve`)
---------------------------------------------------------
inner_settings : dict
    Clarabel settings passed through (e.g. ``{"static_regularization_constant":
    1e-7, "direct_solve_method": "qdldl"}``), applied after socp_cd's defaults
    (``DEFAULT_SETTINGS``, plus ``SMALL_PROBLEM_SETTINGS`` in the De Saxcé
    loop of small local problems).
time_limit : float
    Seconds: Clarabel's ``time_limit``; in the De Saxcé loop (``coulomb``) each inner
    solve gets what is left of the budget counted from the loop's start (Clarabel
    0.11 gives every ``solve()`` its whole limit), and the outer loop stops once it is
    spent; Clarabel's set-up and first factorization cannot be cut.
verbose : bool
    Clarabel's printout.
threshold : array_like
    Tresca thresholds (required for ``tresca``).
inner_tol : float
    Clarabel tolerance for the single-SOCP formulations (default ``min(1e-10, tol/100)``).
accel, memory, adaptive_tol, kappa, inner_tol_max, inner_tol_min, polish,
polish_max_iter, patience
    De Saxcé outer-loop options (see :func:`~socp_cd.solvers.desaxce.desaxce_fixed_point`).

Statuses
--------
Clarabel's status string is kept in ``info["clarabel_status"]`` and mapped to a
provisional status (``solve()`` then decides ``converged`` from the recomputed
residual): ``Solved`` → converged; ``AlmostSolved`` and
``InsufficientProgress`` → stalled; ``MaxIterations`` → max_iter; ``MaxTime``
→ time_limit; ``NumericalError``, ``(Almost)PrimalInfeasible``,
``(Almost)DualInfeasible`` (a contact problem always has a feasible point
``r = 0``; dual infeasibility means an unbounded relaxation, e.g. ``W``
singular along a cone direction with ``qᵀd < 0``), ``Unsolved`` and
``CallbackTerminated`` → numerical_error.
"""
from __future__ import annotations

import time as _time

import numpy as np

import clarabel

from ..condensation import DENSE_CONDENSE_MAX, condense_dense
from ..errors import UnsupportedError
from .conic_data import global_conic_data, local_conic_data
from .desaxce import DENSE_MAX, OUTER_DEFAULTS, check_outer_options, desaxce_fixed_point
from .options import check_unknown, inner_tolerance
from . import newton
from .polish import natural_map_newton
from .result import SolverResult
from .spec import SolverSpec

#: Clarabel status string -> (provisional socp_cd status, explanation); the same shape as
#: every backend's ``STATUS_MAP``
STATUS_MAP = {
    "Solved": ("converged", ""),
    "AlmostSolved": ("stalled", "Clarabel stopped at reduced accuracy"),
    "InsufficientProgress": ("stalled", "Clarabel made insufficient progress"),
    "MaxIterations": ("max_iter", "Clarabel hit its iteration cap"),
    "MaxTime": ("time_limit", "Clarabel hit its time limit"),
    "NumericalError": ("numerical_error", "Clarabel: numerical error"),
    "PrimalInfeasible": ("numerical_error", "reported infeasible, impossible (r = 0 is feasible)"),
    "DualInfeasible": ("numerical_error", "reported dual infeasible: the relaxation is unbounded"),
    "AlmostPrimalInfeasible": ("numerical_error", "reported almost infeasible"),
    "AlmostDualInfeasible": ("numerical_error", "reported almost dual infeasible"),
    "Unsolved": ("numerical_error", "Clarabel did not run"),
    "CallbackTerminated": ("numerical_error", "terminated by a callback"),
}

#: statuses whose iterate is a usable (possibly inaccurate) solution
USABLE = ("Solved", "AlmostSolved", "InsufficientProgress", "MaxIterations", "MaxTime")

#: socp_cd's Clarabel defaults (tuned on the shared data, see formulations/associated.md)
DEFAULT_SETTINGS = dict(
    verbose=False,
    max_iter=200,
    presolve_enable=False,   # keeps the data layout fixed for solver.update(q=..., b=...)
)


#: added for the De Saxcé loop on small local problems (``m <= desaxce.DENSE_MAX``): the
#: Newton polish finishes from the interior-point iterate, so Clarabel's
#: iterative refinement buys nothing there (measured: 5-30 % faster, same outcome on the
#: shared data; see validation/conic_vs_siconos.py).  A solve that does not end "Solved"
#: (rank-deficient ``W``: unbounded relaxation; large ``mu``) is redone with refinement,
#: which then stays on (:class:`ClarabelInner`, ``refine_on_failure``).
SMALL_PROBLEM_SETTINGS = dict(iterative_refinement_enable=False)


_CLARABEL_CONES = {"zero": clarabel.ZeroConeT, "nonneg": clarabel.NonnegativeConeT,
                   "soc": clarabel.SecondOrderConeT}
_CONE_CACHE: dict = {}


def clarabel_cones(cones) -> list:
    """Clarabel cone objects of neutral ``(kind, size)`` cones (:mod:`.conic_data`)."""
    out = []
    for c in cones:
        obj = _CONE_CACHE.get(c)
        if obj is None:
            obj = _CONE_CACHE[c] = _CLARABEL_CONES[c[0]](c[1])
        out.append(obj)
    return out


def map_status(clarabel_status) -> str:
    """Provisional socp_cd status of a Clarabel status (string or ``SolverStatus``)."""
    return STATUS_MAP.get(str(clarabel_status), ("numerical_error", ""))[0]


_SETTINGS_CACHE: dict = {}


def make_settings(tol: float | None = None, settings: dict | None = None, *,
                  time_limit=None, verbose=False, max_iter=None):
    """Clarabel settings: socp_cd defaults, ``tol`` on gap/feasibility, user overrides.

    Settings objects are cached per argument set (Clarabel copies them into
    each solver, so sharing one is safe); user ``settings`` with unhashable
    values bypass the cache.
    """
    try:
        key = (tol, time_limit, bool(verbose), max_iter,
               tuple(sorted(settings.items())) if settings else ())
        hit = _SETTINGS_CACHE.get(key)
    except TypeError:
        key, hit = None, None
    if hit is not None:
        return hit
    s = _build_settings(tol, settings, time_limit=time_limit, verbose=verbose, max_iter=max_iter)
    if key is not None and len(_SETTINGS_CACHE) < 256:
        _SETTINGS_CACHE[key] = s
    return s


def _build_settings(tol, settings, *, time_limit, verbose, max_iter):
    s = clarabel.DefaultSettings()
    vals = dict(DEFAULT_SETTINGS)
    vals["verbose"] = bool(verbose)
    if tol is not None:
        vals.update(tol_gap_abs=tol, tol_gap_rel=tol, tol_feas=tol, tol_ktratio=min(1e-6, tol))
    if time_limit is not None:
        vals["time_limit"] = float(time_limit)
    if max_iter is not None:
        vals["max_iter"] = int(max_iter)
    vals.update(settings or {})
    for key, val in vals.items():
        if not hasattr(s, key):
            raise UnsupportedError(f"unknown Clarabel setting {key!r} (inner_settings)")
        setattr(s, key, val)
    return s


class ClarabelInner:
    """Associated SOCP solved repeatedly with a changing linear term.

    Implements the ``inner`` protocol of
    :func:`~socp_cd.solvers.desaxce.desaxce_fixed_point`: ``solve(q_shift, tol)
    -> (r, info)``.  The Clarabel solver is built once; later calls update
    ``q`` (local form) or ``b`` (global form) with ``solver.update`` and reuse
    the KKT structure (Clarabel has no iterate warm start).

    ``refine_on_failure=True`` (set by the backend when it switched iterative
    refinement off, ``SMALL_PROBLEM_SETTINGS``): the first solve that does not
    end "Solved" is redone with refinement, kept on for later solves.
    """

    def __init__(self, problem, W_sym=None, *, settings=None, time_limit=None, verbose=False,
                 clarabel_max_iter=None, refine_on_failure=False):
        self.problem = problem
        self.user_settings = dict(settings or {})
        # iterative refinement was switched off for speed (SMALL_PROBLEM_SETTINGS): turn it
        # back on, for this and every later solve, when a solve does not end "Solved"
        self.refine_on_failure = refine_on_failure
        # (Clarabel 0.11 gives each solve() the whole limit again: each solve gets what is
        # left of the budget, counted from here, the De Saxcé loop's set-up)
        self.deadline = None if time_limit is None else _time.perf_counter() + time_limit
        self.verbose = verbose
        self.clarabel_max_iter = clarabel_max_iter
        if problem.is_global:
            self.data = global_conic_data(problem)
        else:
            self.data = local_conic_data(problem, "associated", W_sym=W_sym)
        self.cones = clarabel_cones(self.data.cones)
        self.solver = None
        self.tol = None
        self.last_v = None
        self.statuses = []

    def _settings(self, tol):
        if self.deadline is not None:       # (not cached: the time left differs per solve)
            left = max(self.deadline - _time.perf_counter(), 1e-9)
            return _build_settings(tol, self.user_settings, time_limit=left,
                                   verbose=self.verbose, max_iter=self.clarabel_max_iter)
        return make_settings(tol, self.user_settings, time_limit=None,
                             verbose=self.verbose, max_iter=self.clarabel_max_iter)

    def solve(self, q_shift, tol):
        """Solve ``min ½ rᵀW_s r + q_shiftᵀ r, r ∈ K_mu``; returns ``(r, info)``."""
        p, d = self.problem, self.data
        q_shift = np.asarray(q_shift, dtype=np.float64)
        if p.is_global:
            c = q_shift - p.q_local
            qv, b = d.q, d.cone_map.G @ (p.w + c) + d.cone_map.g
        else:
            qv, b = q_shift, d.b
        if self.solver is None:
            self.tol = tol
            self.solver = clarabel.DefaultSolver(d.P, qv, d.A, b, self.cones, self._settings(tol))
        else:
            kw = {"q": qv} if not p.is_global else {"b": b}
            if tol != self.tol or self.deadline is not None:
                kw["settings"] = self._settings(tol)
                self.tol = tol
            self.solver.update(**kw)
        sol = self.solver.solve()
        status = str(sol.status)
        if self.refine_on_failure and status not in ("Solved", "MaxTime"):
            # without refinement an ill-conditioned KKT system (rank-deficient W, large mu)
            # gives inaccurate or unbounded iterates: re-solve with Clarabel's default
            self.refine_on_failure = False
            self.user_settings["iterative_refinement_enable"] = True
            self.solver.update(settings=self._settings(tol))
            first = sol
            sol = self.solver.solve()
            status = str(sol.status)
            self.statuses.append(str(first.status))
            sol_its = int(first.iterations)
        else:
            sol_its = 0
        self.statuses.append(status)
        if p.is_global:
            self.last_v = np.asarray(sol.x, dtype=np.float64)
            r = d.cone_map.multiplier(sol.z)
        else:
            r = np.asarray(sol.x, dtype=np.float64)
        return r, {"iterations": int(sol.iterations) + sol_its, "status": status,
                   "ok": status in USABLE[:2], "timed_out": status == "MaxTime"}


def _single_socp(problem, formulation, tol, options):
    """One Clarabel solve of the associated / Tresca / frictionless program."""
    itol = options.get("inner_tol", inner_tolerance(tol))
    s = make_settings(itol, options.get("settings"), time_limit=options.get("time_limit"),
                      verbose=options.get("verbose", False),
                      max_iter=options.get("clarabel_max_iter"))
    if problem.is_global:
        d = global_conic_data(problem)
    else:
        d = local_conic_data(problem, formulation, threshold=options.get("threshold"))
    solver = clarabel.DefaultSolver(d.P, d.q, d.A, d.b, clarabel_cones(d.cones), s)
    sol = solver.solve()
    status = str(sol.status)
    v = None
    if problem.is_global:
        v = np.asarray(sol.x, dtype=np.float64)
        r = d.cone_map.multiplier(sol.z)
    else:
        r = np.asarray(sol.x, dtype=np.float64)
    if status not in USABLE:
        r = np.where(np.isfinite(r), r, 0.0)
    info = {"clarabel_status": status, "clarabel_iterations": int(sol.iterations),
            "solve_time": float(sol.solve_time), "inner_tol": itol, "polish_iterations": 0}
    prov = map_status(status)
    polish = options.get("polish", "newton")
    if polish and formulation in ("associated", "frictionless") and status in USABLE:
        # interior-point iterates sit ~sqrt(gap) inside degenerate contacts: polish
        # (frictionless = Coulomb with mu = 0: the Newton method's local core;
        # associated: the natural-map Newton of socp_cd.solvers.polish), keep the
        # polished point only if its residual is lower
        from ..laws import LAW_RESIDUALS
        if polish != "newton":
            raise UnsupportedError(f"polish must be 'newton' or None for {formulation!r}")
        law_err = LAW_RESIDUALS[formulation]
        e0 = law_err(problem, r)
        if e0 > tol:
            target = problem.to_local() if problem.is_global else problem
            budget = options.get("polish_max_iter", 15)
            if formulation == "frictionless":
                target = target.with_(mu=np.zeros(problem.n_contacts))
                r_pol, pinfo = newton.newton_polish(target, r, tol, {"max_iter": budget})
                its = pinfo["iterations"]
            else:
                r_pol, its = natural_map_newton(target, r, tol=tol, max_iter=budget)
            info["polish_iterations"] = its
            if law_err(problem, r_pol) < e0:
                r = r_pol
                v = problem.global_velocity(r) if problem.is_global else None
    return SolverResult(r=r, v=v, status=prov, iterations=int(sol.iterations),
                        info=info, message=f"Clarabel: {status}")


_OUTER_KEYS = tuple(OUTER_DEFAULTS)


#: solver-specific options (name -> description)
OPTIONS = {
    "threshold": "Tresca thresholds (formulation 'tresca')",
    "inner_tol": "Clarabel tolerance of the single-SOCP formulations (default min(1e-10, tol/100))",
    "accel": "outer acceleration: 'anderson' (default) or None",
    "memory": "Anderson memory (default 5)",
    "adaptive_tol": "inner tolerance follows the outer error (default False)",
    "kappa": "adaptive inner tolerance factor (default 1e-2)",
    "inner_tol_max": "loosest adaptive inner tolerance (default 1e-4)",
    "inner_tol_min": "tightest inner tolerance (default min(1e-10, tol/100))",
    "polish": "'newton' (default), None or a callable polish(problem, r, tol, options)",
    "polish_max_iter": "Newton polish budget per call: outer proximal iterations (default 15)",
    "polish_switch": "error below which the polish is tried (default: per problem size)",
    "patience": "outer iterations without 10 % progress before 'stalled' (default 8)",
}


def clarabel_solve(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                   time_limit=None, verbose=False, inner_settings=None, **options):
    """Backend entry point (see the module docstring for options and statuses).

    ``inner_settings`` are Clarabel settings (its ``max_iter`` caps each
    interior-point solve); ``max_iter`` caps the outer iterations of the fixed
    point (default 100), or Clarabel's iterations for the single-SOCP laws.
    """
    check_unknown("clarabel", options, OPTIONS)
    inner_settings = dict(inner_settings or {})
    cap = inner_settings.pop("max_iter", None)
    native = dict(settings=inner_settings or None, time_limit=time_limit, verbose=verbose or None,
                  clarabel_max_iter=cap)
    options.update({k: v for k, v in native.items() if v is not None})
    condensed = False
    if problem.is_global and problem.n_dofs <= DENSE_CONDENSE_MAX:
        problem, condensed = condense_dense(problem), True
    if problem.is_global and not problem.is_symmetric:
        problem = problem.to_local()  # the SOCP needs a symmetric M; the local path handles skew W
    skew_assoc = formulation == "associated" and not problem.is_global and not problem.is_symmetric
    if formulation != "coulomb" and not skew_assoc:
        check_unknown("clarabel", options, {"settings", "time_limit", "verbose", "threshold",
                                            "inner_tol", "clarabel_max_iter", "polish",
                                            "polish_max_iter"})
        if max_iter is not None:  # one SOCP: max_iter caps Clarabel's interior-point iterations
            if options.get("clarabel_max_iter") is None:
                options["clarabel_max_iter"] = max_iter
        res = _single_socp(problem, formulation, tol, options)
        if condensed:
            res.info["condensed_dense"] = True
        return res
    # (time_limit stays in options too: each inner Clarabel solver gets it, below; until
    # session 25 it went to the outer loop only, and an inner solve ran unbounded: 3.6 s
    # under a 1e-4 s limit on a 7184-contact deposit)
    outer = {k: options.pop(k) for k in list(options) if k in _OUTER_KEYS and k != "time_limit"}
    if skew_assoc:  # asymmetric W: the skew part goes to an outer fixed point, no friction shift
        outer["law"] = "associated"
        options.pop("inner_tol", None)
    check_unknown("clarabel", options, {"settings", "time_limit", "verbose", "clarabel_max_iter"})
    if options.get("time_limit") is not None:
        outer.setdefault("time_limit", options["time_limit"])

    def factory(prob, W_sym):
        settings = options.get("settings")
        refine = False
        if not prob.is_global and prob.m <= DENSE_MAX:   # the compiled polish finishes the job
            refine = "iterative_refinement_enable" not in (settings or {})
            settings = {**SMALL_PROBLEM_SETTINGS, **(settings or {})}
        return ClarabelInner(prob, W_sym, settings=settings,
                             time_limit=options.get("time_limit"),
                             verbose=options.get("verbose", False),
                             clarabel_max_iter=options.get("clarabel_max_iter"),
                             refine_on_failure=refine)

    factory.accepts_dense = True   # ClarabelInner takes a dense W_sym for small problems
    max_iter = max_iter or 100
    outer["polish"] = newton.resolve_polish(outer.get("polish", "newton"))
    res = desaxce_fixed_point(problem, factory, tol=tol, max_iter=max_iter, r0=r0,
                              history=history, **outer)
    res.info["clarabel_status"] = res.info.get("inner_status")
    if condensed:
        res.info["condensed_dense"] = True
    return res


SPEC = SolverSpec(
    "clarabel", clarabel_solve, ("coulomb", "associated", "tresca", "frictionless"),
    global_native=("associated", "coulomb"),
    description="Clarabel interior point: SOCP relaxations; Coulomb by the De Saxcé fixed point",
    default_max_iter=100, options=OPTIONS,
    inner_settings="Clarabel settings (clarabel.DefaultSettings fields; max_iter caps each SOCP)",
    check=lambda problem, options, inner_settings: check_outer_options(
        {k: v for k, v in options.items() if k in OUTER_DEFAULTS}))


__all__ = ["SPEC", "OPTIONS", "clarabel_solve", "ClarabelInner", "clarabel_cones",
           "SMALL_PROBLEM_SETTINGS", "STATUS_MAP", "map_status", "make_settings",
           "DEFAULT_SETTINGS"]

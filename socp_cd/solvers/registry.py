"""One ``solve()`` in front of every solver (the dispatcher).

A solver is a :class:`~socp_cd.solvers.spec.SolverSpec` whose ``func(problem,
formulation, *, tol, max_iter, r0, history, time_limit, verbose,
inner_settings, **options) -> SolverResult`` fills ``r`` (and ``v``,
``iterations``, ``history``, ``info``, a provisional ``status``); :func:`solve`
checks every argument first (:mod:`socp_cd.solvers.options`), times the call,
recomputes ``u`` and the law's residual independently, and decides
``converged`` — a solver never does.  Every backend receives the local
problem in balanced units (:mod:`socp_cd.solvers.scaling`) and its ``r`` is
mapped back, so the answer does not depend on the units the problem was
written in; ``converged`` requires Siconos' error ``<= tol`` *and* the same
measure in balanced units (:func:`socp_cd.residuals.guard`) ``<= tol``.  Built-in solvers come from the explicit
table :mod:`socp_cd.solvers.table`; :func:`register` / :func:`unregister` add
and remove others (tests, plug-ins).
"""
from __future__ import annotations

import math
import time as _time

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from ..laws import LAW_RESIDUALS, check_threshold, law_parameters
from ..residuals import failed_guard, guard
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem
from .checks import coulomb_error, coulomb_guard, velocity, zero_error
from .options import COMMON_OPTIONS, check_common, check_unknown, tightened_tolerance
from .result import STATUSES, SolverResult
from .scaling import balance, balanced
from .spec import SolverSpec

FORMULATIONS = ("coulomb", "associated", "tresca", "frictionless", "faceted")
#: :func:`solve`'s plain call's names, bound once (a module attribute costs ~20 ns a look-up)
_INF, _perf_counter = math.inf, _time.perf_counter

_TABLE: dict = {}
_LOADED = [False]
#: ``(name, dim) -> spec`` of the loaded table's solvers with a compiled route for the exact
#: Coulomb law in that dimension (:func:`solve`'s plain call: one look-up instead of the
#: spec's four, 0.1 µs of a 5 µs call); empty until the table is loaded, kept with it
_ROUTED: dict = {}


def _table() -> dict:
    """Name -> spec: the built-in table (imported on first use) plus registered solvers."""
    if not _LOADED[0]:
        from .table import BUILTIN
        for spec in BUILTIN:
            _TABLE.setdefault(spec.name, spec)
        _LOADED[0] = True
        _routed_table()
    return _TABLE


def _routed_table() -> None:
    """Make :data:`_ROUTED` from :data:`_TABLE` (loaded)."""
    _ROUTED.clear()
    for spec in _TABLE.values():
        if spec.route is not None and "coulomb" in spec.formulations:
            for dim in spec.dims:
                _ROUTED[(spec.name, dim)] = spec


def register(name: str, formulations, *, global_native=(), dims=(2, 3), description="",
             default_max_iter=100, options=None, inner_settings="not used"):
    """Decorator registering a solver function under ``name`` (see :class:`SolverSpec`)."""

    def deco(func):
        _table()
        _TABLE[name] = SolverSpec(name, func, tuple(formulations), tuple(global_native),
                                  tuple(dims), description, int(default_max_iter),
                                  dict(options or {}), inner_settings)
        _routed_table()
        return func

    return deco


def unregister(name: str) -> None:
    """Remove a solver registered with :func:`register` (a built-in comes back from the table)."""
    _TABLE.pop(name, None)
    _ROUTED.clear()
    _LOADED[0] = False


def solver_spec(name: str):
    """The :class:`SolverSpec` registered under ``name``, or None."""
    return _table().get(name)


def solvers() -> dict:
    """Registered solvers, their formulations and options.

    Returns
    -------
    dict
        ``name -> {"formulations", "global_native", "dims", "description",
        "default_max_iter", "options" (solver-specific, name -> description),
        "common_options", "inner_settings"}``.
    """
    return {n: {"formulations": s.formulations, "global_native": s.global_native,
                "dims": s.dims, "description": s.description,
                "default_max_iter": s.default_max_iter, "options": dict(s.options),
                "common_options": dict(COMMON_OPTIONS), "inner_settings": s.inner_settings}
            for n, s in sorted(_table().items())}


def law_residual(problem, formulation, r, u=None, **params) -> float:
    """Relative residual of ``r`` for ``formulation`` (its law parameters in ``params``)."""
    return LAW_RESIDUALS[formulation](problem, r, u, **law_parameters(formulation, params))


def _finalize(problem, res: SolverResult, formulation: str, tol: float, params) -> SolverResult:
    """Recompute u and residuals and set honest ``converged``/``status``.

    ``converged`` needs the law's residual ``<= tol`` and the units guard
    (:func:`socp_cd.residuals.guard`, reported in ``info["guard"]``) ``<= tol``;
    ``trivial`` records whether ``r = 0`` already meets ``tol``.  The guard's unit
    factors are the problem's own, computed once (:func:`~socp_cd.solvers.scaling.balanced`).
    """
    r = np.asarray(res.r, dtype=np.float64).reshape(-1)
    res.tol = tol
    err0 = zero_error(problem)
    res.trivial = None if err0 is None else bool(err0 <= tol)
    if r.shape[0] != problem.m or not np.all(np.isfinite(r)):
        res.r = np.where(np.isfinite(r), r, 0.0) if r.shape[0] == problem.m else np.zeros(problem.m)
        res.u = problem.velocity(res.r)
        res.converged = False
        res.status = "numerical_error"
        res.error = res.coulomb_error = float("inf")
        res.info["guard"] = failed_guard()
        res.message = res.message or "backend returned non-finite or mis-sized impulses"
        return res
    res.r = r
    if problem.is_global:
        with np.errstate(all="ignore"):
            res.u = velocity(problem, r)
            if res.v is None:
                res.v = problem.global_velocity(r)
    else:
        res.u = velocity(problem, r)        # compiled: an overflow ends as inf, silently
    # compiled checks need a finite u (the references reject any other u)
    compiled = bool(np.isfinite(res.u).all())
    if compiled and formulation == "coulomb":   # compiled throughout: no NumPy error state
        judged = {"coulomb": coulomb_error(problem, r, res.u)}
    else:
        with np.errstate(all="ignore"):
            # the law's residual and Siconos' Coulomb error, each computed once
            judged = {name: (coulomb_error(problem, r, res.u) if compiled and name == "coulomb"
                             else law_residual(problem, name, r, res.u, **params))
                      for name in {formulation, "coulomb"}}
    res.coulomb_error, law = judged["coulomb"], judged[formulation]
    if not np.isfinite(res.coulomb_error):
        res.coulomb_error = float("inf")
    if not np.isfinite(law):      # overflow (e.g. r0 = 1e300): never report error = nan
        law = float("inf")
        res.status = "numerical_error"
        res.message = (res.message + "; " if res.message else "") + "non-finite residual"
    res.error = law
    if compiled and formulation == "coulomb":
        checked = coulomb_guard(problem, r, res.u)
    else:
        rec = balanced(problem)
        checked = guard(problem, r, res.u, (rec.a, rec.b), law=LAW_RESIDUALS[formulation],
                        **law_parameters(formulation, params))
    return _verdict(res, law, checked, tol)


def _verdict(res: SolverResult, law: float, checked: dict, tol: float) -> SolverResult:
    """Set ``converged`` and an honest ``status`` from the recomputed residual and guard.

    ``converged`` needs the law's residual ``law <= tol`` and the units guard
    ``checked["value"] <= tol``; a backend's claim that these refute becomes
    ``"stalled"`` with the reason in ``message``.
    """
    res.info["guard"] = checked
    res.converged = bool(law <= tol and checked["value"] <= tol)
    if res.converged:
        res.status = "converged"
    elif res.status == "converged" or (law <= tol and res.status != "numerical_error"):
        # the backend believed it had converged, the recomputed residual disagrees
        res.status = "stalled"
        why = (f"recomputed residual {law:.3e} > tol {tol:.1e}" if law > tol else
               f"error {law:.3e} <= tol but the units guard fails: balanced-units error "
               f"{checked['error']:.3e}, rounding floor of u {checked['rounding']:.1e} "
               f"(tol {tol:.1e})")
        res.message = (res.message + "; " if res.message else "") + "backend stopped, but " + why
    if res.status not in STATUSES:
        raise AssertionError(f"backend produced unknown status {res.status!r}")
    return res


def _run_backend(spec, target, scaling, formulation, tol, r0, time_limit, *, max_iter, history,
                 verbose, inner_settings, options) -> SolverResult:
    """Apply the scaling, run the backend, map ``r`` back (``scaling`` None: as is).

    ``r0`` and a Tresca ``threshold`` are given in the caller's units.
    """
    if scaling is None:
        return spec.func(target, formulation, tol=tol, max_iter=max_iter, r0=r0, history=history,
                         time_limit=time_limit, verbose=verbose, inner_settings=inner_settings,
                         **options)
    scaled_options = dict(options)
    if formulation == "tresca":
        scaled_options["threshold"] = scaling.threshold_to_scaled(options["threshold"])
    res = spec.func(scaling.problem(target), formulation, tol=tol, max_iter=max_iter,
                    r0=scaling.reaction_to_scaled(r0), history=history, time_limit=time_limit,
                    verbose=verbose, inner_settings=inner_settings, **scaled_options)
    res.r = scaling.reaction_from_scaled(res.r)
    res.info["scaling"] = scaling.describe()
    return res


def _counts(info) -> dict:
    """The integer entries of a backend's ``info`` (its counters, and integer settings such
    as NSGS's ``error_every``, which a sum over runs must leave out)."""
    return {k: int(v) for k, v in info.items()
            if isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))}


def _retry(first, problem, spec, target, scaling, formulation, tol, options, time_limit,
           t0, run) -> SolverResult:
    """One more backend run when it claimed convergence and the recomputed checks disagree.

    The backend met ``tol`` by its own test (in the balanced units it saw), not by
    the dispatcher's.  The tolerance is tightened by the gap between its measure
    (``guard["balanced_siconos"]``) and ours (errors near a solution are
    proportional), the run warm-started from its ``r`` unless that ``r`` is too
    large for ``u = W r + q`` to mean anything (then from ``r = 0``).  The retry is
    kept when it converged, or when it did not but its worse measure (the
    larger of the law's residual and the guard) is below the first answer's;
    otherwise the first answer (the backend's at the requested ``tol``) stays.
    Either way ``iterations`` counts both runs and ``info["retry"]`` records them; the
    backend's own counters in ``info`` (Newton steps, factorizations, ...) are the kept run's,
    and ``info["retry"]`` holds each run's (``first_counts``, ``retry_counts``: its integer
    ``info`` entries), so a study can add them (a 305-contact 2D problem's first Newton run made
    266 of its 272 steps, the kept retry 6).
    """
    checked = first.info["guard"]
    # the backend measures the balanced residual with Siconos' normalization; ask it for
    # that measure scaled down by how far ours exceed it
    worst = max(first.error, checked["value"])
    measured = min(checked.get("balanced_siconos", tol), tol)
    tighter = tightened_tolerance(tol, measured, worst)
    start = first.r if checked["rounding"] <= tol else np.zeros(problem.m)
    left = None if time_limit is None else time_limit - (_time.perf_counter() - t0)
    if left is not None and left <= 0:
        return first
    res = _run_backend(spec, target, scaling, formulation, tighter, start, left, **run)
    res.solver, res.formulation = first.solver, first.formulation
    res = _finalize(problem, res, formulation, tol, options)
    record = {"tol": tighter, "first_error": first.error, "first_guard": checked["value"],
              "first_iterations": first.iterations, "retry_error": res.error,
              "retry_iterations": res.iterations, "first_counts": _counts(first.info),
              "retry_counts": _counts(res.info)}
    def worse(x):
        return max(x.error, x.info["guard"]["value"])
    if res.converged or worse(res) < worse(first):
        res.iterations += first.iterations
        res.info["retry"] = dict(record, kept="retry")
        return res
    first.info["retry"] = dict(record, kept="first")
    first.iterations += res.iterations
    return first


def _routed(out, name, tol, time_limit, t0):
    """Judge a compiled route's outcome ``out = (result, guard_value, resume)`` (``SolverSpec.route``).

    Returns ``(result, None)`` when the result stands, ``(None, resume)``
    when the general path must run: its retry when the checks refute a claimed
    convergence (``resume`` is then that judged result: the route's answer is the
    general path's first one, which the general path does not compute again), or
    the backend from where the route stopped (``resume`` a dict: the backend
    goes on from there, whatever the checks say of that stage's answer, as
    it would on the general path).  The route filled ``u``, the residuals and the guard with
    the dispatcher's own kernels; the verdict is :func:`_verdict`'s, as on
    the general path (its test is made on ``guard_value`` first, so that a
    result that converged never builds a lazy ``info``).  ``SolverSpec.plain``
    (``auto.plain``) applies the converged branch's rule itself to measures
    clear of ``tol``: keep the two in step.
    """
    res, value, resume = out
    if resume is not None:
        # the route stopped where the backend goes on (auto's chain past a stage that missed
        # tol by its own judge): the backend's answer is the call's
        return None, resume
    claimed = res.status
    res.solver, res.formulation, res.tol = name, "coulomb", tol
    if res.error <= tol and value <= tol:       # _verdict's test: converged
        res.converged, res.status = True, "converged"
    else:
        _verdict(res, res.error, res.info["guard"], tol)
        if claimed == "converged":
            return None, res
    res.time = _time.perf_counter() - t0
    if not res.converged and time_limit is not None and res.time > time_limit:
        res.status = "time_limit"
    return res, None


def _check_problem(problem):
    if not isinstance(problem, (FrictionContactProblem, GlobalFrictionContactProblem)):
        hint = (" (read a file with socp_cd.read_problem(path) first)"
                if isinstance(problem, (str, bytes)) or hasattr(problem, "__fspath__") else "")
        raise InvalidProblemError(
            "problem", "solve() takes a FrictionContactProblem or GlobalFrictionContactProblem, "
                       f"got {type(problem).__name__}{hint}")


def _resolve(solver, table):
    """Spec of ``solver`` (a registered name or a callable solver function)."""
    if type(solver) is str:                 # a registered name: one lookup (every solve)
        spec = table.get(solver)
        if spec is not None:
            return spec
    if callable(solver) and not isinstance(solver, str):
        return SolverSpec(getattr(solver, "__name__", "callable"), solver, FORMULATIONS,
                          options={"*": "any keyword, passed through"})
    if not isinstance(solver, str) or solver not in table:
        raise UnsupportedError(f"unknown solver {solver!r}; available: {sorted(table)} "
                               "(or a callable)")
    return table[solver]


def _general(problem, spec, formulation, tol, max_iter, r0, history, time_limit, verbose,
             inner_settings, options, t0, resume, routed) -> SolverResult:
    """:func:`solve`'s general path, its arguments checked: balance, run the backend (from
    ``resume`` when a compiled route did the first part of the work), judge, retry.

    ``routed``: a route ran and its time counts (``t0`` is then its start); ``resume`` a
    :class:`SolverResult`: the route's judged answer, a claim the checks refuted (the
    backend's first run, done: only the retry follows, see :func:`_routed`).
    """
    target = problem
    if problem.is_global and formulation not in spec.global_native:
        target = problem.local        # condensed once per problem
    if not routed:
        t0 = _time.perf_counter()
    scaling = None if target.is_global else balance(target)
    run = dict(max_iter=max_iter, history=history, verbose=verbose,
               inner_settings=inner_settings, options=options)
    if resume.__class__ is SolverResult:
        res, claimed = resume, "converged"
        res.info.pop("route", None)   # (the general path's answer from here on)
    else:
        if resume is None:
            res = _run_backend(spec, target, scaling, formulation, tol, r0, time_limit, **run)
        else:   # the route did the first part of the work: the backend goes on from there
            left = None if time_limit is None else time_limit - (_time.perf_counter() - t0)
            res = _run_backend(spec, target, scaling, formulation, tol, r0, left,
                               **dict(run, options=dict(options, resume=resume)))
        claimed = res.status
        res.solver, res.formulation = spec.name, formulation
        res = _finalize(problem, res, formulation, tol, options)
    if claimed == "converged" and not res.converged and np.isfinite(res.error):
        res = _retry(res, problem, spec, target, scaling, formulation, tol, options,
                     time_limit, t0, run)
    res.time = _time.perf_counter() - t0
    if target is not problem:
        res.info["condensed_to_local"] = True
    return res


def _plain(problem, spec, tol, max_iter, r0, time_limit):
    """:func:`solve` of a plain call (see there) on a local problem, exact Coulomb law, a
    registered solver with a compiled ``route`` that takes this problem, common options
    only, ``verbose`` False (the general checks of these arguments, in the same order)."""
    if not (type(tol) is float and 0.0 < tol < math.inf and max_iter is None
            and (time_limit is None or type(time_limit) is float and 0.0 < time_limit < math.inf)):
        tol, max_iter, time_limit, _, _ = check_common(tol, max_iter, time_limit, False, None)
    if spec.check is not None:
        spec.check(problem, {}, {})
    if r0 is not None:
        r0 = problem.check_reaction(r0, "r0")
    t0 = _time.perf_counter()
    res, resume, routed = _try_route(problem, spec, tol, max_iter, r0, time_limit, t0)
    if res is not None:
        return res
    return _general(problem, spec, "coulomb", tol, max_iter, r0, False, time_limit, False, {}, {},
                    t0, resume, routed)


def _plain_rest(problem, spec, out, tol, time_limit, t0):
    """:func:`_plain` with ``max_iter`` and ``r0`` None and ``tol``, ``time_limit`` checked,
    after ``spec.plain`` (``SolverSpec.plain``, called by :func:`solve` at ``t0``) returned
    ``out``, the route's outcome for :func:`_routed`, not a finished result."""
    res, resume, routed = _judged(out, spec.name, tol, time_limit, t0)
    if res is not None:
        return res
    return _general(problem, spec, "coulomb", tol, None, None, False, time_limit, False, {}, {},
                    t0, resume, routed)


def _try_route(problem, spec, tol, max_iter, r0, time_limit, t0):
    """Run ``spec``'s compiled route: ``(result, None, True)`` when its result stands,
    else ``(None, resume, routed)`` for :func:`_general` (``routed``: the route ran and its
    time counts; ``resume``: where it stopped, see :func:`_routed`)."""
    out = spec.route(problem, tol=tol, max_iter=max_iter, r0=r0, time_limit=time_limit)
    return _judged(out, spec.name, tol, time_limit, t0)


def _judged(out, name, tol, time_limit, t0):
    """A route's outcome ``out`` (None: it did not apply) as :func:`_try_route` returns it:
    ``(result, None, True)`` when its result stands (:func:`_routed`), else ``(None,
    resume, routed)``."""
    if out is None:
        return None, None, False
    res, resume = _routed(out, name, tol, time_limit, t0)
    return res, resume, True


def solve(problem, solver="auto", formulation: str = "coulomb", *, tol: float = 1e-8,
          max_iter: int | None = None, r0=None, history: bool = False, crosscheck: str | None = None,
          time_limit: float | None = None, verbose: bool = False, inner_settings: dict | None = None,
          **options) -> SolverResult:
    """Solve a frictional contact problem.

    Every argument is checked before any work (:mod:`socp_cd.solvers.options`).

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    solver : str or callable
        ``"auto"`` (default: a portfolio of the methods below, see
        :mod:`socp_cd.solvers.auto`), ``"newton"``, ``"nsgs"``, ``"clarabel"``,
        ``"cvxpy"``, ``"proxsuite"``, ``"projection"``, ``"lemke"`` (see :func:`solvers`), or a
        solver function with the signature of
        :class:`~socp_cd.solvers.spec.SolverSpec` ``func``.
    formulation : str
        Contact law: ``"coulomb"`` (exact, default), ``"associated"``,
        ``"tresca"`` (needs ``threshold=``), ``"frictionless"``, ``"faceted"``.
    tol : float
        Tolerance on the recomputed residual of the law (Siconos' relative
        error for ``"coulomb"``).
    max_iter : int, optional
        Iteration cap (the solver's ``default_max_iter`` when None).
    r0 : array_like, optional
        Initial guess (warm start) for solvers that use one.
    history : bool
        Record the error per iteration when the solver supports it (measured
        by the backend on the balanced problem it was given, see Notes).
    crosscheck : str, optional
        Name of a reference solver (``"nsgs"``) run on the same problem; the
        relative discrepancy in ``u`` is stored in ``result.info["crosscheck"]``
        (``u``, not ``r``: with redundant contacts ``r`` is not unique).
    time_limit : float, optional
        Seconds.
    verbose : bool
        Native solver printout.
    inner_settings : dict, optional
        Passed through to the native solver (see ``solvers()[name]["inner_settings"]``).
    **options
        Solver-specific options (``solvers()[name]["options"]``).

    Returns
    -------
    SolverResult

    Notes
    -----
    Units: the backend solves the local problem in balanced units
    (:mod:`socp_cd.solvers.scaling`; a global problem solved natively is
    passed as is) and ``r`` is mapped back, so the same problem written in
    other units (``q`` or ``W, q`` times any factor, contacts rescaled one
    by one) gets the same answer.  ``converged`` needs Siconos' error
    ``<= tol`` and the units guard ``info["guard"]["value"] <= tol``
    (:func:`socp_cd.residuals.guard`: the law's residual in balanced units
    relative to the velocity scale, and ``u`` computable to ``tol`` from
    ``r``).  When the backend claims convergence and ``solve`` refuses it,
    the backend is run once more with a tolerance tightened by the gap; the
    retry is kept when it converges or fails by less than the first answer
    (the larger of its residual and guard; ``info["retry"]``).
    ``result.trivial`` says whether ``r = 0`` already met ``tol``.

    Raises
    ------
    InvalidProblemError
        ``problem`` is not a problem object, or a bad argument value.
    UnsupportedError
        Unknown solver or option, or a formulation/dimension the solver cannot do.
    """
    if (type(problem) is FrictionContactProblem and formulation == "coulomb" and not options
            and not history and crosscheck is None and verbose is False and inner_settings is None
            and type(solver) is str):
        # the plain call of a compiled route: the same checks as below, in fewer steps
        spec = _ROUTED.get((solver, problem.dim))      # (empty until the table is loaded)
        if spec is not None:
            plain = spec.plain
            if (plain is not None and r0 is None and max_iter is None
                    and type(tol) is float and 0.0 < tol < _INF
                    and (time_limit is None or type(time_limit) is float
                         and 0.0 < time_limit < _INF)):
                # (spec.plain here, not in a helper: a small problem's whole call is a few µs)
                t0 = _perf_counter()
                out = plain(problem, tol, time_limit, t0)
                if out.__class__ is SolverResult:
                    return out
                return _plain_rest(problem, spec, out, tol, time_limit, t0)
            return _plain(problem, spec, tol, max_iter, r0, time_limit)
    _check_problem(problem)
    table = _table()
    spec = _resolve(solver, table)
    name = spec.name
    if formulation not in FORMULATIONS:
        raise UnsupportedError(f"unknown formulation {formulation!r}; available: {FORMULATIONS}")
    if formulation not in spec.formulations:
        raise UnsupportedError(
            f"solver {name!r} cannot solve formulation {formulation!r} "
            f"(it supports {spec.formulations})")
    if problem.dim not in spec.dims:
        raise UnsupportedError(f"solver {name!r} does not support dim = {problem.dim}")
    if options and "*" not in spec.options:
        check_unknown(name, options, spec.options)
    tol, max_iter, time_limit, verbose, inner_settings = check_common(
        tol, max_iter, time_limit, verbose, inner_settings)
    if spec.check is not None:
        spec.check(problem, options, inner_settings)
    if crosscheck is not None:
        cspec = _resolve(crosscheck, table)
        if formulation not in cspec.formulations or problem.dim not in cspec.dims:
            raise UnsupportedError(f"crosscheck solver {cspec.name!r} cannot solve "
                                   f"{formulation!r} in dim {problem.dim}")
    if r0 is not None:
        r0 = problem.check_reaction(r0, "r0")
    if formulation == "tresca":
        options["threshold"] = check_threshold(problem, options.get("threshold"))
    resume, routed, t0 = None, False, _time.perf_counter()
    if (spec.route is not None and formulation == "coulomb" and not problem.is_global
            and not (options or history or verbose or inner_settings) and crosscheck is None):
        res, resume, routed = _try_route(problem, spec, tol, max_iter, r0, time_limit, t0)
        if res is not None:
            return res
    res = _general(problem, spec, formulation, tol, max_iter, r0, history, time_limit, verbose,
                   inner_settings, options, t0, resume, routed)
    if crosscheck is not None:
        ref = solve(problem, solver=crosscheck, formulation=formulation, tol=tol,
                    **law_parameters(formulation, options))
        den = max(float(np.linalg.norm(ref.u)), np.finfo(float).tiny)
        res.info["crosscheck"] = {
            "solver": cspec.name,
            "status": ref.status,
            "error": ref.error,
            "u_discrepancy": float(np.linalg.norm(res.u - ref.u)) / den,
        }
    return res


__all__ = ["solve", "solvers", "solver_spec", "register", "unregister", "law_residual", "FORMULATIONS",
           "SolverSpec"]

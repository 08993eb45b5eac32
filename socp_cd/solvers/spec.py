"""What a solver is to the dispatcher: a :class:`SolverSpec` (no import of the dispatcher).

Each backend module defines its ``SPEC``; :mod:`socp_cd.solvers.table` lists
them; :mod:`socp_cd.solvers.registry` dispatches on them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable


@dataclass(frozen=True)
class SolverSpec:
    """A registered solver.

    Attributes
    ----------
    name : str
    func : callable
        ``func(problem, formulation, *, tol, max_iter, r0, history, time_limit,
        verbose, inner_settings, **options) -> SolverResult``; ``max_iter`` is
        None when the caller gave none (the solver then applies
        ``default_max_iter``); every option is already checked.
    formulations : tuple of str
    global_native : tuple of str
        Formulations solved on the global form directly (others are condensed).
    dims : tuple of int
    description : str
    default_max_iter : int
        ``max_iter`` when the caller gives none (what one iteration is depends
        on the solver: a sweep for NSGS, an outer SOCP for the fixed point).
    options : dict
        Solver-specific options: ``name -> one-line description (with default)``.
    inner_settings : str
        What ``inner_settings=`` is passed to (the native solver's settings).
    check : callable, optional
        ``check(problem, options, inner_settings)`` raising on a bad option
        value; :func:`socp_cd.solve` calls it before any work (e.g. before
        condensing a global problem).
    route : callable, optional
        A compiled route for *plain* calls (a local problem, the exact Coulomb
        law, no solver options, ``inner_settings``, ``history``, ``verbose``
        or ``crosscheck``): ``route(problem, *, tol, max_iter, r0,
        time_limit) -> (SolverResult, guard_value, None)``, ``(None, None,
        resume)`` or None, the
        whole call in compiled code for problems whose Python overhead
        would dominate (e.g. :func:`socp_cd.solvers.nsgs.route`).  Its
        result carries what the dispatcher's checks would compute (``u``,
        ``error``, ``coulomb_error``, ``trivial``, ``info["guard"]``, by the
        same kernels; ``guard_value`` is ``info["guard"]["value"]``, so that
        a lazily built ``info`` need not be built to judge it);
        :func:`socp_cd.solve` then decides ``converged`` as for any
        backend.  None: the route does not apply, take the general path.
        ``resume`` is passed to ``func`` as ``resume=`` (the route did the
        first part of the work and the backend goes on from there; see
        :mod:`socp_cd.solvers.auto`).
    plain : callable, optional
        The whole of a plain call with ``max_iter`` and ``r0`` None and a float
        ``tol`` (and ``time_limit``, when given), for ``route`` solvers whose
        most common call is tiny: ``plain(problem, tol, time_limit, t0)`` returns
        a finished :class:`~socp_cd.solvers.result.SolverResult` (judged as the
        dispatcher would judge the route's: ``converged``, ``solver``,
        ``formulation``, ``tol``, ``time`` since ``t0``), or what ``route``
        returns (the dispatcher judges it).  It replaces ``route`` and
        ``check`` for these calls (no options or ``inner_settings`` to check:
        a ``check`` that reads the problem must be repeated in ``plain``);
        each layer of Python it saves is a few percent of a one-contact call
        (:func:`socp_cd.solvers.auto.plain`).
    """

    name: str
    func: Callable
    formulations: tuple
    global_native: tuple = ()
    dims: tuple = (2, 3)
    description: str = ""
    default_max_iter: int = 100
    options: dict = field(default_factory=dict)
    inner_settings: str = "not used"
    check: Callable | None = None
    route: Callable | None = None
    plain: Callable | None = None


__all__ = ["SolverSpec"]

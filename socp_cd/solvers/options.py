"""The one options contract of :func:`socp_cd.solve`, checked before any work.

Every solver accepts the common options (:data:`COMMON_OPTIONS`):

``tol`` (float > 0, default 1e-8)
    Target on the recomputed residual of the law.
``max_iter`` (int >= 1, default: the solver's ``default_max_iter``)
    Iteration cap (NSGS: sweeps; fixed points: outer iterations; single cone
    programs: interior-point iterations).
``time_limit`` (seconds > 0, default None)
``verbose`` (bool, default False)
``r0`` (array of length m, default None): warm start.
``inner_settings`` (dict, default None)
    Passed through to the native solver (Clarabel settings, cvxpy's solver
    options, ProxQP settings, NSGS's local solver); see ``socp_cd.solvers()``.

Solver-specific options are declared in each solver's
:class:`~socp_cd.solvers.spec.SolverSpec`; anything else raises
:class:`~socp_cd.errors.UnsupportedError` naming the valid options.
Bad values raise :class:`~socp_cd.errors.InvalidProblemError` naming the argument.
"""
from __future__ import annotations

import math
import numbers

from ..errors import InvalidProblemError, UnsupportedError

#: option -> description, accepted by every solver
COMMON_OPTIONS = {
    "tol": "target on the recomputed residual of the law (default 1e-8)",
    "max_iter": "iteration cap (default per solver)",
    "time_limit": "seconds (default None: no limit)",
    "verbose": "print the native solver's progress (default False)",
    "r0": "initial guess / warm start (default None)",
    "inner_settings": "dict passed to the native solver (default None)",
}

#: arguments of solve() itself (not passed to the solver)
SOLVE_ARGUMENTS = ("problem", "solver", "formulation", "history", "crosscheck")


def inner_tolerance(tol: float) -> float:
    """Tolerance of an inner conic solve for an outer target ``tol``: ``min(1e-10, tol/100)``.

    The one inner-tolerance policy of the conic backends (fixed-point inner
    SOCPs and single cone programs alike).
    """
    return min(1e-10, tol * 1e-2)


def tightened_tolerance(tol: float, measured: float, worst: float) -> float:
    """Tolerance for another run after an answer met ``tol`` by a solver's own measure only.

    ``measured``: the solver's measure of that answer (Siconos' error in the
    balanced units it saw, at most ``tol``); ``worst``: the larger of the
    dispatcher's checks (the recomputed error and the units guard).  Errors
    near a solution are proportional, so the solver is asked for its measure
    scaled down by how far the checks exceed it, with a factor 2 of margin:
    ``max(0.5 tol measured / worst, 1e-3 tol)`` (``tol`` when ``worst`` is 0).
    The one policy of the dispatcher's retry and of ``auto``'s later stages.
    """
    return max(0.5 * tol * measured / worst, 1e-3 * tol) if worst > 0 else tol


def check_real(name, value, *, positive=False, minimum=None, maximum=None,
               open_interval=False) -> float:
    """``value`` as a finite float, or :class:`InvalidProblemError` naming ``name``."""
    if type(value) is float and math.isfinite(value) and not (positive or minimum is not None
                                                             or maximum is not None):
        return value                                    # fast path (every solve passes tol)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InvalidProblemError(name, f"must be a real number, got {value!r} "
                                        f"({type(value).__name__})")
    v = float(value)
    if not math.isfinite(v):
        raise InvalidProblemError(name, f"must be finite, got {value!r}")
    if positive and not v > 0:
        raise InvalidProblemError(name, f"must be > 0, got {value!r}")
    if minimum is not None and (v < minimum or (open_interval and v == minimum)):
        raise InvalidProblemError(name, f"must be {'>' if open_interval else '>='} {minimum}, "
                                        f"got {value!r}")
    if maximum is not None and (v > maximum or (open_interval and v == maximum)):
        raise InvalidProblemError(name, f"must be {'<' if open_interval else '<='} {maximum}, "
                                        f"got {value!r}")
    return v


def check_int(name, value, *, minimum=None, maximum=None) -> int:
    """``value`` as an int (no bool, no str, no non-integral float) or ``InvalidProblemError``."""
    if (type(value) is int and (minimum is None or value >= minimum)
            and (maximum is None or value <= maximum)):
        return value                                    # fast path
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if isinstance(value, numbers.Real) and not isinstance(value, bool) \
                and math.isfinite(float(value)) and float(value).is_integer():
            value = int(value)
        else:
            raise InvalidProblemError(name, f"must be an integer, got {value!r} "
                                            f"({type(value).__name__})")
    v = int(value)
    if minimum is not None and v < minimum:
        raise InvalidProblemError(name, f"must be >= {minimum}, got {v}")
    if maximum is not None and v > maximum:
        raise InvalidProblemError(name, f"must be <= {maximum}, got {v}")
    return v


def check_choice(name, value, choices):
    """``value`` if it is one of ``choices`` (strings), else ``InvalidProblemError``.

    Only a ``str`` qualifies: a 0-d NumPy string array compares equal to a choice and then
    fails as a dictionary key deep in a backend."""
    if not isinstance(value, str) or value not in choices:
        raise InvalidProblemError(name, f"must be one of {sorted(choices)}, got {value!r}")
    return value


#: largest ``max_iter`` (the compiled loops count iterations in int64; 2**62 iterations are
#: beyond any run's reach)
MAX_ITER = 2 ** 62


def check_common(tol, max_iter, time_limit, verbose, inner_settings):
    """Validated common options; returns ``(tol, max_iter, time_limit, verbose, inner_settings)``."""
    if tol is None:
        raise InvalidProblemError("tol", "must be a positive finite number, got None")
    if not (type(tol) is float and 0.0 < tol < math.inf):   # fast path: a positive float
        tol = check_real("tol", tol, positive=True)
    # None stays None: the solver applies its documented default (SolverSpec.default_max_iter)
    max_iter = None if max_iter is None else check_int("max_iter", max_iter, minimum=1,
                                                       maximum=MAX_ITER)
    if time_limit is not None and not (type(time_limit) is float and 0.0 < time_limit < math.inf):
        time_limit = check_real("time_limit", time_limit, positive=True)
    if type(verbose) is not bool:
        if not isinstance(verbose, numbers.Integral):
            raise InvalidProblemError("verbose", f"must be a bool, got {verbose!r}")
        verbose = bool(verbose)
    if inner_settings is None:
        return tol, max_iter, time_limit, verbose, {}
    if not isinstance(inner_settings, dict):
        raise InvalidProblemError("inner_settings", f"must be a dict, got "
                                                    f"{type(inner_settings).__name__}")
    return tol, max_iter, time_limit, verbose, dict(inner_settings)


def check_unknown(solver_name, options, declared):
    """Raise :class:`UnsupportedError` when ``options`` holds a name not in ``declared``."""
    if not options:
        return
    unknown = set(options) - set(declared)
    if unknown:
        valid = sorted(set(COMMON_OPTIONS) | set(declared))
        raise UnsupportedError(f"solver {solver_name!r}: unknown option(s) {sorted(unknown)}; "
                               f"valid options: {valid}")


__all__ = ["inner_tolerance", "tightened_tolerance", "COMMON_OPTIONS", "SOLVE_ARGUMENTS", "check_common", "MAX_ITER", "check_unknown", "check_real",
           "check_int", "check_choice"]

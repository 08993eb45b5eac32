"""The result object shared by every solver."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

#: Honest outcomes of a solve. ``converged`` is set only by :func:`socp_cd.solve`
#: after recomputing the residual independently of the backend.
STATUSES = ("converged", "max_iter", "stalled", "numerical_error", "time_limit")


_new_object = object.__new__


class LazyInfo(tuple):
    """``(build, *args)``: a result's ``info`` dict to be built as ``build(*args)`` on first access.

    A compiled route (:mod:`socp_cd.solvers.nsgs_route`) returns the numbers
    ``info`` is made of in a tuple; assembling the nested dicts costs about a
    microsecond, a sixth of a one-contact call, and most callers never read
    them.  :attr:`SolverResult.info` builds the dict the first time it is
    read (the same dict, whenever that is); copying or pickling a result
    builds it first.
    """

    __slots__ = ()


@dataclass
class SolverResult:
    """Outcome of :func:`socp_cd.solve`.

    Attributes
    ----------
    r, u : ndarray
        Contact impulses and local velocities (``u`` recomputed from ``r``).
    v : ndarray or None
        Global velocities, for global problems.
    converged : bool
        True only when the independently recomputed residual ``error`` of the
        law solved is ``<= tol``.
    status : str
        One of :data:`STATUSES`.
    error : float
        Residual of the law solved (for ``formulation="coulomb"`` this is
        Siconos' relative error, :func:`socp_cd.error`).
    coulomb_error : float
        Siconos' relative error of ``r`` for the Coulomb law, whatever the
        formulation (so relaxations can be judged against the exact law).
    iterations : int
        Backend iterations (sweeps for NSGS, outer iterations for fixed points).
    time : float
        Wall-clock seconds spent in the backend (model building included).
    solver, formulation : str
    tol : float
    history : list of float or None
        Error per iteration when requested with ``history=True``.
    info : dict
        Backend-specific statistics (inner iterations, backend status string,
        cross-check discrepancy, ...), and from :func:`socp_cd.solve`:
        ``info["guard"]`` (the units guard, :func:`socp_cd.residuals.guard`:
        Siconos' measure in balanced units, its feasibility and
        complementarity parts, the rounding floor of ``u``; ``converged``
        needs its ``"value" <= tol``) and
        ``info["scaling"]`` (the balancing applied before the backend ran).
        (Stored as given; a :class:`LazyInfo` given instead is built into
        the dict on first access.)
    trivial : bool or None
        True when ``r = 0`` already meets ``tol`` (``problem.trivial_error()
        <= tol``, e.g. ``||q||`` about 1e-18): such a "convergence" is no win
        for a study.  None when it could not be computed.
    message : str
        Human-readable explanation of the status.
    """

    r: np.ndarray
    u: Optional[np.ndarray] = None
    v: Optional[np.ndarray] = None
    converged: bool = False
    status: str = "max_iter"
    error: float = float("inf")
    coulomb_error: float = float("inf")
    iterations: int = 0
    time: float = 0.0
    solver: str = ""
    formulation: str = ""
    tol: float = 0.0
    history: Optional[list] = None
    info: dict = field(default_factory=dict)
    message: str = ""
    trivial: Optional[bool] = None

    @classmethod
    def of_local(cls, r, u, status, error, iterations, info, message, trivial, converged=False,
                 solver="", formulation="", tol=0.0, time=0.0):
        """A local problem's result with ``coulomb_error = error`` (compiled routes; the
        last five fields as the dispatcher sets them when the route judged it itself,
        ``SolverSpec.plain``).

        The fields set one by one, in the dataclass's order, on a bare instance: the
        generated ``__init__`` (its call, and ``info`` through the property's setter)
        cost 0.44 µs of a one-contact call, this 0.19.  ``info`` may be a
        :class:`LazyInfo` (built on first access).  ``tests/test_route.py`` holds the
        result equal to the constructor's, field by field and in order.
        """
        res = _new_object(cls)
        res.r = r
        res.u = u
        res.v = None
        res.converged = converged
        res.status = status
        res.error = error
        res.coulomb_error = error
        res.iterations = iterations
        res.time = time
        res.solver = solver
        res.formulation = formulation
        res.tol = tol
        res.history = None
        res._info = info            # (the storage of the property ``info``)
        res.message = message
        res.trivial = trivial
        return res

    def __repr__(self) -> str:
        return (f"SolverResult(solver={self.solver!r}, formulation={self.formulation!r}, "
                f"status={self.status!r}, error={self.error:.3e}, iterations={self.iterations}, "
                f"time={self.time:.4g}s)")

    def summary(self) -> dict[str, Any]:
        """Flat record of the scalar fields (for tables)."""
        return {
            "solver": self.solver,
            "formulation": self.formulation,
            "status": self.status,
            "converged": self.converged,
            "error": self.error,
            "coulomb_error": self.coulomb_error,
            "iterations": self.iterations,
            "time": self.time,
            "tol": self.tol,
            "guard": self.info.get("guard", {}).get("value", float("nan")),
            f"trivial@{self.tol:g}": self.trivial,
        }


def _getstate(self) -> dict:
    # a copy or a pickle carries the built dict (shared by a shallow copy, as any field
    # is), never a reference to the route's private builder
    _get_info(self)
    return self.__dict__


def _get_info(self) -> dict:
    info = self._info
    if type(info) is LazyInfo:
        info = self._info = info[0](*info[1:])
    return info


def _set_info(self, value) -> None:
    self._info = value


# ``info`` as a property over ``_info`` (set after the dataclass is made, so that its
# generated ``__init__``, ``__eq__``, ``fields`` and ``replace`` keep the field ``info``
# and go through the property): a LazyInfo is built on first read.
SolverResult.info = property(_get_info, _set_info,
                             doc="Backend-specific statistics (see the class docstring).")
SolverResult.__getstate__ = _getstate


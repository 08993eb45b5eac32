"""One ``solve()`` in front of every backend.

A backend is a function ``backend(problem, formulation, *, tol, max_iter, r0,
history, **options) -> SolverResult`` registered with :func:`register`.  It fills
``r`` (and ``v``, ``iterations``, ``history``, ``info``, a provisional
``status``); :func:`solve` then times it, recomputes ``u`` and the residuals
independently, and decides ``converged`` — a backend never does.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from ..laws import LAW_RESIDUALS
from ..residuals import error as coulomb_error
from .result import STATUSES, SolverResult

FORMULATIONS = ("coulomb", "associated", "tresca", "frictionless", "faceted")


@dataclass(frozen=True)
class SolverSpec:
    """What a registered backend can do."""

    name: str
    func: Callable
    formulations: tuple
    global_native: tuple = ()   #: formulations solved on the global form directly
    dims: tuple = (2, 3)
    description: str = ""


_REGISTRY: dict[str, SolverSpec] = {}


def register(name: str, formulations, *, global_native=(), dims=(2, 3), description=""):
    """Decorator registering a backend under ``name``."""

    def deco(func):
        _REGISTRY[name] = SolverSpec(name, func, tuple(formulations), tuple(global_native),
                                     tuple(dims), description)
        return func

    return deco


def _load_backends() -> None:
    """Import the backend modules (they register themselves)."""
    from . import _backends  # noqa: F401


def solvers() -> dict:
    """Registered solvers and the formulations each supports.

    Returns
    -------
    dict
        ``name -> {"formulations": (...), "global_native": (...), "dims": (...),
        "description": str}``.
    """
    _load_backends()
    return {n: {"formulations": s.formulations, "global_native": s.global_native,
                "dims": s.dims, "description": s.description} for n, s in sorted(_REGISTRY.items())}


def law_residual(problem, formulation, r, u=None, **params) -> float:
    """Residual of ``r`` for ``formulation`` (``faceted`` is judged by the backend)."""
    if formulation == "tresca":
        return LAW_RESIDUALS["tresca"](problem, r, u, threshold=params.get("threshold"))
    return LAW_RESIDUALS[formulation](problem, r, u)


def _finalize(problem, res: SolverResult, formulation: str, tol: float, params) -> SolverResult:
    """Recompute u and residuals and set honest ``converged``/``status``."""
    r = np.asarray(res.r, dtype=np.float64).reshape(-1)
    res.tol = tol
    if r.shape[0] != problem.m or not np.all(np.isfinite(r)):
        res.r = np.where(np.isfinite(r), r, 0.0) if r.shape[0] == problem.m else np.zeros(problem.m)
        res.u = problem.velocity(res.r)
        res.converged = False
        res.status = "numerical_error"
        res.error = res.coulomb_error = float("inf")
        res.message = res.message or "backend returned non-finite or mis-sized impulses"
        return res
    res.r = r
    res.u = problem.velocity(r)
    if problem.is_global and res.v is None:
        res.v = problem.global_velocity(r)
    res.coulomb_error = coulomb_error(problem, r, res.u)
    if formulation == "faceted":
        law = float(res.info.get("law_residual", np.inf))
    elif formulation == "coulomb":
        law = res.coulomb_error          # the law's residual is Siconos' error itself
    else:
        law = law_residual(problem, formulation, r, res.u, **params)
    res.error = law
    res.converged = bool(law <= tol)
    if res.converged:
        res.status = "converged"
    elif res.status == "converged":
        # the backend believed it had converged, the recomputed residual disagrees
        res.status = "stalled"
        res.message = (res.message + "; " if res.message else "") + (
            f"backend stopped, but recomputed residual {law:.3e} > tol {tol:.1e}")
    if res.status not in STATUSES:
        raise AssertionError(f"backend produced unknown status {res.status!r}")
    return res


def solve(problem, solver: str = "nsgs", formulation: str = "coulomb", *, tol: float = 1e-8,
          max_iter: int | None = None, r0=None, history: bool = False, crosscheck: str | None = None,
          **options) -> SolverResult:
    """Solve a frictional contact problem.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    solver : str
        Backend: ``"nsgs"``, ``"clarabel"``, ``"cvxpy"``, ``"proxsuite"``
        (see :func:`solvers`).
    formulation : str
        Contact law: ``"coulomb"`` (exact, default), ``"associated"``,
        ``"tresca"`` (needs ``threshold=``), ``"frictionless"``, ``"faceted"``.
    tol : float
        Tolerance on the recomputed residual of the law (Siconos' relative
        error for ``"coulomb"``).
    max_iter : int, optional
        Backend iteration cap (backend default when None).
    r0 : array_like, optional
        Initial guess (warm start) for backends that use one.
    history : bool
        Record the error per iteration when the backend supports it.
    crosscheck : str, optional
        Name of a reference solver (``"nsgs"``) run on the same problem; the
        relative discrepancy in ``u`` is stored in ``result.info["crosscheck"]``
        (``u``, not ``r``: with redundant contacts ``r`` is not unique).
    **options
        Backend options (see each backend's docstring).

    Returns
    -------
    SolverResult

    Raises
    ------
    UnsupportedError
        Unknown solver, or a formulation/dimension the backend cannot do.
    """
    _load_backends()
    if solver not in _REGISTRY:
        raise UnsupportedError(f"unknown solver {solver!r}; available: {sorted(_REGISTRY)}")
    spec = _REGISTRY[solver]
    if formulation not in FORMULATIONS:
        raise UnsupportedError(f"unknown formulation {formulation!r}; available: {FORMULATIONS}")
    if formulation not in spec.formulations:
        raise UnsupportedError(
            f"solver {solver!r} cannot solve formulation {formulation!r} "
            f"(it supports {spec.formulations})")
    if problem.dim not in spec.dims:
        raise UnsupportedError(f"solver {solver!r} does not support dim = {problem.dim}")
    if not (np.isfinite(tol) and tol > 0):
        raise InvalidProblemError("tol", f"must be a positive finite number, got {tol!r}")
    if max_iter is not None and int(max_iter) < 1:
        raise InvalidProblemError("max_iter", f"must be >= 1, got {max_iter!r}")
    if r0 is not None:
        r0 = problem.check_reaction(r0, "r0")
    if formulation == "tresca":
        from ..laws import check_threshold
        options["threshold"] = check_threshold(problem, options.get("threshold"))
    target = problem
    if problem.is_global and formulation not in spec.global_native:
        target = problem.to_local()
    t0 = _time.perf_counter()
    res = spec.func(target, formulation, tol=tol, max_iter=max_iter, r0=r0, history=history,
                    **options)
    res.time = _time.perf_counter() - t0
    res.solver, res.formulation = solver, formulation
    if target is not problem:
        res.info["condensed_to_local"] = True
    res = _finalize(problem, res, formulation, tol, options)
    if crosscheck is not None:
        ref = solve(problem, solver=crosscheck, formulation=formulation, tol=tol,
                    **({"threshold": options["threshold"]} if formulation == "tresca" else {}))
        den = max(float(np.linalg.norm(ref.u)), np.finfo(float).tiny)
        res.info["crosscheck"] = {
            "solver": crosscheck,
            "status": ref.status,
            "error": ref.error,
            "u_discrepancy": float(np.linalg.norm(res.u - ref.u)) / den,
        }
    return res


__all__ = ["solve", "solvers", "register", "law_residual", "FORMULATIONS", "SolverSpec"]

"""What a campaign runs: solver choices, tasks, tolerances, and the record of one run.

A task is (problem reference, solver choice, tolerance, time limit); its
record (:mod:`socp_cd.bench.records`) always carries Siconos' relative error
recomputed here from the returned ``r`` by :func:`socp_cd.error`, whoever the
solver is, and ``success`` means ``error <= tol``.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import datetime, timezone

import numpy as np

from ..errors import UnsupportedError
from ..residuals import error as siconos_error
from ..solvers import solvers as registered_solvers
from .problem_refs import ProblemRef
from .records import new_record, settings_string
from .siconos_peer import SOLVERS as SICONOS_FAMILIES
from .siconos_peer import siconos_available

#: Tolerance presets of ``--preset``.
PRESETS = {"low": 1e-4, "mid": 1e-6, "high": 1e-8}
SWEEP = tuple(10.0 ** -k for k in range(2, 11))
#: Tolerances of ``--preset all``: every other decade of the sweep (contains the presets).
ALL = tuple(10.0 ** -k for k in range(2, 11, 2))
#: Prefix of Siconos peer solvers in solver specs and records.
SICONOS_PREFIX = "siconos:"
#: Siconos solvers the default campaign leaves out: NSGSV is unfinished in Siconos 4.4 (its
#: default local solver is rejected by its own initialization; with the accepted one it
#: dereferences a null local problem), it crashes on every problem
#: (``validation/newton_vs_siconos.py`` still runs it, and shows that).
SICONOS_LEFT_OUT = ("nsgsv",)
#: Siconos solvers run by default when Siconos is available: every solver the worker
#: knows for any problem family (:data:`socp_cd.bench.siconos_peer.SOLVERS`: 3D local, 2D
#: local, global), but :data:`SICONOS_LEFT_OUT`; a solver meets the problems of its own
#: families only (the others are ``unsupported``, not run).
SICONOS_SOLVERS = tuple(dict.fromkeys(
    n for kind in ("local3", "local2", "global3") for n in SICONOS_FAMILIES[kind]
    if n not in SICONOS_LEFT_OUT))

#: File-name patterns grouping the shared problems into families.

@dataclass(frozen=True)
class SolverChoice:
    """A solver as named in a campaign: ``name[:formulation][,key=value...]``.

    ``siconos:NAME`` selects the Siconos peer solver ``NAME`` (Coulomb law).
    """

    name: str
    formulation: str = "coulomb"
    options: tuple = ()

    @property
    def is_siconos(self) -> bool:
        return self.name.startswith(SICONOS_PREFIX)

    @property
    def settings(self) -> str:
        return settings_string(dict(self.options))

    @property
    def label(self) -> str:
        base = self.name if self.is_siconos or self.formulation == "coulomb" else \
            f"{self.name}:{self.formulation}"
        return base + (f"[{self.settings}]" if self.options else "")


def _value(text: str):
    try:
        return json.loads(text)
    except ValueError:
        return text


def parse_solver(spec) -> SolverChoice:
    """Parse ``"nsgs"``, ``"clarabel:associated"``, ``"nsgs,omega=1.3"``, ``"siconos:nsn_ac"``."""
    if isinstance(spec, SolverChoice):
        return spec
    head, *opts = str(spec).split(",")
    options = tuple(sorted((k.strip(), _value(v.strip())) for k, v in (o.split("=", 1) for o in opts)))
    name, _, form = head.strip().partition(":")
    if name == "siconos":
        if not form:
            raise UnsupportedError("siconos solver spec needs a name, e.g. 'siconos:nsgs'")
        return SolverChoice(SICONOS_PREFIX + form.lower(), "coulomb", options)
    return SolverChoice(name, form or "coulomb", options)


def default_solvers(formulation: str = "coulomb", siconos: bool | None = None) -> list[SolverChoice]:
    """Every registered solver supporting ``formulation`` (+ Siconos peers when available)."""
    out = [SolverChoice(n, formulation) for n, s in registered_solvers().items() if formulation in s["formulations"]]
    if siconos is None or siconos:
        if siconos_ready() and formulation == "coulomb":
            out += [SolverChoice(SICONOS_PREFIX + n) for n in SICONOS_SOLVERS]
    return out


def siconos_ready() -> bool:
    """True when Siconos numerics can be imported by the peer interpreter."""
    return siconos_available()


@dataclass(frozen=True)
class RunTask:
    """One run of a campaign."""

    problem: ProblemRef
    solver: SolverChoice
    tol: float
    time_limit: float = 30.0
    max_iter: int | None = None
    suite: str = "bench"


def make_tasks(problems, solvers, tolerances, time_limit=30.0, max_iter=None, suite="bench"):
    """Cartesian product problems × solvers × tolerances as :class:`RunTask` objects."""
    solvers = [parse_solver(s) for s in solvers]
    return [RunTask(p, s, float(t), float(time_limit), max_iter, suite)
            for p in problems for s in solvers for t in tolerances]


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def base_record(task: RunTask, problem=None, **values) -> dict:
    rec = dict(suite=task.suite, problem=task.problem.name, family=task.problem.family,
               source=task.problem.path or "", solver=task.solver.label if not task.solver.is_siconos
               else task.solver.name, formulation=task.solver.formulation,
               settings=task.solver.settings, tol=task.tol, time_limit=task.time_limit,
               timestamp=_now())
    if problem is not None:
        W = problem.W if not problem.is_global else problem.H
        rec.update(dim=problem.dim, contacts=problem.n_contacts, nnz=int(W.nnz))
    rec.update(values)
    return new_record(**rec)


def _relative(a, b) -> float:
    """``||a - b|| / ||b||`` (absolute when ``b = 0``)."""
    den = float(np.linalg.norm(b))
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b))) / (den if den > 0 else 1.0)


def finish_record(task: RunTask, problem, r, *, status: str, iterations=0, time_=math.nan,
                  wall=math.nan, law_error=math.nan, message="") -> dict:
    """Record of a finished solve: recompute Siconos' error of ``r`` and compare to the known solution."""
    r = None if r is None else np.asarray(r, dtype=np.float64).reshape(-1)
    nan = r is None and status == "numerical_error"
    err = u_err = r_err = math.nan
    if r is not None:
        if r.shape[0] != problem.m:
            status, message, r = "crashed", f"solver returned {r.shape[0]} impulses, expected {problem.m}", None
        elif not np.all(np.isfinite(r)):
            nan, err = True, math.inf
            if status == "converged":
                status = "numerical_error"
    if r is not None and not nan:
        with np.errstate(all="ignore"):
            err = siconos_error(problem, r)
            u = problem.velocity(r)
        nan = not math.isfinite(err) or not np.all(np.isfinite(u))
        sol = problem.solution
        if sol is not None and sol.u is not None and not nan:
            u_err = _relative(u, sol.u)
        if sol is not None and sol.r is not None and not nan:
            r_err = _relative(r, sol.r)
    if "non-finite" in (message or ""):
        nan = True
    success = status not in ("time_limit", "crashed", "rejected", "unsupported") and \
        math.isfinite(err) and err <= task.tol
    return base_record(task, problem, status=status, success=bool(success), error=err,
                        law_error=float(law_error), time=float(time_), wall_time=float(wall),
                        iterations=int(iterations), u_error=u_err, r_error=r_err, nan=bool(nan),
                        message=str(message)[:300])


def run_skipped(task: RunTask) -> dict:
    """Record for a run not attempted because a looser tolerance already timed out."""
    problem = None
    try:
        problem = task.problem.load()
    except Exception:  # noqa: BLE001
        pass
    return base_record(task, problem, status="time_limit",
                        message="not run: a looser tolerance already hit the time limit")


def resolve_tolerances(tolerances) -> list[float]:
    """Expand preset names and numbers into a decreasing list of tolerances.

    ``low`` 1e-4, ``mid`` 1e-6, ``high`` 1e-8, ``sweep`` 1e-2, 1e-3, ..., 1e-10,
    ``all`` 1e-2, 1e-4, ..., 1e-10 (the three presets plus both ends).
    """
    if tolerances is None:
        tolerances = ["low", "mid", "high"]
    if isinstance(tolerances, (str, float, int)):
        tolerances = [tolerances]
    out: list[float] = []
    for t in tolerances:
        if isinstance(t, str) and t in PRESETS:
            out.append(PRESETS[t])
        elif t == "sweep":
            out += list(SWEEP)
        elif t == "all":
            out += list(ALL)
        else:
            out.append(float(t))
    return sorted(set(out), reverse=True)


def outcome_record(task: RunTask, problem, outcome: tuple, wall: float) -> dict:
    """Record from an outcome ``("ok", payload)`` or ``(status, message)``."""
    kind, payload = outcome
    if kind != "ok":
        return base_record(task, problem, status=kind, wall_time=wall, message=str(payload)[:300])
    status = payload["status"]
    msg = payload.get("message", "")
    if math.isfinite(payload["time"]) and payload["time"] > task.time_limit:
        status, msg = "time_limit", f"took {payload['time']:.3g} s > time limit {task.time_limit:g} s"
    rec = finish_record(task, problem, payload["r"], status=status, iterations=payload["iterations"],
                        time_=payload["time"], wall=wall, law_error=payload["law_error"], message=msg)
    if status == "time_limit":
        rec["success"] = False
    return rec


__all__ = ["PRESETS", "SWEEP", "ALL", "SICONOS_PREFIX", "SICONOS_SOLVERS", "SICONOS_LEFT_OUT", "SolverChoice",
           "parse_solver", "default_solvers", "siconos_ready", "RunTask", "make_tasks",
           "base_record", "finish_record", "outcome_record", "run_skipped", "resolve_tolerances"]

"""Siconos peer runs in a campaign: task translation and outcome translation.

A campaign task ``siconos:NAME`` becomes a :func:`socp_cd.bench.siconos_peer.siconos_batch`
solve task (Siconos reads ``.dat`` files itself), and the bridge's result
becomes a campaign outcome whose error is then recomputed independently.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import InvalidProblemError
from .siconos_peer import REPEAT_CALLS, SOLVERS, family_of, siconos_batch
from .tasks import SICONOS_PREFIX, RunTask, base_record, outcome_record


#: Siconos iteration cap when the campaign gives none (the bridge's default).
SICONOS_MAX_ITER = 10000


def siconos_spec(task: RunTask, problem) -> dict:
    """A :func:`siconos_batch` solve task (Siconos reads ``.dat`` files itself)."""
    target = task.problem.path if task.problem.path is not None else problem
    return {"task": "solve", "problem": target, "solver": task.solver.name[len(SICONOS_PREFIX):],
            "tol": task.tol, "max_iter": task.max_iter or SICONOS_MAX_ITER,
            "time_limit": task.time_limit, "repeat": REPEAT_CALLS, **dict(task.solver.options)}


def siconos_unsupported_reason(task: RunTask, problem) -> str | None:
    """Why Siconos' solver of ``task`` does not run on ``problem`` (None when it does): the
    solver is not one of the problem's family (:data:`~socp_cd.bench.siconos_peer.SOLVERS`)."""
    name, family = task.solver.name[len(SICONOS_PREFIX):], family_of(problem)
    if name in SOLVERS[family]:
        return None
    return (f"Siconos solver {name!r} does not solve {family} problems (its solvers for "
            f"them: {', '.join(SOLVERS[family])})")


def run_siconos(task: RunTask, problem) -> tuple:
    why = siconos_unsupported_reason(task, problem)
    if why:
        return ("unsupported", why)
    return siconos_outcome(siconos_batch([siconos_spec(task, problem)])[0])


def siconos_outcome(out: dict) -> tuple:
    """Translate a Siconos bridge result dict into a campaign outcome.

    The bridge reports ``status`` ``ok``/``error``/``crashed``/``time_limit``
    and Siconos' return code ``info`` (0: it claims convergence); the
    provisional status is ``converged`` when ``info == 0`` else ``max_iter``,
    and the record then recomputes the error from ``r`` independently.
    """
    status = str(out.get("status", "crashed"))
    msg = str(out.get("message", ""))
    if status == "time_limit":
        return ("time_limit", msg or "killed at the time limit")
    if status == "error":
        unsupported = "unknown solver" in msg or "unsupported" in msg.lower()
        return ("unsupported" if unsupported else "crashed", msg)
    if status != "ok" or out.get("r") is None:
        return ("crashed", msg or f"Siconos task ended with status {status!r}")
    info = out.get("info", 1)
    return ("ok", dict(r=np.asarray(out["r"], dtype=float),
                       status="converged" if info == 0 else "max_iter",
                       iterations=int(out.get("iterations", 0) or 0),
                       time=float(out.get("time", math.nan)),
                       law_error=float(out.get("error", math.nan) if out.get("error") is not None
                                       else math.nan),
                       message=f"siconos info={info}, own residual={out.get('residual')}"))


def run_siconos_batch(tasks) -> list[dict]:
    """Run Siconos tasks in one worker process; records in task order."""
    loaded, specs, recs = [], [], [None] * len(tasks)
    for i, task in enumerate(tasks):
        try:
            problem = task.problem.load()
        except InvalidProblemError as exc:
            recs[i] = base_record(task, status="rejected", message=str(exc)[:300])
            continue
        why = siconos_unsupported_reason(task, problem)
        if why:
            recs[i] = base_record(task, problem, status="unsupported", message=why)
            continue
        loaded.append((i, task, problem))
        specs.append(siconos_spec(task, problem))
    if specs:
        t0 = time.perf_counter()
        try:
            outs = siconos_batch(specs, timeout=sum(t.time_limit + 5.0 for _, t, _ in loaded) + 60.0)
        except Exception as exc:  # noqa: BLE001 - the worker itself failed
            outs = [{"status": "crashed", "message": f"siconos worker: {exc}"[:300]}] * len(specs)
        wall = (time.perf_counter() - t0) / len(specs)
        for (i, task, problem), out in zip(loaded, outs):
            recs[i] = outcome_record(task, problem, siconos_outcome(out),
                                     float(out.get("wall_time", wall) or wall))
    return recs


__all__ = ["SICONOS_MAX_ITER", "siconos_spec", "run_siconos", "siconos_unsupported_reason", "siconos_outcome",
           "run_siconos_batch"]

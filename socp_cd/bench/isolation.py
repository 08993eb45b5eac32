"""Isolation of one solve: a forked child or a fresh interpreter, killed at the time limit.

A hanging or crashing backend cannot stop a campaign: :func:`run_forked`
(default on POSIX) and :func:`run_subprocess` (inside daemonic processes,
e.g. dask workers) return an outcome ``("ok", payload)`` or ``(status,
message)`` with status ``time_limit``, ``crashed``, ``unsupported`` or
``rejected``.
"""
from __future__ import annotations

import copy
import math
import multiprocessing as mp
import pickle
import subprocess
import sys
import time

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from ..solvers import solve
from .siconos_peer import REPEAT_BUDGET, REPEAT_CALLS, REPEAT_SECOND_BELOW
from .tasks import RunTask


def solve_payload(task: RunTask, problem, repeat: int = REPEAT_CALLS) -> tuple:
    """Run ``socp_cd.solve`` and return a small picklable outcome.

    The Siconos worker's repeat rule (:data:`~socp_cd.bench.siconos_peer.REPEAT_CALLS`,
    :data:`~socp_cd.bench.siconos_peer.REPEAT_BUDGET`, ``REPEAT_SECOND_BELOW``): while the
    calls have taken less than the budget (and a second call after a first one shorter
    than ``REPEAT_SECOND_BELOW``), up to ``repeat`` calls, each on a new problem object (a shallow copy
    of ``problem`` as given: what one call caches on its copy does not reach the next; what
    was cached on ``problem`` itself before, its copies share), and the fastest is
    reported (``time``): a per-call time without a first call's cold caches (in a forked
    child, the first call loads every compiled kernel the parent had not: up to 0.5 ms on
    a one-contact problem whose warm call takes 10 µs).  A call that does not converge is
    not repeated.  ``calls``: the calls made; the other fields are the last call's.
    """
    best, spent, calls, res = math.inf, 0.0, 0, None
    try:
        while calls < max(1, int(repeat)) and (calls == 0 or spent < REPEAT_BUDGET
                                               or (calls == 1 and spent < REPEAT_SECOND_BELOW)):
            target = copy.copy(problem)
            t0 = time.perf_counter()
            res = solve(target, solver=task.solver.name, formulation=task.solver.formulation,
                        tol=task.tol, max_iter=task.max_iter, **dict(task.solver.options))
            spent += time.perf_counter() - t0
            calls += 1
            best = min(best, float(res.time))
            if not res.converged:
                break
    except UnsupportedError as exc:
        return ("unsupported", str(exc))
    except InvalidProblemError as exc:
        return ("rejected", str(exc))
    except Exception as exc:  # noqa: BLE001 - a crash is a benchmark outcome
        return ("crashed", f"{type(exc).__name__}: {exc}")
    return ("ok", dict(r=np.asarray(res.r), status=res.status, iterations=int(res.iterations),
                       time=best, law_error=float(res.error), message=res.message, calls=calls))


def _child(conn, task, problem) -> None:
    try:
        conn.send(solve_payload(task, problem))
    finally:
        conn.close()


def run_forked(task: RunTask, problem) -> tuple:
    """Solve in a forked child; kill it at the time limit."""
    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, task, problem), daemon=True)
    proc.start()
    send.close()
    try:
        if recv.poll(task.time_limit):
            try:
                return recv.recv()
            except EOFError:
                proc.join(5)
                return ("crashed", f"solver process died (exit code {proc.exitcode})")
        return ("time_limit", f"killed after the time limit of {task.time_limit:g} s")
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join()
        recv.close()


def run_subprocess(task: RunTask) -> tuple:
    """Solve in a fresh interpreter (used where forking is not allowed, e.g. daemonic dask workers)."""
    try:
        out = subprocess.run([sys.executable, "-m", "socp_cd.bench.isolation"], input=pickle.dumps(task),
                             capture_output=True, timeout=task.time_limit + 30.0)
    except subprocess.TimeoutExpired:
        return ("time_limit", f"killed after the time limit of {task.time_limit:g} s")
    if out.returncode != 0:
        return ("crashed", f"solver process exit code {out.returncode}: {out.stderr.decode()[-200:]}")
    return pickle.loads(out.stdout)


def default_isolation() -> str:
    return "subprocess" if mp.current_process().daemon or "fork" not in mp.get_all_start_methods() \
        else "fork"


__all__ = ["solve_payload", "run_forked", "run_subprocess", "default_isolation"]


if __name__ == "__main__":  # subprocess isolation: task on stdin, outcome on stdout
    _task = pickle.loads(sys.stdin.buffer.read())
    _out = solve_payload(_task, _task.problem.load())
    sys.stdout.buffer.write(pickle.dumps(_out))

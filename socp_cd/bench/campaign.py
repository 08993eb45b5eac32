"""Benchmark campaigns: problems × solvers × tolerances, one isolated run each (orchestration).

A campaign expands its inputs into tasks (:mod:`.tasks`) over problem
references (:mod:`.problem_refs`), runs each one isolated (:mod:`.isolation`;
Siconos peers through :mod:`.siconos_runs`), reports progress
(:mod:`.progress`) and appends one record per run to a table
(:mod:`.records`).  The achieved accuracy is always recomputed from the
returned impulses with :func:`socp_cd.error`.
"""
from __future__ import annotations

import time

from ..solvers import solvers as registered_solvers
from ..solvers.registry import solver_spec
from ..solvers.warm import warmup
from .generators import manufactured
from .isolation import default_isolation, run_forked, run_subprocess, solve_payload
from .problem_refs import ProblemRef, file_problems, shared_problems
from .progress import Progress
from .records import append_records, key_of, read_records
from .schedule import CHUNK, interleaved
from .siconos_runs import run_siconos, run_siconos_batch
from .tasks import (RunTask, SolverChoice, base_record, default_solvers, make_tasks, outcome_record,
                    parse_solver, resolve_tolerances, run_skipped)
from ..errors import InvalidProblemError


def unsupported_reason(task: RunTask, problem) -> str | None:
    """Why the registered solver cannot run this task (None when it can)."""
    reg = registered_solvers()
    s = task.solver
    if s.name not in reg:
        return f"solver {s.name!r} is not registered (available: {sorted(reg)})"
    spec = reg[s.name]
    if s.formulation not in spec["formulations"]:
        return f"solver {s.name!r} cannot solve formulation {s.formulation!r}"
    if problem.dim not in spec["dims"]:
        return f"solver {s.name!r} does not support dim = {problem.dim}"
    return None


_WARM: set = set()


def warm_up(solver: SolverChoice, dim: int) -> None:
    """Solve a 2-contact problem once in this process (JIT compilation, imports), after
    loading every compiled kernel (:func:`socp_cd.warmup`, once per process: a forked child
    would load what the parent has not on its first call; the first calls of a campaign
    timed it, 75 ms instead of 4 ms on a 23-contact problem, 135 instead of 24 ms on a
    60-contact one).

    Forked children inherit the compiled code, so the timings of the runs do
    not include numba compilation or cache loading.
    """
    key = (solver.name, solver.formulation, dim)
    if key in _WARM or solver.is_siconos:
        return
    warmup()
    _WARM.add(key)
    spec = solver_spec(solver.name)
    if spec is None or not spec.func.__module__.startswith("socp_cd.solvers."):
        return  # only socp_cd's own backends are trusted to run outside the isolation
    probe = manufactured(2, dim, 0.3, seed=12345)
    task = RunTask(ProblemRef("warm-up", "warm-up"), solver, 1e-6, 60.0)
    solve_payload(task, probe)


def run_one(task: RunTask, isolation: str | None = None) -> dict:
    """Run one task and return its record.

    Parameters
    ----------
    task : RunTask
    isolation : {"fork", "subprocess", "none"}, optional
        How the solve is isolated: forked child (default on POSIX), fresh
        interpreter (default inside daemonic processes), or in-process
        (no time-limit enforcement beyond flagging an overrun afterwards).
    """
    try:
        problem = task.problem.load()
    except InvalidProblemError as exc:
        return base_record(task, status="rejected", message=str(exc)[:300])
    except Exception as exc:  # noqa: BLE001
        return base_record(task, status="crashed", message=f"loading: {type(exc).__name__}: {exc}"[:300])
    if not task.solver.is_siconos:
        why = unsupported_reason(task, problem)
        if why:
            return base_record(task, problem, status="unsupported", message=why)
    isolation = isolation or default_isolation()
    if isolation == "fork":
        warm_up(task.solver, problem.dim)
    t0 = time.perf_counter()
    if task.solver.is_siconos:
        try:
            outcome = run_siconos(task, problem)
        except Exception as exc:  # noqa: BLE001
            outcome = ("crashed", f"siconos bridge: {type(exc).__name__}: {exc}")
    elif isolation == "fork":
        outcome = run_forked(task, problem)
    elif isolation == "subprocess":
        outcome = run_subprocess(task)
    else:
        outcome = solve_payload(task, problem)
    wall = time.perf_counter() - t0
    return outcome_record(task, problem, outcome, wall)


def run_tasks(tasks, *, isolation=None, verbose=False, skip_after_time_limit=True,
              chunk: int = CHUNK):
    """Run tasks serially; returns records in task order.

    Native solvers run one isolated child per task; Siconos tasks run in one Siconos worker
    per chunk of problems (:func:`run_siconos_batch`).  Within a tolerance level the
    problems are taken in chunks of ``chunk`` (:func:`~.schedule.interleaved`): each chunk's
    native and Siconos tasks run before the next chunk's, the two sides going first in turn,
    so that a slow or fast spell of the machine hits both sides alike.  With
    ``skip_after_time_limit`` a (problem, solver) pair that hit the time
    limit at some tolerance is not re-run at tighter tolerances: those runs
    are recorded as ``time_limit`` with an explanatory message (reaching a
    tighter tolerance cannot take less work for these iterative methods).
    """
    tasks = list(tasks)
    order = sorted(range(len(tasks)), key=lambda i: (-tasks[i].tol, tasks[i].problem.name,
                                                     tasks[i].solver.label))
    recs: list = [None] * len(tasks)
    timed_out: set = set()
    progress = Progress(len(tasks), verbose)

    def _key(t):
        return (t.problem.name, t.solver, t.suite)

    def peer(here):
        todo = [i for i in here if tasks[i].solver.is_siconos and recs[i] is None]
        if todo:
            for i, rec in zip(todo, run_siconos_batch([tasks[i] for i in todo])):
                recs[i] = rec
                progress.update(rec)

    def ours(here):
        for i in here:
            if recs[i] is None and not tasks[i].solver.is_siconos:
                recs[i] = run_one(tasks[i], isolation=isolation)
                progress.update(recs[i])

    for tol in sorted({t.tol for t in tasks}, reverse=True):
        level = [i for i in order if tasks[i].tol == tol]
        for i in level:
            if skip_after_time_limit and _key(tasks[i]) in timed_out:
                recs[i] = run_skipped(tasks[i])
                progress.update(recs[i])
        names = list(dict.fromkeys(tasks[i].problem.name for i in level))
        for part, first in interleaved(len(names), chunk):
            in_chunk = {names[k] for k in part}
            here = [i for i in level if tasks[i].problem.name in in_chunk]
            for side in ((ours, peer) if first == "ours" else (peer, ours)):
                side(here)
        for i in level:
            if recs[i] is None:     # (a Siconos task its batch left without a record)
                recs[i] = run_one(tasks[i], isolation=isolation)
                progress.update(recs[i])
            if recs[i]["status"] == "time_limit":
                timed_out.add(_key(tasks[i]))
    progress.close()
    return recs


def run_campaign(problems, solvers=None, tolerances=None, time_limit: float = 30.0, *,
                 max_iter=None, suite: str = "bench", csv_path=None, resume: bool = False,
                 dask=None, n_workers: int = 2, isolation=None, verbose: bool = False) -> list[dict]:
    """Run a benchmark campaign and return its records.

    Parameters
    ----------
    problems : list
        :class:`ProblemRef` objects, problem files or directories (strings /
        paths), or ``"shared"`` for the shared real problems.
    solvers : list of str or SolverChoice, optional
        Solver specs ``name[:formulation][,key=value]`` or ``siconos:NAME``;
        default: every registered Coulomb solver plus the Siconos peers when
        Siconos is available.
    tolerances : list, optional
        Numbers and/or preset names ``low`` (1e-4), ``mid`` (1e-6),
        ``high`` (1e-8), ``sweep`` (1e-2 ... 1e-10, every decade), ``all``
        (1e-2 ... 1e-10, every other decade); default the three presets.
    time_limit : float
        Seconds per run; a run exceeding it is killed (status ``time_limit``).
    max_iter : int, optional
        Iteration cap passed to the solvers (backend default when None).
    suite : str
        Label stored in the records (part of the dedupe key).
    csv_path : path, optional
        Records table to append to (a new run replaces an old one with the same key).
    resume : bool
        Skip tasks whose key is already in ``csv_path``.
    dask : None, True, str or distributed.Client
        Run the tasks on dask: ``True`` starts a LocalCluster, a string is a
        scheduler address, a Client is used as is.
    n_workers : int
        Worker processes of the LocalCluster started for ``dask=True``.
    isolation : {"fork", "subprocess", "none"}, optional
    verbose : bool
        Print one line per run.

    Returns
    -------
    list of dict
        The records of this campaign (see :data:`socp_cd.bench.records.FIELDS`).
    """
    refs: list[ProblemRef] = []
    for p in problems:
        if isinstance(p, ProblemRef):
            refs.append(p)
        elif str(p) == "shared":
            refs += shared_problems()
        else:
            refs += file_problems([p])
    choices = [parse_solver(s) for s in solvers] if solvers else default_solvers()
    tasks = make_tasks(refs, choices, resolve_tolerances(tolerances), time_limit, max_iter, suite)
    if resume and csv_path is not None:
        done = {key_of(r) for r in read_records(csv_path)}
        tasks = [t for t in tasks if key_of(base_record(t)) not in done]
    if dask is not None and dask is not False:
        from .distributed import run_tasks_dask
        records = run_tasks_dask(tasks, run_one, dask, n_workers=n_workers, verbose=verbose)
    else:
        records = run_tasks(tasks, isolation=isolation, verbose=verbose)
    if csv_path is not None:
        append_records(csv_path, records)
    return records


__all__ = ["run_campaign", "run_tasks", "run_one", "warm_up", "unsupported_reason"]

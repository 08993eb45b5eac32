"""Benchmark campaigns: problems × solvers × tolerances, one isolated run each.

A campaign expands its inputs into :class:`RunTask` objects and turns each
into one record (see :mod:`socp_cd.bench.records`).  Every solve runs in a
child process that is killed when it exceeds the time limit (status
``time_limit``), so a hanging or crashing backend cannot stop the campaign.
The achieved accuracy is always recomputed here with :func:`socp_cd.error`
(Siconos' relative error) from the returned impulses ``r``, whoever the
solver is, and ``success`` means ``error <= tol``.
"""
from __future__ import annotations

import json
import math
import multiprocessing as mp
import pickle
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..data import shared_problems_dir
from ..errors import InvalidProblemError, UnsupportedError
from .records import append_records, new_record, settings_string

#: Tolerance presets (qpbenchmark style) and the work–precision sweep.
PRESETS = {"low": 1e-4, "mid": 1e-6, "high": 1e-8}
SWEEP = tuple(10.0 ** -k for k in range(2, 11))
#: Tolerances of ``--preset all``: every other decade of the sweep (contains the presets).
ALL = tuple(10.0 ** -k for k in range(2, 11, 2))
#: Prefix of Siconos peer solvers in solver specs and records.
SICONOS_PREFIX = "siconos:"
#: Siconos solvers run by default when Siconos is available.
SICONOS_SOLVERS = ("nsgs", "nsn_ac", "admm", "aclmfp", "vi_fpp")
PROBLEM_SUFFIXES = (".hdf5", ".h5", ".dat")

#: File-name patterns grouping the shared problems into families.
FAMILY_PATTERNS = (
    (r"^Rover", "Rover"),
    (r"^Capsules", "Capsules"),
    (r"^(BoxesStack|Box_Stacks|KaplasTower|OneObject|LMGC_100_PR)", "stacks"),
    (r"^(FC3D_Example|FrictionContact3D_|Confeti|NESpheres)", "small3d"),
    (r"^(FC2D|fc2d|FrictionContactProblem)", "2d"),
    (r"^(GFC3D|CubeH8|LMGC_Global)", "global"),
)


def file_family(name: str) -> str:
    """Family of a problem file (see :data:`FAMILY_PATTERNS`; else its first word)."""
    for pat, fam in FAMILY_PATTERNS:
        if re.search(pat, name):
            return fam
    return re.split(r"[-_.0-9]", name, maxsplit=1)[0] or name


# --------------------------------------------------------------------- problems
@dataclass(frozen=True)
class ProblemRef:
    """A loadable problem: a file, or a member of a generated family.

    Attributes
    ----------
    name : str
        Identifier used in records.
    family : str
    path : str, optional
        Problem file (FCLib HDF5 or Siconos ``.dat``).
    generator : str, optional
        JSON of the keyword arguments of :func:`socp_cd.bench.generators.generate`
        (or of :func:`socp_cd.bench.extremes.build` when ``family`` starts with
        ``"extreme"``).
    """

    name: str
    family: str
    path: str | None = None
    generator: str | None = None

    def load(self):
        """Read or build the problem (cached per process)."""
        return _load(self)


@lru_cache(maxsize=8)
def _load(ref: ProblemRef):
    if ref.path is not None:
        from .. import read_problem
        return read_problem(ref.path)
    kw = json.loads(ref.generator)
    if kw.pop("_builder", "generate") == "extremes":
        from .extreme_cases import build
        return build(**kw)
    from .generators import generate
    return generate(**kw)


def file_problems(paths) -> list[ProblemRef]:
    """Problem refs for files and directories (directories: every problem file inside)."""
    out = []
    for p in paths:
        p = Path(p)
        files = sorted(f for f in p.iterdir() if f.suffix in PROBLEM_SUFFIXES) if p.is_dir() else [p]
        out += [ProblemRef(f.name, file_family(f.name), path=str(f)) for f in files]
    return out


def generated_problems(family: str = "manufactured", sizes=(1, 10, 100), dims=(2, 3),
                       seeds=(0,), **params) -> list[ProblemRef]:
    """Problem refs for a generated family over sizes × dims × seeds."""
    out = []
    for dim in dims:
        for n in sizes:
            for seed in seeds:
                kw = dict(family=family, n_contacts=int(n), dim=int(dim), seed=int(seed), **params)
                out.append(ProblemRef(f"{family}-{dim}d-{n}-s{seed}", f"{family}-{dim}d",
                                      generator=json.dumps(kw, sort_keys=True)))
    return out


def shared_problems() -> list[ProblemRef]:
    """The shared real problems (``socp_cd.data.shared_problems_dir()``); [] if absent."""
    d = shared_problems_dir()
    return file_problems([d]) if d is not None and d.is_dir() else []


# ---------------------------------------------------------------------- solvers
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
    from ..solvers import solvers
    out = [SolverChoice(n, formulation) for n, s in solvers().items() if formulation in s["formulations"]]
    if siconos is None or siconos:
        if siconos_ready() and formulation == "coulomb":
            out += [SolverChoice(SICONOS_PREFIX + n) for n in SICONOS_SOLVERS]
    return out


def siconos_ready() -> bool:
    """True when Siconos numerics can be imported by the peer interpreter."""
    from .siconos_peer import siconos_available
    return siconos_available()


# ------------------------------------------------------------------------ tasks
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


def _base_record(task: RunTask, problem=None, **values) -> dict:
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
    from ..residuals import error as siconos_error
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
    return _base_record(task, problem, status=status, success=bool(success), error=err,
                        law_error=float(law_error), time=float(time_), wall_time=float(wall),
                        iterations=int(iterations), u_error=u_err, r_error=r_err, nan=bool(nan),
                        message=str(message)[:300])


def _supported(task: RunTask, problem) -> str | None:
    """Why the registered solver cannot run this task (None when it can)."""
    from ..solvers import solvers
    reg = solvers()
    s = task.solver
    if s.name not in reg:
        return f"solver {s.name!r} is not registered (available: {sorted(reg)})"
    spec = reg[s.name]
    if s.formulation not in spec["formulations"]:
        return f"solver {s.name!r} cannot solve formulation {s.formulation!r}"
    if problem.dim not in spec["dims"]:
        return f"solver {s.name!r} does not support dim = {problem.dim}"
    return None


def _solve_payload(task: RunTask, problem) -> tuple:
    """Run ``socp_cd.solve`` and return a small picklable outcome."""
    from ..solvers import solve
    try:
        res = solve(problem, solver=task.solver.name, formulation=task.solver.formulation,
                    tol=task.tol, max_iter=task.max_iter, **dict(task.solver.options))
    except UnsupportedError as exc:
        return ("unsupported", str(exc))
    except InvalidProblemError as exc:
        return ("rejected", str(exc))
    except Exception as exc:  # noqa: BLE001 - a crash is a benchmark outcome
        return ("crashed", f"{type(exc).__name__}: {exc}")
    return ("ok", dict(r=np.asarray(res.r), status=res.status, iterations=int(res.iterations),
                       time=float(res.time), law_error=float(res.error), message=res.message))


def _child(conn, task, problem) -> None:
    try:
        conn.send(_solve_payload(task, problem))
    finally:
        conn.close()


def _run_forked(task: RunTask, problem) -> tuple:
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


def _run_subprocess(task: RunTask) -> tuple:
    """Solve in a fresh interpreter (used where forking is not allowed, e.g. daemonic dask workers)."""
    try:
        out = subprocess.run([sys.executable, "-m", "socp_cd.bench.campaign"], input=pickle.dumps(task),
                             capture_output=True, timeout=task.time_limit + 30.0)
    except subprocess.TimeoutExpired:
        return ("time_limit", f"killed after the time limit of {task.time_limit:g} s")
    if out.returncode != 0:
        return ("crashed", f"solver process exit code {out.returncode}: {out.stderr.decode()[-200:]}")
    return pickle.loads(out.stdout)


#: Siconos iteration cap when the campaign gives none (the bridge's default).
SICONOS_MAX_ITER = 10000


def _siconos_spec(task: RunTask, problem) -> dict:
    """A :func:`siconos_batch` solve task (Siconos reads ``.dat`` files itself)."""
    target = task.problem.path if task.problem.path is not None else problem
    return {"task": "solve", "problem": target, "solver": task.solver.name[len(SICONOS_PREFIX):],
            "tol": task.tol, "max_iter": task.max_iter or SICONOS_MAX_ITER,
            "time_limit": task.time_limit, **dict(task.solver.options)}


def _run_siconos(task: RunTask, problem) -> tuple:
    from .siconos_peer import siconos_batch
    return siconos_outcome(siconos_batch([_siconos_spec(task, problem)])[0])


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
    from .siconos_peer import siconos_batch
    loaded, specs, recs = [], [], [None] * len(tasks)
    for i, task in enumerate(tasks):
        try:
            problem = task.problem.load()
        except InvalidProblemError as exc:
            recs[i] = _base_record(task, status="rejected", message=str(exc)[:300])
            continue
        loaded.append((i, task, problem))
        specs.append(_siconos_spec(task, problem))
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


_WARM: set = set()


def warm_up(solver: SolverChoice, dim: int) -> None:
    """Solve a 2-contact problem once in this process (JIT compilation, imports).

    Forked children inherit the compiled code, so the timings of the runs do
    not include numba compilation or cache loading.
    """
    key = (solver.name, solver.formulation, dim)
    if key in _WARM or solver.is_siconos:
        return
    _WARM.add(key)
    from ..solvers.registry import solver_spec
    spec = solver_spec(solver.name)
    if spec is None or not spec.func.__module__.startswith("socp_cd.solvers."):
        return  # only socp_cd's own backends are trusted to run outside the isolation
    from .generators import manufactured
    probe = manufactured(2, dim, 0.3, seed=12345)
    task = RunTask(ProblemRef("warm-up", "warm-up"), solver, 1e-6, 60.0)
    _solve_payload(task, probe)


def _isolation() -> str:
    return "subprocess" if mp.current_process().daemon or "fork" not in mp.get_all_start_methods() \
        else "fork"


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
        return _base_record(task, status="rejected", message=str(exc)[:300])
    except Exception as exc:  # noqa: BLE001
        return _base_record(task, status="crashed", message=f"loading: {type(exc).__name__}: {exc}"[:300])
    if not task.solver.is_siconos:
        why = _supported(task, problem)
        if why:
            return _base_record(task, problem, status="unsupported", message=why)
    isolation = isolation or _isolation()
    if isolation == "fork":
        warm_up(task.solver, problem.dim)
    t0 = time.perf_counter()
    if task.solver.is_siconos:
        try:
            outcome = _run_siconos(task, problem)
        except Exception as exc:  # noqa: BLE001
            outcome = ("crashed", f"siconos bridge: {type(exc).__name__}: {exc}")
    elif isolation == "fork":
        outcome = _run_forked(task, problem)
    elif isolation == "subprocess":
        outcome = _run_subprocess(task)
    else:
        outcome = _solve_payload(task, problem)
    wall = time.perf_counter() - t0
    return outcome_record(task, problem, outcome, wall)


def outcome_record(task: RunTask, problem, outcome: tuple, wall: float) -> dict:
    """Record from an outcome ``("ok", payload)`` or ``(status, message)``."""
    kind, payload = outcome
    if kind != "ok":
        return _base_record(task, problem, status=kind, wall_time=wall, message=str(payload)[:300])
    status = payload["status"]
    msg = payload.get("message", "")
    if math.isfinite(payload["time"]) and payload["time"] > task.time_limit:
        status, msg = "time_limit", f"took {payload['time']:.3g} s > time limit {task.time_limit:g} s"
    rec = finish_record(task, problem, payload["r"], status=status, iterations=payload["iterations"],
                        time_=payload["time"], wall=wall, law_error=payload["law_error"], message=msg)
    if status == "time_limit":
        rec["success"] = False
    return rec


def _progress(i, n, rec, verbose):
    if verbose:
        print(f"[{i:4d}/{n}] {rec['problem'][:38]:38s} {rec['solver'][:22]:22s} tol={rec['tol']:.0e} "
              f"{rec['status']:15s} err={rec['error']:.2e} t={rec['time']:.3g}s", flush=True)


def run_tasks(tasks, *, isolation=None, verbose=False, skip_after_time_limit=True):
    """Run tasks serially; returns records in task order.

    Native solvers run one isolated child per task; Siconos tasks run in one
    Siconos worker per tolerance level (:func:`run_siconos_batch`).  With
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
    done = 0

    def _key(t):
        return (t.problem.name, t.solver, t.suite)

    for tol in sorted({t.tol for t in tasks}, reverse=True):
        level = [i for i in order if tasks[i].tol == tol]
        sic = [i for i in level if tasks[i].solver.is_siconos]
        for i in level:
            if skip_after_time_limit and _key(tasks[i]) in timed_out:
                recs[i] = run_skipped(tasks[i])
        todo = [i for i in sic if recs[i] is None]
        if todo:
            for i, rec in zip(todo, run_siconos_batch([tasks[i] for i in todo])):
                recs[i] = rec
        for i in level:
            if recs[i] is None:
                recs[i] = run_one(tasks[i], isolation=isolation)
            if recs[i]["status"] == "time_limit":
                timed_out.add(_key(tasks[i]))
            done += 1
            _progress(done, len(tasks), recs[i], verbose)
    return recs


def run_skipped(task: RunTask) -> dict:
    """Record for a run not attempted because a looser tolerance already timed out."""
    problem = None
    try:
        problem = task.problem.load()
    except Exception:  # noqa: BLE001
        pass
    return _base_record(task, problem, status="time_limit",
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
        from .records import key_of, read_records
        done = {key_of(r) for r in read_records(csv_path)}
        tasks = [t for t in tasks if key_of(_base_record(t)) not in done]
    if dask is not None and dask is not False:
        from .distributed import run_tasks_dask
        records = run_tasks_dask(tasks, run_one, dask, n_workers=n_workers, verbose=verbose)
    else:
        records = run_tasks(tasks, isolation=isolation, verbose=verbose)
    if csv_path is not None:
        append_records(csv_path, records)
    return records


if __name__ == "__main__":  # subprocess isolation: task on stdin, outcome on stdout
    _task = pickle.loads(sys.stdin.buffer.read())
    _out = _solve_payload(_task, _task.problem.load())
    sys.stdout.buffer.write(pickle.dumps(_out))

"""Bridge to Siconos numerics 4.4, the C peer socp_cd is measured against.

Siconos is *not* a dependency: it is installed for another interpreter (the
system ``/usr/bin/python3``), so every call goes through one subprocess that
runs the standalone script :mod:`socp_cd.bench._siconos_worker` on a JSON job
file and an npz of arrays, and writes its results to an npz file.  A whole
benchmark runs in *one* worker process (:func:`siconos_batch`); inside it each
task is forked, so a Siconos crash (C ``abort``) or a time limit loses only
that task.

Problems are given as a path or a problem object.  A Siconos text file
(``.dat``, detected from content) is read by Siconos itself; an FCLib HDF5 file
is read by :func:`socp_cd.read_problem` and, like a problem object, shipped to
the worker as arrays (``W``/``M``/``H`` as COO triplets).

Solver names (plain strings): local 3D ``"nsgs"`` (``SICONOS_FRICTION_3D_NSGS``),
``"nsn_ac"``, ``"admm"``, ``"aclmfp"``, ``"vi_fpp"`` and more (see
:data:`SOLVERS`); local 2D ``"nsgs"`` (``SICONOS_FRICTION_2D_NSGS``); global 3D
``"nsgs_wr"``, ``"admm"``, ``"nsn_ac"``....  A Siconos constant name
(``"SICONOS_FRICTION_3D_NSGS"``) is accepted too.

Known Siconos 4.4 quirks: ``fc2d_driver`` rejects CSparse storage (the worker
densifies such 2D problems); the global ``"nsgs_wr"`` returns an r that solves
the problem but ``v``, ``u`` not recomputed from it (recompute them, as
:func:`socp_cd.error` does); the C ``fc2d_compute_error`` is not wrapped by
SWIG (the worker calls it through ctypes); there is no local error for global
problems (``gfc3d_compute_error`` measures something else); PFP needs
sparse-block storage (``storage="sbm"``; dense or CSparse ``W`` abort it:
"createSplittedFrictionContactProblem: storageType value 0 not implemented",
a double free); SOCLCP rewrites its options (a second driver call with them
fails: the worker builds new options for every call); NSGSV is unfinished
(its default local solver is rejected by its own initialization, and with the
accepted one it dereferences a null local problem): it crashes on every
problem; the storage of ``W`` moves the Newton solvers' times up to ×40 on
small problems (PROX, NSN_AC on 4–9 contacts: CSparse 0.6–2.7 ms, dense or
sparse-block 0.02–0.06 ms).
"""
from __future__ import annotations

import functools
import json
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError, UnsupportedError

#: Interpreter with ``siconos.numerics`` (override with ``SOCP_CD_SICONOS_PYTHON``).
DEFAULT_PYTHON = "/usr/bin/python3"
#: Solver names understood by the worker, per problem family.
SOLVERS = {
    "local3": ("nsgs", "nsgsv", "nsn_ac", "nsn_fb", "nsn_nm", "admm", "aclmfp", "dsfp", "tfp",
               "pfp", "prox", "vi_fpp", "vi_eg", "fpp", "eg", "hp", "soclcp"),
    "local2": ("nsgs", "cpg", "lemke", "enum"),
    "global3": ("nsgs_wr", "nsgs", "admm", "admm_wr", "nsn_ac", "nsn_ac_wr", "aclmfp",
                "vi_fpp", "vi_eg", "ipm", "prox_wr"),
}
#: The worker's repeat rule: a task's ``repeat`` calls stop once they have taken
#: REPEAT_BUDGET seconds, but a first call shorter than REPEAT_SECOND_BELOW seconds is
#: always followed by a second (the worker's own constants, copied here: it runs
#: standalone); REPEAT_CALLS is the ``repeat`` the benchmarks ask for, so that a Siconos
#: time is a warm call's (a single call is a cold first call, ~60 µs on one contact against
#: 3 µs warm).  Our side of the benchmarks follows the same rule.
REPEAT_BUDGET = 0.05
REPEAT_SECOND_BELOW = 1.0
REPEAT_CALLS = 200
#: Keyword options of :func:`siconos_solve` forwarded to the worker.
SOLVE_PARAMS = ("iparam", "dparam", "internal_iparam", "internal_dparam", "r0", "u0", "v0", "repeat",
                "kind", "dense", "storage")
_ARRAY_PARAMS = ("r0", "u0", "v0")
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


def family_of(problem) -> str:
    """Siconos' problem family of ``problem`` (a key of :data:`SOLVERS`): ``"local3"``,
    ``"local2"`` or ``"global3"``."""
    return "global3" if problem.is_global else f"local{problem.dim}"


def siconos_python() -> str:
    """Path of the interpreter that has ``siconos.numerics``."""
    return os.environ.get("SOCP_CD_SICONOS_PYTHON", DEFAULT_PYTHON)


def worker_path() -> Path:
    """Path of the worker script run by :func:`siconos_python`."""
    return Path(__file__).with_name("_siconos_worker.py")


@functools.lru_cache(maxsize=None)
def siconos_available() -> bool:
    """True when :func:`siconos_python` exists and imports what the worker needs (cached).

    That is ``siconos.numerics`` and ``scipy.sparse``: Siconos 4.4's SWIG typemaps look
    SciPy's sparse modules up, and a system with ``python3-siconos`` but without
    ``python3-scipy`` imports Siconos yet fails every job.
    """
    py = siconos_python()
    if not Path(py).exists():
        return False
    try:
        done = subprocess.run([py, "-c", "import scipy.sparse, siconos.numerics"],
                              capture_output=True, timeout=120)
    except (OSError, subprocess.SubprocessError):
        return False
    return done.returncode == 0


# ------------------------------------------------------------------ packing
def _is_siconos_text(path: Path) -> bool:
    with open(path, "rb") as fh:
        return fh.read(8) != _HDF5_MAGIC


def _put_matrix(arrays: dict, key: str, A) -> None:
    A = sp.coo_matrix(A)
    arrays[key + "_row"] = A.row.astype(np.int64)
    arrays[key + "_col"] = A.col.astype(np.int64)
    arrays[key + "_val"] = A.data.astype(np.float64)
    arrays[key + "_shape"] = np.asarray(A.shape, dtype=np.int64)


def _pack_problem(problem, arrays: dict, key: str) -> None:
    """Store a problem object as npz arrays under prefix *key*."""
    arrays[key + ".dim"] = np.asarray(problem.dim)
    arrays[key + ".mu"] = np.asarray(problem.mu, dtype=np.float64)
    if getattr(problem, "is_global", False):
        arrays[key + ".kind"] = np.asarray(1)
        _put_matrix(arrays, key + ".M", problem.M)
        _put_matrix(arrays, key + ".H", problem.H)
        arrays[key + ".f"] = np.asarray(problem.f, dtype=np.float64)
        arrays[key + ".w"] = np.asarray(problem.w, dtype=np.float64)
    else:
        arrays[key + ".kind"] = np.asarray(0)
        _put_matrix(arrays, key + ".W", problem.W)
        arrays[key + ".q"] = np.asarray(problem.q, dtype=np.float64)


class _Packer:
    """Collect the arrays of a job, sharing one copy per distinct problem."""

    def __init__(self):
        self.arrays: dict = {}
        self._problems: dict = {}

    def problem(self, problem) -> dict:
        """Task fields naming *problem* (path or object)."""
        if isinstance(problem, (str, os.PathLike)):
            path = Path(problem).resolve()
            if not path.is_file():
                raise SolverError(f"{path}: problem file not found")
            if _is_siconos_text(path):
                return {"file": str(path)}
            if str(path) not in self._problems:
                from .. import read_problem
                self._problems[str(path)] = self._add(read_problem(path))
            return {"data": self._problems[str(path)]}
        if not hasattr(problem, "mu") or not hasattr(problem, "dim"):
            raise UnsupportedError(f"not a problem or a path: {type(problem).__name__}")
        ident = f"obj{id(problem)}"
        if ident not in self._problems:
            self._problems[ident] = self._add(problem)
        return {"data": self._problems[ident]}

    def _add(self, problem) -> str:
        key = f"p{len(self._problems)}"
        _pack_problem(problem, self.arrays, key)
        return key

    def array(self, name: str, value) -> str:
        key = f"a{len(self.arrays)}.{name}"
        self.arrays[key] = np.asarray(value, dtype=np.float64)
        return key


def _job_task(spec: dict, packer: _Packer) -> dict:
    """Translate a venv-side task dict into a worker task."""
    spec = dict(spec)
    kind = spec.pop("task", None)
    if kind not in ("load", "error", "solve", "ping", "_abort"):
        raise UnsupportedError(f"unknown Siconos task {kind!r} (load, error, solve)")
    task = {"task": kind}
    if "problem" in spec:
        task.update(packer.problem(spec.pop("problem")))
    elif kind in ("load", "error", "solve"):
        raise UnsupportedError(f"Siconos task {kind!r} needs a 'problem'")
    if kind == "error":
        rs = np.atleast_2d(np.asarray(spec.pop("rs"), dtype=np.float64))
        task["rs"] = packer.array("rs", rs)
    for name in _ARRAY_PARAMS:
        if spec.get(name) is not None:
            task[name] = packer.array(name, spec.pop(name))
        else:
            spec.pop(name, None)
    for name in ("iparam", "dparam", "internal_iparam", "internal_dparam"):
        if spec.get(name):
            task[name] = {str(k): v for k, v in dict(spec.pop(name)).items()}
        else:
            spec.pop(name, None)
    if spec.get("storage") not in (None, "dense", "sbm", "csc"):
        raise UnsupportedError(f"storage must be 'dense', 'sbm' or 'csc', got {spec['storage']!r}")
    for name in ("solver", "tol", "max_iter", "time_limit", "kind", "dense", "storage", "repeat"):
        if name in spec:
            value = spec.pop(name)
            if value is not None:
                task[name] = value if name != "solver" else str(value)
    if spec:
        raise UnsupportedError(f"unknown Siconos task option(s): {', '.join(sorted(spec))}")
    return task


def _run_worker(tasks: list, arrays: dict, timeout=None) -> list:
    """Run the worker once on *tasks*; return the per-task result dicts."""
    if not siconos_available():
        raise SolverError(f"Siconos is not available ({siconos_python()} cannot import "
                          "siconos.numerics)")
    with tempfile.TemporaryDirectory(prefix="socp_cd_siconos_") as tmp:
        tmp = Path(tmp)
        inputs = None
        if arrays:
            inputs = tmp / "inputs.npz"
            np.savez(inputs, **arrays)
        job = tmp / "job.json"
        job.write_text(json.dumps({"inputs": None if inputs is None else str(inputs),
                                   "tasks": tasks}))
        out = tmp / "out.npz"
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
        env.pop("PYTHONPATH", None)  # the venv's paths must not leak into the system python
        env.pop("PYTHONHOME", None)
        try:
            done = subprocess.run([siconos_python(), str(worker_path()), str(job), str(out)],
                                  capture_output=True, timeout=timeout, env=env, cwd=tmp)
        except subprocess.TimeoutExpired:
            raise SolverError(f"Siconos worker exceeded {timeout} s") from None
        if done.returncode != 0 or not out.exists():
            tail = done.stderr.decode("utf-8", "replace")[-1500:]
            raise SolverError(f"Siconos worker failed (exit code {done.returncode}): {tail}")
        results = []
        with np.load(out, allow_pickle=False) as z:
            metas = json.loads(str(z["__meta__"]))
            for i, meta in enumerate(metas):
                for name in meta.pop("arrays", []):
                    meta[name] = z[f"t{i}.{name}"]
                results.append(meta)
    return results


def _matrix(res: dict, key: str) -> sp.csr_matrix:
    shape = tuple(int(s) for s in res.pop(key + "_shape"))
    A = sp.coo_matrix((res.pop(key + "_val"), (res.pop(key + "_row"), res.pop(key + "_col"))),
                      shape=shape)
    return A.tocsr()


def _finish(task: dict, res: dict) -> dict:
    """Turn raw worker arrays into user-facing values (matrices)."""
    if task["task"] == "load" and res.get("status") == "ok":
        for key in ("W", "M", "H"):
            if key + "_shape" in res:
                res[key] = _matrix(res, key)
    return res


# ------------------------------------------------------------------ public API
def siconos_batch(tasks, timeout=None) -> list:
    """Run many Siconos tasks in one worker process.

    Parameters
    ----------
    tasks : list of dict
        Each has ``"task"`` (``"load"``, ``"error"`` or ``"solve"``), ``"problem"``
        (path or problem object) and the options of :func:`siconos_load`,
        :func:`siconos_errors` (``"rs"``) or :func:`siconos_solve` (``"solver"``,
        ``"tol"``, ``"max_iter"``, ``"time_limit"``, ``"iparam"``...).
    timeout : float, optional
        Limit for the whole worker process (per-task limits are ``time_limit``).

    Returns
    -------
    list of dict
        One result per task, in order, with ``"status"``: ``"ok"``, ``"error"``
        (``"message"``), ``"crashed"`` or ``"time_limit"``.  A task failure is
        data, not an exception.

    Raises
    ------
    SolverError
        When Siconos is unavailable or the worker process itself fails.
    """
    packer = _Packer()
    job = [_job_task(t, packer) for t in tasks]
    results = _run_worker(job, packer.arrays, timeout=timeout)
    if len(results) != len(job):
        raise SolverError(f"Siconos worker returned {len(results)} results for {len(job)} tasks")
    return [_finish(t, r) for t, r in zip(job, results)]


def _single(task: dict) -> dict:
    res = siconos_batch([task])[0]
    if res.get("status") != "ok":
        raise SolverError(f"Siconos task {task['task']!r} failed ({res.get('status')}): "
                          f"{res.get('message', '')} {res.get('log', '')}".strip())
    return res


def siconos_load(path, kind=None) -> dict:
    """Read a problem file with Siconos' own reader.

    Parameters
    ----------
    path : str or Path
        Siconos ``.dat`` file (FCLib HDF5 files are read by socp_cd, not Siconos).
    kind : {"local", "global"}, optional
        Default: global when the file name starts with ``GFC``.

    Returns
    -------
    dict
        ``kind, dim, n_contacts, mu`` and, local, ``W`` (CSR), ``q``, ``storage``
        (Siconos storage: 0 dense, 1 sparse-block, 2 CSparse); global ``M``,
        ``H``, ``f``, ``w``.
    """
    res = _single({"task": "load", "problem": path, "kind": kind})
    for key in ("status", "wall_time"):
        res.pop(key, None)
    return res


def siconos_errors(problem, rs) -> np.ndarray:
    """Siconos' error (``fc3d_compute_error``; 2D ``fc2d_compute_error``) of each r.

    ``norm = ||q||`` is passed to Siconos as its solvers do; Siconos 4.4 divides
    the natural-map residual by ``max(norm, ||r||, ||u||)`` (absolute when that
    is below machine epsilon).

    Parameters
    ----------
    problem : path or FrictionContactProblem
        A local problem.
    rs : array_like, shape (k, m) or (m,)

    Returns
    -------
    ndarray, shape (k,)
    """
    res = _single({"task": "error", "problem": problem, "rs": rs})
    if res.get("errors") is None:
        raise UnsupportedError(res.get("message", "Siconos error not available"))
    return np.asarray(res["errors"], dtype=np.float64)


def siconos_solve(problem, solver: str, tol: float = 1e-8, max_iter: int = 10000,
                  time_limit: float | None = None, **params) -> dict:
    """Solve *problem* with a Siconos solver.

    Parameters
    ----------
    problem : path or problem object
    solver : str
        ``"nsgs"``, ``"nsn_ac"``, ``"admm"``, ``"aclmfp"``, ``"vi_fpp"``... (see
        :data:`SOLVERS`) or a Siconos constant name.
    tol, max_iter : Siconos ``dparam[SICONOS_DPARAM_TOL]`` and
        ``iparam[SICONOS_IPARAM_MAX_ITER]``.
    time_limit : float, optional
        Seconds; the task is killed past it (status ``"time_limit"``).
    **params
        ``iparam`` / ``dparam`` (``{index or constant name: value}``),
        ``internal_iparam`` / ``internal_dparam`` (first internal solver, e.g.
        NSGS's local solver), ``r0`` / ``u0`` / ``v0`` (initial guesses),
        ``kind``, ``storage`` (a local problem's ``W`` in Siconos' ``"dense"``,
        ``"sbm"`` (sparse-block, the storage its local solvers are written for;
        PFP accepts no other) or ``"csc"`` storage; None: as stored in a ``.dat``
        file, sparse-block when shipped as arrays), ``dense`` (older spelling of
        ``storage="dense"``), ``repeat`` (call the driver up to
        this many times from the same start, in one process, and report the
        fastest call: a per-call time without cold caches; repeating stops once
        the calls have taken 0.05 s; each call gets a fresh problem; local
        problems only: global drivers are called once).

    Returns
    -------
    dict
        ``status`` (``"ok"``, ``"error"``, ``"crashed"``, ``"time_limit"``),
        ``r``, ``u`` (``v``), ``info`` (Siconos return code, 0 = it claims
        convergence), ``iterations``, ``residual`` (Siconos' own final error,
        ``dparam[SICONOS_DPARAM_RESIDU]``), ``error`` (``fc3d_compute_error`` of
        the returned r), ``time`` (solver call alone), ``wall_time``,
        ``solver_name``.
    """
    unknown = set(params) - set(SOLVE_PARAMS)
    if unknown:
        raise UnsupportedError(f"unknown Siconos option(s): {', '.join(sorted(unknown))}")
    task = {"task": "solve", "problem": problem, "solver": solver, "tol": tol,
            "max_iter": max_iter, "time_limit": time_limit, **params}
    return siconos_batch([task])[0]


__all__ = ["family_of", "siconos_available", "siconos_python", "siconos_load", "siconos_errors",
           "siconos_solve", "siconos_batch", "SOLVERS", "worker_path", "REPEAT_BUDGET",
           "REPEAT_CALLS"]

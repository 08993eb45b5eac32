"""Helpers of the hostile-input tests: Siconos text writer, capped reading.

A reader that tries a huge allocation under the caps dies with MemoryError
(reported as ``"memory"``, or as ``InputTooLargeError`` by ``read_problem``)
instead of swapping the machine; one that hangs is stopped (``"timeout"``).
"""
from __future__ import annotations

import contextlib
import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

#: Address-space cap of a reading subprocess (Python + NumPy + SciPy + h5py need ~0.3 GB).
DEFAULT_CAP_MB = 1024


# ------------------------------------------------------------ Siconos text writer
def siconos_dense_text(W, q, mu, dim, trailing=None, layout="row") -> str:
    """A local problem laid out as Siconos ``frictionContact_printInFile`` writes it.

    ``layout="row"``: one line per W column, q and mu on one line each (Siconos 4);
    ``"column"``: one value per line (older files).  ``%.17g`` keeps every bit.
    """
    W = np.asarray(W, dtype=float)
    m = W.shape[0]
    vals = W.T.reshape(-1)  # column-major
    sep = " " if layout == "row" else "\n"
    fmt = "{:.17g}".format
    rows = [sep.join(fmt(v) for v in vals[k:k + m]) for k in range(0, vals.size, m)]
    lines = [str(dim), str(len(mu)), "0", str(m), str(m), f"{m}\t{m}", *rows,
             sep.join(fmt(v) for v in q), sep.join(fmt(v) for v in mu)]
    if trailing is not None:
        lines.append(trailing)
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------ in-process caps
def _vm_size() -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


class ReadTimeout(Exception):
    """Raised by :func:`capped` when the guarded block runs too long."""


@contextlib.contextmanager
def capped(extra_mb: int = 512, seconds: int = 20):
    """Limit the address space to its current size + *extra_mb* and the time to *seconds*.

    Only the soft limit is lowered, and restored on exit (single-threaded use).
    """
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = _vm_size() + (extra_mb << 20)
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)

    def on_alarm(signum, frame):
        raise ReadTimeout(f"still reading after {seconds} s")
    old = signal.signal(signal.SIGALRM, on_alarm)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
        signal.signal(signal.SIGALRM, old)


# ------------------------------------------------------------ capped subprocess
_CHILD = r"""
import json, resource, signal, sys
cap, per_case = int(sys.argv[1]) << 20, int(sys.argv[2])
resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
from socp_cd.errors import InputTooLargeError, SocpCdError
from socp_cd.io import read_problem

class Timeout(BaseException):
    pass

def alarm(signum, frame):
    raise Timeout()

def hwm_kb():
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) for line in fh if line.startswith("VmHWM:"))

def reset_hwm():  # the peak RSS (VmHWM) back to the current RSS: measure each read, not the imports
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass

signal.signal(signal.SIGALRM, alarm)
for path in sys.stdin.read().splitlines():
    reset_hwm()
    signal.alarm(per_case)
    try:
        p = read_problem(path)
        out = {"status": "ok", "m": int(p.m), "global": bool(p.is_global)}
    except InputTooLargeError as exc:
        out = {"status": "memory", "message": str(exc)[:2000]}
    except SocpCdError as exc:
        out = {"status": "error", "type": type(exc).__name__, "message": str(exc)[:2000]}
    except MemoryError:
        out = {"status": "memory"}
    except Timeout:
        out = {"status": "timeout"}
    except BaseException as exc:  # noqa: BLE001 - reported to the test, which fails on it
        out = {"status": "raw", "type": type(exc).__name__, "message": str(exc)[:2000]}
    signal.alarm(0)
    out["path"] = path
    out["maxrss_kb"] = hwm_kb()          # peak RSS during this read (imports excluded)
    print(json.dumps(out), flush=True)
"""


def read_many_capped(paths, cap_mb: int = DEFAULT_CAP_MB, per_case: int = 20,
                     timeout: float = 600.0) -> list:
    """Read every file of *paths* with ``read_problem`` in one capped subprocess.

    Returns
    -------
    list of dict
        One per path, in order; ``status`` is ``"ok"`` (a valid problem),
        ``"error"`` (a SocpCdError other than InputTooLargeError, with ``type``
        and ``message``), ``"memory"``, ``"raw"`` (any other exception),
        ``"timeout"`` (per case, or of the whole run) or ``"crash"`` (the
        interpreter died, e.g. a segfault in a C library, on that path).
    """
    paths = [str(p) for p in paths]
    repo = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=repo + os.pathsep + os.environ.get("PYTHONPATH", ""))
    try:
        proc = subprocess.run([sys.executable, "-c", _CHILD, str(cap_mb), str(per_case)],
                              input="\n".join(paths) + "\n", capture_output=True, text=True,
                              timeout=timeout, env=env, cwd=repo)
        stdout, stderr, rc = proc.stdout, proc.stderr, proc.returncode
    except subprocess.TimeoutExpired as exc:
        stdout = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        stderr, rc = "", "timeout"
    results = [json.loads(line) for line in stdout.splitlines() if line.startswith("{")]
    if len(results) < len(paths):
        results.append({"status": "crash" if rc != "timeout" else "timeout",
                        "path": paths[len(results)], "returncode": rc, "stderr": stderr[-2000:]})
        results += [{"status": "not run", "path": p} for p in paths[len(results):]]
    return results


def read_capped(path, cap_mb: int = DEFAULT_CAP_MB, timeout: float = 60.0) -> dict:
    """:func:`read_many_capped` for one file."""
    return read_many_capped([path], cap_mb, per_case=int(timeout), timeout=timeout + 30)[0]


_TRACE_CHILD = r"""
import json, sys, tracemalloc
from socp_cd.io import read_problem
import h5py, scipy.sparse  # imported before measuring

def status(key):
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith(key))

try:  # reset the peak RSS (VmHWM) to the current RSS
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")
except OSError:
    pass
rss0 = status("VmRSS:")
tracemalloc.start()
p = read_problem(sys.argv[1])
peak = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
hwm = status("VmHWM:")
import time
times = []
for _ in range(2):
    t0 = time.perf_counter()
    read_problem(sys.argv[1])
    times.append(time.perf_counter() - t0)
print(json.dumps({"traced_peak": peak, "maxrss_delta": hwm - rss0, "m": int(p.m), "time": min(times),
                  "module": read_problem.__module__, "file": sys.modules["socp_cd"].__file__}))
"""


def read_memory(path, python=sys.executable, pythonpath=None, timeout: float = 300.0) -> dict:
    """Memory needed to read *path*, measured in a fresh subprocess.

    Returns
    -------
    dict
        ``traced_peak``: peak bytes allocated while reading (tracemalloc, which
        NumPy reports to); ``maxrss_delta``: growth of the peak resident size
        (bytes, noisier: allocator caching); ``m``: unknowns of the problem;
        ``file``: the ``socp_cd/__init__.py`` that was imported; ``time``: min of two
        more reads, untraced (seconds).
    """
    repo = str(Path(__file__).resolve().parent.parent) if pythonpath is None else pythonpath
    env = dict(os.environ, PYTHONPATH=repo)
    proc = subprocess.run([python, "-c", _TRACE_CHILD, str(Path(path).resolve())],
                          capture_output=True, text=True, timeout=timeout, env=env, check=True,
                          cwd=repo)  # "-c" puts the working directory first on sys.path
    return json.loads(proc.stdout.strip().splitlines()[-1])


def dense_zeros_text(m: int) -> str:
    """A Siconos dense local problem whose W is diagonal, zeros written ``0``: short tokens."""
    nc = m // 3
    zeros = ["0"] * m
    lines = [str(3), str(nc), "0", str(m), str(m), f"{m}\t{m}"]
    for j in range(m):
        col = list(zeros)
        col[j] = "2"
        lines.append(" ".join(col))
    lines += [" ".join(["-1"] * m), " ".join(["0.3"] * nc)]
    return "\n".join(lines) + "\n"

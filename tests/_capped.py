"""Run a problem reader in a subprocess with capped address space and a timeout.

Used by the hostile-input tests: a reader that tries a huge allocation dies
with MemoryError (reported as ``"memory"``) instead of swapping the machine,
and one that hangs is killed (``"timeout"``).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

#: Address-space cap of the reading subprocess (Python + NumPy + SciPy + h5py need ~0.3 GB).
DEFAULT_CAP_MB = 1024

_CHILD = r"""
import json, resource, sys
cap = int(sys.argv[2]) << 20
resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
from socp_cd.errors import SocpCdError
from socp_cd.io import read_problem
out = {}
try:
    p = read_problem(sys.argv[1])
    out = {"status": "ok", "m": int(p.m), "global": bool(p.is_global)}
except SocpCdError as exc:
    out = {"status": "error", "type": type(exc).__name__, "message": str(exc)[:2000]}
except MemoryError:
    out = {"status": "memory"}
except BaseException as exc:  # noqa: BLE001 - reported to the test, which fails on it
    out = {"status": "raw", "type": type(exc).__name__, "message": str(exc)[:2000]}
out["maxrss_kb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps(out))
"""


def read_capped(path, cap_mb: int = DEFAULT_CAP_MB, timeout: float = 60.0) -> dict:
    """Read *path* with :func:`socp_cd.io.read_problem` in a capped subprocess.

    Returns
    -------
    dict
        ``status`` is ``"ok"`` (a valid problem), ``"error"`` (a SocpCdError,
        with ``type`` and ``message``), ``"memory"`` (raw MemoryError),
        ``"raw"`` (any other exception), ``"timeout"`` or ``"crash"``
        (the interpreter died, e.g. a segfault in a C library).
    """
    repo = str(Path(__file__).resolve().parent.parent)
    env = dict(os.environ, PYTHONPATH=repo + os.pathsep + os.environ.get("PYTHONPATH", ""))
    try:
        proc = subprocess.run([sys.executable, "-c", _CHILD, str(path), str(cap_mb)],
                              capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return {"status": "timeout"}
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        return {"status": "crash", "returncode": proc.returncode, "stderr": proc.stderr[-2000:]}
    return json.loads(lines[-1])

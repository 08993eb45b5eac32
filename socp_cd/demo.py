"""The ``make demo`` job: inspect a real problem and solve it two ways."""
from __future__ import annotations

from pathlib import Path

import numpy as np

DEMO_PROBLEM = "Capsules-i122-1617.dat"


def _row(label, values, width=22):
    return f"{label:24s}" + "".join(f"{v:>{width}s}" for v in values)


def run_demo(data_dir: Path, name: str = DEMO_PROBLEM, tol: float = 1e-8) -> int:
    """Load ``name`` from ``data_dir``, print its properties and compare solvers.

    Prints the problem summary, the Siconos error of the zero reaction, then
    solves with the Clarabel De Saxcé fixed point and with NSGS and prints
    error, iterations, time and the discrepancy in ``u`` side by side.

    Returns
    -------
    int
        0 when both solvers converged, 1 otherwise.
    """
    import socp_cd

    path = Path(data_dir) / name
    if not path.exists():
        print(f"demo: {path} not found (pass --data DIR with the shared problems)")
        return 2
    p = socp_cd.read_problem(path)
    print(f"Problem {path.name}")
    for k, v in p.summary().items():
        print(f"  {k:16s} {v}")
    r0 = np.zeros(p.m)
    print(f"  {'error(r = 0)':16s} {socp_cd.error(p, r0):.6e}")
    print()
    results = {}
    for solver in ("clarabel", "nsgs"):
        if solver not in socp_cd.solvers():
            print(f"solver {solver!r} is not available")
            continue
        opts = {"max_iter": 100000} if solver == "nsgs" else {}
        results[solver] = socp_cd.solve(p, solver=solver, tol=tol, **opts)
    if not results:
        return 1
    names = list(results)
    print(_row("", [f"{n} (coulomb)" for n in names]))
    print(_row("status", [results[n].status for n in names]))
    print(_row("Siconos error", [f"{results[n].error:.3e}" for n in names]))
    print(_row("iterations", [str(results[n].iterations) for n in names]))
    print(_row("time [s]", [f"{results[n].time:.4f}" for n in names]))
    if len(names) == 2:
        a, b = (results[n].u for n in names)
        disc = np.linalg.norm(a - b) / max(np.linalg.norm(b), np.finfo(float).tiny)
        print(f"{'||u_clarabel - u_nsgs|| / ||u_nsgs||':40s} {disc:.3e}")
    return 0 if all(r.converged for r in results.values()) else 1

"""Per-call wall time of ``socp_cd.solve`` on the small shared problems, for interleaved rounds.

Prints one line per run: for each problem, the min over 5 × 5 000 calls of
``solve(p)`` (the same problem object), ``solve(copy.copy(p), time_limit=1)``
(a new problem per call, the benchmark's call) and ``solve(p, "nsgs")``, in µs,
then the benchmark's call again with the copies made before the timer, as the
benchmark makes them (``validation/newton_vs_siconos.py``): the second column
also times ``copy.copy`` itself (~1.4 µs) and its effect on the caches; then (since
session 22) ``solve(p, "newton")`` (min over 5 × 2 000 calls).
Compare two trees in alternating rounds on the same machine (the README's
session-9 table: two rounds each)::

    for k in 1 2; do for d in /tmp/old_tree $PWD; do
        PYTHONPATH=$d python validation/per_call_rounds.py; done; done

Appends each line, with the tree it ran, to ``validation/results/per_call_rounds.txt``.
"""
from __future__ import annotations

import copy
import gc
import time
import timeit
from pathlib import Path

import socp_cd
from socp_cd.data import shared_problems_dir

PROBLEMS = ["FrictionContact3D_1c.dat", "FrictionContact3D_RR_1c.dat", "Rover11035.dat",
            "FC3D_Example1.dat", "Rover4396.dat"]


def per_call(f, number=5000, repeat=5) -> float:
    """Min over ``repeat`` loops of ``number`` calls, µs per call."""
    return min(timeit.repeat(f, number=number, repeat=repeat)) / number * 1e6


def per_call_fresh(p, number=5000, repeat=5) -> float:
    """Min over ``repeat`` loops of ``number`` calls ``solve(copy, time_limit=1)``, µs per
    call, the copies made before the timer (garbage collection off during the calls, as
    ``timeit``, and left as it was).  Also the per-call measure of
    ``validation/per_call_ab.py`` and the benchmark's ``calibration_call``."""
    best = float("inf")
    was = gc.isenabled()
    for _ in range(repeat):
        copies = [copy.copy(p) for _ in range(number)]
        gc.disable()
        try:
            t0 = time.perf_counter()
            for c in copies:
                socp_cd.solve(c, time_limit=1.0)
            best = min(best, time.perf_counter() - t0)
        finally:
            if was:
                gc.enable()
    return best / number * 1e6


def main() -> int:
    out = []
    for name in PROBLEMS:
        p = socp_cd.read_problem(shared_problems_dir() / name)
        socp_cd.solve(p)
        socp_cd.solve(p, "nsgs")
        socp_cd.solve(p, "newton")
        same = per_call(lambda: socp_cd.solve(p))
        fresh = per_call(lambda: socp_cd.solve(copy.copy(p), time_limit=1.0))
        nsgs = per_call(lambda: socp_cd.solve(p, "nsgs"))
        outside = per_call_fresh(p)
        newton = per_call(lambda: socp_cd.solve(p, "newton"), number=2000)
        out.append(f"{name}:{same:.1f}/{fresh:.1f}/{nsgs:.1f}/{outside:.1f}/{newton:.1f}")
    line = f"{Path(socp_cd.__file__).resolve().parents[1]} " + " ".join(out)
    print(line)
    results = Path(__file__).resolve().parent / "results"
    results.mkdir(exist_ok=True)
    with open(results / "per_call_rounds.txt", "a") as fh:
        fh.write(line + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Per-call wall time of a plain ``solve`` on tiny shared problems (three of one contact,
FC3D_Example1 of three): two trees, alternating.

The benchmark's call (``solve(copy.copy(p), time_limit=1.0)``, the copies made before the
timer), min over ``--loops`` loops of ``--number`` calls with garbage collection off, in a
fresh process per tree and round; the processes alternate (A, B, A, B, ...), so both trees
see the same load.  Min over rounds, per problem::

    git worktree add /tmp/base HEAD~1
    .venv/bin/python validation/per_call_ab.py --trees /tmp/base . --rounds 4 \\
        --out validation/results/per_call_ab_s27.md

(``validation/per_call_rounds.py`` times more call forms, with fewer, longer loops.)
"""
from __future__ import annotations

import argparse
import copy
import gc
import os
import subprocess
import sys
from pathlib import Path

PROBLEMS = ["FrictionContact3D_1c.dat", "FrictionContact3D_RR_1c.dat", "Rover11035.dat",
            "FC3D_Example1.dat"]


def measure(names, loops, number) -> list[float]:
    """µs per call of each problem in ``names`` (this process's ``socp_cd``)."""
    import socp_cd
    from per_call_rounds import per_call_fresh      # (this folder: the same loop)
    from socp_cd.data import shared_problems_dir
    problems = [socp_cd.read_problem(shared_problems_dir() / n) for n in names]
    for p in problems:                      # JIT, caches, the plain call's prepared arguments
        for _ in range(500):
            socp_cd.solve(copy.copy(p), time_limit=1.0)
    best = [float("inf")] * len(problems)
    gc.disable()
    try:
        for _ in range(loops):
            for i, p in enumerate(problems):    # (interleaved: a slow spell hits them all)
                best[i] = min(best[i], per_call_fresh(p, number, repeat=1))
    finally:
        gc.enable()
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trees", nargs=2, type=Path, help="two source trees (A B)")
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--loops", type=int, default=40)
    ap.add_argument("--number", type=int, default=500)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(" ".join(f"{t:.3f}" for t in measure(PROBLEMS, args.loops, args.number)))
        return
    from socp_cd.bench.reports import emit
    from socp_cd.data import shared_problems_dir
    data = shared_problems_dir()
    if data is None:
        raise SystemExit("per_call_ab: shared data not found (set SOCP_CD_DATA)")
    trees = [t.resolve() for t in args.trees]
    rows = {t: [] for t in trees}
    for k in range(args.rounds):
        for t in trees:
            # (the shared data where this tree finds them: a worktree elsewhere would not)
            env = dict(os.environ, PYTHONPATH=str(t), SOCP_CD_DATA=str(data))
            out = subprocess.run([sys.executable, __file__, "--child", "--loops", str(args.loops),
                                  "--number", str(args.number)], env=env, cwd="/",
                                 capture_output=True, text=True, check=True).stdout.split()
            rows[t].append([float(x) for x in out])
            print(f"round {k + 1} {t}: {' '.join(out)}", flush=True)
    a, b = trees
    best = {t: [min(r[i] for r in rows[t]) for i in range(len(PROBLEMS))] for t in trees}
    lines = [f"# Per-call time of a plain `solve`, tiny shared problems (1, 1, 1, 3 contacts): two trees",
             "",
             f"`python validation/per_call_ab.py --trees A B --rounds {args.rounds} --loops "
             f"{args.loops} --number {args.number}`; A = `{a}`, B = `{b}`. µs per call, min over "
             "rounds of the min over loops (each round a fresh process per tree, alternating).",
             "", "| problem | A | B | B / A | B's rounds |", "|---|---|---|---|---|"]
    for i, n in enumerate(PROBLEMS):
        lines.append(f"| {n} | {best[a][i]:.2f} | {best[b][i]:.2f} | {best[b][i] / best[a][i]:.3f} "
                     f"| {', '.join(f'{r[i]:.2f}' for r in rows[b])} |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()

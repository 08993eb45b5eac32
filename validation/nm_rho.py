"""The natural map's parameter: ours against Siconos NSN_NM's default, on the same Newton loop.

``solver="newton", equation="natural_map"`` takes ``rho_i = 1/s_i`` per contact in the
balanced units (``rho="block"``, ``s_i`` the scale of ``W``'s diagonal block); Siconos
NSN_NM takes ``rho = 1`` for every contact in the units of the problem as written
(``fc3d_nsn_nm_set_default``).  On the dispatcher's balanced copy (``r = a r~``,
``u = b u~``) the latter is ``rho~_i = b_i / a_i``.  This study runs the same loop (plain
steps, ``formulations/newton.md`` §8, §13) with each, from ``r = 0``, on the local 3D cases
of a split of the evaluation set (1 s; 10 s above 250 contacts), judged by Siconos' error
and the units guard of the answer mapped back::

    python validation/nm_rho.py --split tune --out results/nm_rho_tune.md

Siconos' value is passed as the option ``rho=1.0`` (values in the problem's units; since
session 36, before which the study swapped a private function of the solver).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.reports import emit
from socp_cd.data import shared_problems_dir
from socp_cd.solvers import newton
from socp_cd.solvers.scaling import balanced, origin

HERE = Path(__file__).resolve().parent


def run(p, mode, limit, tol):
    """``(solved, max(error, guard), seconds)`` of plain natural-map steps with ``mode``'s rho."""
    cp = balanced(p).problem
    a, _, _ = origin(cp)
    # (Siconos' rho = 1 as written: the backend maps it onto the balanced copy, rho b / a)
    t0 = time.perf_counter()
    res = newton.newton_backend(cp, "coulomb", tol=tol, max_iter=10_000, time_limit=limit,
                                policy="plain", equation="natural_map",
                                rho=1.0 if mode == "siconos" else "block")
    wall = time.perf_counter() - t0
    r = a * res.r
    worst = max(socp_cd.error(p, r), socp_cd.guard(p, r)["value"])
    return worst <= tol, worst, wall


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", choices=("tune", "holdout", "all"), default="tune")
    ap.add_argument("--family", default="", help="only the cases whose id contains this")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    out = args.out if args.out.is_absolute() else HERE / args.out
    cases = [c for c in evalset.manufactured_cases(shared_problems_dir())
             if (args.split == "all" or c.split == args.split) and args.family in c.case_id]
    socp_cd.warmup()
    modes = ("ours", "siconos")
    solved = dict.fromkeys(modes, 0)
    diff, n = [], 0
    for c in cases:
        p = c.problem()
        if p.is_global or p.dim != 3:
            continue
        n += 1
        limit = 10.0 if c.n_contacts > 250 else 1.0
        got = {m: run(p, m, limit, args.tol) for m in modes}
        for m in modes:
            solved[m] += got[m][0]
        if got["ours"][0] != got["siconos"][0] or args.family:
            diff.append(f"| {c.case_id} | " + " | ".join(
                f"{'solved' if got[m][0] else 'missed'}, {got[m][1]:.1e}, {got[m][2]:.2f} s"
                for m in modes) + " |")
        print(c.case_id, got, flush=True)
    command = "python validation/nm_rho.py " + " ".join(argv if argv is not None else sys.argv[1:])
    lines = [f"# The natural map's rho: ours against Siconos NSN_NM's ({args.split} split)", "",
             f"`{command}`; plain natural-map steps from `r = 0`, tol {args.tol:g}, 1 s (10 s "
             "above 250 contacts); solved = Siconos' error and the units guard of the answer "
             "mapped back.", "",
             f"Local 3D cases: {n}. Solved: ours (`1/s_i`, balanced) {solved['ours']}, "
             f"Siconos' (`1` as written) {solved['siconos']}.", "",
             "| case | ours: outcome, max(error, guard), time | Siconos' rho: same |",
             "|---|---|---|"] + diff
    emit(lines, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The left-looking LU against SuperLU where session 38's rule picks SuperLU (session 39).

Session 38 set ``sparse_lu.LEFT_LOOKING_MAX_FLOPS_PER_ROW = 200`` against SuperLU ordering
each matrix by COLAMD, on fresh factorizations.  Since session 39 both LUs factorize in one
order per solve (minimum degree of ``A + Aᵀ``), SuperLU with no ordering of its own, and
the Newton steps after the first are mostly refactorizations for the left-looking LU.  This
script asks whether the threshold still separates the two where it matters: the problems
whose ordering costs more than 200 multiply-adds per row (the 2D deposits, the Kapla
tower).  For each, whole ``solve(p, "newton", tol=1e-8, time_limit=30)`` runs with
``linear_solver="left_looking"`` and ``"splu"``, interleaved in one process, min of
``--repeats`` after a warm-up call each; beside them the ordering's multiply-adds per row
and the left-looking LU's refactorizations.

Split: ``tune`` — the Kapla tower, the first 1 000-grain deposit step (session 38's tune
problems) and the steps of ``evalset_sim_tune/deposit2d-tune-1500``
(``build_sim_collections.py --tune``: another size and packing seed, made for tuning);
``holdout`` — the other 1 000-grain deposit steps and the 4 000-grain step of
``sparse_lu_choice.py``'s list.

    python validation/ll_threshold.py [--repeats 3] [--out validation/results/ll_threshold]
"""
from __future__ import annotations

import argparse
import glob
import os
import sys
import time

import numpy as np
import scipy.sparse as sp

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

import socp_cd  # noqa: E402
from socp_cd.bench.reports import emit  # noqa: E402
from socp_cd.io import read_problem  # noqa: E402
from socp_cd.solvers import newton, sparse_lu  # noqa: E402
from sparse_lu_choice import SHARED, problem_list  # noqa: E402


def problems():
    """``(split, path)`` of the problems, tune first."""
    items = [("tune", os.path.join(SHARED, "KaplasTower-i1061-4.hdf5.dat"))]
    tune_dep = sorted(glob.glob(os.path.join(HERE, "evalset_sim_tune", "deposit2d-tune-1500",
                                             "*.hdf5")))
    items += [("tune", f) for f in tune_dep]
    for split, path in problem_list(False):
        if "Deposit2D" in path:
            items.append((split, path))
    return items


def flops_per_row(p):
    """The ordering's multiply-adds per row on the Newton matrix's block pattern (the
    quantity :class:`~socp_cd.solvers.sparse_lu.NewtonLU` chooses by)."""
    jac = newton.BlockJacobian(sp.csr_matrix(p.W, dtype=np.float64), p.dim)
    lu = sparse_lu.NewtonLU(jac.indptr, jac.indices, p.m, newton.SPLU_OPTIONS, "splu",
                            block=p.dim)
    return lu.flops / p.m


def whole(p, repeats):
    """``{ls: (min time, status, error, steps, refactorizations)}`` for both LUs."""
    for ls in ("left_looking", "splu"):
        socp_cd.solve(p, "newton", tol=1e-8, linear_solver=ls, time_limit=30)
    times = {"left_looking": [], "splu": []}
    last = {}
    for _ in range(repeats):
        for ls in ("left_looking", "splu"):
            t = time.perf_counter()
            r = socp_cd.solve(p, "newton", tol=1e-8, linear_solver=ls, time_limit=30)
            times[ls].append(time.perf_counter() - t)
            last[ls] = r
    return {ls: (min(times[ls]), last[ls].status, last[ls].error,
                 last[ls].info.get("newton_steps"), last[ls].info.get("lu_refactorizations"))
            for ls in times}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(HERE, "results", "ll_threshold"))
    args = ap.parse_args(argv)
    rows = ["| split | problem | m | flops/row | left-looking: time (s), status, error, steps, "
            "refactorized | SuperLU: time (s), status, error, steps | ratio LL / SuperLU |",
            "|---|---|---|---|---|---|---|"]
    points = []
    for split, path in problems():
        p = read_problem(path)
        fpr = flops_per_row(p)
        if fpr <= sparse_lu.LEFT_LOOKING_MAX_FLOPS_PER_ROW:
            print(os.path.basename(path), f"{fpr:.0f} per row: the left-looking LU already",
                  flush=True)
            continue
        w = whole(p, args.repeats)
        ll, su = w["left_looking"], w["splu"]
        ratio = ll[0] / su[0]
        points.append((split, fpr, ratio))
        rows.append(f"| {split} | {os.path.basename(path)} | {p.m} | {fpr:.0f} | "
                    f"{ll[0]:.3f}, {ll[1]}, {ll[2]:.1e}, {ll[3]}, {ll[4]} | "
                    f"{su[0]:.3f}, {su[1]}, {su[2]:.1e}, {su[3]} | {ratio:.2f} |")
        print(rows[-1], flush=True)
    summary = []
    for split in ("tune", "holdout"):
        pts = sorted((f, r) for s, f, r in points if s == split)
        if pts:
            summary.append(f"- {split}: " + "; ".join(f"{f:.0f} per row ×{r:.2f}" for f, r in pts))
    emit(["# The left-looking LU against SuperLU above session 38's threshold", "",
          "Generated by `validation/ll_threshold.py` (module docstring: what is timed; min of "
          f"{args.repeats}, the two interleaved). Ratio below 1: the left-looking LU is faster. "
          "Time-limited runs compare steps, not times.", "", *summary, "", *rows],
         args.out + ".md")
    return 0


if __name__ == "__main__":
    sys.exit(main())

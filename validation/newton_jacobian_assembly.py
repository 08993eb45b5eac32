"""Whole ``solver="newton"`` solves with the compiled sparse Jacobian assembly vs scipy's product.

On the sparse path the local Newton matrix ``J = Dr + Du (W + alpha I)`` is
assembled by :class:`socp_cd.solvers.newton.BlockJacobian` (a compiled kernel
on ``W``'s block pattern, one gather into CSC arrays computed once, stored
zeros dropped).  Before, it was scipy's ``(Dr + alpha Du) + Du @ W`` with
block-diagonal BSR factors, then ``tocsc()``.  Both give the same matrix
(``tests/test_newton.py``), so the iterates are the same; this script measures
what the assembly costs in whole solves: every problem of shared/ and of the
evaluation set's manufactured cases (seeds 0-1) whose Newton run takes the
sparse path, each solved alternately with both assemblies in the same process,
min of ``--repeats`` wall times, time limit 3 s, SuperLU (``linear_solver="splu"``, the
factorization of the sparse path when this was measured, session 16).  Both sides pay the new assembly's
one-time set-up (pattern and gather, 0.15–1.4 ms per solve on these problems, the cost
of 2–4 assemblies), which the former code did not: the ratios overstate the gain by
that much.

Writes ``validation/results/newton_jacobian_assembly.{csv,md}``.
Usage: ``python validation/newton_jacobian_assembly.py [--repeats 3]``
"""
from __future__ import annotations

import argparse
import csv
import math
import statistics
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import socp_cd
from socp_cd.bench import evalset
from socp_cd.data import shared_problems, shared_problems_dir
from socp_cd.solvers import newton, sparse_lu

# session 16's path, where SuperLU gets the assembled matrix and orders it on each call (since
# session 39 SuperLU's default input is built from the block values in the solve's order)
sparse_lu.SPLU_ORDER_ONCE = False

OUT = Path(__file__).resolve().parent / "results"


def scipy_matrix(self, Dr, Du, alpha):
    """The former assembly: scipy's product of block-diagonal BSR factors with ``W``."""
    nc = Dr.shape[0]
    ind, ptr = np.arange(nc, dtype=np.int32), np.arange(nc + 1, dtype=np.int32)
    Dr_s = sp.bsr_matrix((Dr + alpha * Du, ind, ptr), shape=self.shape)
    Du_s = sp.bsr_matrix((Du, ind, ptr), shape=self.shape)
    return (Dr_s.tocsr() + Du_s.tocsr() @ self.W).tocsc()


def problems(seeds):
    for path in shared_problems():
        yield "shared", path.file, socp_cd.read_problem(path)
    cases = evalset.manufactured_cases(shared_problems_dir(), seeds=range(seeds))
    for case, p in evalset.iter_problems(cases):
        yield case.split, case.case_id, p


def timed(p, repeats, time_limit):
    best, res = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = socp_cd.solve(p, solver="newton", time_limit=time_limit, linear_solver="splu")
        best = min(best, time.perf_counter() - t0)
    return best, res


def install(fn):
    """SuperLU's matrix of the sparse path built by ``fn(self, Dr, Du, alpha)``:
    ``BlockJacobian.values`` records its arguments, and the sparse LU's matrix builder
    (``sparse_lu.csc_without_zeros``, which ``NewtonLU.solve`` calls for SuperLU when SuperLU
    orders each matrix itself: ``SPLU_ORDER_ONCE = False`` above, ``linear_solver="splu"``)
    returns ``fn``'s matrix instead.  (Until session 42 ``NewtonLU.solve`` took the matrix as a
    callable, ``BlockJacobian.current``, which this study swapped.)"""
    state = {}

    def values(self, Dr, Du, alpha):
        state["jacobian"], state["args"] = self, (Dr, Du, alpha)
        VALUES(self, Dr, Du, alpha)

    def build(data, indices, indptr, n):
        state["calls"] = state.get("calls", 0) + 1
        return fn(state["jacobian"], *state["args"])

    newton.BlockJacobian.values = values
    sparse_lu.csc_without_zeros = build
    return state


VALUES, BUILD = newton.BlockJacobian.values, sparse_lu.csc_without_zeros


def run(args, compiled):
    """The measured rows (both assemblies alternately on every sparse-path problem)."""
    socp_cd.solve(socp_cd.read_problem(shared_problems()[0]), solver="newton")
    rows = []
    for part, name, p in problems(args.seeds):
        if p.is_global or p.m <= newton.DENSE_ALWAYS_M:
            continue
        first = socp_cd.solve(p, solver="newton", max_iter=1, linear_solver="splu")
        if first.info.get("linear_solver") != "splu":
            continue
        out = {}
        for label, fn in (("scipy", scipy_matrix), ("compiled", compiled), ):
            state = install(fn)
            timed(p, 1, args.time_limit)                       # warm (caches, JIT)
            out[label] = timed(p, args.repeats, args.time_limit)
            if not state.get("calls"):
                raise SystemExit("the swapped assembly was never called: the study measures nothing")
        install(compiled)
        (ts, rs), (tc, rc) = out["scipy"], out["compiled"]
        rows.append({"part": part, "problem": name, "m": p.m, "scipy_s": ts, "compiled_s": tc,
                     "ratio": tc / ts, "scipy_error": rs.error, "compiled_error": rc.error,
                     "scipy_status": rs.status, "compiled_status": rc.status,
                     "factorizations": rc.info.get("factorizations")})
        print(part, name, p.m, f"{ts:.4f}", f"{tc:.4f}", f"{tc / ts:.2f}", rs.status, rc.status,
              flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--time-limit", type=float, default=3.0)
    args = ap.parse_args(argv)
    compiled = newton.BlockJacobian.matrix
    original_init = newton.BlockJacobian.__init__

    def init_keeping_w(self, W, d, pattern=None):
        original_init(self, W, d, pattern)
        self.W = W

    newton.BlockJacobian.__init__ = init_keeping_w
    try:
        rows = run(args, compiled)
    finally:
        newton.BlockJacobian.__init__ = original_init
        newton.BlockJacobian.values, sparse_lu.csc_without_zeros = VALUES, BUILD
    if not rows:
        raise SystemExit("no problem took Newton's sparse path")
    OUT.mkdir(exist_ok=True)
    with open(OUT / "newton_jacobian_assembly.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["# Newton's sparse Jacobian: compiled assembly vs scipy's product "
             "(`validation/newton_jacobian_assembly.py`)", "",
             f"Whole `solver=\"newton\"` solves (time limit {args.time_limit:g} s), min of "
             f"{args.repeats}, both assemblies alternately in one process. Both sides pay the "
             "new assembly's one-time set-up (0.15–1.4 ms per solve, 2–4 assemblies' worth), "
             "which the former code did not: the ratios overstate the gain by that much.", "",
             "| part | problems | time ratio compiled / scipy: gmean | median | best | worst | "
             "same status |", "|---|---|---|---|---|---|---|"]
    for part in ("shared", "tune", "holdout"):
        sel = [r for r in rows if r["part"] == part]
        if not sel:
            continue
        rat = [r["ratio"] for r in sel]
        gm = math.exp(statistics.fmean(math.log(x) for x in rat))
        same = sum(r["scipy_status"] == r["compiled_status"] for r in sel)
        lines.append(f"| {part} | {len(sel)} | {gm:.2f} | {statistics.median(rat):.2f} | "
                     f"{min(rat):.2f} | {max(rat):.2f} | {same} of {len(sel)} |")
    (OUT / "newton_jacobian_assembly.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""SuperLU settings for the Newton matrices of ``solver="newton"``: time, fill and accuracy.

``solver="newton"`` factorizes one sparse matrix per Newton step when the
local problem is too large for the dense path (``J = Dr + Du (W + alpha I)``,
:class:`socp_cd.solvers.newton`'s local system) and on a global problem
solved natively (the saddle-point matrix of ``M v = H r + f``,
``u = Hᵀ v + w``).  Both have the sparsity pattern of a symmetric matrix
(up to the block-diagonal ``Du``).  SuperLU's defaults (COLAMD on ``AᵀA``,
partial pivoting) ignore that; its documented settings for such matrices are
the minimum-degree ordering on ``Aᵀ + A`` with a preference for diagonal
pivots (``diag_pivot_thresh``, ``SymmetricMode``).

The script captures the matrices Newton factorizes (first, middle and last
factorization of a run) on every problem whose Newton run takes the sparse
path: shared/ and the evaluation set's tune split ("chosen on") and its
holdout split plus the simulation collections ("held out"), then factorizes
each capture with every candidate setting: min of 3 wall times, fill
``nnz(L) + nnz(U)``, relative residual ``||J x - b|| / ||b||`` of a solve
with a random right-hand side, and failures (SuperLU's singular-matrix
error).  Writes ``validation/results/newton_splu_options.{csv,md}``.

Usage: ``python validation/newton_splu_options.py [--seeds 2] [--sim evalset_sim]``
"""
from __future__ import annotations

import argparse
import csv
import math
import statistics
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.bench import evalset
from socp_cd.data import shared_problems, shared_problems_dir
from socp_cd.solvers import newton, sparse_lu

HERE = Path(__file__).resolve().parent
OUT = HERE / "results"

#: candidate settings: name -> keyword arguments of ``scipy.sparse.linalg.splu``
CANDIDATES = {
    "colamd": dict(permc_spec="COLAMD"),
    "colamd_sym": dict(permc_spec="COLAMD", diag_pivot_thresh=0.1,
                       options=dict(SymmetricMode=True)),
    "mmd_at_plus_a": dict(permc_spec="MMD_AT_PLUS_A"),
    "mmd_at_plus_a_sym": dict(permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                              options=dict(SymmetricMode=True)),
}


def capture(problem, time_limit):
    """The matrices ``solver="newton"`` factorizes on ``problem`` (first, middle, last)."""
    seen = []
    original = spla.splu

    def spy(A, **kw):
        seen.append(A.copy())
        return original(A, **kw)

    newton.spla.splu = spy
    # (session 38's SuperLU path: each Newton matrix as it is, stored zeros dropped; since
    # session 39 the default computes an ordering by factorizing an artificial matrix of
    # the pattern, then gives SuperLU the matrices permuted into it, which the spy would see)
    once, sparse_lu.SPLU_ORDER_ONCE = sparse_lu.SPLU_ORDER_ONCE, False
    try:
        # (SuperLU forced: the default takes the left-looking LU on low-fill patterns, and its
        # choice factorizes an artificial matrix of the pattern through splu, session 38)
        socp_cd.solve(problem, solver="newton", time_limit=time_limit, linear_solver="splu")
    finally:
        sparse_lu.SPLU_ORDER_ONCE = once
        newton.spla.splu = original
    if not seen:
        return []
    picks = sorted({0, len(seen) // 2, len(seen) - 1})
    return [seen[k] for k in picks]


def measure(A, kw, rng):
    """``(seconds, fill, relative residual)`` of SuperLU with ``kw`` on ``A``; None on failure."""
    b = rng.standard_normal(A.shape[0])
    best = math.inf
    lu = None
    for _ in range(3):
        t0 = time.perf_counter()
        try:
            lu = spla.splu(A, **kw)
        except RuntimeError:
            return None
        best = min(best, time.perf_counter() - t0)
    x = lu.solve(b)
    res = float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))
    return best, int(lu.L.nnz + lu.U.nnz), res


def problems(args):
    """``(part, name, problem)``: part "chosen on" (shared, tune) or "held out"."""
    for path in shared_problems():
        yield "chosen on", path.file, socp_cd.read_problem(path)
    cases = evalset.manufactured_cases(shared_problems_dir(), seeds=range(args.seeds))
    for case, p in evalset.iter_problems(cases):
        yield ("chosen on" if case.split == "tune" else "held out"), case.case_id, p
    if args.sim:
        folder = HERE / args.sim
        if folder.is_dir():
            for sub in sorted(x for x in folder.iterdir() if x.is_dir()):
                for case, p in evalset.iter_problems(evalset.collection_cases(sub)):
                    yield "held out", case.case_id, p


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=2, help="manufactured seeds per real file and mu")
    ap.add_argument("--sim", default="evalset_sim", help="simulation collections folder")
    ap.add_argument("--time-limit", type=float, default=0.3, help="of each capturing Newton run")
    ap.add_argument("--min-m", type=int, default=newton.DENSE_ALWAYS_M + 1,
                    help="skip problems of fewer unknowns (dense path)")
    ap.add_argument("--max-m", type=int, default=6000)
    args = ap.parse_args(argv)
    socp_cd.solve(socp_cd.read_problem(next(iter(shared_problems()))), solver="newton")
    rng = np.random.default_rng(0)
    rows = []
    for part, name, p in problems(args):
        if not args.min_m <= p.m <= args.max_m:
            continue
        for k, A in enumerate(capture(p, args.time_limit)):
            row = {"part": part, "problem": name, "global": p.is_global, "n": A.shape[0],
                   "nnz": A.nnz, "capture": k}
            for c, kw in CANDIDATES.items():
                got = measure(A, kw, rng)
                row[f"{c}_ms"] = got[0] * 1e3 if got else math.inf
                row[f"{c}_fill"] = got[1] if got else -1
                row[f"{c}_res"] = got[2] if got else math.inf
            rows.append(row)
            print(part, name, A.shape[0], A.nnz,
                  " ".join(f"{c}={row[c + '_ms']:.2f}ms" for c in CANDIDATES), flush=True)
    OUT.mkdir(exist_ok=True)
    with open(OUT / "newton_splu_options.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    write_report(rows)
    return 0


def write_report(rows):
    lines = ["# SuperLU settings for Newton's matrices (`validation/newton_splu_options.py`)", "",
             "Each row: the matrices captured from `solver=\"newton\"` runs (first, middle, last "
             "factorization), factorized with each setting; time = min of 3. Ratios are "
             "against the current setting (`colamd`); geometric means over the captures.", ""]
    for part in ("chosen on", "held out"):
        for glob in (False, True):
            sel = [r for r in rows if r["part"] == part and r["global"] == glob]
            if not sel:
                continue
            lines += [f"## {part}, {'global (saddle point)' if glob else 'local'}: "
                      f"{len(sel)} matrices from {len({r['problem'] for r in sel})} problems, "
                      f"n = {min(r['n'] for r in sel)}–{max(r['n'] for r in sel)}", "",
                      "| setting | failures | time ratio (gmean) | worst time ratio | "
                      "time ratio on captures ≥ 1 ms | fill ratio (gmean) | worst residual |",
                      "|---|---|---|---|---|---|---|"]
            for c in CANDIDATES:
                ok = [r for r in sel if math.isfinite(r[f"{c}_ms"]) and math.isfinite(r["colamd_ms"])]
                ratios = [r[f"{c}_ms"] / r["colamd_ms"] for r in ok]
                big = [r[f"{c}_ms"] / r["colamd_ms"] for r in ok if r["colamd_ms"] >= 1.0]
                fills = [r[f"{c}_fill"] / r["colamd_fill"] for r in ok]
                fails = sum(1 for r in sel if not math.isfinite(r[f"{c}_ms"]))
                gm = (lambda xs: math.exp(statistics.fmean(math.log(x) for x in xs)) if xs
                      else math.nan)
                lines.append(f"| {c} | {fails} | {gm(ratios):.2f} | "
                             f"{max(ratios, default=math.nan):.2f} | "
                             f"{gm(big):.2f} ({len(big)}) | {gm(fills):.2f} | "
                             f"{max((r[f'{c}_res'] for r in ok), default=math.nan):.1e} |")
            lines.append("")
    (OUT / "newton_splu_options.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    raise SystemExit(main())

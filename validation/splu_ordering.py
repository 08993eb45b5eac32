"""SuperLU's ordering for the sparse Newton matrices: once per solve by minimum degree on
``A + Aᵀ`` (session 39), or per matrix by COLAMD (session 38).

The local Newton matrix ``J = Dr + Du (W + alpha I)`` keeps ``W``'s block pattern, which is
symmetric.  Session 38's path gave SuperLU each step's matrix (stored zeros dropped) with
``permc_spec="COLAMD"``: an ordering of ``AᵀA`` computed on every call.  Session 39's path
(:class:`socp_cd.solvers.sparse_lu.NewtonLU`, ``ORDERING = "MMD_AT_PLUS_A"``,
``SPLU_ORDER_ONCE = True``) orders the full pattern once per solve by the minimum degree of
``A + Aᵀ`` (SuperLU's documented setting for a symmetric pattern) and hands SuperLU each
matrix permuted into that order with ``permc_spec="NATURAL"``.  The same order feeds the
left-looking LU and its flop count (the choice between the two LUs).

For every local problem of ``validation/sparse_lu_choice.py``'s list (same tune / holdout
split), three measurements:

1. **the orders**: ``nnz(L + U)`` and multiply-adds per row of the full pattern's
   factorization in COLAMD's and in MMD's order (the second decides the LU);
2. **per factorization** (first, middle and last step of a captured Newton run): session
   38's SuperLU call and session 39's, factorize + one solve, min of 5, and what SuperLU
   stored for each (``SuperLU.nnz``: the ``L.nnz + U.nnz`` of scipy's copies leave out the
   zeros stored in supernodes);
3. **whole solves**: ``solve(p, "newton", tol=1e-8, time_limit=30)`` with session 38's knobs
   (``ORDERING = "COLAMD"``, ``SPLU_ORDER_ONCE = False``) and with the defaults, the two
   interleaved in one process, min and median of ``--repeats`` (5) after a warm-up call each.

The ordering was not fitted: ``MMD_AT_PLUS_A`` with ``SymmetricMode`` is SuperLU's own
recommendation for such matrices.  Session 16's study (``newton_splu_options.py``,
n ≤ 1 710) found it slower *as a per-call ordering* (its cost is paid on each call there);
here it is paid once per solve.

    python validation/splu_ordering.py [--quick] [--out validation/results/splu_ordering]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import scipy.sparse.linalg as spla

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

from socp_cd.io import read_problem  # noqa: E402
from socp_cd.solvers import newton, sparse_lu  # noqa: E402
from sparse_lu_choice import (best_of, captured, interleaved_solves, problem_list,  # noqa: E402
                              sparse_lu_knobs)

#: session 38's knobs
OLD = {"ORDERING": "COLAMD", "SPLU_ORDER_ONCE": False}


def orders(jac, n):
    """``{ordering: (nnz(L + U), flops per row)}`` of the full pattern."""
    out = {}
    for name in ("COLAMD", "MMD_AT_PLUS_A"):
        with sparse_lu_knobs({"ORDERING": name}):
            _, flops, nnz, _ = sparse_lu.column_order(jac.indptr, jac.indices, n,
                                                      newton.SPLU_OPTIONS)
        out[name] = (nnz, flops / n)
    return out


def per_factorization(p):
    """``(orders, rows)``: :func:`orders` and, per captured step, the two SuperLU paths'
    time, fill and residual (None, [] on the dense path)."""
    got = captured(p, "splu")
    if got is None:
        return None, []
    steps, jac, lu = got
    n = p.m
    # (the ordered path on every matrix, its fill beside it: the fallback of
    # SPLU_FILL_GROWTH is what the whole solves measure)
    with sparse_lu_knobs({"SPLU_FILL_GROWTH": float("inf")}):
        return orders(jac, n), _factor_rows(p, steps, jac, lu)


def _factor_rows(p, steps, jac, lu):
    n = p.m
    b = np.random.default_rng(0).standard_normal(n)
    rows = []
    for tag, args in (("first", steps[0]), ("middle", steps[len(steps) // 2]),
                      ("last", steps[-1])):
        jac.values(*args)
        vals = jac.out.reshape(-1).copy()
        J = jac.current()
        old = lambda: spla.splu(J, **newton.SPLU_OPTIONS).solve(b)  # noqa: E731
        new = lambda: lu.solve(vals, jac.perm, b)  # noqa: E731
        x_old, x_new = old(), new()
        t_old, t_new = best_of(old, 5), best_of(new, 5)
        f_old = spla.splu(J, **newton.SPLU_OPTIONS)
        ordered = J[lu.q][:, lu.q].tocsc()      # (J: stored zeros dropped, as the path does)
        f_new = spla.splu(ordered, **dict(newton.SPLU_OPTIONS, permc_spec="NATURAL"))
        res = lambda x: float(np.linalg.norm(J @ x - b) / np.linalg.norm(b))  # noqa: E731
        rows.append((tag, t_old, t_new, f_old.nnz, f_new.nnz, res(x_old), res(x_new)))
    return rows


def whole(p, repeats):
    """``{"old": row, "new": row}``, row ``(min time, median time, status, error, steps,
    LU)`` of ``repeats`` interleaved solves after a warm-up call each."""
    runs = interleaved_solves(p, {"old": ({}, OLD), "new": ({}, {})}, repeats)
    return {tag: (min(ts), float(np.median(ts)), r.status, r.error,
                  r.info.get("newton_steps"), r.info.get("linear_solver"))
            for tag, (ts, r) in runs.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeats", type=int, default=5, help="timed whole solves per path")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "splu_ordering"))
    args = ap.parse_args(argv)
    fact = ["| split | problem | m | LU | nnz(L+U) COLAMD / MMD | flops/row COLAMD / MMD | "
            "matrix | SuperLU s38 (ms) | s39 (ms) | ratio | stored s38 / s39 | "
            "residual s38 / s39 |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    whl = ["| split | problem | m | LU | s38: min / median time (s), status, error, steps | "
           "s39: the same | ratio of the minima / medians |", "|---|---|---|---|---|---|---|"]
    # the ratios where SuperLU is the default's choice (elsewhere the left-looking LU or the
    # dense path factorizes, and the whole-solve ratios are the orders' fill and noise)
    ratios = {"tune": [], "holdout": []}
    wratios = {("tune", "splu"): [], ("holdout", "splu"): [], ("tune", "other"): [],
               ("holdout", "other"): []}
    for split, path in problem_list(args.quick):
        p = read_problem(path)
        name = os.path.basename(path)
        od, rows = per_factorization(p)
        if od is None:
            print(name, "dense path: skipped", flush=True)
            continue
        w = whole(p, args.repeats)
        chosen = w["new"][5]
        oc = f"{od['COLAMD'][0]} / {od['MMD_AT_PLUS_A'][0]}"
        of = f"{od['COLAMD'][1]:.0f} / {od['MMD_AT_PLUS_A'][1]:.0f}"
        for tag, t_old, t_new, f_old, f_new, r_old, r_new in rows:
            if chosen == "splu":
                ratios[split].append(t_new / t_old)
            fact.append(f"| {split} | {name} | {p.m} | {chosen} | {oc} | {of} | {tag} | "
                        f"{t_old * 1e3:.3f} | {t_new * 1e3:.3f} | {t_new / t_old:.2f} | "
                        f"{f_old} / {f_new} | {r_old:.1e} / {r_new:.1e} |")
        cell = lambda v: f"{v[0]:.4f} / {v[1]:.4f}, {v[2]}, {v[3]:.1e}, {v[4]}"  # noqa: E731
        wr, wm = w["new"][0] / w["old"][0], w["new"][1] / w["old"][1]
        wratios[(split, "splu" if chosen == "splu" else "other")].append(wr)
        whl.append(f"| {split} | {name} | {p.m} | {chosen} | {cell(w['old'])} | "
                   f"{cell(w['new'])} | {wr:.2f} / {wm:.2f} |")
        print(fact[-3:], whl[-1], sep="\n", flush=True)

    def summary(d):
        return "; ".join(f"{k if isinstance(k, str) else ' '.join(k)}: "
                         f"×{min(v):.2f}–{max(v):.2f} "
                         f"(median ×{np.median(v):.2f}, {len(v)})" for k, v in d.items() if v)
    lines = ["# SuperLU's ordering for the sparse Newton matrices: per matrix (COLAMD, session 38) "
             "or once per solve (MMD on A + Aᵀ, session 39)", "",
             "Generated by `validation/splu_ordering.py` (module docstring: what is timed). "
             "Ratios: session 39 / session 38 (below 1: faster).", "",
             f"- per factorization, where SuperLU is the choice: {summary(ratios)}",
             f"- whole Newton solves (ratio of the minima; `splu`: SuperLU is the choice, "
             f"`other`: the left-looking LU or the dense path, where only the left-looking "
             f"LU's order changed): {summary(wratios)}", "",
             "## Per factorization (factorize + one solve; min of 5)", "", *fact, "",
             f"## Whole Newton solves (min and median of {args.repeats}, interleaved)", "",
             *whl, ""]
    with open(args.out + ".md", "w") as fh:
        fh.write("\n".join(lines))
    print("\n".join(lines[:8]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

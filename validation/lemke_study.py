"""Lemke's method on small 2D problems: its pivot tolerance, its accuracy and its cost (issue #10).

Three tables (``formulations/lemke.md``):

1. **Pivot tolerance.**  For each candidate ``socp_cd.lcp.PIVOT_TOL`` (an entry of the
   entering column counts as positive above this share of the column's largest), Lemke's
   method (the NumPy reference, on the dispatcher's balanced copy) on every 2D problem of at
   most ``--max-contacts`` contacts of a split: how many end "solved" with a wrong answer
   (Siconos' error above 1e-10: the pivots went astray on a near-zero pivot), how many on a
   secondary ray or the pivot cap.  ``tune``: the simulation collections
   ``validation/evalset_sim_small2d_tune`` (``build_sim_collections.py --small2d --tune``)
   and 300 manufactured problems on rank-deficient ``W`` (``generators.manufactured``,
   ``structure="redundant"``); ``holdout``: ``validation/evalset_sim_small2d`` and the
   evaluation set's held-out 2D manufactured cases.
2. **Large μ.**  Random 5-contact problems with positive definite ``W`` (six seeds), as
   written and balanced, ``μ`` from 0.5 to 1e6: how many runs end on a secondary ray.
3. **Cost.**  ``solver="lemke"``'s compiled kernel (balanced problem, min of 50 calls) and the
   pivots, by contacts, next to ``solver="auto"`` with the ``"lemke"`` stage off
   (``auto.LEMKE_MAX_NC = None``: NSGS first) and ``solver="newton"`` (min of 5 calls each,
   ``time_limit=1``), on the same problems.

Usage::

    .venv/bin/python validation/lemke_study.py --split tune --out validation/results/lemke_study_tune.md
    .venv/bin/python validation/lemke_study.py --split holdout --out validation/results/lemke_study_holdout.md
"""
from __future__ import annotations

import argparse
import statistics
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd import lcp
from socp_cd.bench.evalset import collection_cases, manufactured_cases
from socp_cd.bench.generators import manufactured
from socp_cd.bench.reports import emit
from socp_cd.data import shared_problems_dir
from socp_cd.problem import FrictionContactProblem, kernel_array
from socp_cd.solvers import auto
from socp_cd.solvers.kernels.lemke import lemke_coulomb_2d
from socp_cd.solvers.lemke import pivot_cap
from socp_cd.solvers.scaling import balanced

HERE = Path(__file__).resolve().parent
TOLS = (1e-12, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6)
COLLECTIONS = {"tune": "evalset_sim_small2d_tune", "holdout": "evalset_sim_small2d"}


def problems(split, max_contacts):
    """``[(label, problem)]`` of the split's 2D local problems of at most ``max_contacts``."""
    out = []
    for sub in sorted({p.parent for p in (HERE / COLLECTIONS[split]).rglob("*.hdf5")}):
        for c in collection_cases(sub):
            p = c.problem()
            if p.dim == 2 and p.n_contacts <= max_contacts and p.mu.max() > 0.0:
                out.append((sub.name, p))
    if split == "tune":
        rng = np.random.default_rng(0)
        mixes = ((0.25, 0.25, 0.25, 0.25), (0, 0, 1, 0), (0, 1, 0, 0), (0.1, 0.3, 0.5, 0.1))
        for s in range(300):
            nc = int(rng.integers(2, max_contacts + 1))
            mu = float(rng.choice([0.1, 0.3, 0.5, 1.0, 2.0]))
            out.append(("manufactured-redundant", manufactured(
                nc, dim=2, mu=mu, structure="redundant", mix=mixes[s % 4], seed=s,
                bodies_per_contact=float(rng.choice([0.25, 0.5])))))
    else:
        for c in manufactured_cases(Path(shared_problems_dir()), max_contacts=max_contacts):
            if c.split == "holdout" and not c.is_global:
                p = c.problem()
                if p.dim == 2 and p.mu.max() > 0.0:
                    out.append(("manufactured-real", p))
    return out


def tolerance_table(probs) -> list:
    lines = ["| PIVOT_TOL | problems | solved, error ≤ 1e-10 | 'solved', error > 1e-10 (the "
             "largest) | secondary ray | pivot cap |", "|---|---|---|---|---|---|"]
    kept = lcp.PIVOT_TOL
    try:
        for tol in TOLS:
            lcp.PIVOT_TOL = tol
            counts, worst = defaultdict(int), 0.0
            for _, p in probs:
                b = balanced(p).problem
                M, q = lcp.coulomb_lcp_2d(b.W.toarray(), b.q, b.mu)
                z, code, _ = lcp.lemke_reference(M, q, pivot_cap(q.shape[0], None))
                if code == lcp.LEMKE_SOLVED:
                    e = socp_cd.error(b, lcp.coulomb_impulses(z, b.n_contacts))
                    counts["good" if e <= 1e-10 else "bad"] += 1
                    worst = max(worst, e) if e > 1e-10 else worst
                else:
                    counts[code] += 1
            lines.append(f"| {tol:g}{' (adopted)' if tol == kept else ''} | {len(probs)} | "
                         f"{counts['good']} | {counts['bad']}"
                         + (f" ({worst:.1e})" if counts["bad"] else "")
                         + f" | {counts[lcp.LEMKE_RAY]} | "
                         f"{counts[lcp.LEMKE_MAX_PIVOTS]} |")
    finally:
        lcp.PIVOT_TOL = kept
    return lines


def mu_table() -> list:
    """Lemke's method (the reference) on random 5-contact problems with positive definite
    ``W`` (six seeds), as written and balanced, for friction coefficients up to 1e6: the runs
    that end on a secondary ray (a solution exists: ``W`` is positive definite)."""
    mus = (0.5, 10.0, 1e2, 1e3, 1e4, 1e6)
    rays = {mu: 0 for mu in mus}
    for seed in range(8, 14):
        rng = np.random.default_rng(seed)
        A = rng.standard_normal((10, 10))
        W, q = A @ A.T, rng.standard_normal(10)
        for mu in mus:
            p = FrictionContactProblem(W, q, np.full(5, mu), dim=2)
            for b in (p, balanced(p).problem):
                M, ql = lcp.coulomb_lcp_2d(b.W.toarray(), b.q, b.mu)
                rays[mu] += lcp.lemke_reference(M, ql, pivot_cap(20, None))[1] == lcp.LEMKE_RAY
    return (["| μ | " + " | ".join(f"{mu:g}" for mu in mus) + " |",
             "|---|" + "---|" * len(mus),
             "| runs ending on a ray, of 12 | " + " | ".join(str(rays[mu]) for mu in mus) + " |"])


def best_time(fn, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def cost_table(probs) -> list:
    rows = defaultdict(list)
    kept = auto.LEMKE_MAX_NC
    for _, p in probs:
        b = balanced(p).problem
        ip, ix, d = b.csr_parts
        q, mu, r = kernel_array(b.q), kernel_array(b.mu), np.empty(b.m)
        t_kernel, (code, piv) = best_time(
            lambda: lemke_coulomb_2d(ip, ix, d, q, mu, pivot_cap(4 * b.n_contacts, None), np.inf, r), 50)
        try:
            auto.LEMKE_MAX_NC = None
            t_nsgs_first, _ = best_time(lambda: socp_cd.solve(p, time_limit=1.0), 5)
        finally:
            auto.LEMKE_MAX_NC = kept
        t_newton, _ = best_time(lambda: socp_cd.solve(p, "newton", time_limit=1.0), 5)
        rows[p.n_contacts].append((t_kernel, piv, t_nsgs_first, t_newton))
    lines = ["| contacts | problems | Lemke kernel, median [µs] | pivots, median | auto with NSGS "
             "first, median [µs] | newton, median [µs] |", "|---|---|---|---|---|---|"]
    for nc in sorted(rows):
        rs = rows[nc]
        lines.append(f"| {nc} | {len(rs)} | {1e6 * statistics.median(x[0] for x in rs):.1f} | "
                     f"{statistics.median(x[1] for x in rs):.0f} | "
                     f"{1e6 * statistics.median(x[2] for x in rs):.1f} | "
                     f"{1e6 * statistics.median(x[3] for x in rs):.1f} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=("tune", "holdout"), required=True)
    ap.add_argument("--max-contacts", type=int, default=12)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    socp_cd.warmup()
    probs = problems(args.split, args.max_contacts)
    lines = [f"# Lemke's method on small 2D problems, split `{args.split}`", "",
             f"`validation/lemke_study.py --split {args.split}`: {len(probs)} problems of at most "
             f"{args.max_contacts} contacts (see the script's docstring).", "",
             "## The pivot tolerance", ""] + tolerance_table(probs)
    lines += ["", "## Large friction coefficients (random problems, not the split's)", ""]
    lines += mu_table()
    lines += ["", "## Cost by size (this machine, one process)", ""] + cost_table(probs)
    emit(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

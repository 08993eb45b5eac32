"""A semismooth Levenberg–Marquardt prototype on the cases `auto` misses (measured, not adopted).

formulations/newton.md §9 left one idea untried for the Kapla-tower manufactured cases
(rank 504 of 1710, 48–78 % of the exact ``r*`` in ``null(W)``: non-isolated solutions): a
regularization tied to ``||F||`` with a monotone test, the Levenberg–Marquardt method whose
local convergence needs an error bound, not a nonsingular Jacobian (Yamashita and Fukushima
2001; Fan and Yuan 2005).  This prototype runs it on the same Alart–Curnier equation as
``solver="newton"`` (:func:`~socp_cd.solvers.kernels.newton_ac.ac_blocks`, ρ per contact
"block" as :func:`~socp_cd.solvers.kernels.newton_ac.block_rho_dense`, the balanced problem
of :func:`socp_cd.solvers.scaling.balanced`):

* ``J = Dr + Du W`` (a generalized Jacobian), ``(Jᵀ J + λ I) d = −Jᵀ F`` by SuperLU,
  ``λ = c ||F||^δ`` (δ = 2, ``c`` starting at 1e-2);
* trust-ratio control: ``ρ = (||F||² − ||F(r + d)||²) / (||F||² − ||F + J d||²)``; the
  step is taken when ``ρ > 1e-4``; ``c × 4`` when ``ρ < 0.25``, the step is refused or the
  matrix is singular, ``c / 4`` (not below 1e-8) when ``ρ > 0.75``; stalled when
  ``c > 1e16``; the time limit is read between steps;
* stop when Siconos' error and the units guard of ``r`` as written are ``<= tol``.

Cases: the Kapla and Capsules cases of the ``tune`` split that `auto` misses at 1 s (never
the held-out split), from ``r = 0`` and from ``solver="newton"``'s iterate after 0.5 s.
Writes ``results/lm_study.{csv,md}``::

    python validation/lm_study.py [--time-limit 10]

A few minutes on one core (one run per case and start: times are indicative).
"""
from __future__ import annotations

import argparse
import copy
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.reports import emit
from socp_cd.data import shared_problems_dir
from socp_cd.solvers.kernels.newton_ac import ac_blocks, block_rho_dense
from socp_cd.solvers.newton import BlockJacobian
from socp_cd.solvers.scaling import balanced

from auto_probe import write_csv

RESULTS = Path(__file__).with_name("results")
#: the tune split's cases `auto` misses at 1 s (auto_chain_tune_s25manu.md), asserted tune below
CASES = ("real-manufactured/KaplasTower-i1061-4.hdf5.dat/mu0.5-sticking-s1",
         "real-manufactured/KaplasTower-i1061-4.hdf5.dat/mu2-sticking-s1",
         "real-manufactured/KaplasTower-i1061-4.hdf5.dat/mu1-sliding-s2",
         "real-manufactured/Capsules-i122-1617.dat/mu2-mixed-s0",
         "real-manufactured/Capsules-i122-1617.dat/mu2-sliding-s2",
         "real-scaled/Capsules-i122-1617.dat/qx1e-06",
         "real-scaled/Capsules-i122-1617.dat/Wqx1e+06")


def balanced_setup(problem):
    """What the prototypes share: ``(a, W, q, mu, d, m, nc, rho, jac)`` of the dispatcher's
    balanced copy of ``problem`` (``r = a r~``; ``W`` CSR; ``rho`` per contact by
    ``solver="newton"``'s "block" strategy; ``jac`` the Newton backend's
    :class:`~socp_cd.solvers.newton.BlockJacobian` of ``W``)."""
    rec = balanced(problem)
    bp, a = rec.problem, rec.a
    W = sp.csr_matrix(bp.W, dtype=np.float64)
    q = np.asarray(bp.q, dtype=np.float64)
    d, m = bp.dim, bp.m
    nc = m // d
    mu = np.asarray(bp.mu, dtype=np.float64)
    rho = np.empty(nc)
    block_rho_dense(np.ascontiguousarray(W.toarray()), d, rho)
    return a, W, q, mu, d, m, nc, rho, BlockJacobian(W, d)


def judged(problem, r, a, best):
    """``(e, written, best)``: ``written = a r`` (the balanced iterate as written), ``e`` the
    larger of its Siconos error and units guard, ``best`` the pair ``(e, written)`` with the
    lowest ``e`` so far (updated)."""
    written = r * a
    e = max(socp_cd.error(problem, written), socp_cd.guard(problem, written)["value"])
    return e, written, ((e, written.copy()) if e < best[0] else best)


def levenberg_marquardt(problem, r0=None, tol=1e-8, time_limit=10.0, c0=1e-2, delta=2.0):
    """The prototype (module docstring): ``(status, r as written, iterations, factorizations,
    seconds)``, ``r`` the iterate with the lowest ``max(error, guard)``."""
    a, W, q, mu, d, m, nc, rho, jac = balanced_setup(problem)
    eye = sp.identity(m, format="csc")

    def law(r):
        u = W @ r + q
        F, Dr, Du = np.empty(m), np.empty((nc, d, d)), np.empty((nc, d, d))
        nF = ac_blocks(r, u, mu, rho, rho, d, True, F, Dr, Du, np.empty(nc, np.int64))
        return F, Dr, Du, nF

    r = np.zeros(m) if r0 is None else np.asarray(r0, dtype=np.float64) / a
    F, Dr, Du, nF = law(r)
    c, t0, facts, k = c0, time.perf_counter(), 0, 0
    best = (np.inf, r * a)
    while True:
        e, written, best = judged(problem, r, a, best)
        if e <= tol:
            return "converged", written, k, facts, time.perf_counter() - t0
        if time.perf_counter() - t0 > time_limit:
            return "time_limit", best[1], k, facts, time.perf_counter() - t0
        J = jac.matrix(Dr, Du, 0.0)
        JT = J.T.tocsc()
        g = JT @ F
        while True:
            facts += 1
            try:
                step = spla.splu((JT @ J + c * nF ** delta * eye).tocsc()).solve(-g)
            except RuntimeError:          # (singular: more regularization)
                c *= 4.0
                if c > 1e16:
                    return "stalled", best[1], k, facts, time.perf_counter() - t0
                continue
            predicted = nF ** 2 - np.linalg.norm(F + J @ step) ** 2
            trial = law(r + step)
            ratio = (nF ** 2 - trial[3] ** 2) / predicted if predicted > 0 else -1.0
            if ratio > 1e-4:
                r = r + step
                F, Dr, Du, nF = trial
                c = c * 4.0 if ratio < 0.25 else (max(c / 4.0, 1e-8) if ratio > 0.75 else c)
                break
            c *= 4.0
            if c > 1e16:
                return "stalled", best[1], k, facts, time.perf_counter() - t0
        k += 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--newton-start", type=float, default=0.5,
                    help="seconds of solver='newton' for the second start")
    args = ap.parse_args(argv)
    found = {c.case_id: c for c in evalset.manufactured_cases(shared_problems_dir(),
                                                              max_contacts=2000)}
    rows = []
    for cid in CASES:
        case = found[cid]
        assert case.split == "tune", cid       # never the held-out split
        p = case.problem()
        for start in ("zero", "newton"):
            r0, note = None, ""
            if start == "newton":
                res = socp_cd.solve(copy.copy(p), solver="newton", time_limit=args.newton_start)
                r0, note = res.r, f"{res.status} {res.error:.1e}"
            st, r, its, facts, sec = levenberg_marquardt(p, r0, time_limit=args.time_limit)
            rows.append({"case": cid, "start": start, "start_state": note, "status": st,
                         "error": socp_cd.error(p, r), "guard": socp_cd.guard(p, r)["value"],
                         "iterations": its, "factorizations": facts, "time": sec})
            print(rows[-1], flush=True)
    write_csv(rows, RESULTS / "lm_study.csv")
    lines = ["# Semismooth Levenberg–Marquardt prototype on the tune cases `auto` misses", "",
             f"`python validation/lm_study.py --time-limit {args.time_limit:g}` (one run per "
             "case and start; the `newton` start is `solver=\"newton\"`'s iterate after "
             f"{args.newton_start:g} s, the LM time not counting it). Method: the script's "
             "docstring.", "",
             "| case | start | start's state | LM status | error | guard | its | LU | time [s] |",
             "|---|---|---|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['case']} | {r['start']} | {r['start_state']} | {r['status']} | "
              f"{r['error']:.1e} | {r['guard']:.1e} | {r['iterations']} | "
              f"{r['factorizations']} | {r['time']:.2f} |" for r in rows]
    emit(lines, RESULTS / "lm_study.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

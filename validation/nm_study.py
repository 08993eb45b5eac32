"""A semismooth Newton prototype on the natural map, on the tune cases `auto` misses (a study).

Session 29 found that Siconos' NSN_NM (semismooth Newton on a natural-map equation of the
law) solves a held-out Capsules case that ``auto`` misses at 10 s
(``results/misses_vs_siconos_s29_capsules.md``); our Newton solves the Alart–Curnier
equation only.  This prototype asks whether the natural map itself, with Siconos' plain
globalization, solves what our chain misses, on the misses of the *tune* split only
(the held-out case is not run):

* on the balanced problem of :func:`socp_cd.solvers.scaling.balanced`,
  ``F(r) = r − P_K(r − ρ û(r))`` per contact (:func:`socp_cd.cones.natural_map`),
  ``û = u + μ ||u_T|| e_N``, ``u = W r + q``, ``ρ`` per contact as ``solver="newton"``'s
  "block" strategy (:func:`~socp_cd.solvers.kernels.newton_ac.block_rho_dense`);
* a generalized Jacobian ``J = (I − P') + ρ P' D W`` (``P'`` the cone projection's,
  :func:`socp_cd.cones.project_cone_jacobian`; ``D_i = I + e_N μ_i [0, w_iᵀ]``, ``w_i =
  u_T / ||u_T||``, 0 when ``u_T = 0``), assembled as ``solver="newton"``'s ``Dr + Du W``
  (:class:`socp_cd.solvers.newton.BlockJacobian`), SuperLU; when singular (``W`` rank
  deficient and contacts inside the cone), retried with ``W + 1e-10 s̄ I`` (``s̄`` the mean
  diagonal), as ``policy="plain"`` does;
* Siconos' plain globalization (formulations/newton.md §8): Armijo on ``½||F||²``
  (``1e-4``, at most 30 halvings), else the full step; the best iterate by
  ``max(error, guard)`` of ``r`` as written is kept; stop when both are ``<= tol``, after
  ``--max-iter`` steps or ``--time-limit`` seconds.

    python validation/nm_study.py [--time-limit 10] [--max-iter 1000]

Writes ``results/nm_study.{csv,md}``; one run per case, from ``r = 0``.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.reports import emit
from socp_cd.cones import natural_map, project_cone_jacobian
from socp_cd.data import shared_problems_dir
from auto_probe import write_csv
from lm_study import balanced_setup, judged

RESULTS = Path(__file__).with_name("results")
#: the tune Capsules cases `auto` misses at 10 s (results/auto_chain_tune_s28large10.md) that
#: a Siconos solver solves (results/misses_vs_siconos_s29_capsules.md)
CASES = ("real-manufactured/Capsules-i122-1617.dat/mu2-mixed-s0",
         "real-manufactured/Capsules-i122-1617.dat/mu2-sliding-s2",
         "real-scaled/Capsules-i122-1617.dat/qx1e-06",
         "real-scaled/Capsules-i122-1617.dat/Wqx1e+06")


def natural_map_newton(problem, tol=1e-8, time_limit=10.0, max_iter=1000):
    """The prototype (module docstring): ``(status, r as written, steps, full steps taken,
    seconds)``."""
    a, W, q, mu, d, m, nc, rho, jac = balanced_setup(problem)
    eye = np.eye(d)[None]
    reg = 1e-10 * float(np.mean(W.diagonal()))  # W + reg I when J is singular (§8's plain policy)

    def law(r):
        u = W @ r + q
        return natural_map(r, u, mu, d, rho[:, None]), u

    def jacobian(r, u, alpha):
        R, U = r.reshape(nc, d), u.reshape(nc, d)
        t = np.sqrt(np.einsum("ij,ij->i", U[:, 1:], U[:, 1:]))
        w = np.where(t[:, None] > 0, U[:, 1:] / np.where(t > 0, t, 1.0)[:, None], 0.0)
        Uh = U.copy()
        Uh[:, 0] += mu * t
        P = project_cone_jacobian(R - rho[:, None] * Uh, mu, d)
        D = np.repeat(eye, nc, axis=0)
        D[:, 0, 1:] += mu[:, None] * w
        return jac.matrix(eye - P, rho[:, None, None] * np.einsum("kij,kjl->kil", P, D), alpha)

    r = np.zeros(m)
    F, u = law(r)
    t0, full, best = time.perf_counter(), 0, (np.inf, r * a)
    for k in range(max_iter + 1):
        e, written, best = judged(problem, r, a, best)
        if e <= tol:
            return "converged", written, k, full, time.perf_counter() - t0
        if k == max_iter:
            break
        if time.perf_counter() - t0 > time_limit:
            return "time_limit", best[1], k, full, time.perf_counter() - t0
        try:
            step = spla.splu(jacobian(r, u, 0.0).tocsc()).solve(-F)
        except RuntimeError:      # singular (W rank deficient, contacts inside the cone)
            try:
                step = spla.splu(jacobian(r, u, reg).tocsc()).solve(-F)
            except RuntimeError:
                return "singular", best[1], k, full, time.perf_counter() - t0
        f0, s = 0.5 * F.dot(F), 1.0
        for _ in range(31):
            F1, u1 = law(r + s * step)
            if 0.5 * F1.dot(F1) <= (1.0 - 2e-4 * s) * f0:
                break
            s *= 0.5
        else:                              # the line search failed: the full step
            s, full = 1.0, full + 1
            F1, u1 = law(r + step)
        r, F, u = r + s * step, F1, u1
    return "max_iter", best[1], max_iter, full, time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--max-iter", type=int, default=1000)
    args = ap.parse_args(argv)
    found = {c.case_id: c for c in evalset.manufactured_cases(shared_problems_dir())
             if c.case_id in CASES}
    rows = []
    for cid in CASES:
        case = found[cid]
        assert case.split == "tune", cid       # never the held-out split
        p = case.problem()
        st, r, its, full, sec = natural_map_newton(p, time_limit=args.time_limit,
                                                   max_iter=args.max_iter)
        rows.append({"case": cid, "status": st, "error": socp_cd.error(p, r),
                     "guard": socp_cd.guard(p, r)["value"], "steps": its, "full_steps": full,
                     "time": sec})
        print(rows[-1], flush=True)
    write_csv(rows, RESULTS / "nm_study.csv")
    lines = ["# Semismooth Newton on the natural map: the tune Capsules cases `auto` misses", "",
             f"`python validation/nm_study.py --time-limit {args.time_limit:g} --max-iter "
             f"{args.max_iter}` (one run per case from `r = 0`; method: the script's "
             "docstring). Solved: error and units guard ≤ 1e-8.", "",
             "| case | status | error | guard | steps | full steps | time [s] |",
             "|---|---|---:|---:|---:|---:|---:|"]
    lines += [f"| {r['case']} | {r['status']} | {r['error']:.1e} | {r['guard']:.1e} | "
              f"{r['steps']} | {r['full_steps']} | {r['time']:.2f} |" for r in rows]
    emit(lines, RESULTS / "nm_study.md")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

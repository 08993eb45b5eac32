"""Siconos' ADMM design on our balanced problems: measured, not adopted (issue #10, session 26).

Siconos ``fc3d_admm`` (4.4 defaults: constant ``rho = 1`` on ``W`` as written, Nesterov
acceleration with restart, ``eta = 0.999``) is the fastest Siconos solver on the shared
Kapla tower in the issue's benchmark (12.7 ms against ``auto``'s 155 ms) and on a few held-out
box-stack steps.  This study runs the same iteration on the dispatcher's balanced copy
(``W~`` has a unit mean diagonal, so ``rho`` is relative to it):

* the De Saxcé shift ``s = mu ||u_T||`` of the current ``r`` (``u = W r + q``) enters the
  linear term: ``(W + rho I) r = -(q + s) - rho (xi^ - z^)`` (one factorization of
  ``W + rho I`` for the whole run, dense Cholesky up to 300 unknowns, SuperLU above);
* ``z = P_K(r + xi^)``, ``xi = xi^ + r - z``;
* accelerated while ``e = ||r - z||^2 + rho^2 ||z^ - z||^2`` falls by ``eta``, else
  restarted from the previous iterate;
* stop when Siconos' error of ``z`` (every 10 iterations, and when ``sqrt(e) / ||q||``
  is below ``tol``) meets ``tol``.

It is a study (NumPy, one process, no time limit), not a backend: it solves the Kapla tower in
16-23 iterations with ``rho`` 0.01-0.03, needs hundreds to thousands of iterations or fails on
the other rank-deficient shared problems, and fails the Kapla manufactured cases
(``validation/results/admm_study.md``).

Usage::

    .venv/bin/python validation/admm_study.py
"""
from __future__ import annotations

import argparse
import copy
import time
from functools import partial
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import socp_cd
from socp_cd.bench.evalset import manufactured_cases
from socp_cd.cones import project_cone
from socp_cd.data import shared_problems_dir
from socp_cd.residuals import error as siconos_error
from socp_cd.solvers import newton, nsgs
from socp_cd.solvers.result import SolverResult

OUT = Path(__file__).resolve().parent / "results"
SHARED = ("KaplasTower-i1061-4.hdf5.dat", "Capsules-i122-1617.dat", "Capsules-i125-1213.hdf5",
          "LMGC_100_PR_PerioBox-i00361-60-03000.hdf5", "BoxesStack1-i100000-32.hdf5.dat",
          "OneObject-i1028-138.hdf5.dat")
KAPLA_TUNE = ("mu0.5-sticking-s1", "mu2-sticking-s1", "mu1-sliding-s2")


def admm(problem, formulation, *, tol, max_iter=None, r0=None, history=False, time_limit=None,
         verbose=False, inner_settings=None, rho=1.0, eta=0.999):
    """The iteration of the module docstring as a ``solve(solver=callable)`` function."""
    d, mu, m = problem.dim, problem.mu, problem.m
    indptr, indices, data = problem.csr_parts
    W = sp.csr_matrix((data, indices, indptr), shape=(m, m))
    q = problem.q
    rho = rho * max(float(np.mean(np.abs(W.diagonal()))), 1e-300)
    A = (W + rho * sp.identity(m)).tocsc()
    if m <= 300:
        factor = sla.cho_factor(A.toarray(), check_finite=False)
        solve = partial(sla.cho_solve, factor, check_finite=False)
    else:
        solve = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options={"SymmetricMode": True}).solve
    r = np.zeros(m) if r0 is None else np.array(r0, dtype=float)
    z, z_k, z_hat = r.copy(), r.copy(), r.copy()
    xi, xi_k, xi_hat = np.zeros(m), np.zeros(m), np.zeros(m)
    norm_q = float(np.linalg.norm(q)) or 1.0
    e_k, t_k = np.inf, 1.0
    status, best, r_best, it = "max_iter", np.inf, r.copy(), 0
    for it in range(1, (max_iter or 20000) + 1):
        u = W @ r + q
        ut = u.reshape(-1, d)[:, 1:]
        q_s = q.copy()
        q_s[::d] += mu * np.sqrt((ut * ut).sum(axis=1))
        r = solve(-q_s - rho * (xi_hat - z_hat))
        z = project_cone(r + xi_hat, mu, d)
        xi = xi_hat + (r - z)
        e = float(np.linalg.norm(r - z) ** 2 + (rho * np.linalg.norm(z_hat - z)) ** 2)
        if e < eta * e_k:
            t = 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * t_k * t_k))
            a = (t_k - 1.0) / t
            z_hat, xi_hat, t_k, e_k = z + a * (z - z_k), xi + a * (xi - xi_k), t, e
        else:
            t_k, e_k, z_hat, xi_hat = 1.0, e_k / eta, z_k.copy(), xi_k.copy()
        z_k, xi_k = z.copy(), xi.copy()
        if np.sqrt(e) / norm_q < tol or it % 10 == 0:
            err = siconos_error(problem, z)
            if err < best:
                best, r_best = err, z.copy()
            if err <= tol:
                status = "converged"
                break
    return SolverResult(r=r_best, status=status, iterations=it, info={"rho": rho})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rhos", type=float, nargs="+", default=[0.01, 0.03, 0.1, 0.3, 1.0])
    ap.add_argument("--max-iter", type=int, default=3000)
    ap.add_argument("--tol", type=float, default=1e-8)
    args = ap.parse_args(argv)
    newton.warmup()
    nsgs.warmup()
    data = shared_problems_dir()
    cases = [(f"shared/{n}", socp_cd.read_problem(Path(data) / n)) for n in SHARED]
    cases += [(c.case_id, c.problem()) for c in manufactured_cases(data, max_contacts=2000)
              if c.split == "tune" and "KaplasTower" in c.case_id
              and c.case_id.rsplit("/", 1)[-1] in KAPLA_TUNE]
    lines = ["# Siconos' ADMM design on our balanced problems (measured, not adopted)", "",
             f"`python validation/admm_study.py` (tol {args.tol:g}, at most {args.max_iter} "
             "iterations per run (the dispatcher's retry after a refused claim adds its own), "
             "one call each on a new problem object; `rho` relative to the mean "
             "diagonal of the balanced `W`; `auto` with `time_limit=5`, min of 2 calls after an "
             "untimed one). Converged = `solve`'s verdict (Siconos' error and the units guard).",
             "",
             "| problem | auto: status, error, time | " + " | ".join(
                 f"ADMM rho = {r:g}: status, error, iterations, time" for r in args.rhos) + " |",
             "|---|---|" + "---|" * len(args.rhos)]
    for pid, p in cases:
        socp_cd.solve(copy.copy(p), tol=args.tol, time_limit=5.0)      # (first call: caches)
        best = np.inf
        for _ in range(2):
            t0 = time.perf_counter()
            ref = socp_cd.solve(copy.copy(p), tol=args.tol, time_limit=5.0)
            best = min(best, time.perf_counter() - t0)
        cells = [pid, f"{ref.status}, {ref.error:.1e}, {best:.3f} s"]
        for rho in args.rhos:
            f = partial(admm, rho=rho)
            f.__name__ = "admm"
            t0 = time.perf_counter()
            res = socp_cd.solve(copy.copy(p), solver=f, tol=args.tol, max_iter=args.max_iter)
            cells.append(f"{res.status}, {res.error:.1e}, {res.iterations}, "
                         f"{time.perf_counter() - t0:.3f} s")
        lines.append("| " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "admm_study.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

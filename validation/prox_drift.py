"""The proximal Newton loop's outer steps on one problem, from an NSGS iterate (a trace).

``solve(..., solver="newton", history=True)`` returns ``info["trace"]``: per outer iteration
the proximal parameter, Siconos' error, whether the subproblem was solved, its Newton steps
and halvings, and the outer step's ``||r - r_k||``, ``||u - u_k||`` and the cosine with the
previous outer step (``socp_cd.solvers.newton.prox_newton``).  A step with ``u`` unchanged is
a step in the null space of ``W``; equal cosines of 1 with ``alpha * ||r - r_k||`` constant
are a drift along one such direction, the proximal term carrying a residual the step does
not reduce (``formulations/auto.md``, session 49).

Usage (the dominoes step of session 48's lead)::

    .venv/bin/python validation/prox_drift.py \\
        validation/evalset_sim_newkinds/dominoes3d-16/dominoes3d-16-i00014-62-00300.hdf5 \\
        --out validation/results/prox_drift_s49.md
"""
from __future__ import annotations

import argparse
from pathlib import Path

import socp_cd
from socp_cd.bench.reports import emit


def trace_lines(path, sweeps: int, max_iter: int, tol: float) -> list[str]:
    """The Markdown record of one problem's trace."""
    p = socp_cd.read_problem(path)
    start = socp_cd.solve(p, solver="nsgs", tol=tol, max_iter=sweeps)
    res = socp_cd.solve(p, solver="newton", tol=tol, r0=start.r, history=True,
                        max_iter=max_iter)
    lines = [f"# Proximal Newton's outer steps: `{Path(path).name}`", "",
             f"`python validation/prox_drift.py {path} --sweeps {sweeps} --max-iter {max_iter} "
             f"--tol {tol:g}`: {p.n_contacts} contacts; the start: NSGS, {sweeps} sweeps, error "
             f"{start.error:.4e} ({start.status}); then `newton` with `history=True`: "
             f"{res.status}, error {res.error:.4e} after {res.iterations} outer iterations. "
             "Norms in the balanced units the backend runs in.", "",
             "| outer | alpha | error | solved | Newton steps | halvings | branch changes "
             "| `‖r − r_k‖` | `‖u − u_k‖` | `alpha ‖r − r_k‖` | cosine with the last step |",
             "|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for k, t in enumerate(res.info["trace"], start=1):
        alpha, err, solved, _, steps, halvings, changed, _, step, ustep, turn = t
        lines.append(f"| {k} | {alpha:.2e} | {err:.4e} | {'yes' if solved else 'no'} | {steps} "
                     f"| {halvings} | {changed} | {step:.2e} | {ustep:.2e} | {alpha * step:.2e} "
                     f"| {turn:.4f} |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("problem", help="a problem file (FCLib HDF5 or Siconos .dat)")
    ap.add_argument("--sweeps", type=int, default=1000, help="NSGS sweeps of the start")
    ap.add_argument("--max-iter", type=int, default=30, help="Newton's outer iterations")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", default=None, help="Markdown record")
    args = ap.parse_args(argv)
    emit(trace_lines(args.problem, args.sweeps, args.max_iter, args.tol), args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

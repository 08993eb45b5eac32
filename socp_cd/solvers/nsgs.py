"""Reference NSGS: Moreau–Jean nonlinear block Gauss–Seidel (backend ``"nsgs"``).

One sweep visits every contact ``i`` and solves its one-contact problem
``u_i = W_ii r_i + b_i`` with ``b_i = q_i + sum_{j != i} W_ij r_j`` (using
the impulses already updated in this sweep) exactly or to a tight local
tolerance, as Moreau's and Jean's NSCD codes and Siconos' ``fc3d_nsgs`` do.
The sweeps run in compiled code (:mod:`socp_cd.solvers.nsgs_kernels`) over a
block-sparse copy of ``W`` (:mod:`socp_cd.solvers.block_storage`).

Options (``socp_cd.solve(problem, solver="nsgs", **options)``)
---------------------------------------------------------------
local_solver : {"exact", "ac_newton", "projection"}
    One-contact solver. ``"exact"`` (2D default, Coulomb law): Moreau's
    explicit case analysis. ``"ac_newton"`` (3D default): Alart–Curnier
    semismooth Newton with line search, projection fallback.
    ``"projection"``: projected fixed point only.  The associated law always
    uses the projection fixed point; Tresca uses Newton for ``"exact"``.
omega : float, default 1
    Relaxation ``r_i <- omega r_i^new + (1 - omega) r_i^old``, ``0 < omega < 2``.
ordering : {"natural", "shuffled"}, default "natural"
    Contact order; ``"shuffled"`` draws a new permutation every sweep from ``seed``.
seed : int, default 0
error_every : int, default 10
    Evaluate the full relative error every ``error_every`` sweeps (``0``: only
    when the light error ``||r_k+1 - r_k|| / ||r_k+1||`` falls below its
    tolerance, as Siconos' LIGHT_WITH_FULL_FINAL).
stall_window : int, default 5000
    Status ``"stalled"`` when the full error has not dropped by 1 % over that
    many sweeps (``0``: never).
local_tol : float, default 1e-13
    Relative tolerance of the one-contact solvers.
newton_max_iter : int, default 10; projection_max_iter : int, default 100
threshold : array_like
    Tresca threshold per contact (formulation ``"tresca"``).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from .block_storage import problem_blocks
from .local_solvers import (KIND_AC_NEWTON, KIND_EXACT, KIND_PROJECTION, LAW_ASSOCIATED,
                            LAW_COULOMB, LAW_TRESCA)
from .nsgs_kernels import (STATUS_NAMES, STATUS_NUMERICAL, full_error, local_parameters,
                           nsgs_loop)
from .registry import register
from .result import SolverResult

DEFAULT_MAX_ITER = 1000

_KINDS = {"exact": KIND_EXACT, "ac_newton": KIND_AC_NEWTON, "projection": KIND_PROJECTION}
_LAWS = {"coulomb": LAW_COULOMB, "frictionless": LAW_COULOMB, "associated": LAW_ASSOCIATED,
         "tresca": LAW_TRESCA}
_OPTIONS = {"local_solver", "omega", "ordering", "seed", "error_every", "stall_window",
            "local_tol", "newton_max_iter", "projection_max_iter", "threshold"}


def _option(options, name, default):
    v = options.get(name, default)
    return default if v is None else v


@register("nsgs", ("coulomb", "frictionless", "tresca", "associated"), dims=(2, 3),
          description="Moreau–Jean nonlinear block Gauss–Seidel (numba), exact 2D / "
                      "Alart–Curnier Newton 3D local solvers")
def nsgs_backend(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                 **options) -> SolverResult:
    """NSGS backend for :func:`socp_cd.solve` (see the module docstring for options)."""
    unknown = set(options) - _OPTIONS
    if unknown:
        raise UnsupportedError(f"nsgs: unknown option(s) {sorted(unknown)}; "
                               f"known: {sorted(_OPTIONS)}")
    d, nc = problem.dim, problem.n_contacts
    t_setup, cpu0 = time.perf_counter(), time.process_time()
    ls_name = _option(options, "local_solver", "exact" if d == 2 else "ac_newton")
    if ls_name not in _KINDS:
        raise InvalidProblemError("local_solver", f"must be one of {sorted(_KINDS)}, got {ls_name!r}")
    if ls_name == "exact" and d == 3:
        raise UnsupportedError("nsgs: local_solver='exact' exists in 2D only; use 'ac_newton' in 3D")
    omega = float(_option(options, "omega", 1.0))
    if not 0.0 < omega < 2.0:
        raise InvalidProblemError("omega", f"relaxation must lie in (0, 2), got {omega}")
    ordering = _option(options, "ordering", "natural")
    if ordering not in ("natural", "shuffled"):
        raise InvalidProblemError("ordering", f"must be 'natural' or 'shuffled', got {ordering!r}")
    seed = int(_option(options, "seed", 0))
    error_every = int(_option(options, "error_every", 10))
    stall_window = int(_option(options, "stall_window", 5000))
    loc_tol = float(_option(options, "local_tol", 1e-13))
    newton_maxit = int(_option(options, "newton_max_iter", 10))
    proj_maxit = int(_option(options, "projection_max_iter", 100))
    if error_every < 0 or stall_window < 0 or newton_maxit < 1 or proj_maxit < 1:
        raise InvalidProblemError("options", "error_every, stall_window must be >= 0 and "
                                  "newton_max_iter, projection_max_iter >= 1")
    max_iter = DEFAULT_MAX_ITER if max_iter is None else int(max_iter)

    law = _LAWS[formulation]
    mu = np.ascontiguousarray(problem.mu, dtype=np.float64)
    if formulation == "frictionless":
        mu = np.zeros(nc)
    g = np.zeros(nc)
    if formulation == "tresca":
        g = np.ascontiguousarray(options["threshold"], dtype=np.float64)

    S = problem_blocks(problem)
    q = np.ascontiguousarray(problem.q, dtype=np.float64)
    r = np.zeros(problem.m) if r0 is None else np.array(r0, dtype=np.float64).reshape(-1)
    rhoN, rhoT, rhoP, bad = local_parameters(S.diag, S.blocks)
    info = {"local_solver": ls_name, "omega": omega, "ordering": ordering,
            "error_every": error_every}
    if bad.any():
        # a contact whose W_NN is not positive has no well-posed one-contact problem
        bad = np.flatnonzero(bad)
        info["singular_contacts"] = bad.tolist()
        return SolverResult(r=r, status="numerical_error", iterations=0, info=info,
                            message=f"diagonal block W_ii of contact(s) {bad[:10].tolist()} has "
                                    f"W_NN <= 0: one-contact problem ill-posed")

    hist = np.full(max_iter if history else 1, np.nan)
    info["setup_time"] = time.perf_counter() - t_setup
    t0 = time.perf_counter()
    status, iters, err, n_full, n_fail, light = nsgs_loop(
        d, nc, S.indptr, S.indices, S.blocks, S.diag, q, mu, g, law, _KINDS[ls_name],
        rhoN, rhoT, rhoP, r, float(tol), max_iter, omega, ordering == "shuffled", seed,
        error_every, stall_window, bool(history), loc_tol, newton_maxit, proj_maxit, hist)
    info["loop_time"] = time.perf_counter() - t0
    info["cpu_time"] = time.process_time() - cpu0
    info.update(full_error_evaluations=int(n_full), local_failures=int(n_fail),
                light_error=float(light), internal_error=float(err))
    status_name = STATUS_NAMES[status]
    message = ""
    if status == STATUS_NUMERICAL:
        message = "non-finite value in a local solve; r is the last finite iterate"
    elif status_name == "stalled" and light == 0.0:
        message = f"a sweep left r unchanged but the error is {err:.3e} > tol"
    elif status_name == "stalled":
        message = f"no progress of the error over {stall_window} sweeps (error {err:.3e})"
    return SolverResult(r=r, status=status_name, iterations=int(iters),
                        history=hist[:iters].tolist() if history else None,
                        info=info, message=message)


def warmup() -> float:
    """Compile (or load from cache) the numba kernels on tiny problems; returns seconds."""
    from ..problem import FrictionContactProblem
    from .registry import solve
    t0 = time.perf_counter()
    for d in (2, 3):
        W = np.eye(2 * d) + 0.1
        prob = FrictionContactProblem(W, -np.ones(2 * d), 0.3, d)
        for ls in (("exact", "ac_newton", "projection") if d == 2 else ("ac_newton", "projection")):
            solve(prob, "nsgs", tol=1e-8, max_iter=5, local_solver=ls)
    return time.perf_counter() - t0


__all__ = ["nsgs_backend", "local_parameters", "warmup", "full_error", "DEFAULT_MAX_ITER"]

"""The projection method: ``r = P(r - rho F(r))`` with a self-adaptive step (backend ``"projection"``).

Moreau's law written as a fixed point of a projection (``formulations/projection.md``):
``r`` solves the contact problem iff ``r = P_K(r - rho û)`` for any ``rho > 0``,
``û = W r + q + mu ||u_T|| e_N`` (De Saxcé's modified velocity; ``u`` itself for
the associated, Tresca and frictionless laws, whose ``P`` is the projection on
``K`` or on ``R+ x B(0, g)``).  Each step projects the whole vector at once
(Jacobi-like, against NSGS's contact-by-contact Gauss–Seidel) and costs one
product ``W x``; the step ``rho`` adapts by Khobotov's rule (He & Liao 2002;
Acary, Brémond & Huber 2018 call the method FP-DS; Siconos' ``FPP`` and ``EG``
are its relatives).  It converges where NSGS crawls on some strongly coupled
problems (a periodic box of 60 contacts: 216 products where NSGS needs 860
sweeps, ``validation/projection_study.py``) and crawls where NSGS or Newton
win; it is not a stage of ``solver="auto"`` (``formulations/projection.md`` §4).

Options (``socp_cd.solve(problem, solver="projection", **options)``)
--------------------------------------------------------------------
rho0 : float, default 1
    Initial step relative to ``1 / mean(diag W)``.
L, L_min : float, default 0.9, 0.3
    A step is retried with a shorter ``rho`` while ``rho ||F(r+) - F(r)|| >
    L ||r+ - r||``; ``rho`` grows after a step with ``rho ||ΔF|| < L_min ||Δr||``
    that lowered the error (``0 < L_min <= L < 1``).
tau, tau_min : float, default 0.6, 0.7
    Shrink factor of a retry; ``rho`` grows by ``1 / tau_min`` (both in ``(0, 1)``).
max_retries : int, default 20
    Retries of one step (the last one is accepted).
stall_window : int, default 1000
    ``"stalled"`` after that many steps without a 1 % drop of the best error (0: never).
predict_window : int, default 0
    As NSGS's option: stop early (``"max_iter"``) when the error's mean rate over
    the last window predicts that ``max_iter`` steps will not reach ``tol`` (0: off).

Common options: ``max_iter`` counts accepted steps (default 10000); ``time_limit``
is checked between blocks of steps (10, 20, 40, ... steps, whole prediction
windows); ``r0``; ``verbose``; ``inner_settings`` does not apply (rejected when
non-empty).  ``r`` is the best iterate by Siconos' error; ``info``: ``rho`` (the
step reached), ``products`` (``W x`` done), ``internal_error``.
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import InvalidProblemError, UnsupportedError
from ..problem import kernel_array
from .kernels.cone import LAW_ASSOCIATED, LAW_COULOMB, LAW_TRESCA
from .kernels.projection import Step, projection_loop
from .nsgs_kernels import (STATUS_CONVERGED, STATUS_NAMES, STATUS_TIME_LIMIT, timed_next_block,
                           whole_windows)
from .options import check_int, check_real, check_unknown
from .result import SolverResult
from .spec import SolverSpec

DEFAULT_MAX_ITER = 10000
#: first block of steps when a time limit is checked between blocks
TIME_CHECK_STEPS = 10
#: initial length of the history buffer (doubled as steps go on)
HISTORY_CHUNK = 64
_LAWS = {"coulomb": LAW_COULOMB, "frictionless": LAW_COULOMB, "associated": LAW_ASSOCIATED,
         "tresca": LAW_TRESCA}
#: option -> (default, one-line description)
_DEFAULTS = {"rho0": 1.0, "L": 0.9, "L_min": 0.3, "tau": 0.6, "tau_min": 0.7, "max_retries": 20,
             "stall_window": 1000, "predict_window": 0}
OPTIONS = {
    "rho0": "initial step relative to 1 / mean(diag W) (default 1)",
    "L": "a step is retried while rho ||F(r+) - F(r)|| > L ||r+ - r|| (default 0.9)",
    "L_min": "rho grows after a step with rho ||dF|| < L_min ||dr|| that lowered the error "
             "(default 0.3)",
    "tau": "shrink factor of rho on a retry, in (0, 1) (default 0.6)",
    "tau_min": "rho grows by 1 / tau_min, in (0, 1) (default 0.7)",
    "max_retries": "retries of one step (default 20)",
    "stall_window": "steps without 1 % progress before 'stalled' (default 1000; 0: never)",
    "predict_window": "stop early ('max_iter') when the error's rate over this many steps "
                      "predicts that max_iter steps will not reach tol (default 0: off)",
    "threshold": "Tresca threshold per contact (formulation 'tresca')",
}


def _settings(options) -> dict:
    """Checked settings (each bad value raises ``InvalidProblemError`` naming it)."""
    def get(name):
        v = options.get(name)
        return _DEFAULTS[name] if v is None else v
    s = {"rho0": check_real("rho0", get("rho0"), positive=True)}
    for name in ("L", "L_min", "tau", "tau_min"):
        s[name] = check_real(name, get(name), minimum=0.0, maximum=1.0, open_interval=True)
    if s["L_min"] > s["L"]:
        raise InvalidProblemError("L_min", f"must be <= L = {s['L']!r}, got {s['L_min']!r}")
    for name in ("max_retries", "stall_window", "predict_window"):
        s[name] = check_int(name, get(name), minimum=0)
    return s


def check(problem, options, inner_settings) -> dict:
    """Reject ``inner_settings`` and bad option values before any work; the checked settings."""
    if inner_settings:
        raise UnsupportedError("solver 'projection': inner_settings does not apply "
                               "(its settings are the solver options)")
    return _settings(options)


def mean_diagonal(indptr, indices, data) -> float:
    """Mean of ``|W_kk|`` over the stored diagonal entries of a CSR ``W`` (1 when none is positive)."""
    m = indptr.shape[0] - 1
    rows = np.repeat(np.arange(m), np.diff(indptr))
    d = np.abs(data[indices == rows])
    s = float(d.sum()) / m if m else 0.0
    return s if np.isfinite(s) and s > 0.0 else 1.0


def projection_backend(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                       time_limit=None, verbose=False, inner_settings=None,
                       **options) -> SolverResult:
    """Projection backend for :func:`socp_cd.solve` (see the module docstring for options)."""
    check_unknown("projection", options, OPTIONS)
    st = check(problem, options, inner_settings)
    t0, cpu0 = time.perf_counter(), time.process_time()
    max_iter = DEFAULT_MAX_ITER if max_iter is None else int(max_iter)
    nc, d = problem.n_contacts, problem.dim
    mu = (np.zeros(nc) if formulation == "frictionless"
          else np.ascontiguousarray(problem.mu, dtype=np.float64))
    g = (np.ascontiguousarray(options["threshold"], dtype=np.float64) if formulation == "tresca"
         else np.zeros(nc))
    indptr, indices, data = problem.csr_parts
    q = kernel_array(problem.q)     # (the balanced copy's q is read-only)
    r = np.zeros(problem.m) if r0 is None else np.array(r0, dtype=np.float64).reshape(-1)
    rho = st["rho0"] / mean_diagonal(indptr, indices, data)
    step = Step(st["L"], st["L_min"], st["tau"], st["tau_min"], st["max_retries"])
    window = st["predict_window"]
    hist = np.full(min(max_iter, HISTORY_CHUNK) if history else 1, np.nan)
    done, products, prev = 0, 0, -1.0
    block = max_iter if time_limit is None else min(max_iter,
                                                    whole_windows(TIME_CHECK_STEPS, window))
    hist_all, best = [], np.inf
    r_best, block_best = r.copy(), np.empty_like(r)
    while True:
        status, its, err, rho, prods, last, hist = projection_loop(
            indptr, indices, data, q, mu, g, d, int(_LAWS[formulation]), r, block_best,
            float(rho), float(tol), int(block), step, st["stall_window"], window,
            int(max_iter - done), float(prev), bool(history), hist)
        if history:
            hist_all.extend(hist[:its].tolist())
        done += int(its)
        products += int(prods)
        if err < best or status == STATUS_CONVERGED:     # the best iterate over the blocks
            best = err
            r_best[:] = block_best
        if time_limit is None:
            break
        block, prev, spent = timed_next_block(status, int(its), int(block), done, max_iter, last,
                                              window, t0, time_limit, time.perf_counter)
        if not block:
            status = STATUS_TIME_LIMIT if spent else status
            break
    name = STATUS_NAMES[status]
    info = {"rho": float(rho), "products": products, "internal_error": float(best),
            "loop_time": time.perf_counter() - t0, "cpu_time": time.process_time() - cpu0}
    message = ""
    if name == "max_iter" and done < max_iter:
        message = (f"stopped after {done} of {max_iter} steps: the error's rate over the last "
                   f"{window} steps predicts more than {max_iter} to reach tol")
    elif name == "stalled":
        message = f"no 1 % progress of the error over {st['stall_window']} steps"
    elif name == "time_limit":
        message = f"time_limit {time_limit:g} s reached after {done} steps"
    elif name == "numerical_error":
        message = "non-finite value; r is the best finite iterate"
    if verbose:
        print(f"projection: {name} after {done} steps ({products} products W x), "
              f"error {info['internal_error']:.3e}, rho {rho:.3g}")
    return SolverResult(r=r_best, status=name, iterations=int(done),
                        history=hist_all if history else None, info=info, message=message)


SPEC = SolverSpec(
    "projection", projection_backend, ("coulomb", "frictionless", "tresca", "associated"),
    dims=(2, 3),
    description="fixed point r = P(r - rho F(r)) of the law with a self-adaptive step "
                "(Khobotov's rule; numba)",
    default_max_iter=DEFAULT_MAX_ITER, options=OPTIONS,
    inner_settings="not applicable (rejected)", check=check)


def warmup() -> float:
    """Compile (or load from cache) the kernel on tiny problems; returns seconds."""
    from ..problem import FrictionContactProblem
    t0 = time.perf_counter()
    for d in (2, 3):
        W = np.eye(2 * d) + 0.1
        prob = FrictionContactProblem(W, -np.ones(2 * d), 0.3, d)
        projection_backend(prob, "coulomb", tol=1e-8, max_iter=5)
        projection_backend(prob, "coulomb", tol=1e-8, max_iter=5, history=True)
    return time.perf_counter() - t0


__all__ = ["SPEC", "OPTIONS", "projection_backend", "mean_diagonal", "warmup", "DEFAULT_MAX_ITER"]

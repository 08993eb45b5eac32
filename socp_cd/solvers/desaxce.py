"""De Saxcé / Acary–Cadoux–Lemaréchal–Malick fixed point for the exact Coulomb law.

With ``s = mu ||u_T||`` frozen, the Coulomb–Signorini law ``K* ∋ û ⊥ r ∈ K``,
``û = u + s e_N``, is the optimality system of the *associated* SOCP::

    min_r  ½ rᵀ W r + (q + s e_N)ᵀ r   s.t.  r ∈ K_mu          (W symmetric)

The fixed point iterates ``s_{k+1} = mu ||u_T(r_{k+1})||`` where ``r_{k+1}``
solves the SOCP with ``s_k``.  An "inner" conic solver (Clarabel, CVXPY, ...)
is plugged in through ``inner_factory``.

Asymmetric ``W``
----------------
The SOCP only sees the symmetric part ``W_s = (W + Wᵀ)/2``; the skew part
``W_a = (W - Wᵀ)/2`` is moved to the outer loop together with ``s``::

    q_shift(r_k) = q + W_a r_k + mu ||u_T(r_k)|| e_N,     u = W r + q,

so a fixed point ``r = r_k`` satisfies ``W_s r + q_shift = û`` exactly.  The
map ``r_k -> r_{k+1}`` is a contraction only when ``W_a`` is small compared
with the smallest curvature of ``W_s`` on the active set; otherwise the
iteration oscillates or stalls (reported as ``stalled`` / ``max_iter``).  The
real data (Capsules: ``max|W_a| ≈ 6e-3`` against ``max|W| ≈ 7.3``) is well
inside the convergent regime.

Accelerations (each optional, measured by ``validation/desaxce_ablation.py``)
-----------------------------------------------------------------------------
* ``adaptive_tol`` (off by default): the inner tolerance follows the outer
  error (``inner_tol_k = clip(kappa * err_{k-1}, inner_tol_min, inner_tol_max)``),
  so early SOCPs are solved loosely.  Measured on the shared data it *costs*
  time: an interior-point method gains little from a loose tolerance (its
  last iterations converge fast) while inexact shifts add outer iterations.
* ``accel="anderson"``: type-II Anderson acceleration (memory ``memory``) on
  the shift vector ``c = q_shift - q`` with a safeguard: the accelerated point
  is kept only while the fixed-point residual ``||T(c) - c||`` decreases,
  otherwise the memory is cleared and a plain step taken.
* ``polish``: a callable ``polish(problem, r, tol, options) -> (r, info)``
  received from the backend (``"newton"`` there: the proximal semismooth
  Newton solver's local core, :func:`socp_cd.solvers.newton.newton_polish`,
  warm-started from the outer iterate) once the outer error is below
  ``polish_switch`` (retried after each 10x gain, and from the best iterate
  at the end); its iterations are counted in ``info["polish_iterations"]``,
  the polished point kept only if its error is lower (``info["error"]``,
  when the polish reports it, is taken as Siconos' Coulomb error of the
  returned ``r``; otherwise the loop computes it).  ``options`` holds
  ``max_iter``, ``law``, ``cache`` (a dict kept across the calls of one
  solve, so the polish forms its system once; on the dense path it starts as
  ``{"dense": (W, q)}``, the arrays formed here) and ``time_limit`` (seconds
  left of the outer loop's ``time_limit``, None without one).  The
  dispatcher recomputes the error of the answer in any case.

Small problems (``m <= DENSE_MAX``)
-----------------------------------
``W`` is formed densely once and the residuals run in compiled code
(:mod:`socp_cd.solvers.kernels`).  By default (``polish_switch=None``) the
polish is tried from the first outer iterate on (every iterate for
``m <= CHEAP_POLISH_MAX``, otherwise after each 10x gain).  When the outer
loop stops unconverged, the last polish from the best iterate gets
``FINAL_POLISH_FACTOR * polish_max_iter`` iterations.  Larger problems keep
``polish_switch = 1e-5``.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from ..cones import tangential_norm
from ..errors import UnsupportedError
from ..laws import associated_error
from ..problem import SYMMETRY_RTOL, kernel_array
from ..residuals import error as coulomb_error
from .anderson import Anderson
from .conic_data import dense_to_csr
from .kernels.cone import LAW_ASSOCIATED, LAW_COULOMB
from .kernels.dense import dense_error, dense_split, matvec
from .options import inner_tolerance
from .result import SolverResult

#: polish names accepted by the option check (the backends turn them into callables)
POLISH_NAMES = ("newton",)

#: Default outer options (see :func:`desaxce_fixed_point`).
OUTER_DEFAULTS = dict(
    accel="anderson",
    memory=5,
    adaptive_tol=False,
    kappa=1e-2,
    inner_tol_max=1e-4,
    inner_tol_min=None,
    polish="newton",
    polish_max_iter=15,
    polish_switch=None,
    law="coulomb",
    patience=8,
    time_limit=None,
)


#: largest ``m`` for which ``W`` is formed densely (compiled residuals and polish)
DENSE_MAX = 200
#: up to this ``m`` the dense polish is retried after every outer iteration
CHEAP_POLISH_MAX = 60
#: budget of the final dense polish, in units of ``polish_max_iter``
FINAL_POLISH_FACTOR = 10
#: ``polish_switch`` of the sparse path (used when ``polish_switch`` is None)
SPARSE_POLISH_SWITCH = 1e-5


@dataclass
class DenseSystem:
    """A small local problem formed densely once (compiled residuals of the outer loop).

    Attributes
    ----------
    W, W_sym, W_skew : ndarray
        ``W`` and its symmetric and skew parts.
    asymmetry, scale : float
        ``max|W - Wᵀ|`` and ``max|W|``.
    q, mu : ndarray
    norm_q : float
    dim : int
    """

    W: np.ndarray
    W_sym: np.ndarray
    W_skew: np.ndarray
    asymmetry: float
    scale: float
    q: np.ndarray
    mu: np.ndarray
    norm_q: float
    dim: int

    @classmethod
    def of(cls, problem) -> "DenseSystem":
        """Dense system of a local problem (``W`` in CSR)."""
        indptr, indices, data = problem.csr_parts
        Wd, Ws, Wa, asym, scale, _ = dense_split(indptr, indices, data, problem.m)
        q = kernel_array(problem.q)   # (the balanced copy's q is read-only)
        return cls(Wd, Ws, Wa, float(asym), float(scale), q,
                   np.ascontiguousarray(problem.mu, dtype=np.float64),
                   float(np.sqrt(np.dot(q, q))), problem.dim)

    def error(self, r, law_code=LAW_COULOMB):
        """``(error, u)`` of ``r`` (``u = W r + q`` recomputed, compiled)."""
        u = np.empty(r.shape[0])
        return float(dense_error(self.W, self.q, r, self.mu, self.dim, law_code, self.norm_q, u)), u


class _Workspace:
    """Per-solve data of the outer loop: ``W_s``, ``W_a`` and the residual evaluator.

    For local problems with ``m <= DENSE_MAX`` ``W`` is densified once
    (:class:`DenseSystem`): every residual is one
    compiled call and the polish runs compiled.  Otherwise the sparse
    ``problem.symmetric_part()`` / :func:`socp_cd.error` path is used.
    """

    def __init__(self, problem, friction: bool, dense_ok: bool = False):
        self.problem = problem
        self.friction = friction
        self.dense = (not problem.is_global) and problem.m <= DENSE_MAX
        self.W_sym = self.W_a = None
        self.system = None
        if self.dense:
            S = self.system = DenseSystem.of(problem)
            self.law = LAW_COULOMB if friction else LAW_ASSOCIATED
            if dense_ok:
                self.W_sym = S.W_sym
            else:
                self.W_sym = problem.W if S.asymmetry == 0.0 else dense_to_csr(S.W_sym)
            if S.asymmetry > SYMMETRY_RTOL * max(S.scale, np.finfo(float).tiny):
                self.W_a = S.W_skew        # same rule as FrictionContactProblem.is_symmetric
        elif not problem.is_global:
            self.W_sym = problem.symmetric_part()
            if not problem.is_symmetric:
                self.W_a = problem.skew_part()
        self._err = coulomb_error if friction else associated_error

    def skew_product(self, r):
        """``W_a r`` (dense: compiled, no BLAS thread pool)."""
        return matvec(self.W_a, r) if self.dense else self.W_a @ r

    def evaluate(self, r):
        """``(error, u)`` of ``r`` (``u = W r + q`` recomputed)."""
        if self.dense:
            return self.system.error(r, self.law)
        u = self.problem.velocity(r)
        return self._err(self.problem, r, u), u

    def error(self, r):
        """The law's relative error of ``r``."""
        return self.evaluate(r)[0]


def desaxce_shift(problem, r, u, W_a=None, friction=True) -> np.ndarray:
    """Outer-loop shift ``c(r) = W_a r + mu ||u_T|| e_N`` (stacked, length ``m``).

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    r, u : ndarray
        Current impulses and velocities ``u = W r + q``.
    W_a : sparse matrix, optional
        Skew part of ``W`` (None when ``W`` is symmetric or the problem global).
    """
    c = np.zeros(problem.m)
    if friction:
        c[::problem.dim] = problem.mu * tangential_norm(u, problem.dim)
    if W_a is not None:
        c += W_a @ r
    return c


def check_outer_options(outer_options) -> dict:
    """Outer options completed with :data:`OUTER_DEFAULTS`; unknown names raise ``UnsupportedError``."""
    opts = dict(OUTER_DEFAULTS)
    unknown = set(outer_options) - set(opts)
    if unknown:
        raise UnsupportedError(f"unknown De Saxcé option(s) {sorted(unknown)}; valid: {sorted(opts)}")
    opts.update(outer_options)
    if opts["law"] not in ("coulomb", "associated"):
        raise UnsupportedError(f"law must be 'coulomb' or 'associated', got {opts['law']!r}")
    pol = opts["polish"]
    if pol is not None and not callable(pol) and pol not in POLISH_NAMES:
        raise UnsupportedError(f"polish must be one of {list(POLISH_NAMES)}, None or a callable, "
                               f"got {pol!r}")
    return opts


class FixedPoint:
    """The De Saxcé outer loop: step, stop test, acceleration, polish hand-off.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    inner_factory : callable
        See :func:`desaxce_fixed_point`.
    tol : float
    opts : dict
        Outer options, checked by :func:`check_outer_options`.
    """

    def __init__(self, problem, inner_factory, tol, opts):
        self.problem, self.tol, self.opts = problem, tol, opts
        self.friction = opts["law"] == "coulomb"
        self.tmin = (opts["inner_tol_min"] if opts["inner_tol_min"] is not None
                     else inner_tolerance(tol))
        self.ws = _Workspace(problem, self.friction,
                             dense_ok=getattr(inner_factory, "accepts_dense", False))
        self.inner = inner_factory(problem, self.ws.W_sym)
        self.q = np.asarray(problem.q_local, dtype=np.float64)
        switch = opts["polish_switch"]
        if switch is None:
            switch = np.inf if self.ws.dense else SPARSE_POLISH_SWITCH
        self.switch = switch
        # retry the polish after a 10x gain (every iterate for a cheap dense polish)
        self.retry_factor = 1.0 if (self.ws.dense and problem.m <= CHEAP_POLISH_MAX) else 0.1
        pol = opts["polish"]
        if isinstance(pol, str):
            raise UnsupportedError(f"polish {pol!r}: the backend passes the polish as a callable "
                                   "(socp_cd.solvers.newton.resolve_polish)")
        self.polish = pol
        # the polish's Newton system reuses the dense W and q formed here
        self._polish_cache = {"dense": (self.ws.system.W, self.ws.system.q)} if self.ws.dense else {}
        self.accel = Anderson(opts["memory"]) if opts["accel"] == "anderson" else None
        self.info = {"polish_iterations": 0, "polish_calls": 0}
        self._local = None

    # ------------------------------------------------------------------ pieces
    def shift(self, r, u):
        """``c(r) = mu ||u_T|| e_N + W_a r``."""
        c = desaxce_shift(self.problem, r, u, None, friction=self.friction)
        if self.ws.W_a is not None:
            c += self.ws.skew_product(r)
        return c

    def inner_tol(self, k, itol, err_prev, err_prev2):
        """Inner tolerance of outer iteration ``k`` (fixed, or adaptive: loose early, tight late)."""
        o = self.opts
        if not o["adaptive_tol"]:
            return self.tmin
        # monotone, and tightened x100 when the error stops halving (the inner accuracy
        # is then what limits the outer error)
        target = float(np.clip(o["kappa"] * err_prev, self.tmin, o["inner_tol_max"]))
        if k > 2 and err_prev > 0.5 * err_prev2:
            target = min(target, itol * 1e-2)
        return max(self.tmin, min(itol, target))

    def polish_from(self, r_start, budget, time_left=None):
        """Polish from ``r_start`` (within ``time_left`` seconds when given); returns
        ``(r, err)`` of the polished point or None."""
        if self.problem.is_global and self._local is None:
            self._local = self.problem.to_local()   # the polish works on W (formed once)
        target = self._local if self._local is not None else self.problem
        options = {"max_iter": budget, "law": self.opts["law"], "cache": self._polish_cache,
                   "time_limit": None if time_left is None else max(time_left, 0.0)}
        r_pol, pinfo = self.polish(target, r_start, self.tol, options)
        if pinfo.get("available") is False:
            return None
        self.info["polish_iterations"] += int(pinfo.get("iterations", 0))
        self.info["polish_calls"] += 1
        r_pol = np.asarray(r_pol, dtype=np.float64)
        err = pinfo.get("error")
        # a polish reports Siconos' Coulomb error; a missing or non-finite one is recomputed
        if err is None or not math.isfinite(err) or not self.friction:
            err = self.ws.error(r_pol)
        return r_pol, float(err)

    def time_left(self, t_start):
        """Seconds left of the ``time_limit`` option (None without one)."""
        limit = self.opts["time_limit"]
        return None if limit is None else limit - (_time.perf_counter() - t_start)

    @staticmethod
    def keep_better(out, r_best, e_best, hist):
        """The polished point ``out = (r, err)`` when it beats the best iterate (then recorded
        in ``hist``), else the best iterate."""
        # a NaN error never wins; any other beats a NaN best (a start whose u overflows: inf
        # since session 42's errors, NaN from other measures)
        if out is None or math.isnan(out[1]) or out[1] >= e_best:
            return r_best, e_best
        if hist is not None:
            hist.append(out[1])
        return out

    # ------------------------------------------------------------------ loop
    def run(self, max_iter, r0=None, history=False) -> SolverResult:
        """Iterate at most ``max_iter`` outer steps from ``r0``; see :func:`desaxce_fixed_point`."""
        o, tol, ws = self.opts, self.tol, self.ws
        t_start = _time.perf_counter()
        if r0 is not None:
            r0 = np.asarray(r0, dtype=np.float64)
            e_r0, u_r0 = ws.evaluate(r0)
            c = self.shift(r0, u_r0)
        else:
            c = np.zeros(self.problem.m)
        hist = [] if history else None
        best_r, best_err = (r0.copy(), e_r0) if r0 is not None else (None, np.inf)
        inner_its, status, message = 0, "max_iter", ""
        last_inner = {}
        polish_at = np.inf
        err_prev = best_err if np.isfinite(best_err) else 1.0
        err_prev2 = np.inf
        itol = o["inner_tol_max"] if o["adaptive_tol"] else self.tmin
        since_improve, ref_err = 0, np.inf

        k = 0
        r = None
        for k in range(1, max_iter + 1):
            itol = self.inner_tol(k, itol, err_prev, err_prev2)
            r, last_inner = self.inner.solve(self.q + c, itol)
            inner_its += int(last_inner.get("iterations", 0))
            r = np.asarray(r, dtype=np.float64)
            if not np.isfinite(r).all():
                status = "numerical_error"
                message = f"inner solver returned non-finite r ({last_inner.get('status')})"
                break
            err, u = ws.evaluate(r)
            if hist is not None:
                hist.append(err)
            if err < best_err:
                best_r, best_err = r, err
            if err <= tol:
                status = "converged"
                break
            if self.polish is not None and err <= min(self.switch, self.retry_factor * polish_at):
                polish_at = err
                best_r, best_err = self.keep_better(self.polish_from(r, o["polish_max_iter"],
                                                                     self.time_left(t_start)),
                                                    best_r, best_err, hist)
                if best_err <= tol:
                    status, message = "converged", "converged after polish"
                    break
            if last_inner.get("timed_out", False):      # the budget cut the inner solve
                status, message = "time_limit", "inner solve stopped at time_limit"
                break
            if not last_inner.get("ok", True) and itol <= self.tmin and err >= err_prev:
                status = "numerical_error"
                message = (f"inner solver failed ({last_inner.get('status')}) and the error "
                           "stopped decreasing")
                break
            # stall: no 10 % improvement of the best error for `patience` iterations
            if best_err < 0.9 * ref_err:
                ref_err, since_improve = best_err, 0
            else:
                since_improve += 1
                if since_improve >= o["patience"]:
                    status, message = "stalled", f"no progress for {o['patience']} outer iterations"
                    break
            if o["time_limit"] is not None and _time.perf_counter() - t_start > o["time_limit"]:
                status, message = "time_limit", "outer loop exceeded time_limit"
                break
            Tc = self.shift(r, u)
            c = self.accel.step(c, Tc) if self.accel is not None else Tc
            err_prev2, err_prev = err_prev, err
        if status == "max_iter":
            message = f"{max_iter} outer iterations reached"

        if (status != "converged" and self.polish is not None and best_r is not None
                and status != "time_limit"):
            # last chance from the best iterate with a longer budget (dense Newton steps
            # are cheap and stop by themselves when the line search fails; on
            # hard-friction problems, e.g. mu = 10, the loop stalls near 1e-3 and
            # Newton needs ~100 steps)
            budget = (FINAL_POLISH_FACTOR if ws.dense else 3) * o["polish_max_iter"]
            best_r, best_err = self.keep_better(self.polish_from(best_r, budget,
                                                                 self.time_left(t_start)),
                                                best_r, best_err,
                                                hist)
            if best_err <= tol:
                status, message = "converged", "converged after polish"
        info = self.info
        info.update({"inner_iterations": inner_its, "inner_status": last_inner.get("status"),
                     "outer_error": best_err,
                     "anderson_restarts": self.accel.restarts if self.accel is not None else 0})
        r_out = best_r if best_r is not None else np.zeros(self.problem.m)
        # the inner v belongs to the last SOCP iterate only (a polished r gets v from solve())
        v = (getattr(self.inner, "last_v", None)
             if (self.problem.is_global and best_r is r) else None)
        return SolverResult(r=r_out, v=v, status=status, iterations=k, history=hist, info=info,
                            message=message, error=best_err)


def desaxce_fixed_point(problem, inner_factory, *, tol, max_iter, r0=None, history=False,
                        **outer_options) -> SolverResult:
    """Solve the Coulomb law by the De Saxcé fixed point over associated SOCPs.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    inner_factory : callable
        ``inner_factory(problem, W_sym)`` returns an object with
        ``inner.solve(q_shift, tol) -> (r, info)`` solving
        ``min ½ rᵀ W_sym r + q_shiftᵀ r, r ∈ K_mu`` (``info`` keys:
        ``iterations`` int, ``status`` str, ``ok`` bool, optionally ``timed_out`` bool:
        the solve was stopped by its time limit, which ends the loop ``time_limit``).
        ``W_sym`` is the
        symmetric part of ``W`` for local problems and None for global ones
        (the inner object then works on ``M, H`` itself; ``q_shift`` still is
        the *local* linear term ``q_local + c``).  ``W_sym`` is a scipy sparse
        matrix, or a dense ndarray for small problems when the factory has an
        attribute ``accepts_dense = True``.
    tol : float
        Target on Siconos' relative error (recomputed every outer iteration).
    max_iter : int
        Maximum number of outer iterations (SOCP solves).
    r0 : ndarray, optional
        Warm start: the first shift is computed from ``r0``.
    history : bool
        Record the Coulomb error of every outer iterate.
    **outer_options
        ``accel`` ("anderson" or None), ``memory`` (int), ``adaptive_tol``
        (bool), ``kappa``, ``inner_tol_max``, ``inner_tol_min`` (default
        :func:`inner_tolerance`), ``polish`` (None or a callable
        ``polish(problem, r, tol, options) -> (r, info)``; the backends pass
        :func:`socp_cd.solvers.newton.newton_polish` for "newton"),
        ``polish_max_iter``, ``polish_switch``
        (error below which the polish is tried; None: ``inf`` for small dense
        problems, ``1e-5`` otherwise), ``patience`` (outer iterations without
        a 10 % improvement before declaring a stall), ``time_limit`` (seconds).

    Returns
    -------
    SolverResult
        Provisional status (``converged`` / ``max_iter`` / ``stalled`` /
        ``numerical_error`` / ``time_limit``); ``iterations`` counts outer
        iterations, ``info`` holds ``inner_iterations`` (total), ``inner_status``
        (last backend string), ``outer_error``, ``polish_iterations``,
        ``anderson_restarts``.

    Raises
    ------
    UnsupportedError
        Unknown outer option or bad ``law`` / ``polish``.
    """
    opts = check_outer_options(outer_options)
    return FixedPoint(problem, inner_factory, tol, opts).run(max_iter, r0=r0, history=history)


__all__ = ["desaxce_fixed_point", "desaxce_shift", "FixedPoint", "check_outer_options",
           "OUTER_DEFAULTS", "DENSE_MAX"]

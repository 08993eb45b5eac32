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
* ``polish="newton"`` (default): a semismooth Newton method on the natural
  map (:func:`natural_map_newton`) started from an outer iterate once its
  error is below ``polish_switch`` (retried after each 10x gain, and from the
  best iterate at the end); steps counted in ``info["polish_iterations"]``,
  the polished point kept only if its error is lower.  ``polish="nsgs"`` uses
  socp_cd's NSGS backend instead (warm-started sweeps).

Small problems (``m <= DENSE_MAX``)
-----------------------------------
``W`` is formed densely once and the residuals and the Newton polish run in
compiled code (:mod:`socp_cd.solvers.desaxce_kernels`).  A polish then costs
less than one SOCP, so by default (``polish_switch=None``) it is tried from the
first outer iterate on (every iterate for ``m <= CHEAP_POLISH_MAX``, otherwise
after each 10x gain); when Newton stalls (degenerate problems) a bounded,
warm-started NSGS polish (``nsgs_polish_sweeps`` sweeps) follows.  When the
outer loop stops unconverged, the last polish from the best iterate gets
``FINAL_POLISH_FACTOR * polish_max_iter`` Newton steps (high friction: the
loop stalls near 1e-3 and Newton needs ~100 steps from there).  Larger
problems keep ``polish_switch = 1e-5`` and the sparse Newton polish.
"""
from __future__ import annotations

import time as _time
import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..cones import tangential_norm
from ..residuals import error as coulomb_error
from ..problem import SYMMETRY_RTOL
from .conic_data import dense_to_csr
from .desaxce_kernels import LAW_ASSOCIATED, LAW_COULOMB
from .desaxce_kernels import dense_error as _dense_error
from .desaxce_kernels import dense_newton as _dense_newton
from .desaxce_kernels import dense_split as _dense_split
from .desaxce_kernels import matvec as _matvec
from .result import SolverResult

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
#: sweeps of the NSGS polish that follows a stalled dense Newton polish
NSGS_POLISH_SWEEPS = 200
#: budget of the final dense polish, in units of ``polish_max_iter``
FINAL_POLISH_FACTOR = 10
#: ``polish_switch`` of the sparse path (used when ``polish_switch`` is None)
SPARSE_POLISH_SWITCH = 1e-5


class _Workspace:
    """Per-solve data of the outer loop: ``W_s``, ``W_a`` and the residual evaluator.

    For local problems with ``m <= DENSE_MAX`` ``W`` is densified once: the
    symmetric/skew split is a pair of dense operations and every residual
    (Siconos' error, ``u = W r + q`` recomputed) is one compiled call
    (:func:`~socp_cd.solvers.desaxce_kernels.dense_error`).  Otherwise the
    sparse ``problem.symmetric_part()`` / :func:`socp_cd.error` path is used.
    """

    def __init__(self, problem, friction: bool, dense_ok: bool = False):
        self.problem = problem
        self.friction = friction
        self.dense = (not problem.is_global) and problem.m <= DENSE_MAX
        self.W_sym = self.W_a = None
        if self.dense:
            W = problem.W
            Wd, Ws, Wa, asym, scale, dsum = _dense_split(W.indptr, W.indices, W.data, problem.m)
            self.Wd = Wd
            self.q = np.ascontiguousarray(problem.q, dtype=np.float64)
            self.mu = np.ascontiguousarray(problem.mu, dtype=np.float64)
            self.norm_q = float(np.sqrt(np.dot(self.q, self.q)))
            self.law = LAW_COULOMB if friction else LAW_ASSOCIATED
            if dense_ok:
                self.W_sym = Ws
            else:
                self.W_sym = problem.W if asym == 0.0 else dense_to_csr(Ws)
            if asym > SYMMETRY_RTOL * max(scale, np.finfo(float).tiny):
                self.W_a = Wa        # same rule as FrictionContactProblem.is_symmetric
            # scale-free map: rho ~ 1 / (mean |diagonal of W|), as natural_map_newton
            self.rho = np.full(problem.n_contacts, problem.m / dsum if dsum > 0.0 else 1.0)
        elif not problem.is_global:
            self.W_sym = problem.symmetric_part()
            if not problem.is_symmetric:
                self.W_a = problem.skew_part()
        self._err = coulomb_error if friction else _associated_error

    def skew_product(self, r):
        """``W_a r`` (dense: compiled, no BLAS thread pool)."""
        return _matvec(self.W_a, r) if self.dense else self.W_a @ r

    def evaluate(self, r):
        """``(error, u)`` of ``r`` (``u = W r + q`` recomputed)."""
        if self.dense:
            u = np.empty(r.shape[0])
            err = _dense_error(self.Wd, self.q, r, self.mu, self.problem.dim, self.law,
                               self.norm_q, u)
            return float(err), u
        u = self.problem.velocity(r)
        return self._err(self.problem, r, u), u

    def error(self, r):
        """Siconos' relative error of ``r``."""
        return self.evaluate(r)[0]

    def dense_newton(self, r, tol, budget):
        """Compiled Newton polish; returns ``(r, iterations, error)``."""
        r_pol, its, err = _dense_newton(self.Wd, self.q, self.mu, self.problem.dim, self.law,
                                        np.ascontiguousarray(r, dtype=np.float64), tol, budget,
                                        self.rho, self.norm_q)
        return r_pol, int(its), float(err)


def _associated_error(problem, r, u=None):
    from ..laws import associated_error
    return associated_error(problem, r, u)


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


class _Anderson:
    """Type-II Anderson acceleration of ``c -> T(c)`` with restart safeguard."""

    def __init__(self, memory: int, reg: float = 1e-12):
        self.memory = memory
        self.reg = reg
        self.X, self.G = [], []
        self.last_res = np.inf
        self.restarts = 0

    def step(self, c: np.ndarray, Tc: np.ndarray) -> np.ndarray:
        g = Tc - c
        res = float(np.linalg.norm(g))
        if res > self.last_res and self.X:  # safeguard: the extrapolation did not help
            self.X, self.G = [], []
            self.restarts += 1
        self.last_res = res
        self.X.append(c.copy())
        self.G.append(g.copy())
        if len(self.X) > self.memory + 1:
            self.X.pop(0)
            self.G.pop(0)
        if len(self.X) < 2:
            return Tc
        dX = np.diff(np.array(self.X), axis=0).T
        dG = np.diff(np.array(self.G), axis=0).T
        A = dG.T @ dG
        A += self.reg * max(np.trace(A), 1e-300) * np.eye(A.shape[0])
        try:
            gamma = np.linalg.solve(A, dG.T @ g)
        except np.linalg.LinAlgError:
            self.X, self.G = [self.X[-1]], [self.G[-1]]
            return Tc
        return c + g - (dX + dG) @ gamma


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
        ``iterations`` int, ``status`` str, ``ok`` bool).  ``W_sym`` is the
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
        ``min(1e-10, tol/100)``), ``polish`` ("newton", "nsgs" or None),
        ``polish_max_iter``, ``polish_switch`` (error below which the polish is
        tried; None: ``inf`` for small dense problems, ``1e-5`` otherwise),
        ``patience`` (outer iterations without a 10 %
        improvement before declaring a stall), ``time_limit`` (seconds).

    Returns
    -------
    SolverResult
        Provisional status (``converged`` / ``max_iter`` / ``stalled`` /
        ``numerical_error`` / ``time_limit``); ``iterations`` counts outer
        iterations, ``info`` holds ``inner_iterations`` (total), ``inner_status``
        (last backend string), ``outer_error``, ``polish_iterations``,
        ``anderson_restarts``.
    """
    opts = dict(OUTER_DEFAULTS)
    unknown = set(outer_options) - set(opts)
    if unknown:
        raise TypeError(f"unknown De Saxcé options {sorted(unknown)}")
    opts.update(outer_options)
    if opts["law"] not in ("coulomb", "associated"):
        raise ValueError(f"law must be 'coulomb' or 'associated', got {opts['law']!r}")
    tmin = opts["inner_tol_min"] if opts["inner_tol_min"] is not None else min(1e-10, tol * 1e-2)
    t_start = _time.perf_counter()
    friction = opts["law"] == "coulomb"

    ws = _Workspace(problem, friction, dense_ok=getattr(inner_factory, "accepts_dense", False))
    inner = inner_factory(problem, ws.W_sym)
    q = np.asarray(problem.q_local, dtype=np.float64)
    switch = opts["polish_switch"]
    if switch is None:
        switch = np.inf if ws.dense else SPARSE_POLISH_SWITCH
    retry_factor = 1.0 if (ws.dense and problem.m <= CHEAP_POLISH_MAX) else 0.1

    def shift(r, u):
        c = desaxce_shift(problem, r, u, None, friction=friction)
        if ws.W_a is not None:
            c += ws.skew_product(r)
        return c

    if r0 is not None:
        r0 = np.asarray(r0, dtype=np.float64)
        e_r0, u_r0 = ws.evaluate(r0)
        c = shift(r0, u_r0)
    else:
        c = np.zeros(problem.m)
    aa = _Anderson(opts["memory"]) if opts["accel"] == "anderson" else None

    hist = [] if history else None
    best_r, best_err = (r0.copy(), e_r0) if r0 is not None else (None, np.inf)
    inner_its, status, message = 0, "max_iter", ""
    last_inner = {}
    info = {"polish_iterations": 0, "polish_calls": 0}
    polish_at = np.inf
    cache = {}
    err_prev = best_err if np.isfinite(best_err) else 1.0
    err_prev2 = np.inf
    itol = opts["inner_tol_max"] if opts["adaptive_tol"] else tmin
    since_improve, ref_err = 0, np.inf

    def try_polish(r_start, budget):
        """Polish from ``r_start``; returns (r, err) of the polished point or None."""
        if ws.dense and opts["polish"] == "newton":
            r_pol, its, e_pol = ws.dense_newton(r_start, tol, budget)
            info["polish_iterations"] += its
            info["polish_calls"] += 1
            if e_pol > tol:   # stalled Newton (degenerate problem): warm-started NSGS sweeps
                r_ns, sweeps, ok = _polish(problem, r_pol, tol, "nsgs", NSGS_POLISH_SWEEPS,
                                           opts["law"])
                if ok and r_ns is not None:
                    info["nsgs_polish_sweeps"] = info.get("nsgs_polish_sweeps", 0) + sweeps
                    e_ns = ws.error(r_ns)
                    if e_ns < e_pol:
                        r_pol, e_pol = r_ns, e_ns
            return r_pol, e_pol
        if problem.is_global and "local" not in cache:
            cache["local"] = problem.to_local()   # the polish works on W (formed once)
        r_pol, its, _ = _polish(cache.get("local", problem), r_start, tol, opts["polish"], budget,
                                opts["law"])
        info["polish_iterations"] += its
        info["polish_calls"] += 1
        if r_pol is None:
            return None
        return r_pol, ws.error(r_pol)

    def keep_better(out, r_best, e_best):
        """The polished point when it beats the best iterate (recorded in the history)."""
        if out is None or out[1] >= e_best:
            return r_best, e_best
        if hist is not None:
            hist.append(out[1])
        return out

    k = 0
    for k in range(1, max_iter + 1):
        if opts["adaptive_tol"]:
            # loose early, tight late; monotone, and tightened x100 when the error
            # stops halving (the inner accuracy is then what limits the outer error)
            target = float(np.clip(opts["kappa"] * err_prev, tmin, opts["inner_tol_max"]))
            if k > 2 and err_prev > 0.5 * err_prev2:
                target = min(target, itol * 1e-2)
            itol = max(tmin, min(itol, target))
        else:
            itol = tmin
        r, last_inner = inner.solve(q + c, itol)
        inner_its += int(last_inner.get("iterations", 0))
        r = np.asarray(r, dtype=np.float64)
        if not np.isfinite(r).all():
            status, message = "numerical_error", f"inner solver returned non-finite r ({last_inner.get('status')})"
            break
        err, u = ws.evaluate(r)
        if hist is not None:
            hist.append(err)
        if err < best_err:
            best_r, best_err = r, err
        if err <= tol:
            status = "converged"
            break
        if opts["polish"] and err <= min(switch, retry_factor * polish_at):
            polish_at = err  # retry after a 10x gain (every iterate for cheap dense polish)
            best_r, best_err = keep_better(try_polish(r, opts["polish_max_iter"]), best_r, best_err)
            if best_err <= tol:
                status, message = "converged", "converged after polish"
                break
        if not last_inner.get("ok", True) and itol <= tmin and err >= err_prev:
            status = "numerical_error"
            message = f"inner solver failed ({last_inner.get('status')}) and the error stopped decreasing"
            break
        # stall detection: no 10 % improvement of the best error for `patience` iterations
        if best_err < 0.9 * ref_err:
            ref_err, since_improve = best_err, 0
        else:
            since_improve += 1
            if since_improve >= opts["patience"]:
                status, message = "stalled", f"no progress for {opts['patience']} outer iterations"
                break
        if opts["time_limit"] is not None and _time.perf_counter() - t_start > opts["time_limit"]:
            status, message = "time_limit", "outer loop exceeded time_limit"
            break
        Tc = shift(r, u)
        c = aa.step(c, Tc) if aa is not None else Tc
        err_prev2, err_prev = err_prev, err
    if status == "max_iter":
        message = f"{max_iter} outer iterations reached"

    if status != "converged" and opts["polish"] and best_r is not None and status != "time_limit":
        # last chance from the best iterate: a longer budget (the dense Newton steps are
        # cheap and stop by themselves when the line search fails; on hard-friction
        # problems, e.g. mu = 10, the outer loop stalls and Newton needs ~100 steps)
        best_r, best_err = keep_better(
            try_polish(best_r, FINAL_POLISH_FACTOR * opts["polish_max_iter"]
                       if ws.dense else 3 * opts["polish_max_iter"]), best_r, best_err)
        if best_err <= tol:
            status, message = "converged", "converged after polish"
    info.update({"inner_iterations": inner_its, "inner_status": last_inner.get("status"),
                 "outer_error": best_err,
                 "anderson_restarts": aa.restarts if aa is not None else 0})
    r_out = best_r if best_r is not None else np.zeros(problem.m)
    # the inner v belongs to the last SOCP iterate only (a polished r gets v from solve())
    v = getattr(inner, "last_v", None) if (problem.is_global and best_r is r) else None
    return SolverResult(r=r_out, v=v, status=status, iterations=k, history=hist, info=info,
                        message=message, error=best_err)


def _projection_jacobian(x, mu, dim):
    """Blocks ``dP_K/dx`` (an element of the generalized Jacobian), shape ``(nc, dim, dim)``."""
    X = x.reshape(-1, dim)
    nc = X.shape[0]
    xn, xt = X[:, 0], X[:, 1:]
    t = np.sqrt(np.einsum("ij,ij->i", xt, xt))
    J = np.zeros((nc, dim, dim))
    polar = mu * t <= -xn
    inside = (t <= mu * xn) & ~polar
    side = ~(polar | inside)
    J[inside] = np.eye(dim)
    if np.any(side):
        m_, ts = mu[side], t[side]
        w = xt[side] / ts[:, None]
        a = 1.0 / (1.0 + m_ ** 2)
        pn = (xn[side] + m_ * ts) * a
        Js = np.zeros((len(ts), dim, dim))
        Js[:, 0, 0] = a
        Js[:, 0, 1:] = (m_ * a)[:, None] * w
        Js[:, 1:, 0] = (m_ * a)[:, None] * w
        ww = np.einsum("ki,kj->kij", w, w)
        eye = np.eye(dim - 1)[None]
        Js[:, 1:, 1:] = (m_ ** 2 * a)[:, None, None] * ww + (m_ * pn / ts)[:, None, None] * (eye - ww)
        J[side] = Js
    return J


def _block_diag(B):
    """Block-diagonal CSR matrix from blocks ``(nc, d, d)``."""
    nc, d, _ = B.shape
    return sp.bsr_matrix((B, np.arange(nc), np.arange(nc + 1)), shape=(nc * d, nc * d)).tocsr()


def _newton_directions(J, F, eye):
    """Candidate steps: the Newton step, then Levenberg–Marquardt steps of growing damping."""
    nF = float(np.linalg.norm(F))
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            d = spla.spsolve(J, -F)
        if np.all(np.isfinite(d)) and np.linalg.norm(J @ d + F) <= 1e-6 * nF:
            yield d
    except Exception:  # singular factorization
        pass
    JtJ = (J.T @ J).tocsc()
    g = -(J.T @ F)
    scale = max(float(abs(JtJ).max()), 1e-300)
    for lam in (1e-12, 1e-9, 1e-6, 1e-3):
        try:
            d = spla.spsolve(JtJ + (lam * scale) * eye, g)
        except Exception:
            continue
        if np.all(np.isfinite(d)):
            yield d


def natural_map_newton(problem, r, *, tol, max_iter=20, law="coulomb", rho=None):
    """Semismooth Newton on the natural map, started from ``r`` (a polish).

    Solves ``F(r) = r - P_K(r - û(r)) = 0`` (``law="associated"``: ``u`` instead
    of ``û``) with the generalized Jacobian
    ``J = I - J_P (I - D_S W)``, ``J_P`` the block-diagonal derivative of the
    cone projection and ``D_S = I + e_N (mu u_Tᵀ/||u_T||)`` that of the De Saxcé
    map.  Each step is a sparse LU solve (a Levenberg–Marquardt step
    ``(JᵀJ + λI) d = -JᵀF`` when ``J`` is singular, e.g. rank-deficient ``W``),
    followed by a backtracking line search on Siconos' error.  Global problems
    are condensed (``W`` formed) for the polish.

    Returns
    -------
    r : ndarray
        Best iterate found (never worse than the input).
    iterations : int
        Newton steps taken (each one sparse factorization).
    """
    from ..laws import associated_error
    from ..cones import desaxce_velocity, project_cone
    prob = problem.to_local() if problem.is_global else problem
    err_fn = coulomb_error if law == "coulomb" else associated_error
    W = prob.W.tocsr()
    if rho is None:  # scale-free map: rho ~ 1 / (typical diagonal of W); same zeros as rho = 1
        dg = np.abs(W.diagonal())
        rho = 1.0 / float(np.mean(dg)) if np.any(dg > 0) else 1.0
    dim, mu = prob.dim, prob.mu
    m = prob.m
    eye = sp.identity(m, format="csr")
    r = np.asarray(r, dtype=np.float64).copy()
    err = err_fn(prob, r)
    its = 0
    for its in range(1, max_iter + 1):
        if err <= tol:
            its -= 1
            break
        u = prob.velocity(r)
        uh = desaxce_velocity(u, mu, dim) if law == "coulomb" else u
        x = r - rho * uh
        F = r - project_cone(x, mu, dim)   # zero iff the law holds (any rho > 0)
        JP = _block_diag(_projection_jacobian(x, mu, dim))
        if law == "coulomb":
            U = u.reshape(-1, dim)
            tn = tangential_norm(U, dim)
            DS = np.zeros((prob.n_contacts, dim, dim))
            DS[:] = np.eye(dim)
            ok = tn > 0
            DS[ok, 0, 1:] = (mu[ok] / tn[ok])[:, None] * U[ok, 1:]
            dU = _block_diag(DS) @ W
        else:
            dU = W
        J = (eye - JP @ (eye - rho * dU)).tocsc()
        improved = False
        for d in _newton_directions(J, F, eye):
            step = 1.0
            for _ in range(10):
                r_try = r + step * d
                e_try = err_fn(prob, r_try)
                if e_try < err:
                    r, err, improved = r_try, e_try, True
                    break
                step *= 0.5
            if improved:
                break
        if not improved:
            break
    return r, its


def _polish(problem, r, tol, method, max_iter, law="coulomb"):
    """Warm-started polish of ``r``; returns ``(r_polished or None, work, available)``."""
    if method == "newton":
        r_new, its = natural_map_newton(problem, r, tol=tol, max_iter=max_iter, law=law)
        return r_new, its, True
    if method != "nsgs":
        raise ValueError(f"unknown polish {method!r}")
    try:
        from .registry import _REGISTRY, _load_backends
        _load_backends()
        spec = _REGISTRY.get("nsgs")
    except Exception:  # pragma: no cover - registry import problems
        spec = None
    if spec is None:
        return None, 0, False
    target = problem.to_local() if problem.is_global else problem
    try:
        res = spec.func(target, law, tol=tol, max_iter=max_iter, r0=r, history=False)
    except Exception:
        return None, 0, False
    return np.asarray(res.r, dtype=np.float64), int(res.iterations), True


__all__ = ["desaxce_fixed_point", "desaxce_shift", "OUTER_DEFAULTS"]

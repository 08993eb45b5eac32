"""Polishes: warm-started local methods that finish an approximate solution.

A polish is a callable ``polish(problem, r, tol, options) -> (r, info)``:

* ``problem`` — a *local* :class:`~socp_cd.problem.FrictionContactProblem`;
* ``r`` — the starting impulses;
* ``options`` — ``{"max_iter": int, "law": "coulomb" | "associated"}`` and,
  optionally, ``"dense"``: a :class:`DenseSystem` of the problem (formed once by
  the caller, so repeated polishes of a small problem cost no setup);
* returns the polished ``r`` (never worse than the input by the law's error)
  and ``info`` with ``iterations`` (steps taken) and ``error`` (the law's
  relative error of the returned ``r``).

The De Saxcé fixed point (:mod:`socp_cd.solvers.desaxce`) takes its polish as
such a callable (:data:`POLISHES` names the built-in ones), so a new method
(e.g. a proximal semismooth Newton solver) plugs in without touching the loop.

:func:`newton_polish` — semismooth Newton on the natural map
``F(r) = r - P_K(r - rho û(r))`` with generalized Jacobian
``J = I - J_P (I - rho D_S W)``: compiled and dense for small problems
(:func:`socp_cd.solvers.kernels.polish.dense_newton`), sparse LU here
(:func:`natural_map_newton`) otherwise; one damping sequence
(:data:`~socp_cd.solvers.kernels.polish.LM_DAMPING`).  When the dense Newton
stalls (degenerate problems), warm-started NSGS sweeps follow.
:func:`nsgs_polish` — warm-started NSGS sweeps only.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..cones import desaxce_velocity, project_cone, project_cone_jacobian, tangential_norm
from ..laws import associated_error
from ..residuals import error as coulomb_error
from .kernels.cone import LAW_ASSOCIATED, LAW_COULOMB
from .kernels.dense import dense_error, dense_split
from .kernels.polish import LINE_SEARCH_STEPS, LM_DAMPING, dense_newton
from .nsgs import nsgs_backend

#: sweeps of the NSGS polish that follows a stalled dense Newton polish
NSGS_POLISH_SWEEPS = 200


@dataclass
class DenseSystem:
    """A small local problem formed densely once (compiled residuals and polish).

    Attributes
    ----------
    W, W_sym, W_skew : ndarray
        ``W`` and its symmetric and skew parts.
    asymmetry, scale : float
        ``max|W - Wᵀ|`` and ``max|W|``.
    q, mu : ndarray
    norm_q : float
    rho : ndarray
        Per-contact step of the natural map, ``m / sum|diag W|`` (scale-free).
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
    rho: np.ndarray
    dim: int

    @classmethod
    def of(cls, problem) -> "DenseSystem":
        """Dense system of a local problem (``W`` in CSR)."""
        W = problem.W
        Wd, Ws, Wa, asym, scale, dsum = dense_split(W.indptr, W.indices, W.data, problem.m)
        q = np.ascontiguousarray(problem.q, dtype=np.float64)
        rho = np.full(problem.n_contacts, problem.m / dsum if dsum > 0.0 else 1.0)
        return cls(Wd, Ws, Wa, float(asym), float(scale), q,
                   np.ascontiguousarray(problem.mu, dtype=np.float64),
                   float(np.sqrt(np.dot(q, q))), rho, problem.dim)

    def error(self, r, law_code=LAW_COULOMB):
        """``(error, u)`` of ``r`` (``u = W r + q`` recomputed, compiled)."""
        u = np.empty(r.shape[0])
        return float(dense_error(self.W, self.q, r, self.mu, self.dim, law_code, self.norm_q, u)), u


def _law_code(law):
    if law not in ("coulomb", "associated"):
        raise ValueError(f"law must be 'coulomb' or 'associated', got {law!r}")
    return LAW_COULOMB if law == "coulomb" else LAW_ASSOCIATED


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
    for lam in LM_DAMPING:
        try:
            d = spla.spsolve(JtJ + (lam * scale) * eye, g)
        except Exception:
            continue
        if np.all(np.isfinite(d)):
            yield d


def natural_map_newton(problem, r, *, tol, max_iter=20, law="coulomb", rho=None):
    """Semismooth Newton on the natural map, sparse (a polish for larger problems).

    Solves ``F(r) = r - P_K(r - rho û(r)) = 0`` (``law="associated"``: ``u``
    instead of ``û``) with ``J = I - J_P (I - rho D_S W)``, ``J_P`` the
    block-diagonal derivative of the cone projection
    (:func:`socp_cd.cones.project_cone_jacobian`) and ``D_S = I + e_N (mu
    u_Tᵀ/||u_T||)`` that of the De Saxcé map.  Each step is a sparse LU solve
    (a Levenberg–Marquardt step when ``J`` is singular), followed by a
    backtracking line search on the law's error.  Global problems are
    condensed (``W`` formed).

    Returns
    -------
    r : ndarray
        Best iterate found (never worse than the input).
    iterations : int
        Newton steps taken (each one sparse factorization).
    """
    _law_code(law)
    prob = problem.to_local() if problem.is_global else problem
    err_fn = coulomb_error if law == "coulomb" else associated_error
    W = prob.W.tocsr()
    if rho is None:  # scale-free map: rho ~ 1 / (typical diagonal of W); same zeros as rho = 1
        dg = np.abs(W.diagonal())
        rho = 1.0 / float(np.mean(dg)) if np.any(dg > 0) else 1.0
    dim, mu = prob.dim, prob.mu
    eye = sp.identity(prob.m, format="csr")
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
        JP = _block_diag(project_cone_jacobian(x, mu, dim))
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
            for _ in range(LINE_SEARCH_STEPS):
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


def nsgs_polish(problem, r, tol, options):
    """Warm-started NSGS sweeps (``options["max_iter"]`` of them); see the module docstring."""
    law = options.get("law", "coulomb")
    try:
        res = nsgs_backend(problem, law, tol=tol, max_iter=int(options["max_iter"]), r0=r,
                           history=False)
    except Exception:   # noqa: BLE001 - a polish never fails the solve: keep r
        return r, {"iterations": 0, "error": np.inf, "available": False}
    r_new = np.asarray(res.r, dtype=np.float64)
    dense = options.get("dense")
    if dense is not None:
        e = dense.error(r_new, _law_code(law))[0]
    else:
        e = (coulomb_error if law == "coulomb" else associated_error)(problem, r_new)
    return r_new, {"iterations": int(res.iterations), "error": float(e), "available": True}


def newton_polish(problem, r, tol, options):
    """Semismooth Newton polish (compiled when ``options["dense"]`` is given); see the module docstring.

    ``info`` also holds ``nsgs_sweeps`` when the dense Newton stalled above
    ``tol`` and NSGS sweeps (``options.get("nsgs_sweeps", NSGS_POLISH_SWEEPS)``) were tried.
    """
    law = options.get("law", "coulomb")
    code = _law_code(law)
    budget = int(options["max_iter"])
    dense = options.get("dense")
    if dense is None:
        r_pol, its = natural_map_newton(problem, r, tol=tol, max_iter=budget, law=law)
        e = (coulomb_error if law == "coulomb" else associated_error)(problem, r_pol)
        return r_pol, {"iterations": int(its), "error": float(e)}
    r_pol, its, e_pol = dense_newton(dense.W, dense.q, dense.mu, dense.dim, code,
                                     np.ascontiguousarray(r, dtype=np.float64), tol, budget,
                                     dense.rho, dense.norm_q)
    info = {"iterations": int(its), "error": float(e_pol)}
    sweeps = options.get("nsgs_sweeps", NSGS_POLISH_SWEEPS)
    if e_pol > tol and sweeps:   # stalled Newton (degenerate problem): warm-started NSGS sweeps
        r_ns, ns = nsgs_polish(problem, r_pol, tol, {"max_iter": sweeps, "law": law, "dense": dense})
        if ns.get("available"):
            info["nsgs_sweeps"] = ns["iterations"]
            if ns["error"] < info["error"]:
                r_pol, info["error"] = r_ns, ns["error"]
    return r_pol, info


#: built-in polishes by name (``polish=`` option of the De Saxcé fixed point)
POLISHES = {"newton": newton_polish, "nsgs": nsgs_polish}

__all__ = ["DenseSystem", "natural_map_newton", "newton_polish", "nsgs_polish", "POLISHES",
           "NSGS_POLISH_SWEEPS"]

"""Polish of the *associated* law: semismooth Newton on its natural map (sparse).

The exact Coulomb law is polished by the proximal semismooth Newton method's
local core (:func:`socp_cd.solvers.newton.newton_polish`, the one polish of the
Clarabel and cvxpy paths).  The Alart–Curnier equation it solves does not
model the associated law ``K* ∋ u ⊥ r ∈ K`` (relaxation, single SOCP, and the
outer loop of an asymmetric ``W``); this module finishes those iterates with a
semismooth Newton method on ``F(r) = r - P_K(r - rho u(r))``.

A polish is a callable ``polish(problem, r, tol, options) -> (r, info)``:
``problem`` local, ``r`` the starting impulses, ``options["max_iter"]`` the
step budget; returns the polished ``r`` (never worse than the input by the
law's error) and ``info = {"iterations", "error"}``.
"""
from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..cones import project_cone, project_cone_jacobian
from ..laws import associated_error

#: Levenberg–Marquardt damping factors (relative to ``max|JᵀJ|``), tried in order
LM_DAMPING = (1e-12, 1e-9, 1e-6, 1e-3)
#: backtracking halvings of the line search
LINE_SEARCH_STEPS = 10


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


def natural_map_newton(problem, r, *, tol, max_iter=20, rho=None):
    """Semismooth Newton on the associated law's natural map, sparse.

    Solves ``F(r) = r - P_K(r - rho u(r)) = 0`` with ``J = I - J_P (I - rho W)``,
    ``J_P`` the block-diagonal derivative of the cone projection
    (:func:`socp_cd.cones.project_cone_jacobian`).  Each step is a sparse LU
    solve (a Levenberg–Marquardt step when ``J`` is singular), followed by a
    backtracking line search on the law's error.  Global problems are
    condensed (``W`` formed).

    Returns
    -------
    r : ndarray
        Best iterate found (never worse than the input).
    iterations : int
        Newton steps taken (each one sparse factorization).
    """
    prob = problem.to_local() if problem.is_global else problem
    W = prob.W.tocsr()
    if rho is None:  # scale-free map: rho ~ 1 / (typical diagonal of W); same zeros as rho = 1
        dg = np.abs(W.diagonal())
        rho = 1.0 / float(np.mean(dg)) if np.any(dg > 0) else 1.0
    dim, mu = prob.dim, prob.mu
    eye = sp.identity(prob.m, format="csr")
    r = np.asarray(r, dtype=np.float64).copy()
    err = associated_error(prob, r)
    its = 0
    for its in range(1, max_iter + 1):
        if err <= tol:
            its -= 1
            break
        x = r - rho * prob.velocity(r)
        F = r - project_cone(x, mu, dim)   # zero iff the law holds (any rho > 0)
        JP = _block_diag(project_cone_jacobian(x, mu, dim))
        J = (eye - JP @ (eye - rho * W)).tocsc()
        improved = False
        for d in _newton_directions(J, F, eye):
            step = 1.0
            for _ in range(LINE_SEARCH_STEPS):
                r_try = r + step * d
                e_try = associated_error(prob, r_try)
                if e_try < err:
                    r, err, improved = r_try, e_try, True
                    break
                step *= 0.5
            if improved:
                break
        if not improved:
            break
    return r, its


def associated_polish(problem, r, tol, options):
    """Polish callable of the associated law (see the module docstring)."""
    r_pol, its = natural_map_newton(problem, r, tol=tol, max_iter=int(options["max_iter"]))
    return r_pol, {"iterations": int(its), "error": float(associated_error(problem, r_pol))}


__all__ = ["natural_map_newton", "associated_polish", "LM_DAMPING", "LINE_SEARCH_STEPS"]

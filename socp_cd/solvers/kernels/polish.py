"""Semismooth Newton polish on the natural map, dense ``W`` (numba): the one compiled polish.

Solves ``F(r) = r - P_K(r - rho û(r)) = 0`` (``law`` = ``LAW_ASSOCIATED``: ``u``
instead of ``û``) from a starting point, with the generalized Jacobian
``J = I - J_P (I - rho D_S W)`` (``J_P`` from
:func:`~socp_cd.solvers.kernels.cone.project_cone_jacobian_block`, ``D_S =
dû/du``), a plain Newton step when the LU solve is accurate, otherwise
Levenberg–Marquardt steps ``(JᵀJ + λ s I) d = -JᵀF`` with the one damping
sequence :data:`LM_DAMPING`, and a backtracking line search (10 halvings) on
Siconos' error.  No Python in the loop.

The sparse NumPy version for larger problems is
:func:`socp_cd.solvers.polish.natural_map_newton` (same steps, same damping).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .cone import LAW_COULOMB, law_velocity_block, project_cone_jacobian_block, project_law_block
from .dense import dense_error, lu_solve, matvec_into, normal_matrix

#: Levenberg–Marquardt damping factors (relative to ``max|JᵀJ|``), tried in order
LM_DAMPING = (1e-12, 1e-9, 1e-6, 1e-3)
#: backtracking halvings of the line search
LINE_SEARCH_STEPS = 10


@njit(cache=True)
def _residual_and_jacobian(W, r, u, mu, dim, law, rho, F, J):
    """Natural map ``F(r)`` and ``J = I - J_P (I - rho D_S W)`` (dense, into ``F``, ``J``)."""
    m = r.shape[0]
    nc = m // dim
    uh = np.empty(dim)
    x = np.empty(dim)
    p = np.empty(dim)
    JP = np.empty((dim, dim))
    DS = np.empty((dim, dim))
    B = np.empty((dim, dim))
    for i in range(nc):
        o = i * dim
        law_velocity_block(u[o:o + dim], dim, mu[i], law, uh)
        for a in range(dim):
            x[a] = r[o + a] - rho[i] * uh[a]
        project_law_block(x, dim, mu[i], 0.0, law, p)
        for a in range(dim):
            F[o + a] = r[o + a] - p[a]
        project_cone_jacobian_block(x, dim, mu[i], JP)
        # D_S = d û / d u: identity plus mu u_T / ||u_T|| in the normal row (Coulomb)
        DS[:, :] = 0.0
        for a in range(dim):
            DS[a, a] = 1.0
        if law == LAW_COULOMB:
            tn = 0.0
            for a in range(1, dim):
                tn += u[o + a] * u[o + a]
            tn = np.sqrt(tn)
            if tn > 0.0:
                for a in range(1, dim):
                    DS[0, a] = mu[i] * u[o + a] / tn
        for a in range(dim):
            for b in range(dim):
                s = 0.0
                for c in range(dim):
                    s += JP[a, c] * DS[c, b]
                B[a, b] = rho[i] * s
        # rows of contact i: B W[rows_i, :] + (I - J_P) on the diagonal block
        for a in range(dim):
            for k in range(m):
                s = 0.0
                for c in range(dim):
                    s += B[a, c] * W[o + c, k]
                J[o + a, k] = s
            for b in range(dim):
                J[o + a, o + b] += (1.0 if a == b else 0.0) - JP[a, b]


@njit(cache=True)
def _line_search(W, q, mu, dim, law, norm_q, r, d, err, r_try, u):
    """Backtracking (10 halvings) on Siconos' error; returns the accepted error or -1."""
    step = 1.0
    for _ in range(LINE_SEARCH_STEPS):
        for k in range(r.shape[0]):
            r_try[k] = r[k] + step * d[k]
        e = dense_error(W, q, r_try, mu, dim, law, norm_q, u)
        if e < err:
            return e
        step *= 0.5
    return -1.0


@njit(cache=True)
def dense_newton(W, q, mu, dim, law, r0, tol, max_iter, rho, norm_q):
    """Semismooth Newton polish on the natural map (dense ``W``).

    Returns
    -------
    r : ndarray
        Best iterate (never worse than ``r0``).
    iterations : int
        Newton steps taken.
    error : float
        Siconos' relative error of ``r``.
    """
    m = r0.shape[0]
    r = r0.copy()
    u = np.empty(m)
    ut = np.empty(m)
    r_try = np.empty(m)
    F = np.empty(m)
    J = np.empty((m, m))
    err = dense_error(W, q, r, mu, dim, law, norm_q, u)
    its = 0
    Jw = np.empty((m, m))
    JtJ = np.empty((m, m))
    g = np.empty(m)
    res = np.empty(m)
    while its < max_iter and err > tol:
        its += 1
        _residual_and_jacobian(W, r, u, mu, dim, law, rho, F, J)
        nF = np.sqrt(np.dot(F, F))
        improved = False
        # 1) plain Newton step (kept when the linear solve is accurate)
        Jw[:, :] = J
        for k in range(m):
            res[k] = -F[k]
        d, ok = lu_solve(Jw, res)
        if ok:
            matvec_into(J, d, F, res)
            ok = np.sqrt(np.dot(res, res)) <= 1e-6 * nF
        if ok:
            e = _line_search(W, q, mu, dim, law, norm_q, r, d, err, r_try, ut)
            if e >= 0.0:
                r[:] = r_try
                err = e
                improved = True
        # 2) Levenberg–Marquardt steps of growing damping
        if not improved:
            normal_matrix(J, F, JtJ, g)
            scale = max(np.max(np.abs(JtJ)), 1e-300)
            for lam in LM_DAMPING:
                Jw[:, :] = JtJ
                for k in range(m):
                    Jw[k, k] += lam * scale
                    res[k] = g[k]
                d, ok = lu_solve(Jw, res)
                if not ok:
                    continue
                e = _line_search(W, q, mu, dim, law, norm_q, r, d, err, r_try, ut)
                if e >= 0.0:
                    r[:] = r_try
                    err = e
                    improved = True
                    break
        if not improved:
            break
        err = dense_error(W, q, r, mu, dim, law, norm_q, u)   # refresh u for the next Jacobian
    return r, its, err


@njit(cache=True)
def error_then_newton(W, q, mu, dim, law, r, tol, max_iter, rho):
    """:func:`dense_error` of ``r`` then, above ``tol``, :func:`dense_newton` (one call).

    ``rho`` is a scalar here.  Returns ``(r_best, newton_steps, error_of_r, error_of_r_best)``
    (``error_of_r`` is NaN when ``r`` is not finite; ``r_best`` is then ``r``).
    """
    m = r.shape[0]
    norm_q = np.sqrt(np.dot(q, q))
    u = np.empty(m)
    for k in range(m):
        if not np.isfinite(r[k]):
            return r, 0, np.nan, np.nan
    e0 = dense_error(W, q, r, mu, dim, law, norm_q, u)
    if e0 <= tol or max_iter <= 0:
        return r, 0, e0, e0
    rho_v = np.full(mu.shape[0], rho)
    r_pol, its, e = dense_newton(W, q, mu, dim, law, r, tol, max_iter, rho_v, norm_q)
    return r_pol, its, e0, e


__all__ = ["dense_newton", "error_then_newton", "LM_DAMPING", "LINE_SEARCH_STEPS"]

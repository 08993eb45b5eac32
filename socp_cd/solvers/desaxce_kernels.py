"""Compiled (numba) kernels of the De Saxcé outer loop for small problems.

The Clarabel fixed point spends most of its time, on problems with a few
contacts, in Python-level bookkeeping: residual evaluations and the Newton
polish.  For a *dense* Delassus operator ``W`` (small ``m``) these kernels do
both in compiled code:

* :func:`dense_error` — Siconos' relative error ``||r - P_K(r - û)|| /
  max(||q||, ||r||, ||u||)`` with ``u = W r + q`` recomputed (the same measure
  as :func:`socp_cd.error`; ``law`` selects û (Coulomb) or u (associated));
* :func:`dense_newton` — the semismooth Newton polish on the natural map
  ``F(r) = r - P_K(r - rho û(r))`` of :func:`socp_cd.solvers.desaxce.natural_map_newton`
  (same generalized Jacobian ``J = I - J_P (I - rho D_S W)``, same
  Levenberg–Marquardt fallback and backtracking line search on Siconos'
  error), with LAPACK dense solves and no Python in the loop.

Per-contact projections reuse :mod:`socp_cd.solvers.local_solvers`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .local_solvers import LAW_ASSOCIATED, LAW_COULOMB, law_velocity, project_law

_EPS = 2.220446049250313e-16


@njit(cache=True)
def dense_error(W, q, r, mu, dim, law, norm_q, u):
    """Relative natural-map error of ``r`` (``u = W r + q`` written into ``u``)."""
    m = r.shape[0]
    nc = m // dim
    u[:] = W @ r + q
    x = np.empty(dim)
    p = np.empty(dim)
    s = 0.0
    nr = 0.0
    nu = 0.0
    for i in range(nc):
        o = i * dim
        law_velocity(u[o:o + dim], dim, mu[i], law, x)
        for a in range(dim):
            x[a] = r[o + a] - x[a]
            nr += r[o + a] * r[o + a]
            nu += u[o + a] * u[o + a]
        project_law(x, dim, mu[i], 0.0, law, p)
        for a in range(dim):
            e = r[o + a] - p[a]
            s += e * e
    den = max(norm_q, np.sqrt(nr), np.sqrt(nu))
    if den <= _EPS:
        den = 1.0
    return np.sqrt(s) / den


@njit(cache=True)
def _projection_jacobian(x, dim, mu, JP):
    """One element of the generalized Jacobian of ``P_K`` at ``x`` (into ``JP``)."""
    xn = x[0]
    t = 0.0
    for a in range(1, dim):
        t += x[a] * x[a]
    t = np.sqrt(t)
    JP[:, :] = 0.0
    if mu * t <= -xn:            # polar cone: P = 0
        return
    if t <= mu * xn:             # inside: P = identity
        for a in range(dim):
            JP[a, a] = 1.0
        return
    a_ = 1.0 / (1.0 + mu * mu)
    pn = (xn + mu * t) * a_
    JP[0, 0] = a_
    for b in range(1, dim):
        wb = x[b] / t
        JP[0, b] = mu * a_ * wb
        JP[b, 0] = mu * a_ * wb
        for c in range(1, dim):
            wc = x[c] / t
            eye = 1.0 if b == c else 0.0
            JP[b, c] = mu * mu * a_ * wb * wc + (mu * pn / t) * (eye - wb * wc)


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
        law_velocity(u[o:o + dim], dim, mu[i], law, uh)
        for a in range(dim):
            x[a] = r[o + a] - rho[i] * uh[a]
        project_law(x, dim, mu[i], 0.0, law, p)
        for a in range(dim):
            F[o + a] = r[o + a] - p[a]
        _projection_jacobian(x, dim, mu[i], JP)
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
    for _ in range(10):
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
    while its < max_iter and err > tol:
        its += 1
        _residual_and_jacobian(W, r, u, mu, dim, law, rho, F, J)
        nF = np.sqrt(np.dot(F, F))
        improved = False
        # 1) plain Newton step (kept when the linear solve is accurate)
        ok = True
        d = np.zeros(m)
        try:
            d = np.linalg.solve(J, -F)
        except Exception:  # noqa: BLE001 - singular J
            ok = False
        if ok:
            for k in range(m):
                if not np.isfinite(d[k]):
                    ok = False
                    break
        if ok:
            res = J @ d + F
            ok = np.sqrt(np.dot(res, res)) <= 1e-6 * nF
        if ok:
            e = _line_search(W, q, mu, dim, law, norm_q, r, d, err, r_try, ut)
            if e >= 0.0:
                r[:] = r_try
                err = e
                improved = True
        # 2) Levenberg–Marquardt steps of growing damping
        if not improved:
            JtJ = J.T @ J
            g = -(J.T @ F)
            scale = max(np.max(np.abs(JtJ)), 1e-300)
            for lam in (1e-12, 1e-9, 1e-6, 1e-3):
                A = JtJ.copy()
                for k in range(m):
                    A[k, k] += lam * scale
                ok = True
                try:
                    d = np.linalg.solve(A, g)
                except Exception:  # noqa: BLE001
                    ok = False
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


__all__ = ["dense_error", "dense_newton", "LAW_COULOMB", "LAW_ASSOCIATED"]

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
  error), with no Python in the loop.

The linear algebra is written out (matrix-vector products, LU with partial
pivoting) instead of calling BLAS/LAPACK: at these sizes it costs about the
same, and it cannot fall into multithreaded-OpenBLAS oversubscription, which
on a loaded machine turns a 0.2 ms ``162 x 162`` solve into 50-100 ms.

:func:`dense_condense` forms the local problem of a small global one.
Per-contact projections reuse :mod:`socp_cd.solvers.local_solvers`.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .local_solvers import LAW_ASSOCIATED, LAW_COULOMB, law_velocity, project_law

_EPS = 2.220446049250313e-16


@njit(cache=True)
def _matvec(A, x, b, out):
    """``out = A x + b`` (no BLAS)."""
    n, k = A.shape
    for i in range(n):
        s = b[i]
        for j in range(k):
            s += A[i, j] * x[j]
        out[i] = s


@njit(cache=True)
def _lu_solve_many(A, B):
    """Solve ``A X = B`` (``B`` of shape ``(n, k)``) by LU with partial pivoting.

    In place: ``A`` and ``B`` are destroyed.  Returns ``(X, ok)``; ``ok`` is
    False on a zero (or non-finite) pivot or a non-finite solution.
    """
    n, k = B.shape
    X = np.zeros((n, k))
    scale = 0.0
    for i in range(n):
        for j in range(n):
            a = abs(A[i, j])
            if a > scale:
                scale = a
    tiny = 1e-300 + 1e-15 * scale
    for c in range(n):
        p = c
        amax = abs(A[c, c])
        for i in range(c + 1, n):
            a = abs(A[i, c])
            if a > amax:
                amax = a
                p = i
        if not (amax > tiny):          # also catches NaN
            return X, False
        if p != c:
            for j in range(c, n):
                t = A[c, j]
                A[c, j] = A[p, j]
                A[p, j] = t
            for j in range(k):
                t = B[c, j]
                B[c, j] = B[p, j]
                B[p, j] = t
        inv = 1.0 / A[c, c]
        for i in range(c + 1, n):
            f = A[i, c] * inv
            if f != 0.0:
                for j in range(c + 1, n):
                    A[i, j] -= f * A[c, j]
                for j in range(k):
                    B[i, j] -= f * B[c, j]
    for i in range(n - 1, -1, -1):
        for j in range(k):
            s = B[i, j]
            for l in range(i + 1, n):
                s -= A[i, l] * X[l, j]
            X[i, j] = s / A[i, i]
            if not np.isfinite(X[i, j]):
                return X, False
    return X, True


@njit(cache=True)
def _lu_solve(A, b):
    """Solve ``A x = b`` (in place, ``A`` destroyed); returns ``(x, ok)``."""
    X, ok = _lu_solve_many(A, b.reshape(b.shape[0], 1).copy())
    return X[:, 0].copy(), ok


@njit(cache=True)
def _normal_matrix(J, F, A, g):
    """``A = JᵀJ`` and ``g = -JᵀF`` (zero entries of ``J`` skipped)."""
    m = J.shape[0]
    A[:, :] = 0.0
    g[:] = 0.0
    for k in range(m):
        for i in range(m):
            a = J[k, i]
            if a != 0.0:
                g[i] -= a * F[k]
                for j in range(m):
                    A[i, j] += a * J[k, j]


@njit(cache=True)
def dense_error(W, q, r, mu, dim, law, norm_q, u):
    """Relative natural-map error of ``r`` (``u = W r + q`` written into ``u``)."""
    m = r.shape[0]
    nc = m // dim
    _matvec(W, r, q, u)
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
        d, ok = _lu_solve(Jw, res)
        if ok:
            _matvec(J, d, F, res)
            ok = np.sqrt(np.dot(res, res)) <= 1e-6 * nF
        if ok:
            e = _line_search(W, q, mu, dim, law, norm_q, r, d, err, r_try, ut)
            if e >= 0.0:
                r[:] = r_try
                err = e
                improved = True
        # 2) Levenberg–Marquardt steps of growing damping
        if not improved:
            _normal_matrix(J, F, JtJ, g)
            scale = max(np.max(np.abs(JtJ)), 1e-300)
            for lam in (1e-12, 1e-9, 1e-6, 1e-3):
                Jw[:, :] = JtJ
                for k in range(m):
                    Jw[k, k] += lam * scale
                    res[k] = g[k]
                d, ok = _lu_solve(Jw, res)
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
def dense_condense(M, H, f, w):
    """Local form of a small global problem: ``W = Hᵀ M⁻¹ H``, ``q = Hᵀ M⁻¹ f + w``.

    One LU of ``M`` with partial pivoting (no LAPACK), ``M``, ``H`` dense.
    Returns ``(W, q, ok)``; ``ok`` is False when ``M`` is numerically singular.
    """
    n, m = H.shape
    A = M.copy()
    B = np.empty((n, m + 1))
    for i in range(n):
        for j in range(m):
            B[i, j] = H[i, j]
        B[i, m] = f[i]
    W = np.zeros((m, m))
    q = np.zeros(m)
    X, ok = _lu_solve_many(A, B)
    if not ok:
        return W, q, False
    for a in range(m):
        for i in range(n):
            h = H[i, a]
            if h != 0.0:
                for b in range(m):
                    W[a, b] += h * X[i, b]
                q[a] += h * X[i, m]
        q[a] += w[a]
    for a in range(m):
        if not np.isfinite(q[a]):
            return W, q, False
        for b in range(m):
            if not np.isfinite(W[a, b]):
                return W, q, False
    return W, q, True


@njit(cache=True)
def dense_split(indptr, indices, data, m):
    """Dense ``W`` (from CSR arrays) and its symmetric and skew parts.

    Returns ``(W, W_s, W_a, max|W_a|·2, max|W|, sum|diag W|)``; the second
    value is ``max|W - Wᵀ|`` as :attr:`FrictionContactProblem.asymmetry`.
    """
    W = np.zeros((m, m))
    for i in range(m):
        for p in range(indptr[i], indptr[i + 1]):
            W[i, indices[p]] += data[p]
    Ws = np.empty((m, m))
    Wa = np.empty((m, m))
    asym = 0.0
    scale = 0.0
    dsum = 0.0
    for i in range(m):
        dsum += abs(W[i, i])
        for j in range(m):
            a = W[i, j]
            b = W[j, i]
            Ws[i, j] = 0.5 * (a + b)
            Wa[i, j] = 0.5 * (a - b)
            if abs(a - b) > asym:
                asym = abs(a - b)
            if abs(a) > scale:
                scale = abs(a)
    return W, Ws, Wa, asym, scale, dsum


@njit(cache=True)
def matvec(A, x):
    """``A x`` without BLAS (no thread pool involved)."""
    out = np.zeros(A.shape[0])
    _matvec(A, x, out, out)
    return out


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


__all__ = ["dense_error", "dense_newton", "error_then_newton", "dense_condense", "dense_split", "matvec", "LAW_COULOMB", "LAW_ASSOCIATED"]

"""One-contact solvers used inside NSGS (numba-compiled).

Cone projections and De Saxcé velocities come from
:mod:`socp_cd.solvers.kernels.cone` (one implementation).  Each solver receives the *local problem* of contact ``i``: the diagonal block
``A = W_ii`` (``dim x dim``, possibly nonsymmetric), the local free velocity
``b = q_i + sum_{j != i} W_ij r_j`` and the friction coefficient ``mu``; it
returns ``r`` such that ``u = A r + b`` and ``r`` obey the contact law of the
formulation:

* ``LAW_COULOMB``    — Signorini + Coulomb, ``K* ∋ û ⊥ r ∈ K_mu`` (``mu = 0``:
  frictionless);
* ``LAW_ASSOCIATED`` — ``K* ∋ u ⊥ r ∈ K_mu`` (no De Saxcé correction);
* ``LAW_TRESCA``     — Signorini normally, ``r_T ∈ B(0, g)`` with a given
  threshold ``g`` tangentially.

Solvers (see ``formulations/nsgs.md`` for the equations):

* :func:`exact_2d` — Moreau's explicit case analysis in 2D (separation, stick,
  slide forward, slide backward), Coulomb law only;
* :func:`ac_newton` — Alart–Curnier semismooth Newton with an Armijo line
  search on ``½||F_AC||²`` (Coulomb and Tresca);
* :func:`projection_fp` — the projected fixed point
  ``r <- P(r - rho û)`` (every law).

:func:`local_solve` chains them as NSGS uses them (exact → Newton fallback,
Newton → projection → Newton, projection alone).  All buffers are passed in:
nothing is allocated per call.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .kernels.cone import (LAW_ASSOCIATED, LAW_COULOMB, LAW_TRESCA, law_velocity_block,
                           project_law_block)


KIND_EXACT = 0
KIND_AC_NEWTON = 1
KIND_PROJECTION = 2

#: return flags of :func:`local_solve`
LOCAL_OK = 0
LOCAL_NOT_CONVERGED = 1


@njit(cache=True, inline="always")
def _matvec_plus(A, x, b, d, out):
    """``out = A x + b``."""
    for a in range(d):
        s = b[a]
        for c in range(d):
            s += A[a, c] * x[c]
        out[a] = s


@njit(cache=True, inline="always")
def _norm(x, d):
    s = 0.0
    for a in range(d):
        s += x[a] * x[a]
    return np.sqrt(s)


@njit(cache=True)
def local_residual(A, b, mu, g, law, r, d, w1, w2):
    """Natural-map residual ``||r - P(r - û)||`` of the local problem (rho = 1)."""
    _matvec_plus(A, r, b, d, w1)
    law_velocity_block(w1, d, mu, law, w2)
    for a in range(d):
        w2[a] = r[a] - w2[a]
    project_law_block(w2, d, mu, g, law, w1)
    s = 0.0
    for a in range(d):
        e = r[a] - w1[a]
        s += e * e
    return np.sqrt(s)


# --------------------------------------------------------------------------- 2D exact
@njit(cache=True, inline="always")
def exact_2d(A, b, mu, r):
    """Moreau's explicit solution of the 2D one-contact Coulomb problem.

    Tries, in order, separation (``r = 0``, ``b_N >= 0``), stick (``A r = -b``
    with ``|r_T| <= mu r_N``), slide forward (``r_T = -mu r_N``, ``u_N = 0``,
    ``u_T >= 0``) and slide backward (``r_T = mu r_N``, ``u_N = 0``,
    ``u_T <= 0``) and writes the first consistent case in ``r``.

    Returns
    -------
    bool
        False when no case is consistent (degenerate or non-P block); ``r``
        is then left unchanged.
    """
    bn = b[0]
    bt = b[1]
    if bn >= 0.0:
        r[0] = 0.0
        r[1] = 0.0
        return True
    a00 = A[0, 0]
    a01 = A[0, 1]
    a10 = A[1, 0]
    a11 = A[1, 1]
    scale = abs(a00) + abs(a01) + abs(a10) + abs(a11)
    det = a00 * a11 - a01 * a10
    if abs(det) > 1e-14 * scale * scale:
        rn = -(a11 * bn - a01 * bt) / det
        rt = -(-a10 * bn + a00 * bt) / det
        if rn >= 0.0 and abs(rt) <= mu * rn * (1.0 + 1e-12):
            bound = mu * rn
            if rt > bound:
                rt = bound
            elif rt < -bound:
                rt = -bound
            r[0] = rn
            r[1] = rt
            return True
    slack = 1e-12 * (abs(bt) + abs(bn))
    for k in range(2):
        s = 1.0 if k == 0 else -1.0     # s = sign(u_T), r_T = -s mu r_N
        den = a00 - s * mu * a01
        if den > 0.0:
            rn = -bn / den
            ut = (a10 - s * mu * a11) * rn + bt
            if s * ut >= -slack:
                r[0] = rn
                r[1] = -s * mu * rn
                return True
    return False


# --------------------------------------------------------------------------- projection
@njit(cache=True)
def projection_fp(A, b, mu, g, law, rho, r, d, maxit, tol, w1, w2):
    """Projected fixed point ``r <- P(r - rho (A r + b)^)`` on one contact.

    Stops when ``||Δr|| <= tol * max(||r||, tiny)`` or after ``maxit``
    iterations.  Returns the number of iterations (negative when not converged).
    """
    for k in range(maxit):
        _matvec_plus(A, r, b, d, w1)
        law_velocity_block(w1, d, mu, law, w2)
        for a in range(d):
            w2[a] = r[a] - rho * w2[a]
        project_law_block(w2, d, mu, g, law, w1)
        s = 0.0
        for a in range(d):
            e = w1[a] - r[a]
            s += e * e
            r[a] = w1[a]
        nr = _norm(r, d)
        if np.sqrt(s) <= tol * (nr if nr > 1e-300 else 1e-300):
            return k + 1
    return -maxit


# --------------------------------------------------------------------------- Alart–Curnier
@njit(cache=True, inline="always")
def ac_function(A, b, mu, g, law, rhoN, rhoT, r, d, u, F, J, want_jac):
    """Alart–Curnier function ``F(r)`` and one element ``J`` of its generalized Jacobian.

    ``F_N = r_N - max(0, r_N - rhoN u_N)``,
    ``F_T = r_T - P_{B(0, R)}(r_T - rhoT u_T)`` with ``R = mu max(0, r_N - rhoN u_N)``
    (Coulomb) or ``R = g`` (Tresca), ``u = A r + b``.  Returns ``||F||``.
    """
    _matvec_plus(A, r, b, d, u)
    a_n = r[0] - rhoN * u[0]
    if a_n > 0.0:
        F[0] = rhoN * u[0]
        if want_jac:
            for c in range(d):
                J[0, c] = rhoN * A[0, c]
    else:
        F[0] = r[0]
        if want_jac:
            J[0, 0] = 1.0
            for c in range(1, d):
                J[0, c] = 0.0
    if law == LAW_TRESCA:
        R = g
        dR_active = False
    else:
        R = mu * a_n if a_n > 0.0 else 0.0
        dR_active = a_n > 0.0 and mu > 0.0
    # x_T = r_T - rhoT u_T
    x1 = r[1] - rhoT * u[1]
    x2 = 0.0
    if d == 3:
        x2 = r[2] - rhoT * u[2]
    t = np.sqrt(x1 * x1 + x2 * x2)
    if t <= R:
        for a in range(1, d):
            F[a] = rhoT * u[a]
            if want_jac:
                for c in range(d):
                    J[a, c] = rhoT * A[a, c]
    else:
        n1 = x1 / t
        n2 = x2 / t
        F[1] = r[1] - R * n1
        if d == 3:
            F[2] = r[2] - R * n2
        if want_jac:
            k = R / t
            for c in range(d):
                # dx_T/dr column c
                dx1 = (1.0 if c == 1 else 0.0) - rhoT * A[1, c]
                dx2 = 0.0
                if d == 3:
                    dx2 = (1.0 if c == 2 else 0.0) - rhoT * A[2, c]
                proj = n1 * dx1 + n2 * dx2
                dR = 0.0
                if dR_active:
                    dR = mu * ((1.0 if c == 0 else 0.0) - rhoN * A[0, c])
                dP1 = k * (dx1 - n1 * proj) + n1 * dR
                J[1, c] = (1.0 if c == 1 else 0.0) - dP1
                if d == 3:
                    dP2 = k * (dx2 - n2 * proj) + n2 * dR
                    J[2, c] = (1.0 if c == 2 else 0.0) - dP2
    return _norm(F, d)


@njit(cache=True, inline="always")
def solve_small(J, rhs, d, x, M):
    """Solve ``J x = rhs`` (``d <= 3``) by Gaussian elimination with partial pivoting.

    Returns False when ``J`` is numerically singular.
    """
    scale = 0.0
    for a in range(d):
        for c in range(d):
            M[a, c] = J[a, c]
            if abs(J[a, c]) > scale:
                scale = abs(J[a, c])
        x[a] = rhs[a]
    if scale == 0.0:
        return False
    for k in range(d):
        p = k
        for a in range(k + 1, d):
            if abs(M[a, k]) > abs(M[p, k]):
                p = a
        if abs(M[p, k]) <= 1e-13 * scale:
            return False
        if p != k:
            for c in range(d):
                tmp = M[k, c]
                M[k, c] = M[p, c]
                M[p, c] = tmp
            tmp = x[k]
            x[k] = x[p]
            x[p] = tmp
        for a in range(k + 1, d):
            f = M[a, k] / M[k, k]
            for c in range(k, d):
                M[a, c] -= f * M[k, c]
            x[a] -= f * x[k]
    for k in range(d - 1, -1, -1):
        s = x[k]
        for c in range(k + 1, d):
            s -= M[k, c] * x[c]
        x[k] = s / M[k, k]
    return True


@njit(cache=True, inline="always")
def ac_newton(A, b, mu, g, law, rhoN, rhoT, r, d, maxit, tol, u, F, J, M, dr, rt, Ft):
    """Semismooth Newton on the Alart–Curnier function with an Armijo line search.

    Converged when ``||F|| <= tol * max(||r||, rhoN ||b||)`` (or ``F = 0``).
    Returns the number of Newton iterations, negative when not converged
    (iteration cap, singular Jacobian or failed line search).  One evaluation
    site of ``F`` (compact code once inlined): the trial point ``rt`` is
    evaluated with its Jacobian, reused when the step is accepted.
    """
    nb = _norm(b, d) * rhoN
    for a in range(d):
        rt[a] = r[a]
    k = 0
    ls = 0
    step = 1.0
    merit0 = 0.0
    searching = False
    while True:
        nF = ac_function(A, b, mu, g, law, rhoN, rhoT, rt, d, u, Ft, J, True)
        if searching:
            if not (nF * nF <= (1.0 - 2e-4 * step) * merit0):
                ls += 1
                if ls == 10:
                    return -(k + 1)
                step *= 0.5
                for a in range(d):
                    rt[a] = r[a] + step * dr[a]
                continue
            for a in range(d):
                r[a] = rt[a]
            k += 1
        nr = _norm(r, d)
        scale = nr if nr > nb else nb
        if nF <= tol * scale or nF == 0.0:
            return k
        if k >= maxit:
            return -maxit
        for a in range(d):
            F[a] = -Ft[a]
        if not solve_small(J, F, d, dr, M):
            return -(k + 1)
        merit0 = nF * nF
        step = 1.0
        ls = 0
        searching = True
        for a in range(d):
            rt[a] = r[a] + dr[a]


# --------------------------------------------------------------------------- dispatcher
@njit(cache=True, inline="always")
def local_solve(kind, A, b, mu, g, law, rhoN, rhoT, rhoP, r, d, tol, newton_maxit, proj_maxit,
                work, J, M):
    """Solve one contact problem in place in ``r`` (warm-started from ``r``).

    ``kind``: ``KIND_EXACT`` (2D Coulomb; falls back to Newton/projection when
    no case is consistent), ``KIND_AC_NEWTON`` (Newton; on failure the
    projection fixed point, then Newton again, keeping the iterate with the
    smaller local residual), ``KIND_PROJECTION``.  The associated law always
    uses the projection fixed point.  ``work`` is a ``(8, d)`` buffer.

    Returns ``LOCAL_OK`` or ``LOCAL_NOT_CONVERGED``.
    """
    u = work[0]
    F = work[1]
    dr = work[2]
    rt = work[3]
    Ft = work[4]
    best = work[5]
    if kind == KIND_EXACT and law == LAW_COULOMB and d == 2:
        if exact_2d(A, b, mu, r):
            return LOCAL_OK
        kind = KIND_AC_NEWTON
    newton = not (law == LAW_ASSOCIATED or kind == KIND_PROJECTION)
    e_best = 0.0
    for attempt in range(2 if newton else 1):
        if newton:
            if attempt == 0:
                for a in range(d):
                    best[a] = r[a]
            it = ac_newton(A, b, mu, g, law, rhoN, rhoT, r, d, newton_maxit, tol, u, F, J, M,
                           dr, rt, Ft)
            if it >= 0:
                return LOCAL_OK
            # keep the better of the failed Newton iterate and the previous best
            for a in range(d):
                rt[a] = best[a]
            for c in range(2):
                e = local_residual(A, b, mu, g, law, rt if c == 0 else r, d, u, F)
                if c == 0:
                    e_best = e
            if not (e <= e_best):
                for a in range(d):
                    r[a] = best[a]
            else:
                for a in range(d):
                    best[a] = r[a]
            if attempt == 1:
                return LOCAL_NOT_CONVERGED
        it = projection_fp(A, b, mu, g, law, rhoP, r, d, proj_maxit, tol, u, F)
        if not newton:
            return LOCAL_OK if it > 0 else LOCAL_NOT_CONVERGED
    return LOCAL_NOT_CONVERGED

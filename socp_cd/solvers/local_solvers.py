"""One-contact solvers used inside NSGS (numba-compiled).

Cone projections and De Saxcé velocities come from
:mod:`socp_cd.solvers.kernels.cone` (one implementation).  Each solver receives the *local problem* of contact ``i``: the diagonal block
``W_ii`` (``dim x dim``, possibly nonsymmetric), the local free velocity
``b = q_i + sum_{j != i} W_ij r_j`` and the friction coefficient ``mu``; it
returns ``r`` such that ``u = W_ii r + b`` and ``r`` obey the contact law of the
formulation.  :func:`exact_2d`, :func:`projection_fp` and :func:`local_residual`
take the block itself as ``A``; :func:`ac_function`, :func:`ac_newton` and
:func:`local_solve` take the stacked diagonal blocks ``A`` (``n_contacts x dim
x dim``) and the index ``i``, and work on scalars (no array view per contact:
numba's reference counting of views cost more than the arithmetic).  The laws:

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
#: ... and of :func:`local_solve_first` when :func:`local_solve_rest` must go on
NEEDS_PROJECTION = 2
NEWTON_FAILED = 3


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
# The Newton iteration works on scalars (the contact's d <= 3 components): no array
# is created or passed per iteration.  Measured on a 301-contact sphere pile at its
# solution, one local solve (free velocity included) took 315 ns with the
# array-buffer version of the same iteration and 28 ns with scalars; numba's
# reference counting of every array handed between inlined functions was the cost.
@njit(cache=True, inline="always")
def ac_function(A, i, b0, b1, b2, mu, g, law, rhoN, rhoT, r0, r1, r2, d):
    """Alart–Curnier function ``F(r)`` and one element ``J`` of its generalized Jacobian.

    ``F_N = r_N - max(0, r_N - rhoN u_N)``,
    ``F_T = r_T - P_{B(0, R)}(r_T - rhoT u_T)`` with ``R = mu max(0, r_N - rhoN u_N)``
    (Coulomb) or ``R = g`` (Tresca), ``u = A_i r + b``, ``A_i = A[i]`` (the
    diagonal block of contact ``i``).  ``d = 2``: the third components
    (``b2``, ``r2``) are 0 and ignored.

    Returns
    -------
    tuple
        ``(||F||, F0, F1, F2, J00, J01, J02, J10, J11, J12, J20, J21, J22)``
        (``J`` row by row; only its ``d x d`` part is meaningful).
    """
    a00 = A[i, 0, 0]
    a01 = A[i, 0, 1]
    a10 = A[i, 1, 0]
    a11 = A[i, 1, 1]
    a02 = a12 = a20 = a21 = a22 = 0.0
    if d == 3:
        a02 = A[i, 0, 2]
        a12 = A[i, 1, 2]
        a20 = A[i, 2, 0]
        a21 = A[i, 2, 1]
        a22 = A[i, 2, 2]
    u0 = b0 + a00 * r0 + a01 * r1
    u1 = b1 + a10 * r0 + a11 * r1
    u2 = 0.0
    if d == 3:
        u0 += a02 * r2
        u1 += a12 * r2
        u2 = b2 + a20 * r0 + a21 * r1 + a22 * r2
    a_n = r0 - rhoN * u0
    if a_n > 0.0:
        F0 = rhoN * u0
        j00 = rhoN * a00
        j01 = rhoN * a01
        j02 = rhoN * a02
    else:
        F0 = r0
        j00 = 1.0
        j01 = 0.0
        j02 = 0.0
    if law == LAW_TRESCA:
        R = g
        dR_active = False
    else:
        R = mu * a_n if a_n > 0.0 else 0.0
        dR_active = a_n > 0.0 and mu > 0.0
    # x_T = r_T - rhoT u_T
    x1 = r1 - rhoT * u1
    x2 = r2 - rhoT * u2 if d == 3 else 0.0
    t = np.sqrt(x1 * x1 + x2 * x2)
    if t <= R:
        F1 = rhoT * u1
        F2 = rhoT * u2
        j10 = rhoT * a10
        j11 = rhoT * a11
        j12 = rhoT * a12
        j20 = rhoT * a20
        j21 = rhoT * a21
        j22 = rhoT * a22
    else:
        n1 = x1 / t
        n2 = x2 / t
        F1 = r1 - R * n1
        F2 = r2 - R * n2 if d == 3 else 0.0
        k = R / t
        # column c of J_T = I_T - dP: dx_T/dr_c = e_c - rhoT A_T,c, dR/dr_c = mu (e_0 - rhoN A_0c)
        j10, j20 = _slide_column(k, n1, n2, 0.0 - rhoT * a10, 0.0 - rhoT * a20,
                                 mu * (1.0 - rhoN * a00) if dR_active else 0.0, 0.0, 0.0)
        j11, j21 = _slide_column(k, n1, n2, 1.0 - rhoT * a11, 0.0 - rhoT * a21,
                                 mu * (0.0 - rhoN * a01) if dR_active else 0.0, 1.0, 0.0)
        j12, j22 = _slide_column(k, n1, n2, 0.0 - rhoT * a12, 1.0 - rhoT * a22,
                                 mu * (0.0 - rhoN * a02) if dR_active else 0.0, 0.0, 1.0)
    nF = np.sqrt(F0 * F0 + F1 * F1 + F2 * F2) if d == 3 else np.sqrt(F0 * F0 + F1 * F1)
    return nF, F0, F1, F2, j00, j01, j02, j10, j11, j12, j20, j21, j22


@njit(cache=True, inline="always")
def _slide_column(k, n1, n2, dx1, dx2, dR, e1, e2):
    """Tangential rows of one column of the sliding Jacobian: ``e_T - dP_{B(0,R)}``."""
    proj = n1 * dx1 + n2 * dx2
    return e1 - (k * (dx1 - n1 * proj) + n1 * dR), e2 - (k * (dx2 - n2 * proj) + n2 * dR)


@njit(cache=True, inline="always")
def solve_small(M, d):
    """Solve ``J x = rhs`` (``d <= 3``) in place by Gaussian elimination with partial pivoting.

    ``M`` is the ``d x (d + 1)`` augmented matrix ``[J | rhs]`` (its first ``d + 1``
    columns are used); on success ``x`` replaces column ``d``.  Returns False
    when ``J`` is numerically singular.
    """
    scale = 0.0
    for a in range(d):
        for c in range(d):
            if abs(M[a, c]) > scale:
                scale = abs(M[a, c])
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
            for c in range(d + 1):
                tmp = M[k, c]
                M[k, c] = M[p, c]
                M[p, c] = tmp
        for a in range(k + 1, d):
            f = M[a, k] / M[k, k]
            for c in range(k, d + 1):
                M[a, c] -= f * M[k, c]
    for k in range(d - 1, -1, -1):
        s = M[k, d]
        for c in range(k + 1, d):
            s -= M[k, c] * M[c, d]
        M[k, d] = s / M[k, k]
    return True


@njit(cache=True, inline="always")
def ac_newton(A, i, b0, b1, b2, mu, g, law, rhoN, rhoT, r0, r1, r2, d, maxit, tol, M):
    """Semismooth Newton on the Alart–Curnier function with an Armijo line search.

    Contact ``i`` (block ``A[i]``, free velocity ``(b0, b1, b2)``) from
    ``(r0, r1, r2)`` (``d = 2``: ``b2 = r2 = 0``).  Converged when
    ``||F|| <= tol * max(||r||, rhoN ||b||)`` (or ``F = 0``); a trial step is
    halved at most 9 times until ``||F||² <= (1 - 2e-4 t) ||F_k||²``.  ``M`` is
    a ``(>= d, >= d + 1)`` buffer for the linear solves.

    Returns
    -------
    tuple
        ``(iterations, r0, r1, r2)``: the number of Newton iterations, negative
        when not converged (iteration cap, singular Jacobian or failed line
        search), and the last accepted iterate.
    """
    nb = np.sqrt(b0 * b0 + b1 * b1 + b2 * b2) * rhoN
    t0 = r0
    t1 = r1
    t2 = r2
    d0 = d1 = d2 = 0.0
    k = 0
    ls = 0
    step = 1.0
    merit0 = 0.0
    searching = False
    while True:
        nF, F0, F1, F2, j00, j01, j02, j10, j11, j12, j20, j21, j22 = ac_function(
            A, i, b0, b1, b2, mu, g, law, rhoN, rhoT, t0, t1, t2, d)
        if searching:
            if not (nF * nF <= (1.0 - 2e-4 * step) * merit0):
                ls += 1
                if ls == 10:
                    return -(k + 1), r0, r1, r2
                step *= 0.5
                t0 = r0 + step * d0
                t1 = r1 + step * d1
                t2 = r2 + step * d2
                continue
            r0 = t0
            r1 = t1
            r2 = t2
            k += 1
        nr = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        scale = nr if nr > nb else nb
        if nF <= tol * scale or nF == 0.0:
            return k, r0, r1, r2
        if k >= maxit:
            return -maxit, r0, r1, r2
        M[0, 0] = j00
        M[0, 1] = j01
        M[1, 0] = j10
        M[1, 1] = j11
        M[0, d] = -F0
        M[1, d] = -F1
        if d == 3:
            M[0, 2] = j02
            M[1, 2] = j12
            M[2, 0] = j20
            M[2, 1] = j21
            M[2, 2] = j22
            M[2, 3] = -F2
        if not solve_small(M, d):
            return -(k + 1), r0, r1, r2
        d0 = M[0, d]
        d1 = M[1, d]
        d2 = M[2, d] if d == 3 else 0.0
        merit0 = nF * nF
        step = 1.0
        ls = 0
        searching = True
        t0 = r0 + d0
        t1 = r1 + d1
        t2 = r2 + d2


@njit(cache=True, inline="always")
def _newton_on(A, i, b, mu, g, law, rhoN, rhoT, r, d, maxit, tol, M):
    """:func:`ac_newton` from the array ``r`` (length ``d``), its iterate written back."""
    b2 = b[2] if d == 3 else 0.0
    r2 = r[2] if d == 3 else 0.0
    it, x0, x1, x2 = ac_newton(A, i, b[0], b[1], b2, mu, g, law, rhoN, rhoT, r[0], r[1], r2, d,
                               maxit, tol, M)
    r[0] = x0
    r[1] = x1
    if d == 3:
        r[2] = x2
    return it


@njit(cache=True)
def _after_failed_newton(A, i, b, mu, g, law, rhoN, rhoT, rhoP, r, start, d, tol, newton_maxit,
                         proj_maxit, work, M):
    """The rest of :func:`local_solve`'s chain once Newton from ``start`` failed (``r`` its
    last iterate): keep the better of the two, the projection fixed point, Newton again,
    and the better of that and the best so far (not inlined: rarely run)."""
    u = work[0]
    F = work[1]
    best = work[2]
    Ai = A[i]
    for a in range(d):
        best[a] = start[a]
    for attempt in range(2):
        e_best = local_residual(Ai, b, mu, g, law, best, d, u, F)
        e = local_residual(Ai, b, mu, g, law, r, d, u, F)
        if not (e <= e_best):
            for a in range(d):
                r[a] = best[a]
        else:
            for a in range(d):
                best[a] = r[a]
        if attempt == 1:
            return LOCAL_NOT_CONVERGED
        projection_fp(Ai, b, mu, g, law, rhoP, r, d, proj_maxit, tol, u, F)
        if _newton_on(A, i, b, mu, g, law, rhoN, rhoT, r, d, newton_maxit, tol, M) >= 0:
            return LOCAL_OK
    return LOCAL_NOT_CONVERGED


# --------------------------------------------------------------------------- dispatcher
@njit(cache=True, inline="always")
def local_solve_first(kind, A, i, b, mu, g, law, rhoN, rhoT, r, d, tol, newton_maxit, M):
    """The first, cheap attempt of :func:`local_solve` (inlined in the sweep's contact loop).

    Moreau's explicit 2D solution (``KIND_EXACT``, 2D Coulomb), then, unless
    that succeeded, Newton from ``r`` (``KIND_AC_NEWTON``, or ``KIND_EXACT``
    with no consistent case).  Calls nothing that is not inlined: a compiled
    call with array arguments anywhere in a loop slows every pass through it
    (the sweep of a 304-contact pile 29 -> 14 µs with the rest of the chain
    moved out of the loop, :func:`local_solve_rest`).

    Returns
    -------
    int
        ``LOCAL_OK``; ``NEEDS_PROJECTION`` (nothing done: the associated law or
        ``KIND_PROJECTION``); ``NEWTON_FAILED`` (``r`` holds Newton's last
        iterate).  Both of the latter go on with :func:`local_solve_rest`.
    """
    if law == LAW_ASSOCIATED or kind == KIND_PROJECTION:
        return NEEDS_PROJECTION
    if kind == KIND_EXACT and law == LAW_COULOMB and d == 2:
        if exact_2d(A[i], b, mu, r):
            return LOCAL_OK
    if _newton_on(A, i, b, mu, g, law, rhoN, rhoT, r, d, newton_maxit, tol, M) >= 0:
        return LOCAL_OK
    return NEWTON_FAILED


@njit(cache=True)
def local_solve_rest(first, A, i, b, mu, g, law, rhoN, rhoT, rhoP, r, start, d, tol,
                     newton_maxit, proj_maxit, work, M):
    """The rest of :func:`local_solve` after :func:`local_solve_first` returned ``first``
    (``start``: the contact's iterate before the first attempt).  Not inlined: rarely run.

    Returns ``LOCAL_OK`` or ``LOCAL_NOT_CONVERGED``.
    """
    if first == NEEDS_PROJECTION:
        it = projection_fp(A[i], b, mu, g, law, rhoP, r, d, proj_maxit, tol, work[0], work[1])
        return LOCAL_OK if it > 0 else LOCAL_NOT_CONVERGED
    return _after_failed_newton(A, i, b, mu, g, law, rhoN, rhoT, rhoP, r, start, d, tol,
                                newton_maxit, proj_maxit, work, M)


@njit(cache=True)
def local_solve(kind, A, i, b, mu, g, law, rhoN, rhoT, rhoP, r, d, tol, newton_maxit, proj_maxit,
                work, M):
    """Solve the problem of contact ``i`` in place in ``r`` (warm-started from ``r``).

    ``A`` holds the diagonal blocks ``(n_contacts, d, d)``; ``b`` the contact's
    free velocity.  ``kind``: ``KIND_EXACT`` (2D Coulomb; falls back to
    Newton/projection when no case is consistent), ``KIND_AC_NEWTON``
    (Newton; on failure the projection fixed point, then Newton again,
    keeping the iterate with the smaller local residual), ``KIND_PROJECTION``.
    The associated law always uses the projection fixed point.  ``work`` is a
    ``(>= 4, d)`` buffer (rows 0–3 used), ``M`` a ``(d, d + 1)`` one.
    :func:`local_solve_first` then, when it did not solve it,
    :func:`local_solve_rest` (the sweep calls the two itself).

    Returns ``LOCAL_OK`` or ``LOCAL_NOT_CONVERGED``.
    """
    start = work[3]
    for a in range(d):
        start[a] = r[a]
    first = local_solve_first(kind, A, i, b, mu, g, law, rhoN, rhoT, r, d, tol, newton_maxit, M)
    if first == LOCAL_OK:
        return LOCAL_OK
    return local_solve_rest(first, A, i, b, mu, g, law, rhoN, rhoT, rhoP, r, start, d, tol,
                            newton_maxit, proj_maxit, work, M)

"""Lemke's complementary pivoting method, compiled (numba, ``cache=True``).

The compiled twin of :func:`socp_cd.lcp.lemke_reference` (the same tableau, the same pivot
rules, the same refinement; ``tests/test_lemke.py`` holds the two equal), with a deadline
on :mod:`~socp_cd.solvers.kernels.clock`'s clock.  The tableau is dense, ``n x (2n + 1)``:
the method is for small LCPs (the caller bounds ``n``).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .clock import past
from .dense import lu_solve

# (the values of socp_cd.lcp's constants: this layer imports nothing from socp_cd outside
# it; tests/test_lemke.py holds the two equal)
#: outcome codes (:data:`socp_cd.lcp.LEMKE_SOLVED` ...)
SOLVED, RAY, MAX_PIVOTS, TIME_LIMIT = 0, 1, 2, 3
#: :data:`socp_cd.lcp.PIVOT_TOL`, :data:`socp_cd.lcp.TIE_TOL`
PIVOT_TOL, TIE_TOL = 1e-8, 1e-12
#: pivots between two readings of the clock
CLOCK_EVERY = 16


@njit(cache=True)
def _lex_row(T, b, col, ties, count, n):
    """The lexicographic minimum over ``ties[:count]`` of ``[b_i, T_i,0:n] / c_i``, ``c`` the
    tableau's column ``col``."""
    for k in range(-1, n):
        if count == 1:
            break
        lo = np.inf
        for t in range(count):
            i = ties[t]
            v = (b[i] if k < 0 else T[i, k]) / T[i, col]
            if v < lo:
                lo = v
        gap = TIE_TOL * max(1.0, abs(lo))
        kept = 0
        for t in range(count):
            i = ties[t]
            v = (b[i] if k < 0 else T[i, k]) / T[i, col]
            if v <= lo + gap:
                ties[kept] = i
                kept += 1
        count = kept
    return ties[0]


@njit(cache=True)
def lemke(M, q, max_pivots, deadline, z):
    """Lemke's method on ``w = M z + q`` (see :func:`socp_cd.lcp.lemke_reference`).

    Parameters
    ----------
    M : ndarray (n, n), q : ndarray (n,)
    max_pivots : int
    deadline : float
        A time on :func:`~socp_cd.solvers.kernels.clock.monotonic`'s clock (``inf``: none),
        read every :data:`CLOCK_EVERY` pivots.
    z : ndarray (n,)
        Written: the solution, or the last basic ``z`` (clipped to ``>= 0``).

    Returns
    -------
    (code, pivots) : (int, int)
    """
    n = q.shape[0]
    for j in range(n):
        z[j] = 0.0
    if n == 0:
        return SOLVED, 0
    lo = q[0]
    r = 0
    for i in range(n):
        if q[i] <= lo:          # (ties: the last row, as the reference)
            lo = q[i]
            r = i
    if lo >= 0.0:
        return SOLVED, 0
    width = 2 * n + 1
    T = np.zeros((n, width))
    b = q.copy()
    basis = np.empty(n, np.int64)
    for i in range(n):
        T[i, i] = 1.0
        for j in range(n):
            T[i, n + j] = -M[i, j]
        T[i, 2 * n] = -1.0
        basis[i] = i
    ties = np.empty(n, np.int64)
    nonzero = np.empty(width, np.int64)      # (the pivot row's nonzero columns)
    enter = 2 * n
    pivots = 0
    code = MAX_PIVOTS
    while pivots < max_pivots:
        if pivots % CLOCK_EVERY == CLOCK_EVERY - 1 and past(deadline):
            code = TIME_LIMIT
            break
        p = T[r, enter]
        nnz = 0
        for j in range(width):
            T[r, j] /= p
            if T[r, j] != 0.0:
                nonzero[nnz] = j
                nnz += 1
        b[r] /= p
        for i in range(n):
            f = T[i, enter]
            if i != r and f != 0.0:
                # (x - f * 0 is x: the pivot row's zeros skipped, the same numbers)
                for t in range(nnz):
                    j = nonzero[t]
                    T[i, j] -= f * T[r, j]
                b[i] -= f * b[r]
        for i in range(n):
            T[i, enter] = 0.0
        T[r, enter] = 1.0
        leaving = basis[r]
        basis[r] = enter
        pivots += 1
        if leaving == 2 * n:
            code = SOLVED
            break
        enter = leaving + n if leaving < n else leaving - n
        cmax = 0.0
        for i in range(n):
            cmax = max(cmax, abs(T[i, enter]))
        theta = np.inf
        found = False
        for i in range(n):
            c = T[i, enter]
            if cmax > 0.0 and c > PIVOT_TOL * cmax:
                theta = min(theta, b[i] / c)
                found = True
        if not found:
            code = RAY
            break
        gap = TIE_TOL * max(1.0, abs(theta))
        count = np.int64(0)     # (not the literal 0: _lex_row is compiled once)
        r = -1
        for i in range(n):
            c = T[i, enter]
            if c > PIVOT_TOL * cmax and b[i] / c <= theta + gap:
                ties[count] = i
                count += 1
                if r < 0 and basis[i] == 2 * n:
                    r = i
        if r < 0:
            r = _lex_row(T, b, enter, ties, count, n)
    vals = np.empty(n)
    for i in range(n):
        vals[i] = max(b[i], 0.0)
    if code == SOLVED:
        _refine(M, q, basis, b, vals)
    for i in range(n):
        if n <= basis[i] < 2 * n:
            z[basis[i] - n] = vals[i]
    return code, pivots


@njit(cache=True)
def _refine(M, q, basis, b, vals):
    """:func:`socp_cd.lcp._refined`'s solve, into ``vals`` when it is kept."""
    n = q.shape[0]
    B = np.zeros((n, n))
    for i in range(n):
        j = basis[i]
        if j < n:
            B[j, i] = 1.0
        else:
            for k in range(n):
                B[k, i] = -M[k, j - n]
    x, ok = lu_solve(B, q)
    if not ok:
        return
    scale = 1.0
    for i in range(n):
        scale = max(scale, abs(b[i]))
    for i in range(n):
        if not np.isfinite(x[i]) or x[i] < -1e-9 * scale:
            return
    for i in range(n):
        vals[i] = max(x[i], 0.0)


@njit(cache=True)
def coulomb_lcp_2d(indptr, indices, data, q, mu):
    """:func:`socp_cd.lcp.coulomb_lcp_2d` from ``W`` in CSR form: ``(M, q_lcp)``."""
    nc = mu.shape[0]
    n = 4 * nc
    M = np.zeros((n, n))
    q_lcp = np.zeros(n)
    for c in range(nc):
        q_lcp[c] = q[2 * c]
        q_lcp[nc + c] = q[2 * c + 1]
        q_lcp[2 * nc + c] = -q[2 * c + 1]
        M[nc + c, 3 * nc + c] = 1.0                 # λ + u_T
        M[2 * nc + c, 3 * nc + c] = 1.0             # λ - u_T
        M[3 * nc + c, c] = mu[c]                    # μ r_N - β⁺ - β⁻
        M[3 * nc + c, nc + c] = -1.0
        M[3 * nc + c, 2 * nc + c] = -1.0
    for row in range(2 * nc):
        i, normal_row = row // 2, row % 2 == 0
        for k in range(indptr[row], indptr[row + 1]):
            col = indices[k]
            j, a = col // 2, data[k]
            if normal_row:
                if col % 2 == 0:
                    M[i, j] += a
                else:
                    M[i, nc + j] += a
                    M[i, 2 * nc + j] -= a
            elif col % 2 == 0:
                M[nc + i, j] += a
                M[2 * nc + i, j] -= a
            else:
                M[nc + i, nc + j] += a
                M[nc + i, 2 * nc + j] -= a
                M[2 * nc + i, nc + j] -= a
                M[2 * nc + i, 2 * nc + j] += a
    return M, q_lcp


@njit(cache=True)
def lemke_coulomb_2d(indptr, indices, data, q, mu, max_pivots, deadline, r):
    """Lemke's method on the exact 2D Coulomb law of ``u = W r + q`` (``W`` in CSR form):
    builds the LCP (:func:`coulomb_lcp_2d`), solves it (:func:`lemke`) and writes ``r``
    (:func:`socp_cd.lcp.coulomb_impulses`).  Returns ``(code, pivots)``."""
    nc = mu.shape[0]
    M, q_lcp = coulomb_lcp_2d(indptr, indices, data, q, mu)
    z = np.empty(4 * nc)
    code, pivots = lemke(M, q_lcp, max_pivots, deadline, z)
    for c in range(nc):
        r[2 * c] = z[c]
        r[2 * c + 1] = z[nc + c] - z[2 * nc + c]
    return code, pivots


__all__ = ["lemke", "coulomb_lcp_2d", "lemke_coulomb_2d", "SOLVED", "RAY", "MAX_PIVOTS",
           "TIME_LIMIT", "PIVOT_TOL", "TIE_TOL",
           "CLOCK_EVERY"]

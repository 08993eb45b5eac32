"""Linear complementarity problems (LCP): the 2D Coulomb law as one, and Lemke's method.

An LCP asks for ``z >= 0`` with ``w = M z + q >= 0`` and ``w ⊥ z``.  Polyhedral contact laws
are LCPs (``formulations/lemke.md``):

* the frictionless law (Signorini): ``z = r_N``, ``M = W_NN``, ``q = q_N``;
* the exact 2D Coulomb law (Signorini + Coulomb friction on a line): per contact
  ``z = (r_N, β⁺, β⁻, λ)`` with ``r_T = β⁺ - β⁻`` and

  ===========================  =====
  ``w``                        ``⊥``
  ===========================  =====
  ``u_N``                      ``r_N``
  ``λ + u_T``                  ``β⁺``
  ``λ - u_T``                  ``β⁻``
  ``μ r_N - β⁺ - β⁻``          ``λ``
  ===========================  =====

  (``λ`` is ``|u_T|`` where the contact slides; ``u = W r + q``).

:func:`lemke_reference` is the NumPy reference of Lemke's complementary pivoting method
with the lexicographic ratio test (no cycling on degenerate problems);
:func:`socp_cd.solvers.kernels.lemke.lemke` is its compiled twin (the same pivots; the tests
hold the two equal).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from .errors import InvalidProblemError

#: outcome codes of Lemke's method (both implementations)
LEMKE_SOLVED, LEMKE_RAY, LEMKE_MAX_PIVOTS, LEMKE_TIME_LIMIT = 0, 1, 2, 3
#: their names, as :class:`socp_cd.solvers.result.SolverResult` statuses
LEMKE_STATUS = ("converged", "numerical_error", "max_iter", "time_limit")
#: a pivot column entry counts as positive above this share of the column's largest entry
PIVOT_TOL = 1e-8
#: two ratios (lexicographic entries) are tied within this relative gap
TIE_TOL = 1e-12
#: the refinement's LU counts a pivot below this share of ``max |B|`` as zero (the compiled
#: LU's test, :data:`socp_cd.solvers.kernels.dense.PIVOT_TOL`)
LU_PIVOT_TOL = 1e-15


def coulomb_lcp_2d(W, q, mu):
    """The LCP ``(M, q_lcp)`` of the exact 2D Coulomb law on ``u = W r + q`` (dense ``W``).

    Unknowns in four blocks of ``nc``: ``r_N``, ``β⁺``, ``β⁻``, ``λ`` (see the module);
    :func:`coulomb_impulses` maps a solution back to ``r``.

    Parameters
    ----------
    W : ndarray (2 nc, 2 nc)
        Delassus operator, contacts ``(r_N, r_T)`` in turn.
    q : ndarray (2 nc,)
    mu : ndarray (nc,)

    Returns
    -------
    M : ndarray (4 nc, 4 nc)
    q_lcp : ndarray (4 nc,)
    """
    W = np.asarray(W, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    mu = np.asarray(mu, dtype=np.float64)
    nc = mu.shape[0]
    if W.shape != (2 * nc, 2 * nc) or q.shape != (2 * nc,):
        raise InvalidProblemError("W, q", f"a 2D problem of {nc} contacts needs W of shape "
                                          f"{(2 * nc, 2 * nc)} and q of {(2 * nc,)}, got "
                                          f"{W.shape} and {q.shape}")
    nn, nt = W[0::2, 0::2], W[0::2, 1::2]
    tn, tt = W[1::2, 0::2], W[1::2, 1::2]
    eye, zero = np.eye(nc), np.zeros((nc, nc))
    M = np.block([[nn, nt, -nt, zero],
                  [tn, tt, -tt, eye],
                  [-tn, -tt, tt, eye],
                  [np.diag(mu), -eye, -eye, zero]])
    q_lcp = np.concatenate([q[0::2], q[1::2], -q[1::2], np.zeros(nc)])
    return M, q_lcp


def coulomb_impulses(z, nc):
    """``r`` (``(r_N, r_T)`` per contact) of a solution ``z`` of :func:`coulomb_lcp_2d`."""
    r = np.empty(2 * nc)
    r[0::2] = z[:nc]
    r[1::2] = z[nc:2 * nc] - z[2 * nc:3 * nc]
    return r


def _lex_row(T, b, c, rows, n):
    """The lexicographic minimum over ``rows`` of ``[b_i, T_i,0:n] / c_i`` (its row)."""
    rows = list(rows)
    for k in range(-1, n):
        if len(rows) == 1:
            break
        vals = np.array([(b[i] if k < 0 else T[i, k]) / c[i] for i in rows])
        lo = vals.min()
        gap = TIE_TOL * max(1.0, abs(lo))
        rows = [i for i, v in zip(rows, vals) if v <= lo + gap]
    return rows[0]


def lemke_reference(M, q, max_pivots, refine=True):
    """Lemke's method on ``w = M z + q`` (covering vector ``e``), the NumPy reference.

    The tableau ``[I, -M, -e | q]`` (columns: ``w``, ``z``, the artificial ``z0``) is pivoted
    by the complementary rule; the leaving row is the lexicographic minimum of ``[b_i,
    (B⁻¹)_i] / c_i`` over the rows whose entry ``c_i`` of the entering column is positive
    (the ``z0`` row first when it ties), so degenerate problems do not cycle.  When ``z0``
    leaves, the basic unknowns are solved for once more from ``M`` and ``q`` (``refine``:
    the tableau's rounding after many pivots is not kept) and kept when that answer is
    nonnegative to rounding.

    Parameters
    ----------
    M : ndarray (n, n)
    q : ndarray (n,)
    max_pivots : int
        Pivots allowed (the first, ``z0`` entering, included).
    refine : bool

    Returns
    -------
    z : ndarray (n,)
        The solution (code :data:`LEMKE_SOLVED`), else the last basic ``z`` (clipped to ``>= 0``).
    code : int
        :data:`LEMKE_SOLVED`, :data:`LEMKE_RAY` (a secondary ray: no solution reached; for a
        copositive-plus ``M`` the LCP is then infeasible) or :data:`LEMKE_MAX_PIVOTS`.
    pivots : int
    """
    M = np.asarray(M, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    n = q.shape[0]
    z = np.zeros(n)
    if n == 0 or q.min() >= 0.0:
        return z, LEMKE_SOLVED, 0
    T = np.hstack([np.eye(n), -M, -np.ones((n, 1))])
    b = q.copy()
    basis = np.arange(n)
    lo = b.min()
    r = int(np.flatnonzero(b <= lo)[-1])      # ties: the last row keeps the rows lex-positive
    enter, pivots, code = 2 * n, 0, LEMKE_MAX_PIVOTS
    while pivots < max_pivots:
        # pivot on (r, enter)
        p = T[r, enter]
        T[r] /= p
        b[r] /= p
        for i in range(n):
            if i != r and T[i, enter] != 0.0:
                f = T[i, enter]
                T[i] -= f * T[r]
                b[i] -= f * b[r]
        T[:, enter] = 0.0
        T[r, enter] = 1.0
        leaving = basis[r]
        basis[r] = enter
        pivots += 1
        if leaving == 2 * n:
            code = LEMKE_SOLVED
            break
        enter = leaving + n if leaving < n else leaving - n
        c = T[:, enter]
        cmax = np.abs(c).max()
        cand = np.flatnonzero(c > PIVOT_TOL * cmax) if cmax > 0.0 else np.empty(0, int)
        if cand.size == 0:
            code = LEMKE_RAY
            break
        ratios = b[cand] / c[cand]
        theta = ratios.min()
        ties = cand[ratios <= theta + TIE_TOL * max(1.0, abs(theta))]
        z0_row = np.flatnonzero(basis[ties] == 2 * n)
        r = int(ties[z0_row[0]]) if z0_row.size else _lex_row(T, b, c, ties, n)
    vals = np.maximum(b, 0.0)
    if code == LEMKE_SOLVED and refine:
        vals = _refined(M, q, basis, b)
    for i in range(n):
        if n <= basis[i] < 2 * n:
            z[basis[i] - n] = vals[i]
    return z, code, pivots


def _refined(M, q, basis, b):
    """The basic unknowns solved from ``B x = q`` (``B``'s column of ``w_j``: ``e_j``; of
    ``z_j``: ``-M_j``; LU with partial pivoting), or the tableau's ``b`` (clipped) when a
    pivot is below :data:`LU_PIVOT_TOL` of ``max |B|`` or ``x`` is not nonnegative to
    rounding."""
    n = q.shape[0]
    B = np.zeros((n, n))
    for i in range(n):
        j = basis[i]
        if j < n:
            B[j, i] = 1.0
        else:
            B[:, i] = -M[:, j - n]
    lu, piv = lu_factor(B, check_finite=False)
    if not np.abs(np.diag(lu)).min() > 1e-300 + LU_PIVOT_TOL * np.abs(B).max():
        return np.maximum(b, 0.0)       # (singular to the compiled LU's test)
    x = lu_solve((lu, piv), q, check_finite=False)
    scale = max(1.0, np.abs(b).max())
    if not np.all(np.isfinite(x)) or x.min() < -1e-9 * scale:
        return np.maximum(b, 0.0)
    return np.maximum(x, 0.0)


__all__ = ["coulomb_lcp_2d", "coulomb_impulses", "lemke_reference", "LEMKE_SOLVED", "LEMKE_RAY",
           "LEMKE_MAX_PIVOTS", "LEMKE_TIME_LIMIT", "LEMKE_STATUS", "PIVOT_TOL", "TIE_TOL"]

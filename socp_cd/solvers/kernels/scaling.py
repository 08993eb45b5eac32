"""Units balancing of a local problem in one compiled pass (numba, ``cache=True``).

The dispatcher (:mod:`socp_cd.solvers.scaling`) hands every backend a local
problem in balanced units.  :func:`balance_csr` computes, from ``W`` in CSR
form, ``q`` and ``mu``, everything that needs: the unit factors of
:func:`socp_cd.residuals.contact_scales` (the NumPy reference), the entries of
``S W S`` on the same sparsity (:meth:`socp_cd.problem.FrictionContactProblem.rescaled`),
``q~ = q / b``, the norms ``||q||`` and ``||q~||``, and Siconos' error of
``r = 0`` (:func:`socp_cd.residuals.error` with ``r = 0``).  On a one-contact
problem the NumPy path costs ~50 µs of small-array calls; this one call costs
a few.  ``tests/test_checks.py`` holds it equal to the references (to rounding:
sums are taken in another order).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .cone import (LAW_COULOMB, coulomb_violations, error_parts, relative_error,
                   scaled_error_parts)


@njit(cache=True)
def unit_factors(diag, q, dim):
    """The unit factors of :func:`socp_cd.residuals.contact_scales` from ``diag(W)``.

    Parameters
    ----------
    diag : ndarray (m,)
        Diagonal of ``W`` (or its estimate); ``d_i`` is the mean of ``|diag|``
        over contact ``i``'s components.
    q : ndarray (m,)
    dim : int

    Returns
    -------
    a, b, q_s : ndarray (m,)
        The factors and ``q / b``.
    q2, q_s2 : float
        ``||q||²`` and ``||q / b||²``.
    """
    m = q.shape[0]
    nc = m // dim
    d = np.zeros(nc)
    for i in range(nc):
        for k in range(dim):
            d[i] += abs(diag[i * dim + k])
    a = np.empty(m)
    b = np.empty(m)
    q_s = np.empty(m)
    q2, qs2 = factors_from_sums(d, q, dim, a, b, q_s)
    return a, b, q_s, q2, qs2


@njit(cache=True, inline="always")
def factors_from_sums(d, q, dim, a, b, q_s):
    """:func:`unit_factors` from ``d_i``, the sum of ``|diag|`` over contact ``i``'s
    components, into ``a``, ``b``, ``q_s``; returns ``(||q||², ||q / b||²)``.  ``d`` is
    overwritten (with the scales ``s_i``: no temporary array)."""
    nc = d.shape[0]
    m = q.shape[0]
    n_good = 0
    for i in range(nc):
        d[i] /= dim
        if np.isfinite(d[i]) and d[i] > 0.0:
            n_good += 1
    if n_good < nc:         # the geometric mean of the good ones (logs only when needed)
        log_sum = 0.0
        for i in range(nc):
            if np.isfinite(d[i]) and d[i] > 0.0:
                log_sum += np.log(d[i])
        fill = np.exp(log_sum / n_good) if n_good > 0 else 1.0
        for i in range(nc):
            if not (np.isfinite(d[i]) and d[i] > 0.0):
                d[i] = fill
    s = d
    sq = 0.0
    for i in range(nc):
        s[i] = 1.0 / np.sqrt(d[i])
        for k in range(dim):
            v = s[i] * q[i * dim + k]
            sq += v * v
    sigma = np.sqrt(sq) / np.sqrt(m)
    if not (np.isfinite(sigma) and sigma > 0.0):
        sigma = 1.0
    q2 = 0.0
    qs2 = 0.0
    for i in range(nc):
        ai = sigma * s[i]
        bi = sigma / s[i]
        for k in range(dim):
            j = i * dim + k
            a[j] = ai
            b[j] = bi
            q_s[j] = q[j] / bi
            q2 += q[j] * q[j]
            qs2 += q_s[j] * q_s[j]
    return q2, qs2


@njit(cache=True)
def jacobi_diagonal(indptr, indices, data, inv_m, m):
    """``diag(Hᵀ diag(inv_m) H)`` for ``H`` (``n x m``) in CSR form: the Jacobi estimate of
    ``diag(W)`` of a global problem (:func:`socp_cd.residuals.contact_scales`)."""
    out = np.zeros(m)
    for row in range(indptr.shape[0] - 1):
        w = inv_m[row]
        for k in range(indptr[row], indptr[row + 1]):
            out[indices[k]] += data[k] * data[k] * w
    return out


@njit(cache=True)
def balance_csr(indptr, indices, data, q, mu, dim):
    """Balancing factors, balanced entries of ``W`` and ``q``, and the norms of a local problem.

    Parameters
    ----------
    indptr, indices, data : ndarray
        ``W`` (``m x m``) in CSR form (duplicates summed, entries finite).
    q : ndarray (m,)
    mu : ndarray (nc,)
    dim : int

    Returns
    -------
    a, b : ndarray (m,)
        ``r = a r~``, ``u = b u~`` (:func:`socp_cd.residuals.contact_scales`):
        ``d_i`` the mean ``|diagonal|`` of block ``W_ii`` (contacts without a
        positive finite one get the geometric mean of the others, or 1),
        ``s = 1/sqrt(d)``, ``sigma = ||s q|| / sqrt(m)`` (1 when not positive
        and finite), ``a = sigma s``, ``b = sigma / s``.
    data_s : ndarray
        Entries of ``S W S`` with ``S = diag(sqrt(a / b))`` (same ``indptr``,
        ``indices``).
    q_s : ndarray (m,)
        ``q / b``.
    q_norm, q_s_norm : float
        ``||q||``, ``||q / b||``.
    zero_error : float
        Siconos' relative error of ``r = 0`` (``u = q``) of the original problem.
    """
    # (one allocation, the four outputs and d views of it: a one-contact call of the compiled
    # route runs this, and each allocation costs ~20 ns of its few microseconds)
    m = q.shape[0]
    nc = m // dim
    buf = np.empty(4 * m + data.shape[0])
    a = buf[:m]
    b = buf[m:2 * m]
    q_s = buf[2 * m:3 * m]
    # d: the sums of |diag| per contact (d[:nc]), then the zero r, then sqrt(a / b) per unknown
    d = buf[3 * m:4 * m]
    d[:] = 0.0
    data_s = buf[4 * m:]
    for i in range(nc):
        for k in range(dim):
            row = i * dim + k
            w = 0.0                      # W_row,row (duplicates summed in CSR order)
            for p in range(indptr[row], indptr[row + 1]):
                if indices[p] == row:
                    w += data[p]
            d[i] += abs(w)
    q2, qs2 = factors_from_sums(d[:nc], q, dim, a, b, q_s)
    q_norm = np.sqrt(q2)
    d[:] = 0.0      # Siconos' error of r = 0, with d (its scales no longer needed) as r
    zero_error = coulomb_zero_error_of(d, q, mu, dim, q_norm)
    for i in range(nc):          # a / b is one value per contact: one square root each
        v = np.sqrt(a[i * dim] / b[i * dim])
        for k in range(dim):
            d[i * dim + k] = v
    for row in range(m):
        for k in range(indptr[row], indptr[row + 1]):
            data_s[k] = data[k] * (d[row] * d[indices[k]])
    return a, b, data_s, q_s, q_norm, np.sqrt(qs2), zero_error


@njit(cache=True)
def coulomb_zero_error(q, mu, dim, q_norm):
    """Siconos' relative error of ``r = 0`` (``u = q``, ``q_norm = ||q||``) for the Coulomb law."""
    return coulomb_zero_error_of(np.zeros(q.shape[0]), q, mu, dim, q_norm)


@njit(cache=True, inline="always")
def coulomb_zero_error_of(zeros, q, mu, dim, q_norm):
    """:func:`coulomb_zero_error` with ``zeros`` (a zero vector of ``q``'s length) for ``r``."""
    # (``mu`` stands in for the thresholds, which the Coulomb law never reads)
    f2, r2, u2 = error_parts(zeros, q, mu, mu, dim, np.int64(LAW_COULOMB))
    return relative_error(f2, r2, u2, q_norm)


@njit(cache=True)
def balanced_guard_parts(r, u, a, b, mu, dim):
    """The Coulomb units guard's raw parts of ``(r / a, u / b)`` in one pass.

    Returns
    -------
    tuple
        ``(finite, f2, r2, u2, cone, normal, gap)``: whether the balanced pair
        is finite (when not, the other entries are 0), then
        :func:`~socp_cd.solvers.kernels.cone.error_parts` and
        :func:`~socp_cd.solvers.kernels.cone.coulomb_violations` of the
        balanced pair (the compiled pieces of :func:`socp_cd.residuals.guard`).
    """
    return guard_parts_into(r, u, a, b, mu, dim, np.empty((2, r.shape[0])))


@njit(cache=True, inline="always")
def guard_parts_into(r, u, a, b, mu, dim, both):
    """:func:`balanced_guard_parts` with ``both`` ``(2, m)`` for the balanced pair."""
    m = r.shape[0]
    rs, us = both[0], both[1]
    for j in range(m):
        rs[j] = r[j] / a[j]
        us[j] = u[j] / b[j]
        if not (np.isfinite(rs[j]) and np.isfinite(us[j])):
            return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    f2, r2, u2 = error_parts(rs, us, mu, mu, dim, np.int64(LAW_COULOMB))   # (mu: unread thresholds)
    cone, normal, gap = coulomb_violations(rs, us, mu, dim)
    return True, f2, r2, u2, cone, normal, gap


#: entries of :func:`balanced_guard`'s array, in order (the keys of the guard's record)
GUARD_KEYS = ("error", "balanced_siconos", "rounding", "value", "cone", "normal_velocity",
              "complementarity")
_EPS = np.finfo(np.float64).eps


@njit(cache=True, inline="always")
def origin_error(r, u, a, b, mu, dim, q_norm):
    """Siconos' Coulomb error of ``(a r, b u)`` over ``q_norm``: of the problem as written.

    ``(r, u)`` a pair of the balanced problem (``r = a r~``, ``u = b u~``,
    :func:`balance_csr`), ``q_norm = ||q||`` of the problem the caller
    wrote.  The measure the dispatcher judges ``converged`` by
    (:func:`socp_cd.error`, up to the rounding of ``u = W r + q``; inf beyond
    ~1e154, where ``socp_cd.error`` measures the pair scaled), for a
    solver that runs on the balanced copy and would otherwise stop on the
    balanced problem's own error.
    """
    # (no temporaries: a one-contact NSGS call runs this once, and three allocations cost
    # 0.2 us of its 8; ``mu`` stands in for the thresholds, which the Coulomb law never reads)
    f2, r2, u2 = scaled_error_parts(r, u, a, b, mu, mu, dim, np.int64(LAW_COULOMB))
    return relative_error(f2, r2, u2, q_norm)


@njit(cache=True)
def balanced_guard(r, u, a, b, mu, dim, q_norm):
    """The Coulomb units guard of ``(r, u)``: :func:`balanced_guard_parts` and the guard's formulas.

    The compiled twin of :func:`socp_cd.residuals.guard_values` (with
    :func:`~socp_cd.residuals.finite_guard` and the Coulomb parts relative to
    the velocity scale), Python's ``max`` semantics included; ``q_norm`` is
    ``||q~||``.

    Returns
    -------
    finite : bool
        Whether the balanced pair is finite (when not, the guard fails and
        ``out`` is all ``inf``).
    out : ndarray (7,)
        The entries named by :data:`GUARD_KEYS` (non-finite ones as ``inf``).
    """
    m = r.shape[0]
    buf = np.empty(2 * m + 7)       # (one allocation: the balanced pair, then out)
    out = buf[2 * m:]
    out[:] = np.inf
    finite, f2, r2, u2, cone, normal, gap = guard_parts_into(r, u, a, b, mu, dim,
                                                            buf[:2 * m].reshape((2, m)))
    if not finite:
        return False, out
    measured = relative_error(f2, r2, u2, q_norm)
    r_norm = np.sqrt(r2)
    u_norm = np.sqrt(u2)
    vel = u_norm if u_norm > q_norm else q_norm           # max(q_norm, u_norm)
    vel = vel if vel > _EPS else 1.0
    sic = q_norm
    if r_norm > sic:
        sic = r_norm
    if u_norm > sic:
        sic = u_norm
    sic = sic if sic > _EPS else 1.0
    error = measured * (sic / vel)
    rounding = _EPS * r_norm / vel
    value = rounding if rounding > error else error       # max(error, rounding)
    vals = (error, measured, rounding, value, cone / vel, normal / vel, gap / (vel * vel))
    for k in range(7):
        if np.isfinite(vals[k]):
            out[k] = vals[k]
    return True, out


@njit(cache=True)
def times_factors(r, a):
    """``r * a`` (a new array; an overflow ends as inf, no NumPy error state involved)."""
    out = np.empty(r.shape[0])
    for k in range(r.shape[0]):
        out[k] = r[k] * a[k]
    return out


@njit(cache=True)
def factor_summary(a, b, dim):
    """``(sqrt(a_0 b_0), min_i d_i, max_i d_i)`` with ``d_i = b_i / a_i`` at each contact's
    first component (:meth:`socp_cd.solvers.scaling.Scaling.describe`)."""
    if a.shape[0] == 0:
        return np.nan, np.nan, np.nan
    lo, hi = np.inf, -np.inf
    for k in range(0, a.shape[0], dim):
        d = b[k] / a[k]
        lo = min(lo, d)
        hi = max(hi, d)
    return np.sqrt(a[0] * b[0]), lo, hi


__all__ = ["balance_csr", "balanced_guard", "GUARD_KEYS", "balanced_guard_parts", "jacobi_diagonal", "unit_factors",
           "times_factors", "factor_summary"]

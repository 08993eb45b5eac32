"""Cone operations of the contact laws, compiled (numba, ``cache=True``).

Stable API (other solvers call these; keep the signatures)
---------------------------------------------------------
Per contact ("block" of ``dim`` entries, normal first), writing into ``out``:

``project_cone_block(x, dim, mu, out)``
    Euclidean projection on the Coulomb cone ``K_mu = {||x_T|| <= mu x_N}``.
``project_dual_cone_block(x, dim, mu, out)``
    Projection on the dual cone ``K*_mu = {mu ||x_T|| <= x_N}`` (``= K_{1/mu}``;
    ``mu = 0``: the half-space ``x_N >= 0``).
``project_cone_jacobian_block(x, dim, mu, J)``
    One element of the generalized (Clarke) Jacobian of ``P_K`` at ``x``
    (``dim x dim``, into ``J``): 0 on the polar cone, I inside, the derivative
    of the boundary projection otherwise.
``desaxce_velocity_block(u, dim, mu, out)``
    De Saxcé's modified velocity ``û = u + mu ||u_T|| e_N``.
``project_law_block(x, dim, mu, g, law, out)`` / ``law_velocity_block(u, dim, mu, law, out)``
    The same for a contact law code (``LAW_COULOMB``, ``LAW_ASSOCIATED``:
    ``u`` unchanged; ``LAW_TRESCA``: projection on ``R+ x B(0, g)``).

The same on scalars (a contact's components ``x0, x1, x2``; ``x2`` ignored in 2D),
returning a tuple of three floats — the forms per-contact loops use:

``tangential_norm(x1, x2, dim)``, ``cone_projection(x0, x1, x2, dim, mu)``,
``law_projection(x0, x1, x2, dim, mu, g, law)``, ``law_velocity(u0, u1, u2, dim, mu, law)``.

Whole stacked vectors (length ``m = dim * n_contacts``):

``project_cone_stacked(x, mu, dim, out)``
    ``P_K`` contact by contact (the compiled twin of :func:`socp_cd.cones.project_cone`).

``siconos_error(r, u, mu, dim, norm_q)``
    Siconos' relative error ``||r - P_K(r - û)|| / max(||q||, ||r||, ||u||)``
    (``fc3d_compute_error``) with ``u`` given (recompute it first).
``error_parts(r, u, mu, g, dim, law)``
    ``(||F||², ||r||², ||u||²)`` of the natural map ``F = r - P(r - û)`` for
    any law; :func:`relative_error` turns them into the relative error.
``coulomb_violations(r, u, mu, dim)``
    ``(max cone distance of r, max(0, -u_N), sum |r · û|)`` over the contacts
    (the parts of the units guard, :func:`socp_cd.residuals.coulomb_parts`).
``relative_error(f2, r2, u2, norm_q)``
    ``sqrt(f2) / max(norm_q, sqrt(r2), sqrt(u2))``; when the three norms are
    below machine epsilon the absolute value is returned (Siconos' rule); inf
    when one of them is not finite (entries beyond ~1e154), where
    :func:`law_error` measures the pair scaled, as :func:`socp_cd.error` does:
    a caller of ``relative_error`` alone is conservative there, never smaller.

Tangential norms in 2D are ``|x_T|``.  Nothing is allocated per block.
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: contact-law codes of the compiled kernels (compiled code passes a code to a kernel that
#: is not inlined as ``np.int64(LAW_COULOMB)``: numba compiles a kernel apart for each
#: literal argument, and a fresh install pays for every version, ``validation/compile_cost.py``)
LAW_COULOMB = 0
LAW_ASSOCIATED = 1
LAW_TRESCA = 2

#: machine epsilon: below it the error normalization falls back to 1 (Siconos' rule)
EPS = 2.220446049250313e-16


# The block operations work on scalars (a contact's <= 3 components): numba counts a
# reference for every array handed between inlined functions, and on one contact that
# bookkeeping cost more than the arithmetic.  The array forms below wrap them.
@njit(cache=True, inline="always")
def tangential_norm(x1, x2, dim):
    """``||x_T||`` of a block given by its tangential components (``x2`` ignored in 2D)."""
    if dim == 2:
        return abs(x1)
    return np.sqrt(x1 * x1 + x2 * x2)


@njit(cache=True, inline="always")
def tangential_norm_block(x, dim):
    """``||x_T||`` of one contact block."""
    return tangential_norm(x[1], x[2] if dim == 3 else 0.0, dim)


@njit(cache=True, inline="always")
def cone_projection(x0, x1, x2, dim, mu):
    """``P_{K_mu}`` of the block ``(x0, x1, x2)`` (``x2`` ignored, returned 0, in 2D).

    The polar test comes first, as in :func:`socp_cd.cones.project_cone`: with
    ``mu = 0`` and ``x_T = 0`` both tests read ``0 <= ...``, and a block with
    ``x_N < 0`` must project to 0, not to itself.
    """
    t = tangential_norm(x1, x2, dim)
    if mu * t <= -x0:
        return 0.0, 0.0, 0.0
    if t <= mu * x0:
        return x0, x1, (x2 if dim == 3 else 0.0)
    pn = (x0 + mu * t) / (1.0 + mu * mu)
    # (t = 0 here only when x0 or mu * x0 is NaN, as 0 * inf: x_T = 0 projects to 0; a
    # division by zero would raise in numba)
    s = mu * pn / t if t > 0.0 else 0.0
    return pn, s * x1, (s * x2 if dim == 3 else 0.0)


@njit(cache=True, inline="always")
def law_projection(x0, x1, x2, dim, mu, g, law):
    """Projection on ``K_mu`` (Coulomb, associated) or ``R+ x B(0, g)`` (Tresca), scalars."""
    if law == LAW_TRESCA:
        t = tangential_norm(x1, x2, dim)
        s = 1.0
        if t > g:
            s = g / t
        return (x0 if x0 > 0.0 else 0.0), s * x1, (s * x2 if dim == 3 else 0.0)
    return cone_projection(x0, x1, x2, dim, mu)


@njit(cache=True, inline="always")
def law_velocity(u0, u1, u2, dim, mu, law):
    """``û = u + mu ||u_T|| e_N`` (Coulomb), ``u`` itself for the other laws, scalars."""
    if law == LAW_COULOMB:
        return u0 + mu * tangential_norm(u1, u2, dim), u1, u2
    return u0, u1, u2


@njit(cache=True, inline="always")
def _write(out, dim, p0, p1, p2):
    out[0] = p0
    out[1] = p1
    if dim == 3:
        out[2] = p2


@njit(cache=True, inline="always")
def project_cone_block(x, dim, mu, out):
    """Project one block ``x`` on ``K_mu`` (into ``out``; ``out`` may be ``x``;
    :func:`cone_projection`)."""
    p0, p1, p2 = cone_projection(x[0], x[1], x[2] if dim == 3 else 0.0, dim, mu)
    _write(out, dim, p0, p1, p2)


@njit(cache=True, inline="always")
def project_dual_cone_block(x, dim, mu, out):
    """Project one block on ``K*_mu = K_{1/mu}`` (``mu = 0``: clip ``x_N`` at 0)."""
    if mu == 0.0:
        for a in range(dim):
            out[a] = x[a]
        if out[0] < 0.0:
            out[0] = 0.0
        return
    project_cone_block(x, dim, 1.0 / mu, out)


@njit(cache=True, inline="always")
def project_law_block(x, dim, mu, g, law, out):
    """Project on ``K_mu`` (Coulomb, associated) or ``R+ x B(0, g)`` (Tresca)
    (:func:`law_projection`)."""
    p0, p1, p2 = law_projection(x[0], x[1], x[2] if dim == 3 else 0.0, dim, mu, g, law)
    _write(out, dim, p0, p1, p2)


@njit(cache=True, inline="always")
def desaxce_velocity_block(u, dim, mu, out):
    """``û = u + mu ||u_T|| e_N`` for one block."""
    p0, p1, p2 = law_velocity(u[0], u[1], u[2] if dim == 3 else 0.0, dim, mu, LAW_COULOMB)
    _write(out, dim, p0, p1, p2)


@njit(cache=True, inline="always")
def law_velocity_block(u, dim, mu, law, out):
    """``û`` for the Coulomb law, ``u`` itself for the others (:func:`law_velocity`)."""
    p0, p1, p2 = law_velocity(u[0], u[1], u[2] if dim == 3 else 0.0, dim, mu, law)
    _write(out, dim, p0, p1, p2)


@njit(cache=True)
def project_cone_jacobian_block(x, dim, mu, J):
    """One element of the generalized Jacobian of ``P_{K_mu}`` at block ``x`` (into ``J``).

    With ``t = ||x_T||``, ``w = x_T / t``, ``a = 1 / (1 + mu²)`` and
    ``p_N = a (x_N + mu t)`` on the side region::

        J = [[a,        mu a wᵀ],
             [mu a w,   mu² a w wᵀ + (mu p_N / t)(I - w wᵀ)]]

    ``J = 0`` on the polar cone (``mu t <= -x_N``), ``I`` inside (``t <= mu x_N``).
    """
    xn = x[0]
    t = tangential_norm_block(x, dim)
    for a in range(dim):
        for b in range(dim):
            J[a, b] = 0.0
    if mu * t <= -xn:            # polar cone: P = 0
        return
    if t <= mu * xn:             # inside: P = identity
        for a in range(dim):
            J[a, a] = 1.0
        return
    if not t > 0.0:             # (NaN or 0 * inf in the tests above: no derivative)
        for a in range(dim):
            for b in range(dim):
                J[a, b] = np.nan
        return
    a_ = 1.0 / (1.0 + mu * mu)
    pn = (xn + mu * t) * a_
    J[0, 0] = a_
    for b in range(1, dim):
        wb = x[b] / t
        J[0, b] = mu * a_ * wb
        J[b, 0] = mu * a_ * wb
        for c in range(1, dim):
            wc = x[c] / t
            eye = 1.0 if b == c else 0.0
            J[b, c] = mu * mu * a_ * wb * wc + (mu * pn / t) * (eye - wb * wc)


@njit(cache=True)
def project_cone_stacked(x, mu, dim, out):
    """Project a stacked vector on ``K_mu`` contact by contact (into ``out``; may be ``x``).

    ``mu`` has one entry per contact.  Returns ``out``.
    """
    for i in range(mu.shape[0]):
        o = i * dim
        p0, p1, p2 = cone_projection(x[o], x[o + 1], x[o + 2] if dim == 3 else 0.0, dim, mu[i])
        out[o] = p0
        out[o + 1] = p1
        if dim == 3:
            out[o + 2] = p2
    return out


@njit(cache=True)
def error_parts(r, u, mu, g, dim, law):
    """``(||F||², ||r||², ||u||²)`` with ``F = r - P(r - û)`` (law ``law``, ``rho = 1``).

    ``mu`` and ``g`` (Tresca thresholds; ignored for the other laws) have one
    entry per contact.
    """
    return _error_parts(r, u, r, u, False, mu, g, dim, law)


@njit(cache=True, inline="always")
def scaled_error_parts(r, u, a, b, mu, g, dim, law):
    """:func:`error_parts` of ``(a r, b u)`` (entrywise products), without forming them."""
    return _error_parts(r, u, a, b, True, mu, g, dim, law)


@njit(cache=True, inline="always")
def _error_parts(r, u, a, b, scaled, mu, g, dim, law):
    # error_parts of (a r, b u) when ``scaled``, of (r, u) otherwise (a, b then unread)
    nc = r.shape[0] // dim
    f2 = 0.0
    r2 = 0.0
    u2 = 0.0
    for i in range(nc):
        o = i * dim
        r0, r1 = r[o], r[o + 1]
        u0, u1 = u[o], u[o + 1]
        r_2 = r[o + 2] if dim == 3 else 0.0
        u_2 = u[o + 2] if dim == 3 else 0.0
        if scaled:
            r0, r1, r_2 = r0 * a[o], r1 * a[o + 1], (r_2 * a[o + 2] if dim == 3 else 0.0)
            u0, u1, u_2 = u0 * b[o], u1 * b[o + 1], (u_2 * b[o + 2] if dim == 3 else 0.0)
        h0, h1, h2 = law_velocity(u0, u1, u_2, dim, mu[i], law)
        x0 = r0 - h0
        x1 = r1 - h1
        x2 = r_2 - h2
        r2 += r0 * r0
        u2 += u0 * u0
        r2 += r1 * r1
        u2 += u1 * u1
        if dim == 3:
            r2 += r_2 * r_2
            u2 += u_2 * u_2
        p0, p1, p2 = law_projection(x0, x1, x2, dim, mu[i], g[i], law)
        e = r0 - p0
        f2 += e * e
        e = r1 - p1
        f2 += e * e
        if dim == 3:
            e = r_2 - p2
            f2 += e * e
    return f2, r2, u2


@njit(cache=True, inline="always")
def relative_error(f2, r2, u2, norm_q):
    """``sqrt(f2) / max(norm_q, sqrt(r2), sqrt(u2))`` (1 when all three are below eps); inf
    when one of them is not finite (an overflowed ``r2`` over a finite ``f2`` would read 0).

    The four are squared norms and a norm (never ``-inf``), so ``x < inf`` is the finiteness
    test: plain comparisons, where four ``np.isfinite`` calls (sessions 42-44) made the least
    of 10 calls of a plain ``solve`` on 1-10 contacts ~10 % slower
    (``validation/results/ab_s42_s44.md``)."""
    if not (f2 < np.inf and r2 < np.inf and u2 < np.inf and norm_q < np.inf):
        return np.inf
    den = norm_q
    if np.sqrt(r2) > den:
        den = np.sqrt(r2)
    if np.sqrt(u2) > den:
        den = np.sqrt(u2)
    if den <= EPS:
        den = 1.0
    return np.sqrt(f2) / den


@njit(cache=True)
def pair_scale(r, u):
    """``max|(r, u)|``, the largest entry of a pair in absolute value: the factor the measures
    divide a pair by when its squared norms overflow (:func:`law_error`,
    ``newton_dense.velocity_error``)."""
    c = 0.0
    for k in range(r.shape[0]):
        if abs(r[k]) > c:
            c = abs(r[k])
        if abs(u[k]) > c:
            c = abs(u[k])
    return c


@njit(cache=True)
def law_error(r, u, mu, g, dim, law, norm_q):
    """Relative natural-map error of ``r`` for any law code, ``u`` given; a pair whose squared
    norms overflow is measured at ``(c r, c u, c g, c norm_q)``, ``c = 1 / max|(r, u)|``, where
    the measure is the same (:func:`socp_cd.residuals.error`: an overflowed ``||r||²`` over a
    finite ``||F||²`` read 0); inf when that is not finite, or ``norm_q`` is not."""
    f2, r2, u2 = error_parts(r, u, mu, g, dim, law)
    e = relative_error(f2, r2, u2, norm_q)
    if np.isfinite(e) or not np.isfinite(norm_q):
        return e
    c = pair_scale(r, u)
    if not (np.isfinite(c) and c > 0.0):
        return np.inf
    f2, r2, u2 = error_parts(r / c, u / c, mu, g / c, dim, law)
    e = relative_error(f2, r2, u2, norm_q / c)
    return e if np.isfinite(e) else np.inf


@njit(cache=True)
def siconos_error(r, u, mu, dim, norm_q):
    """Siconos' relative error (Coulomb law) of ``r`` with velocities ``u`` given."""
    return law_error(r, u, mu, np.zeros(mu.shape[0]), dim, np.int64(LAW_COULOMB), norm_q)


@njit(cache=True)
def coulomb_violations(r, u, mu, dim):
    """``(max_i dist(r_i, K_mu), max_i max(0, -u_N,i), sum_i |r_i · û_i|)``.

    The feasibility and complementarity measures of a Coulomb pair
    (:func:`socp_cd.cones.in_cone_violation`,
    :func:`socp_cd.cones.normal_velocity_violation`,
    :func:`socp_cd.cones.fenchel_young_gap`) reduced over the contacts.
    """
    nc = r.shape[0] // dim
    cone = 0.0
    normal = 0.0
    gap = 0.0
    for i in range(nc):
        o = i * dim
        r0, r1 = r[o], r[o + 1]
        u0, u1 = u[o], u[o + 1]
        r_2 = r[o + 2] if dim == 3 else 0.0
        u_2 = u[o + 2] if dim == 3 else 0.0
        p0, p1, p2 = cone_projection(r0, r1, r_2, dim, mu[i])
        e = r0 - p0
        d2 = e * e
        e = r1 - p1
        d2 += e * e
        if dim == 3:
            e = r_2 - p2
            d2 += e * e
        d = np.sqrt(d2)
        if d > cone or i == 0:
            cone = d
        v = -u0 if -u0 > 0.0 else 0.0
        if v > normal or i == 0:
            normal = v
        h0, h1, h2 = law_velocity(u0, u1, u_2, dim, mu[i], LAW_COULOMB)
        g = r0 * h0 + r1 * h1
        if dim == 3:
            g += r_2 * h2
        gap += abs(g)
    return cone, normal, gap


__all__ = ["pair_scale", "LAW_COULOMB", "LAW_ASSOCIATED", "LAW_TRESCA", "EPS", "tangential_norm_block",
           "tangential_norm", "cone_projection", "law_projection", "law_velocity",
           "project_cone_block", "project_cone_stacked", "project_dual_cone_block", "project_law_block",
           "desaxce_velocity_block", "law_velocity_block", "project_cone_jacobian_block",
           "error_parts", "relative_error", "law_error", "siconos_error", "coulomb_violations"]

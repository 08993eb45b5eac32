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
    below machine epsilon the absolute value is returned (Siconos' rule).

Tangential norms in 2D are ``|x_T|``.  Nothing is allocated per block.
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: contact-law codes of the compiled kernels
LAW_COULOMB = 0
LAW_ASSOCIATED = 1
LAW_TRESCA = 2

#: machine epsilon: below it the error normalization falls back to 1 (Siconos' rule)
EPS = 2.220446049250313e-16


@njit(cache=True, inline="always")
def tangential_norm_block(x, dim):
    """``||x_T||`` of one contact block."""
    if dim == 2:
        return abs(x[1])
    return np.sqrt(x[1] * x[1] + x[2] * x[2])


@njit(cache=True, inline="always")
def project_cone_block(x, dim, mu, out):
    """Project one block ``x`` on ``K_mu`` (into ``out``; ``out`` may be ``x``).

    The polar test comes first, as in :func:`socp_cd.cones.project_cone`: with
    ``mu = 0`` and ``x_T = 0`` both tests read ``0 <= ...``, and a block with
    ``x_N < 0`` must project to 0, not to itself.
    """
    xn = x[0]
    t = tangential_norm_block(x, dim)
    if mu * t <= -xn:
        for a in range(dim):
            out[a] = 0.0
    elif t <= mu * xn:
        for a in range(dim):
            out[a] = x[a]
    else:
        pn = (xn + mu * t) / (1.0 + mu * mu)
        out[0] = pn
        s = mu * pn / t
        for a in range(1, dim):
            out[a] = s * x[a]


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
    """Project on ``K_mu`` (Coulomb, associated) or ``R+ x B(0, g)`` (Tresca)."""
    if law == LAW_TRESCA:
        t = tangential_norm_block(x, dim)
        out[0] = x[0] if x[0] > 0.0 else 0.0
        s = 1.0
        if t > g:
            s = g / t
        for a in range(1, dim):
            out[a] = s * x[a]
        return
    project_cone_block(x, dim, mu, out)


@njit(cache=True, inline="always")
def desaxce_velocity_block(u, dim, mu, out):
    """``û = u + mu ||u_T|| e_N`` for one block."""
    t = tangential_norm_block(u, dim)
    for a in range(dim):
        out[a] = u[a]
    out[0] += mu * t


@njit(cache=True, inline="always")
def law_velocity_block(u, dim, mu, law, out):
    """``û`` for the Coulomb law, ``u`` itself for the others."""
    if law == LAW_COULOMB:
        desaxce_velocity_block(u, dim, mu, out)
    else:
        for a in range(dim):
            out[a] = u[a]


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
        project_cone_block(x[o:o + dim], dim, mu[i], out[o:o + dim])
    return out


@njit(cache=True)
def error_parts(r, u, mu, g, dim, law):
    """``(||F||², ||r||², ||u||²)`` with ``F = r - P(r - û)`` (law ``law``, ``rho = 1``).

    ``mu`` and ``g`` (Tresca thresholds; ignored for the other laws) have one
    entry per contact.
    """
    nc = r.shape[0] // dim
    x = np.empty(dim)
    p = np.empty(dim)
    f2 = 0.0
    r2 = 0.0
    u2 = 0.0
    for i in range(nc):
        o = i * dim
        law_velocity_block(u[o:o + dim], dim, mu[i], law, x)
        for a in range(dim):
            x[a] = r[o + a] - x[a]
            r2 += r[o + a] * r[o + a]
            u2 += u[o + a] * u[o + a]
        project_law_block(x, dim, mu[i], g[i], law, p)
        for a in range(dim):
            e = r[o + a] - p[a]
            f2 += e * e
    return f2, r2, u2


@njit(cache=True, inline="always")
def relative_error(f2, r2, u2, norm_q):
    """``sqrt(f2) / max(norm_q, sqrt(r2), sqrt(u2))`` (1 when all three are below eps)."""
    den = norm_q
    if np.sqrt(r2) > den:
        den = np.sqrt(r2)
    if np.sqrt(u2) > den:
        den = np.sqrt(u2)
    if den <= EPS:
        den = 1.0
    return np.sqrt(f2) / den


@njit(cache=True)
def law_error(r, u, mu, g, dim, law, norm_q):
    """Relative natural-map error of ``r`` for any law code, ``u`` given."""
    f2, r2, u2 = error_parts(r, u, mu, g, dim, law)
    return relative_error(f2, r2, u2, norm_q)


@njit(cache=True)
def siconos_error(r, u, mu, dim, norm_q):
    """Siconos' relative error (Coulomb law) of ``r`` with velocities ``u`` given."""
    return law_error(r, u, mu, np.zeros(mu.shape[0]), dim, LAW_COULOMB, norm_q)


@njit(cache=True)
def coulomb_violations(r, u, mu, dim):
    """``(max_i dist(r_i, K_mu), max_i max(0, -u_N,i), sum_i |r_i · û_i|)``.

    The feasibility and complementarity measures of a Coulomb pair
    (:func:`socp_cd.cones.in_cone_violation`,
    :func:`socp_cd.cones.normal_velocity_violation`,
    :func:`socp_cd.cones.fenchel_young_gap`) reduced over the contacts.
    """
    nc = r.shape[0] // dim
    p = np.empty(dim)
    uh = np.empty(dim)
    cone = 0.0
    normal = 0.0
    gap = 0.0
    for i in range(nc):
        o = i * dim
        project_cone_block(r[o:o + dim], dim, mu[i], p)
        d2 = 0.0
        for a in range(dim):
            e = r[o + a] - p[a]
            d2 += e * e
        d = np.sqrt(d2)
        if d > cone or i == 0:
            cone = d
        v = -u[o] if -u[o] > 0.0 else 0.0
        if v > normal or i == 0:
            normal = v
        desaxce_velocity_block(u[o:o + dim], dim, mu[i], uh)
        g = 0.0
        for a in range(dim):
            g += r[o + a] * uh[a]
        gap += abs(g)
    return cone, normal, gap


__all__ = ["LAW_COULOMB", "LAW_ASSOCIATED", "LAW_TRESCA", "EPS", "tangential_norm_block",
           "project_cone_block", "project_cone_stacked", "project_dual_cone_block", "project_law_block",
           "desaxce_velocity_block", "law_velocity_block", "project_cone_jacobian_block",
           "error_parts", "relative_error", "law_error", "siconos_error", "coulomb_violations"]

"""Fischer–Burmeister equation of the Coulomb law and its generalized Jacobian (numba kernel).

The third nonsmooth equation of :mod:`socp_cd.solvers.newton` (option
``equation="fischer_burmeister"``; ``formulations/newton.md`` §14), the family of Siconos'
NSN_FB.  For every contact with impulse ``r``, velocity ``u``, ``û = u + mu ||u_T|| e_N``
and parameter ``rho > 0``::

    x = (mu r_N, r_T)              r ∈ K_mu   ⇔ x ∈ L  (L the Lorentz cone ||x̄|| <= x₀)
    y = rho (û_N, mu û_T)          û ∈ K*_mu  ⇔ y ∈ L,  xᵀy = rho mu r·û
    F = x + y − (x² + y²)^{1/2}    (Jordan algebra of L: x ∘ y = (xᵀy, x₀ȳ + y₀x̄))

``F = 0`` ⇔ the Coulomb law with Signorini's condition.  ``mu = 0`` (``K_0`` is a half-line):
the scalar Fischer–Burmeister function of ``0 <= r_N ⊥ rho u_N >= 0`` and ``F_T = r_T``.
Blocks ``dF = Dr dr + Du du`` as the other equations' kernels, so the Newton matrix stays
``Dr + Du W``: with ``dφ = (I − Mx) dx + (I − My) dy`` (:func:`lorentz_fb`),
``Dr = (I − Mx) S_r``, ``Du = rho (I − My) S_u D``, ``S_r = diag(mu, 1, 1)``,
``S_u = diag(1, mu, mu)``, ``D = I + mu e_N wᵀ`` (``w = u_T/||u_T||``, 0 when ``u_T = 0``).

Branch codes: ``1`` where ``x² + y²`` is on the boundary of ``L`` (the map's kinks: ``x``
and ``y`` on one boundary ray, at a solution the grazing states; a closed-form limit element
there) or, at ``mu = 0``, where ``r_N = u_N = 0``; else ``0``.

``x = (mu r_N, r_T)`` gives ``r_N`` a weight ``mu`` beside ``y``'s: at small ``mu`` rounding
hides changes of ``r_N`` below ``~eps |y| / mu``, an error floor of that order (at tol 1e-10
the natural map and Alart–Curnier solve problems of ``mu = 1e-8`` this equation does not;
``formulations/newton.md`` §14).  The kernel reads
``rho_n`` (one parameter per contact; ``rho_t`` is not read).  Its NumPy reference is
:func:`socp_cd.cones.fischer_burmeister_jacobian` (tested equal).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .cone import tangential_norm

#: ``λ₁(x² + y²) <= FB_DEGENERATE λ₂(x² + y²)``: the degenerate set (``cones.FB_DEGENERATE``,
#: where the choice is explained)
FB_DEGENERATE = 1e-20
_K = 1.0 / np.sqrt(2.0)


@njit(cache=True)
def lorentz_fb(x, y, d, phi, Mx, My):
    """Fischer–Burmeister function of the Lorentz cone for one block (``cones.lorentz_fb``).

    Writes ``phi = x + y − (x² + y²)^{1/2}`` and ``Mx``, ``My`` with
    ``dφ = (I − Mx) dx + (I − My) dy`` (``x``, ``y``, ``phi`` of length >= d; ``Mx``,
    ``My`` at least d x d); returns True on the degenerate set, where ``Mx``, ``My`` are the
    closed-form limit of the derivative along ``(x + τe, y + τe)``, ``τ → 0⁺``.  ``x``
    and ``y`` are divided by ``t = max|·|`` first and ``phi`` multiplied back (``φ`` is
    positively homogeneous of degree 1, ``Mx``, ``My`` of degree 0: ``det(z)`` grows as
    ``|x|⁴`` and would overflow above 1e77 and underflow below 1e-81); ``x`` and ``y`` are
    overwritten with the scaled pair.
    """
    t = 0.0
    for a in range(d):
        t = max(t, abs(x[a]), abs(y[a]))
    scale = t > 0.0 and t < np.inf
    if scale:
        for a in range(d):
            x[a] /= t
            y[a] /= t
    z0 = 0.0
    for a in range(d):
        z0 += x[a] * x[a] + y[a] * y[a]
    z1 = 2.0 * (x[0] * x[1] + y[0] * y[1])
    z2 = 2.0 * (x[0] * x[2] + y[0] * y[2]) if d == 3 else 0.0
    nz = np.sqrt(z1 * z1 + z2 * z2)
    l2 = z0 + nz
    # λ₁ = det(z) / λ₂, det(z) as a sum of squares (cones.fb_determinant): z₀ − ||z̄|| cancels to
    # ~eps z₀ on the degenerate set, whose square root would put ~1e-8 |x| of noise in F
    nx = np.sqrt(x[1] * x[1] + (x[2] * x[2] if d == 3 else 0.0))
    ny = np.sqrt(y[1] * y[1] + (y[2] * y[2] if d == 3 else 0.0))
    dx = (x[0] - nx) * (x[0] + nx)
    dy = (y[0] - ny) * (y[0] + ny)
    c1 = x[0] * y[1] - y[0] * x[1]
    c2 = (x[0] * y[2] - y[0] * x[2]) if d == 3 else 0.0
    inner = x[0] * y[0] - x[1] * y[1] - (x[2] * y[2] if d == 3 else 0.0)
    wedge = (x[1] * y[2] - x[2] * y[1]) if d == 3 else 0.0
    det_z = dx * dx + dy * dy + 2.0 * (c1 * c1 + c2 * c2 + inner * inner + wedge * wedge)
    l1 = det_z / l2 if l2 > 0.0 else 0.0
    w1 = z1 / nz if nz > 0.0 else 0.0
    w2 = z2 / nz if nz > 0.0 else 0.0
    a1 = np.sqrt(l1) if l1 > 0.0 else 0.0
    a2 = np.sqrt(l2) if l2 > 0.0 else 0.0
    s0 = 0.5 * (a1 + a2)
    h = 0.5 * (a2 - a1)
    s1 = h * w1
    s2 = h * w2
    f = t if scale else 1.0
    phi[0] = (x[0] + y[0] - s0) * f
    phi[1] = (x[1] + y[1] - s1) * f
    if d == 3:
        phi[2] = (x[2] + y[2] - s2) * f
    if l1 > FB_DEGENERATE * l2:
        det = a1 * a2
        # L_s⁻¹ = [[s0, −s̄ᵀ], [−s̄, (det/s0) I + s̄ s̄ᵀ/s0]] / det, times the arrow matrices
        sb = (s1, s2)
        for a in range(d):
            for c in range(d):
                mx = 0.0
                my = 0.0
                for b in range(d):
                    if a == 0 and b == 0:
                        li = s0
                    elif a == 0 or b == 0:
                        li = -sb[a + b - 1]
                    else:
                        li = (det / s0 if a == b else 0.0) + sb[a - 1] * sb[b - 1] / s0
                    # arrow matrices: L_x[b, c]
                    if b == 0 and c == 0:
                        lx = x[0]
                        ly = y[0]
                    elif b == 0 or c == 0:
                        lx = x[b + c]
                        ly = y[b + c]
                    else:
                        lx = x[0] if b == c else 0.0
                        ly = y[0] if b == c else 0.0
                    mx += li * lx
                    my += li * ly
                Mx[a, c] = mx / det
                My[a, c] = my / det
        return False
    if not l2 > 0.0:
        for a in range(d):
            for c in range(d):
                Mx[a, c] = _K if a == c else 0.0
                My[a, c] = _K if a == c else 0.0
        return True
    n = np.sqrt(x[0] * x[0] + y[0] * y[0])
    al = x[0] / n if n > 0.0 else _K
    be = y[0] / n if n > 0.0 else _K
    q = (_K, -_K * w1, -_K * w2)
    for a in range(d):
        for c in range(d):
            e = 1.0 if a == c else 0.0
            Mx[a, c] = al * e + (_K - al) * q[a] * q[c]
            My[a, c] = be * e + (_K - be) * q[a] * q[c]
    return True


@njit(cache=True)
def fb_blocks(r, u, mu, rho_n, rho_t, d, want_jac, F, Dr, Du, branch):
    """Fischer–Burmeister ``F`` and generalized-Jacobian blocks for every contact.

    Same arguments and return value as :func:`~.newton_ac.ac_blocks` (``rho_t`` not read):
    ``||F||``; ``F`` (m,) written, and with ``want_jac`` ``Dr``, ``Du`` (nc, d, d) and
    ``branch`` (nc,).
    """
    nc = mu.shape[0]
    x = np.zeros(3)
    y = np.zeros(3)
    phi = np.zeros(3)
    Mx = np.zeros((3, 3))
    My = np.zeros((3, 3))
    s = 0.0
    for i in range(nc):
        o = i * d
        p = rho_n[i]
        m_ = mu[i]
        if m_ == 0.0:
            a = r[o]
            b = p * u[o]
            n = np.hypot(a, b)
            F[o] = a + b - n
            for c in range(1, d):
                F[o + c] = r[o + c]
            if want_jac:
                for a_ in range(d):
                    for c in range(d):
                        Dr[i, a_, c] = 1.0 if a_ == c else 0.0
                        Du[i, a_, c] = 0.0
                if n > 0.0:
                    Dr[i, 0, 0] = 1.0 - a / n
                    Du[i, 0, 0] = p * (1.0 - b / n)
                    branch[i] = 0
                else:
                    Dr[i, 0, 0] = 1.0 - _K
                    Du[i, 0, 0] = p * (1.0 - _K)
                    branch[i] = 1
        else:
            u1 = u[o + 1]
            u2 = u[o + 2] if d == 3 else 0.0
            tu = tangential_norm(u1, u2, d)
            x[0] = m_ * r[o]
            y[0] = p * (u[o] + m_ * tu)
            for c in range(1, d):
                x[c] = r[o + c]
                y[c] = p * m_ * u[o + c]
            degenerate = lorentz_fb(x, y, d, phi, Mx, My)
            for c in range(d):
                F[o + c] = phi[c]
            if want_jac:
                for a_ in range(d):
                    ga0 = (1.0 if a_ == 0 else 0.0) - My[a_, 0]
                    Dr[i, a_, 0] = ((1.0 if a_ == 0 else 0.0) - Mx[a_, 0]) * m_
                    Du[i, a_, 0] = p * ga0
                    for c in range(1, d):
                        Dr[i, a_, c] = (1.0 if a_ == c else 0.0) - Mx[a_, c]
                        wc = 0.0
                        if tu > 0.0:
                            wc = (u1 if c == 1 else u2) / tu
                        gac = (1.0 if a_ == c else 0.0) - My[a_, c]
                        Du[i, a_, c] = p * (m_ * gac + ga0 * m_ * wc)
                branch[i] = 1 if degenerate else 0
        for c in range(d):
            s += F[o + c] * F[o + c]
    return np.sqrt(s)


__all__ = ["fb_blocks", "lorentz_fb", "FB_DEGENERATE"]

"""Coulomb cones, their duals, projections and the convex-analysis certificates.

All functions act on *stacked* contact vectors (length ``dim * n_contacts``,
normal first) or on ``(n_contacts, dim)`` arrays, and are vectorized over
contacts.  They are the readable reference of the compiled kernels in
:mod:`socp_cd.solvers.kernels.cone` (``tests/test_kernels.py`` holds them equal).

Definitions
-----------
Coulomb cone          ``K_mu  = {(x_N, x_T) : ||x_T|| <= mu x_N}``
Dual cone             ``K*_mu = {(y_N, y_T) : mu ||y_T|| <= y_N} = K_{1/mu}``
                      (``mu = 0``: ``K_0`` is the half-line ``x_T = 0, x_N >= 0``
                      and ``K*_0`` the half-space ``y_N >= 0``).
Polar cone            ``K°_mu = -K*_mu``.
De Saxcé velocity     ``û = u + mu ||u_T|| e_N``.
Coulomb law           ``K*_mu ∋ û ⊥ r ∈ K_mu``  (Signorini + Coulomb, velocity level)
Natural map           ``F(r) = r - P_K(r - rho û)``; zero iff the law holds.
Bipotential           ``b(-u, r) = I_{u_N >= 0}(u) + I_{K_mu}(r) + mu r_N ||u_T||``
                      (De Saxcé).  ``b(-u, r) >= -u·r`` for all pairs, with
                      equality exactly at the law, so the Fenchel–Young gap
                      ``b(-u, r) + u·r = r·û`` (on feasible pairs) certifies a
                      solution contact by contact.
"""
from __future__ import annotations

from enum import IntEnum

import numpy as np


def _blocks(x, dim: int) -> np.ndarray:
    """Reshape a stacked vector (or pass an array) to ``(n_contacts, dim)``."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        return a.reshape(-1, dim)
    return a


def _restore(out: np.ndarray, like) -> np.ndarray:
    return out.reshape(-1) if np.ndim(like) == 1 else out


def project_cone(x, mu, dim: int = 3) -> np.ndarray:
    """Euclidean projection onto the Coulomb cone ``K_mu`` (closed form).

    Parameters
    ----------
    x : array_like
        Stacked vector (length ``dim * nc``) or ``(nc, dim)`` array.
    mu : float or array_like, shape (nc,)
        Friction coefficients, ``>= 0``.
    dim : {2, 3}

    Returns
    -------
    ndarray
        ``P_K(x)`` with the layout of ``x``.

    Notes
    -----
    With ``t = ||x_T||``: if ``t <= mu x_N`` then ``x`` is in the cone; if
    ``mu t <= -x_N`` it is in the polar cone and projects to 0; otherwise it
    projects onto the boundary ray through ``x_T``:
    ``p_N = (x_N + mu t) / (1 + mu^2)``, ``p_T = mu p_N x_T / t``.
    In 2D ``K_mu`` is the wedge ``|x_T| <= mu x_N`` and the formulas coincide.
    """
    X = _blocks(x, dim)
    mu = np.asarray(mu, dtype=np.float64)
    xn = X[:, 0]
    xt = X[:, 1:]
    t = np.sqrt(np.einsum("ij,ij->i", xt, xt)) if dim == 3 else np.abs(xt[:, 0])
    # boundary ray (side region; there t > 0: t = 0 is inside or polar)
    pn = (xn + mu * t) / (1.0 + mu * mu)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale_t = np.where(t > 0.0, mu * pn / t, 0.0)
    polar = mu * t <= -xn
    inside = (t <= mu * xn) & ~polar
    out = np.empty_like(X)
    out[:, 0] = np.where(inside, xn, np.where(polar, 0.0, pn))
    out[:, 1:] = np.where(inside[:, None], xt, np.where(polar, 0.0, scale_t)[:, None] * xt)
    return _restore(out, x)


def project_cone_jacobian(x, mu, dim: int = 3) -> np.ndarray:
    """One element of the generalized Jacobian of :func:`project_cone`, per contact.

    Parameters
    ----------
    x : array_like
        Stacked vector (length ``dim * nc``) or ``(nc, dim)`` array.
    mu : float or array_like, shape (nc,)
    dim : {2, 3}

    Returns
    -------
    ndarray, shape (nc, dim, dim)
        ``0`` on the polar cone, ``I`` inside the cone, and on the side region,
        with ``t = ||x_T||``, ``w = x_T / t``, ``a = 1 / (1 + mu²)``,
        ``p_N = a (x_N + mu t)``:
        ``[[a, mu a wᵀ], [mu a w, mu² a w wᵀ + (mu p_N / t)(I - w wᵀ)]]``.
    """
    X = _blocks(x, dim)
    nc = X.shape[0]
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (nc,))
    xn, xt = X[:, 0], X[:, 1:]
    t = np.sqrt(np.einsum("ij,ij->i", xt, xt))
    J = np.zeros((nc, dim, dim))
    polar = mu * t <= -xn
    inside = (t <= mu * xn) & ~polar
    side = ~(polar | inside)
    J[inside] = np.eye(dim)
    if np.any(side):
        m_, ts = mu[side], t[side]
        w = xt[side] / ts[:, None]
        a = 1.0 / (1.0 + m_ ** 2)
        pn = (xn[side] + m_ * ts) * a
        Js = np.zeros((len(ts), dim, dim))
        Js[:, 0, 0] = a
        Js[:, 0, 1:] = (m_ * a)[:, None] * w
        Js[:, 1:, 0] = (m_ * a)[:, None] * w
        ww = np.einsum("ki,kj->kij", w, w)
        eye = np.eye(dim - 1)[None]
        Js[:, 1:, 1:] = (m_ ** 2 * a)[:, None, None] * ww + (m_ * pn / ts)[:, None, None] * (eye - ww)
        J[side] = Js
    return J


def project_dual_cone(y, mu, dim: int = 3) -> np.ndarray:
    """Projection onto the dual cone ``K*_mu = K_{1/mu}``.

    ``mu = 0`` gives the half-space ``y_N >= 0`` (projection clips ``y_N``).
    """
    Y = _blocks(y, dim)
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (Y.shape[0],))
    zero = mu == 0.0
    out = np.empty_like(Y)
    if np.any(~zero):
        out[~zero] = project_cone(Y[~zero], 1.0 / mu[~zero], dim)
    if np.any(zero):
        out[zero] = Y[zero]
        out[zero, 0] = np.maximum(Y[zero, 0], 0.0)
    return _restore(out, y)


def tangential_norm(x, dim: int = 3) -> np.ndarray:
    """``||x_T||`` per contact."""
    X = _blocks(x, dim)
    return np.sqrt(np.einsum("ij,ij->i", X[:, 1:], X[:, 1:]))


def desaxce_velocity(u, mu, dim: int = 3) -> np.ndarray:
    """De Saxcé modified velocity ``û = u + mu ||u_T|| e_N``."""
    U = _blocks(u, dim)
    out = U.copy()
    out[:, 0] += np.asarray(mu, dtype=np.float64) * tangential_norm(U, dim)
    return _restore(out, u)


def desaxce_velocity_jacobian(u, mu, dim: int = 3) -> np.ndarray:
    """One element of the generalized Jacobian of :func:`desaxce_velocity`, per contact.

    ``D = I + mu e_N wᵀ`` with ``w = u_T / ||u_T||``, and ``w = 0`` when ``u_T = 0`` (an
    element of the norm's subdifferential there); shape ``(nc, dim, dim)``.
    """
    U = _blocks(u, dim)
    nc = U.shape[0]
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (nc,))
    tu = tangential_norm(U, dim)
    w = np.zeros((nc, dim - 1))
    moving = tu > 0
    w[moving] = U[moving, 1:] / tu[moving, None]
    D = np.repeat(np.eye(dim)[None], nc, axis=0)
    D[:, 0, 1:] += mu[:, None] * w
    return D


def natural_map(r, u, mu, dim: int = 3, rho: float = 1.0) -> np.ndarray:
    """Natural map ``F(r) = r - P_K(r - rho û)`` (zero iff the Coulomb law holds)."""
    R = _blocks(r, dim)
    x = R - rho * desaxce_velocity(_blocks(u, dim), mu, dim)
    return _restore(R - project_cone(x, mu, dim), r)


def natural_map_jacobian(r, u, mu, dim: int = 3, rho=1.0):
    """The natural map and one element of its generalized Jacobian, per contact.

    With ``x = r - rho û`` and ``û = u + mu ||u_T|| e_N``, ``F = r - P_K(x)`` and
    ``dF = Dr dr + Du du`` with ``Dr = I - P``, ``Du = rho P D``, ``P`` the projection's
    Jacobian at ``x`` (:func:`project_cone_jacobian`) and ``D`` the De Saxcé velocity's
    (:func:`desaxce_velocity_jacobian`).  The Newton matrix of ``F(r, W r + q) = 0`` is
    ``Dr + Du W`` (``formulations/newton.md`` §13; the NumPy reference of the compiled
    :func:`socp_cd.solvers.kernels.newton_nm.nm_blocks`).

    Parameters
    ----------
    r, u : array_like
        Stacked impulses and velocities (or ``(nc, dim)`` arrays).
    mu : float or array_like, shape (nc,)
    dim : {2, 3}
    rho : float or array_like, shape (nc,)
        One positive parameter per contact.

    Returns
    -------
    F : ndarray, shape (dim * nc,)
    Dr, Du : ndarray, shape (nc, dim, dim)
    branch : ndarray of int64, shape (nc,)
        ``0`` when ``x`` lies on the polar cone (``r`` projected to 0: separated),
        ``2`` inside ``K`` (sticking), ``3`` projected on the cone's surface (sliding):
        the Alart–Curnier kernel's codes of sticking and sliding (it codes a separated
        contact 0 or 1).
    """
    R = _blocks(r, dim)
    U = _blocks(u, dim)
    nc = R.shape[0]
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (nc,))
    rho = np.broadcast_to(np.asarray(rho, dtype=np.float64), (nc,))
    X = R - rho[:, None] * desaxce_velocity(U, mu, dim)
    F = R - project_cone(X, mu, dim)
    P = project_cone_jacobian(X, mu, dim)
    D = desaxce_velocity_jacobian(U, mu, dim)
    Dr = np.eye(dim)[None] - P
    Du = rho[:, None, None] * np.einsum("kij,kjl->kil", P, D)
    xt = tangential_norm(X, dim)
    branch = np.where(mu * xt <= -X[:, 0], 0, np.where(xt <= mu * X[:, 0], 2, 3))
    return F.reshape(-1), Dr, Du, branch.astype(np.int64)


#: the Fischer–Burmeister map's degenerate set (:func:`fischer_burmeister_jacobian`): a block
#: whose ``z = x² + y²`` has ``λ₁(z) <= FB_DEGENERATE λ₂(z)`` takes the closed-form limit
#: element there (the compiled kernel's ``newton_fb.FB_DEGENERATE``, held equal by the tests).
#: ``λ₁/λ₂ ~ δ²/2`` at a relative distance ``δ`` from that set, and the derivative's rounding
#: error is ``~eps (λ₂/λ₁)^{1/2}``: 1e-20 takes the limit element within ``δ ~ 1e-10`` only,
#: where the derivative would carry ~1e-6 of error (1e-10, ``δ ~ 1e-5``, made Newton linear
#: with rate ~0.7 near grazing solutions: ``formulations/newton.md`` §14)
FB_DEGENERATE = 1e-20


def fb_determinant(x, y):
    """``det(x² + y²) = λ₁ λ₂`` as a sum of squares, accurate where ``λ₁ = z₀ − ||z̄||``
    cancels (the degenerate set, where it is 0): ``(x₀² − ||x̄||²)² + (y₀² − ||ȳ||²)²
    + 2 (||x₀ȳ − y₀x̄||² + (x₀y₀ − x̄ᵀȳ)² + ||x̄||²||ȳ||² − (x̄ᵀȳ)²)``, the last two terms
    ``||x̄ × ȳ||²`` in 3D and 0 in 2D."""
    nx, ny = float(np.linalg.norm(x[1:])), float(np.linalg.norm(y[1:]))
    dx = (x[0] - nx) * (x[0] + nx)
    dy = (y[0] - ny) * (y[0] + ny)
    cross = float(np.sum((x[0] * y[1:] - y[0] * x[1:]) ** 2))
    inner = x[0] * y[0] - float(x[1:] @ y[1:])
    wedge = (x[1] * y[2] - x[2] * y[1]) ** 2 if x.shape[0] == 3 else 0.0
    return dx * dx + dy * dy + 2.0 * (cross + inner * inner + wedge)


def _arrow(x):
    """The arrow matrix ``L_x`` of the Jordan product on the Lorentz cone (``L_x y = x ∘ y``)."""
    L = np.eye(x.shape[0]) * x[0]
    L[0, 1:] = x[1:]
    L[1:, 0] = x[1:]
    return L


def lorentz_fb(x, y):
    """Fischer–Burmeister function of the Lorentz cone ``L = {||x̄|| <= x₀}`` for one block.

    ``φ(x, y) = x + y − (x² + y²)^{1/2}`` in the cone's Jordan algebra
    (``x ∘ y = (xᵀy, x₀ȳ + y₀x̄)``); ``φ = 0`` ⇔ ``x ∈ L, y ∈ L, xᵀy = 0``.  Returns
    ``(φ, Mx, My, degenerate)`` with ``dφ = (I − Mx) dx + (I − My) dy`` one element of the
    generalized Jacobian:

    * ``z = x² + y²`` inside ``L`` (``λ₁(z) > FB_DEGENERATE λ₂(z)``): the derivative,
      ``Mx = L_s⁻¹ L_x``, ``My = L_s⁻¹ L_y``, ``s = z^{1/2}``;
    * ``z`` on the boundary of ``L``, ``z ≠ 0``: then ``x = x₀ c``, ``y = y₀ c`` on one ray
      ``c = (1, w)``, ``w = z̄/||z̄||``, and the limit of the derivative along
      ``(x + τe, y + τe)``, ``τ → 0⁺``: ``Mx = α I + (1/√2 − α) q qᵀ``, ``α = x₀/||(x₀, y₀)||``,
      ``q = (1, −w)/√2`` (``My`` with ``β = y₀/||(x₀, y₀)||``), so an element of the
      B-subdifferential (``formulations/newton.md`` §14);
    * ``z = 0`` (``x = y = 0``): the same limit, ``Mx = My = I/√2``.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    d = x.shape[0]
    # φ is positively homogeneous of degree 1 and Mx, My of degree 0: work on (x, y) / t
    # (det(z) grows as |x|⁴: no overflow above 1e77 nor underflow below 1e-81)
    t = float(max(np.abs(x).max(), np.abs(y).max()))
    if t > 0.0 and np.isfinite(t):
        phi, Mx, My, degenerate = _lorentz_fb(x / t, y / t)
        return phi * t, Mx, My, degenerate
    return _lorentz_fb(x, y)


def _lorentz_fb(x, y):
    """:func:`lorentz_fb` on a pair of unit scale (or all zero / not finite)."""
    d = x.shape[0]
    z = np.r_[x @ x + y @ y, 2.0 * (x[0] * x[1:] + y[0] * y[1:])]
    nz = float(np.linalg.norm(z[1:]))
    l2 = z[0] + nz
    l1 = fb_determinant(x, y) / l2 if l2 > 0 else 0.0
    w = z[1:] / nz if nz > 0 else np.zeros(d - 1)
    a1, a2 = np.sqrt(max(l1, 0.0)), np.sqrt(max(l2, 0.0))
    s = np.r_[(a1 + a2) / 2, (a2 - a1) / 2 * w]
    phi = x + y - s
    if l1 > FB_DEGENERATE * l2:
        det = a1 * a2
        Li = np.empty((d, d))
        Li[0, 0] = s[0]
        Li[0, 1:] = -s[1:]
        Li[1:, 0] = -s[1:]
        Li[1:, 1:] = (det / s[0]) * np.eye(d - 1) + np.outer(s[1:], s[1:]) / s[0]
        Li /= det
        return phi, Li @ _arrow(x), Li @ _arrow(y), False
    k = 1.0 / np.sqrt(2.0)
    if not l2 > 0.0:
        return phi, k * np.eye(d), k * np.eye(d), True
    q = np.r_[1.0, -w] * k
    n = float(np.hypot(x[0], y[0]))
    al, be = (x[0] / n, y[0] / n) if n > 0 else (k, k)
    P = np.outer(q, q)
    return phi, al * np.eye(d) + (k - al) * P, be * np.eye(d) + (k - be) * P, True


def fischer_burmeister_jacobian(r, u, mu, dim: int = 3, rho=1.0):
    """The Fischer–Burmeister equation of the Coulomb law and its Jacobian blocks, per contact.

    With ``û = u + mu ||u_T|| e_N``, the pair ``x = (mu r_N, r_T)``, ``y = rho (û_N, mu û_T)``
    maps ``r ∈ K_mu`` to ``x ∈ L``, ``û ∈ K*_mu`` to ``y ∈ L`` and ``r·û`` to a positive
    multiple of ``xᵀy``, so ``F = φ(x, y) = 0`` (:func:`lorentz_fb`) is the law.  For
    ``mu = 0`` (``K_0`` a half-line, not a Lorentz cone) the block is the scalar
    Fischer–Burmeister function of ``0 <= r_N ⊥ rho u_N >= 0`` and ``F_T = r_T``.  Blocks
    ``dF = Dr dr + Du du``: ``Dr = (I − Mx) S_r``, ``Du = rho (I − My) S_u D`` with
    ``S_r = diag(mu, 1, 1)``, ``S_u = diag(1, mu, mu)``, ``D`` the De Saxcé velocity's
    Jacobian (:func:`desaxce_velocity_jacobian`); the NumPy reference of the compiled
    :func:`socp_cd.solvers.kernels.newton_fb.fb_blocks` (``formulations/newton.md`` §14).

    Returns
    -------
    F : ndarray, shape (dim * nc,)
    Dr, Du : ndarray, shape (nc, dim, dim)
    branch : ndarray of int64, shape (nc,)
        ``1`` on the degenerate set (the map's kinks, grazing states), else ``0``.
    """
    R = _blocks(r, dim)
    U = _blocks(u, dim)
    nc = R.shape[0]
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (nc,))
    rho = np.broadcast_to(np.asarray(rho, dtype=np.float64), (nc,))
    Uh = desaxce_velocity(U, mu, dim)
    DUh = desaxce_velocity_jacobian(U, mu, dim)
    F = np.zeros((nc, dim))
    Dr = np.zeros((nc, dim, dim))
    Du = np.zeros((nc, dim, dim))
    branch = np.zeros(nc, dtype=np.int64)
    eye = np.eye(dim)
    for i in range(nc):
        m, p = mu[i], rho[i]
        if m == 0.0:
            a, b = R[i, 0], p * U[i, 0]
            n = float(np.hypot(a, b))
            F[i, 0] = a + b - n
            F[i, 1:] = R[i, 1:]
            ga, gb = (1.0 - a / n, 1.0 - b / n) if n > 0 else (1.0 - 1.0 / np.sqrt(2.0),) * 2
            Dr[i] = eye
            Dr[i, 0, 0] = ga
            Du[i, 0, 0] = p * gb
            branch[i] = 0 if n > 0 else 1
            continue
        Sr = np.diag(np.r_[m, np.ones(dim - 1)])
        Su = np.diag(np.r_[1.0, np.full(dim - 1, m)])
        x = Sr @ R[i]
        y = p * (Su @ Uh[i])
        phi, Mx, My, degenerate = lorentz_fb(x, y)
        F[i] = phi
        Dr[i] = (eye - Mx) @ Sr
        Du[i] = p * (eye - My) @ Su @ DUh[i]
        branch[i] = int(degenerate)
    return F.reshape(-1), Dr, Du, branch


def in_cone_violation(r, mu, dim: int = 3) -> np.ndarray:
    """Distance from ``r`` to ``K_mu`` per contact (0 when feasible)."""
    R = _blocks(r, dim)
    D = R - project_cone(R, mu, dim)
    return np.sqrt(np.einsum("ij,ij->i", D, D))


def fenchel_young_gap(r, u, mu, dim: int = 3) -> np.ndarray:
    """Fenchel–Young (bipotential) gap per contact, ``r·û = u·r + mu r_N ||u_T||``.

    For a feasible pair (``r ∈ K_mu`` and ``u_N >= 0``, i.e. ``û ∈ K*_mu``) it is
    ``b(-u, r) + u·r >= 0`` and vanishes exactly when the pair obeys the
    Coulomb–Signorini law; check feasibility separately with
    :func:`in_cone_violation` and :func:`normal_velocity_violation`.
    """
    R = _blocks(r, dim)
    Uh = desaxce_velocity(_blocks(u, dim), mu, dim)
    return np.einsum("ij,ij->i", R, Uh)


def bipotential(u, r, mu, dim: int = 3, feas_tol: float | None = None) -> np.ndarray:
    """De Saxcé's bipotential ``b(-u, r)`` per contact (``+inf`` off its domain).

    Domain: ``r ∈ K_mu`` and ``u_N >= 0`` up to ``feas_tol`` (default: 1e-13
    times the largest entry of ``r``/``u``, so round-off from a projection does
    not count as infeasible; pass 0.0 for the exact domain).
    """
    R = _blocks(r, dim)
    U = _blocks(u, dim)
    if feas_tol is None:
        feas_tol = 1e-13 * max(float(np.max(np.abs(R), initial=0.0)), float(np.max(np.abs(U), initial=0.0)))
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (R.shape[0],))
    val = mu * R[:, 0] * tangential_norm(U, dim)
    bad = (in_cone_violation(R, mu, dim) > feas_tol) | (U[:, 0] < -feas_tol)
    return np.where(bad, np.inf, val)


def normal_velocity_violation(u, dim: int = 3) -> np.ndarray:
    """``max(0, -u_N)`` per contact: violation of ``û ∈ K*_mu`` (⇔ ``u_N >= 0``)."""
    U = _blocks(u, dim)
    return np.maximum(-U[:, 0], 0.0)


class ContactStatus(IntEnum):
    """Classification of a contact at a (near-)solution."""

    SEPARATED = 0  #: r = 0, û ≠ 0 (taking off, open gap velocity)
    STICKING = 1   #: r_N > 0, u = 0 (r anywhere in K_mu)
    SLIDING = 2    #: r on the boundary of K_mu, u_T ≠ 0 opposite r_T
    GRAZING = 3    #: r = 0 and û = 0 at once (degenerate complementarity)


def classify_contacts(r, u, mu, dim: int = 3, tol: float = 1e-8) -> np.ndarray:
    """Classify every contact as separated, sticking, sliding or grazing.

    Parameters
    ----------
    r, u : array_like
        Impulses and velocities (stacked or ``(nc, dim)``).
    mu : float or array_like
    dim : {2, 3}
    tol : float
        Relative threshold: an impulse counts as zero below
        ``tol * max(1, max|r|)`` and a velocity below ``tol * max(1, max|u|)``.

    Returns
    -------
    ndarray of ContactStatus values, shape (nc,)
    """
    R = _blocks(r, dim)
    U = _blocks(u, dim)
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (R.shape[0],))
    tr = tol * max(1.0, float(np.max(np.abs(R))) if R.size else 1.0)
    tu = tol * max(1.0, float(np.max(np.abs(U))) if U.size else 1.0)
    Uh = desaxce_velocity(U, mu, dim)
    r_zero = np.sqrt(np.einsum("ij,ij->i", R, R)) <= tr
    uh_zero = np.sqrt(np.einsum("ij,ij->i", Uh, Uh)) <= tu
    ut_zero = tangential_norm(U, dim) <= tu
    out = np.full(R.shape[0], ContactStatus.SLIDING, dtype=np.int8)
    out[~r_zero & ut_zero] = ContactStatus.STICKING
    out[r_zero] = ContactStatus.SEPARATED
    out[r_zero & uh_zero] = ContactStatus.GRAZING
    return out


__all__ = [
    "project_cone",
    "project_cone_jacobian",
    "project_dual_cone",
    "tangential_norm",
    "desaxce_velocity",
    "desaxce_velocity_jacobian",
    "natural_map",
    "natural_map_jacobian",
    "lorentz_fb",
    "fb_determinant",
    "fischer_burmeister_jacobian",
    "FB_DEGENERATE",
    "in_cone_violation",
    "fenchel_young_gap",
    "bipotential",
    "normal_velocity_violation",
    "ContactStatus",
    "classify_contacts",
]

"""Alart–Curnier function, its generalized Jacobian and the error (numba kernels).

Used by :mod:`socp_cd.solvers.newton` (see ``formulations/newton.md``).  For
every contact ``i`` with impulse ``r_i``, velocity ``u_i`` and parameters
``rho_N, rho_T > 0`` (normal and tangential; equal for a scalar strategy)::

    a_N = r_N - rho_N u_N,                R = mu max(0, a_N)
    x_T = r_T - rho_T u_T
    F_N = r_N - max(0, a_N)
    F_T = r_T - P_{B(0, R)}(x_T)

``F(r, u) = 0`` with ``u = W r + q`` is exactly the Coulomb law with
Signorini's condition.  The kernels return ``F`` and one element of its
generalized Jacobian split as ``dF_i = Dr_i dr_i + Du_i du_i`` (two
``d x d`` blocks per contact), so that the local Newton matrix is
``Dr + Du W`` and the global one keeps ``H`` and ``M`` sparse.

:func:`ac_blocks_reference` is the NumPy reference of :func:`ac_blocks`
(tested equal).
"""
from __future__ import annotations

import numpy as np
from numba import njit

#: branch codes returned per contact by :func:`ac_blocks` (normal * 2 + tangential)
NORMAL_OPEN, NORMAL_ACTIVE = 0, 1          # a_N <= 0 (separated) / a_N > 0 (in contact)
TANGENT_STICK, TANGENT_SLIDE = 0, 1        # ||x_T|| <= R / ||x_T|| > R


@njit(cache=True)
def ac_blocks(r, u, mu, rho_n, rho_t, d, want_jac, F, Dr, Du, branch):
    """Alart–Curnier ``F`` and generalized-Jacobian blocks for every contact.

    Parameters
    ----------
    r, u : ndarray (m,)
        Impulses and velocities (``u`` already includes any proximal term).
    mu : ndarray (nc,)
        Friction coefficients.
    rho_n, rho_t : ndarray (nc,)
        Normal and tangential Alart–Curnier parameters (the same array twice for
        a scalar parameter per contact).
    d : int
        2 or 3.
    want_jac : bool
        Fill ``Dr``, ``Du`` (nc, d, d) and ``branch`` (nc,) too.
    F : ndarray (m,)
        Output.

    Returns
    -------
    float
        ``||F||``.
    """
    nc = mu.shape[0]
    s = 0.0
    for i in range(nc):
        o = i * d
        p = rho_n[i]
        pt = rho_t[i]
        a_n = r[o] - p * u[o]
        active = a_n > 0.0
        if want_jac:
            for a in range(d):
                for c in range(d):
                    Dr[i, a, c] = 0.0
                    Du[i, a, c] = 0.0
        if active:
            F[o] = p * u[o]
            if want_jac:
                Du[i, 0, 0] = p
        else:
            F[o] = r[o]
            if want_jac:
                Dr[i, 0, 0] = 1.0
        R = mu[i] * a_n if active else 0.0
        x1 = r[o + 1] - pt * u[o + 1]
        x2 = r[o + 2] - pt * u[o + 2] if d == 3 else 0.0
        t = np.sqrt(x1 * x1 + x2 * x2)
        if t <= R:
            F[o + 1] = pt * u[o + 1]
            if d == 3:
                F[o + 2] = pt * u[o + 2]
            if want_jac:
                for a in range(1, d):
                    Du[i, a, a] = pt
                branch[i] = (NORMAL_ACTIVE if active else NORMAL_OPEN) * 2 + TANGENT_STICK
        else:
            if t > 0.0:
                n1 = x1 / t
                n2 = x2 / t
            else:
                # (t = 0 > R fails for every R >= 0: R is NaN, mu * a_n = 0 * inf on a
                # runaway iterate; the NaN goes on into F, where numba's division by zero
                # would raise)
                n1 = n2 = 0.0
            F[o + 1] = r[o + 1] - R * n1
            if d == 3:
                F[o + 2] = r[o + 2] - R * n2
            if want_jac:
                k = R / t if t > 0.0 else R
                # d P_B(x)/dx = k (I - n n^T); dx = dr_T - rho_T du_T; dR = mu (dr_N - rho_N du_N)
                for a in range(1, d):
                    na = n1 if a == 1 else n2
                    for c in range(1, d):
                        nc_ = n1 if c == 1 else n2
                        proj = k * ((1.0 if a == c else 0.0) - na * nc_)
                        Dr[i, a, c] = (1.0 if a == c else 0.0) - proj
                        Du[i, a, c] = pt * proj
                    if active:
                        Dr[i, a, 0] = -mu[i] * na
                        Du[i, a, 0] = mu[i] * p * na
                branch[i] = (NORMAL_ACTIVE if active else NORMAL_OPEN) * 2 + TANGENT_SLIDE
        for a in range(d):
            s += F[o + a] * F[o + a]
    return np.sqrt(s)


@njit(cache=True)
def dense_jacobian(Dr, Du, W, alpha, d, J):
    """``J = Dr + Du (W + alpha I)`` for a dense ``W`` (block-diagonal ``Dr``, ``Du``).

    Row by row: row ``o + a`` of ``Du W`` is ``sum_b Du[i, a, b] W[o + b, :]``, summed in
    ``b``'s order from 0 (the same operations, in the same order, as the entry-by-entry
    dot products: bit for bit the same, signed zeros included, NaN entries at the same places
    with their sign or payload possibly another), with unsigned loop bounds over the
    contiguous rows, which LLVM vectorizes (a 42 x 42 Jacobian 4.8 -> 1.2 µs, 3D;
    formulations/newton.md §11).
    """
    nc = Dr.shape[0]
    um = np.uint64(W.shape[1])
    for i in range(nc):
        o = i * d
        for a in range(d):
            row = J[o + a]
            f = Du[i, a, 0]
            w = W[o]
            for c in range(um):
                row[c] = 0.0 + f * w[c]
            for b in range(1, d):
                f = Du[i, a, b]
                w = W[o + b]
                for c in range(um):
                    row[c] += f * w[c]
            for c in range(d):
                J[o + a, o + c] += Dr[i, a, c] + alpha * Du[i, a, c]


@njit(cache=True)
def block_jacobian(Dr, Du, bptr, bcol, blocks, alpha, out):
    """``J = Dr + Du (W + alpha I)`` block by block, for ``W`` in block-sparse rows.

    The sparse twin of :func:`dense_jacobian`: ``W``'s ``d x d`` blocks
    ``blocks[p]`` (block row ``i``: ``p`` in ``bptr[i]:bptr[i+1]``, block column
    ``bcol[p]``, every diagonal block stored) give ``J``'s blocks on the same
    pattern, ``out[p] = Du_i W_ip`` plus ``Dr_i + alpha Du_i`` on the diagonal.
    """
    nc = Dr.shape[0]
    d = Dr.shape[1]
    for i in range(nc):
        for p in range(bptr[i], bptr[i + 1]):
            for a in range(d):
                for c in range(d):
                    s = 0.0
                    for b in range(d):
                        s += Du[i, a, b] * blocks[p, b, c]
                    if bcol[p] == i:
                        s += Dr[i, a, c] + alpha * Du[i, a, c]
                    out[p, a, c] = s


@njit(cache=True)
def block_rho_dense(W, d, rho):
    """Alart–Curnier parameters ``rho_i = 1 / s_i`` of a dense ``W`` (strategy "block").

    ``s_i = ||W_ii||_F / sqrt(d)`` (the diagonal block of contact ``i``),
    floored at ``1e-8 ref``; ``ref = mean s_i`` (1 when it is not finite and
    positive) is returned, ``rho`` (nc,) is written.  The compiled twin of
    :func:`socp_cd.solvers.newton._rho` with ``strategy="block"``.
    """
    nc = rho.shape[0]
    total = 0.0
    for i in range(nc):
        o = i * d
        s2 = 0.0
        for a in range(d):
            for c in range(d):
                w = W[o + a, o + c]
                s2 += w * w
        rho[i] = np.sqrt(s2 / d)            # the scale s_i, inverted below
        total += rho[i]
    ref = total / nc if nc > 0 else 1.0
    if not np.isfinite(ref) or ref <= 0.0:
        ref = 1.0
    floor = 1e-8 * ref
    for i in range(nc):
        s = rho[i]
        rho[i] = 1.0 / (s if (s > floor or np.isnan(s)) else floor)
    return ref


def ac_blocks_reference(r, u, mu, rho_n, rho_t, d):
    """NumPy reference of :func:`ac_blocks`: returns ``F, Dr, Du, branch``."""
    r = np.asarray(r, float).reshape(-1, d)
    u = np.asarray(u, float).reshape(-1, d)
    mu = np.asarray(mu, float)
    rho_n = np.asarray(rho_n, float)
    rho_t = np.asarray(rho_t, float)
    nc = r.shape[0]
    eye = np.eye(d - 1)
    F = np.zeros((nc, d))
    Dr = np.zeros((nc, d, d))
    Du = np.zeros((nc, d, d))
    branch = np.zeros(nc, dtype=np.int64)
    a_n = r[:, 0] - rho_n * u[:, 0]
    active = a_n > 0
    R = np.where(active, mu * a_n, 0.0)
    x = r[:, 1:] - rho_t[:, None] * u[:, 1:]
    t = np.linalg.norm(x, axis=1)
    F[:, 0] = np.where(active, rho_n * u[:, 0], r[:, 0])
    Du[active, 0, 0] = rho_n[active]
    Dr[~active, 0, 0] = 1.0
    stick = t <= R
    for i in range(nc):
        if stick[i]:
            F[i, 1:] = rho_t[i] * u[i, 1:]
            Du[i, 1:, 1:] = rho_t[i] * eye
        else:
            n = x[i] / t[i]
            F[i, 1:] = r[i, 1:] - R[i] * n
            proj = (R[i] / t[i]) * (eye - np.outer(n, n))
            Dr[i, 1:, 1:] = eye - proj
            Du[i, 1:, 1:] = rho_t[i] * proj
            if active[i]:
                Dr[i, 1:, 0] = -mu[i] * n
                Du[i, 1:, 0] = mu[i] * rho_n[i] * n
        branch[i] = 2 * int(active[i]) + int(not stick[i])
    return F.reshape(-1), Dr, Du, branch


__all__ = ["ac_blocks", "ac_blocks_reference", "dense_jacobian", "block_jacobian", "block_rho_dense",
           "NORMAL_OPEN", "NORMAL_ACTIVE", "TANGENT_STICK", "TANGENT_SLIDE"]

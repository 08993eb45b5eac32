"""Natural map of the Coulomb law, its generalized Jacobian (numba kernel and NumPy reference).

The second nonsmooth equation of :mod:`socp_cd.solvers.newton` (option
``equation="natural_map"``; ``formulations/newton.md`` §13), the one Siconos' NSN_NM
solves.  For every contact ``i`` with impulse ``r_i``, velocity ``u_i`` and parameter
``rho_i > 0``::

    û = u + mu ||u_T|| e_N                    (De Saxcé's modified velocity)
    x = r - rho û
    F = r - P_K(x)                            (K = {||r_T|| <= mu r_N})

``F = 0`` is the cone complementarity ``K ∋ r ⊥ û ∈ K*``, i.e. the Coulomb law with
Signorini's condition (:func:`socp_cd.cones.natural_map` is the same map with one ``rho``).
One element of the generalized Jacobian, split as ``dF_i = Dr_i dr_i + Du_i du_i`` like the
Alart–Curnier kernels (:mod:`~socp_cd.solvers.kernels.newton_ac`), so that the Newton
matrix is again ``Dr + Du W`` (local) or keeps ``H`` and ``M`` sparse (global)::

    P  = P_K'(x)          (0 on the polar cone, I inside K, the side formula on its surface:
                           kernels.cone.project_cone_jacobian_block)
    D  = I + mu e_N wᵀ    (w = u_T / ||u_T||; w = 0 when u_T = 0, an element of the
                           norm's subdifferential there)
    Dr = I - P
    Du = rho P D

Branch codes per contact: ``x`` on the polar cone (``r`` projected to 0: separated)
``0``; ``x`` inside ``K`` (sticking) ``2``; ``x`` projected on the cone's surface
(sliding) ``3``.  Sticking and sliding are coded as the Alart–Curnier kernel codes them
(``normal * 2 + tangential``); that kernel codes a separated contact 0 or 1 by whether
``r_T - rho_T u_T`` vanishes.

The kernel reads one parameter per contact, ``rho_n``; ``rho_t`` is accepted for the
Alart–Curnier kernel's signature and not read (the solver refuses ``rho="split"`` with
this equation).  Its NumPy reference is :func:`socp_cd.cones.natural_map_jacobian`
(tested equal).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .cone import cone_projection, project_cone_jacobian_block, tangential_norm

#: branch codes of :func:`nm_blocks` (stick and slide: the Alart–Curnier codes)
NM_SEPARATED, NM_STICK, NM_SLIDE = 0, 2, 3


@njit(cache=True)
def nm_blocks(r, u, mu, rho_n, rho_t, d, want_jac, F, Dr, Du, branch):
    """Natural-map ``F`` and generalized-Jacobian blocks for every contact.

    Same arguments and return value as :func:`~.newton_ac.ac_blocks` (``rho_t`` not
    read): ``||F||``; ``F`` (m,) written, and with ``want_jac`` ``Dr``, ``Du``
    (nc, d, d) and ``branch`` (nc,).
    """
    nc = mu.shape[0]
    x = np.zeros(3)
    P = np.zeros((3, 3))
    s = 0.0
    for i in range(nc):
        o = i * d
        p = rho_n[i]
        m_ = mu[i]
        u1 = u[o + 1]
        u2 = u[o + 2] if d == 3 else 0.0
        tu = tangential_norm(u1, u2, d)
        x0 = r[o] - p * (u[o] + m_ * tu)
        x1 = r[o + 1] - p * u1
        x2 = r[o + 2] - p * u2 if d == 3 else 0.0
        p0, p1, p2 = cone_projection(x0, x1, x2, d, m_)
        F[o] = r[o] - p0
        F[o + 1] = r[o + 1] - p1
        if d == 3:
            F[o + 2] = r[o + 2] - p2
        for a in range(d):
            s += F[o + a] * F[o + a]
        if not want_jac:
            continue
        x[0] = x0
        x[1] = x1
        x[2] = x2
        project_cone_jacobian_block(x, d, m_, P)
        xt = tangential_norm(x1, x2, d)
        if m_ * xt <= -x0:
            branch[i] = NM_SEPARATED
        elif xt <= m_ * x0:
            branch[i] = NM_STICK
        else:
            branch[i] = NM_SLIDE
        for a in range(d):
            for c in range(d):
                Dr[i, a, c] = (1.0 if a == c else 0.0) - P[a, c]
            # Du = rho P D, D = I + mu e_N wᵀ: column 0 is rho P[:, 0], column c >= 1 adds
            # rho P[:, 0] mu w_c
            Du[i, a, 0] = p * P[a, 0]
            for c in range(1, d):
                wc = 0.0
                if tu > 0.0:
                    wc = (u1 if c == 1 else u2) / tu
                Du[i, a, c] = p * (P[a, c] + P[a, 0] * m_ * wc)
    return np.sqrt(s)


__all__ = ["nm_blocks", "NM_SEPARATED", "NM_STICK", "NM_SLIDE"]

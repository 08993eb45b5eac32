"""Assembly of one time step's operators: contact frames, ``H``, ``M`` and ``W``.

For contact ``c`` between bodies ``i`` and ``j`` with local frame
``E_c = [e_N; e_T(1); e_T(2)]`` (rows, normal first, ``e_N`` from ``j`` into
``i``), the local relative velocity is

    u_c = E_c (v_i + omega_i x a_i - v_j - omega_j x a_j),   a_b = point - x_b,

i.e. ``u = H^T v`` with ``H`` the (n_dofs × dim·nc) matrix whose block for
body ``i`` is ``[E_c^T ; (a_i x e_k)_k]`` and ``-[E_c^T ; (a_j x e_k)_k]`` for
``j`` (in 2D ``a x e`` is the scalar ``a_x e_y - a_y e_x``).  The generalized
impulse of the contact reactions is ``H r``.

The mass matrix ``M`` is diagonal for disks, polygons (body frame at the
centroid) and spheres, so the Delassus operator ``W = H^T M^{-1} H`` is a
sparse product with a diagonal scaling — no factorization.  3D polyhedra have
a full inertia tensor: ``M`` is block diagonal with the world-frame blocks
``I_w = R I_body Rᵀ`` (:func:`block_inverse_mass`), inverted block by block
(``I_w⁻¹ = R I_body⁻¹ Rᵀ``), still without factorization.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def contact_frames(normal: np.ndarray) -> np.ndarray:
    """Orthonormal local frames, normal first.

    Parameters
    ----------
    normal : (nc, d) unit normals

    Returns
    -------
    E : (nc, d, d)
        ``E[c, 0] = n``; in 2D ``E[c, 1] = (-n_y, n_x)``; in 3D two tangents
        ``t1 ⟂ n`` (built from the coordinate axis least aligned with ``n``) and
        ``t2 = n × t1``.
    """
    n = np.asarray(normal, dtype=np.float64)
    nc, d = n.shape
    E = np.zeros((nc, d, d))
    E[:, 0] = n
    if d == 2:
        E[:, 1, 0] = -n[:, 1]
        E[:, 1, 1] = n[:, 0]
        return E
    ax = np.zeros_like(n)
    ax[np.arange(nc), np.argmin(np.abs(n), axis=1)] = 1.0
    t1 = np.cross(n, ax)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    E[:, 1] = t1
    E[:, 2] = np.cross(n, t1)
    return E


def _rot_rows(arm: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Rotational part of the body block: ``(a x e_k)`` for each frame vector."""
    if arm.shape[1] == 2:
        return (arm[:, None, 0] * E[:, :, 1] - arm[:, None, 1] * E[:, :, 0])[:, None, :]  # (nc,1,dim)
    return np.cross(arm[:, None, :], E).transpose(0, 2, 1)                                 # (nc,3,dim)


def body_blocks(arm: np.ndarray, E: np.ndarray) -> np.ndarray:
    """Blocks ``(nc, ndof, dim)`` of ``H`` for bodies with lever arms ``arm``."""
    return np.concatenate([E.transpose(0, 2, 1), _rot_rows(arm, E)], axis=1)


def assemble_H(sys, contacts, pos=None) -> tuple[sp.csr_matrix, np.ndarray]:
    """The matrix ``H`` (n_bodies·ndof × dim·nc) and the frames ``E``.

    Parameters
    ----------
    sys : System
    contacts : Contacts
    pos : ndarray, optional
        Body positions (defaults to ``sys.pos``).

    Returns
    -------
    H : scipy.sparse.csr_matrix
    E : ndarray (nc, d, d)
    """
    pos = sys.pos if pos is None else pos
    d, nd, nc = sys.dim, sys.ndof, contacts.n
    E = contact_frames(contacts.normal)
    Bi = body_blocks(contacts.point - pos[contacts.i], E)
    rows_i = contacts.i[:, None, None] * nd + np.arange(nd)[None, :, None]
    cols = (np.arange(nc)[:, None, None] * d + np.arange(d)[None, None, :])
    R = [np.broadcast_to(rows_i, Bi.shape).ravel()]
    C = [np.broadcast_to(cols, Bi.shape).ravel()]
    V = [Bi.ravel()]
    hasj = contacts.j >= 0
    if hasj.any():
        jj = contacts.j[hasj]
        Bj = -body_blocks(contacts.point[hasj] - pos[jj], E[hasj])
        rows_j = jj[:, None, None] * nd + np.arange(nd)[None, :, None]
        R.append(np.broadcast_to(rows_j, Bj.shape).ravel())
        C.append(np.broadcast_to(cols[hasj], Bj.shape).ravel())
        V.append(Bj.ravel())
    H = sp.csr_matrix((np.concatenate(V), (np.concatenate(R), np.concatenate(C))),
                      shape=(sys.n_bodies * nd, nc * d))
    return H, E


def local_velocity(sys, contacts, v, E=None, pos=None) -> np.ndarray:
    """Local relative velocities ``u = Hᵀ v`` computed contact by contact, (nc, dim).

    Same as ``(assemble_H(...)[0].T @ v).reshape(nc, dim)`` without building ``H``.
    """
    pos = sys.pos if pos is None else pos
    E = contact_frames(contacts.normal) if E is None else E
    V = np.asarray(v, dtype=np.float64).reshape(sys.n_bodies, sys.ndof)
    u = np.einsum("cnk,cn->ck", body_blocks(contacts.point - pos[contacts.i], E), V[contacts.i])
    hasj = contacts.j >= 0
    if hasj.any():
        jj = contacts.j[hasj]
        u[hasj] -= np.einsum("cnk,cn->ck", body_blocks(contacts.point[hasj] - pos[jj], E[hasj]), V[jj])
    return u


def delassus(H: sp.spmatrix, inv_mass) -> sp.csr_matrix:
    """``W = H^T M^{-1} H`` (Delassus operator), CSR.

    ``inv_mass`` is the diagonal of ``M^{-1}`` (ndarray) or the sparse
    block-diagonal ``M^{-1}`` of :func:`block_inverse_mass`.
    """
    H = sp.csr_matrix(H)
    if sp.issparse(inv_mass):
        W = (H.T.tocsr() @ (inv_mass @ H).tocsr()).tocsr()
    else:
        W = (H.T.tocsr() @ H.multiply(inv_mass[:, None]).tocsr()).tocsr()
    W.eliminate_zeros()
    return W


def mass_matrix(inv_mass) -> sp.csr_matrix:
    """Mass matrix from ``M^{-1}`` (diagonal ndarray or block-diagonal sparse); locked dofs: unit mass.

    Locked rotations have ``inv_mass = 0``; for the global form they get mass
    1 and are excluded from ``H`` by zeroing their rows (see the stepper).
    """
    if sp.issparse(inv_mass):
        n = inv_mass.shape[0] // 6
        rows = np.repeat(np.arange(6 * n).reshape(n, 6), 6, axis=1).reshape(n, 6, 6)
        B = np.asarray(inv_mass[rows.ravel(), rows.transpose(0, 2, 1).ravel()]).reshape(n, 6, 6)
        lock = np.all(B == 0, axis=2)
        B[lock[:, :, None] & lock[:, None, :]] = 0.0
        B = B + np.einsum("bi,ij->bij", lock.astype(float), np.eye(6))
        return sp.block_diag(list(np.linalg.inv(B)), format="csr")
    m = np.where(inv_mass > 0, 1.0 / np.where(inv_mass > 0, inv_mass, 1.0), 1.0)
    return sp.diags(m).tocsr()


def world_inverse_inertia(R: np.ndarray, inertia_body: np.ndarray, locked: np.ndarray) -> np.ndarray:
    """``R I_body⁻¹ Rᵀ`` per body, (n, 3, 3); zero for ``locked`` (fixed-rotation) bodies."""
    Ji = np.einsum("bij,bjk,blk->bil", R, np.linalg.inv(inertia_body), R)
    Ji[locked] = 0.0
    return Ji


def world_inertia(R: np.ndarray, inertia_body: np.ndarray) -> np.ndarray:
    """``R I_body Rᵀ`` per body, (n, 3, 3)."""
    return np.einsum("bij,bjk,blk->bil", R, inertia_body, R)


def block_inverse_mass(inv_translational: np.ndarray, inv_rot_world: np.ndarray) -> sp.csr_matrix:
    """Sparse block-diagonal ``M^{-1}`` of 3D bodies (ndof 6): ``diag(1/m)`` then ``I_w⁻¹`` per body.

    Parameters
    ----------
    inv_translational : (n,) inverse (spring-augmented) masses
    inv_rot_world : (n, 3, 3) world-frame inverse inertia tensors
    """
    n = inv_translational.shape[0]
    B = np.zeros((n, 6, 6))
    B[:, [0, 1, 2], [0, 1, 2]] = inv_translational[:, None]
    B[:, 3:, 3:] = inv_rot_world
    rows = np.repeat(np.arange(6 * n).reshape(n, 6), 6, axis=1).reshape(n, 6, 6)
    cols = rows.transpose(0, 2, 1)
    keep = B != 0
    return sp.csr_matrix((B[keep], (rows[keep], cols[keep])), shape=(6 * n, 6 * n))


__all__ = ["contact_frames", "body_blocks", "assemble_H", "local_velocity", "delassus", "mass_matrix",
           "world_inverse_inertia", "world_inertia", "block_inverse_mass"]

"""Copies of a problem that must have the same answer: other units, order, frames, duplicates.

Each transform returns the new problem with its stored solution (and
guesses) mapped, so a solver's answer on the copy can be compared with the
original's or with the exact one:

* :func:`rescaled` — ``W -> alpha W``, ``q -> beta q`` (a change of units of
  impulses and velocities): ``r -> (beta/alpha) r``, ``u -> beta u``.
* :func:`permuted` — contacts renumbered: ``r``, ``u`` permuted alike.
* :func:`reframed` — contacts renumbered *and* each contact's tangent basis
  turned about its normal (local or global problem): ``r -> T r``,
  ``u -> T u`` with the orthogonal map ``T`` of :func:`contact_map`.
  Coulomb's law is isotropic, so the copy is the same physical problem
  written in other contact frames.
* :func:`duplicated` — some contacts appear twice (two rows of ``H`` for one
  physical contact): ``W' = E W E^T``, ``q' = E q`` with ``E`` the copying
  map; ``u' = E u`` and any ``r'`` with ``E^T r' = r`` (each duplicated
  impulse split in half between the copies) solves the copy; ``W'`` is
  singular, so ``r'`` is not unique, ``u'`` is.

Velocities are the quantities to compare: :func:`velocity_back` maps a
copy's ``u'`` back to the original's units and order.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..problem import FrictionContactProblem, GlobalFrictionContactProblem, Solution


def _map_solutions(problem, fr, fu, keep_v=False):
    def one(sol):
        return Solution(r=None if sol.r is None else fr(sol.r),
                        u=None if sol.u is None else fu(sol.u), v=sol.v if keep_v else None)
    return (None if problem.solution is None else one(problem.solution),
            [one(g) for g in problem.guesses])


def _copy(problem, W, q, mu, fr, fu, tag):
    sol, guesses = _map_solutions(problem, fr, fu)
    return FrictionContactProblem(W, q, mu, problem.dim, source=problem.source,
                                  name=f"{problem.name}[{tag}]", info=problem.info,
                                  solution=sol, guesses=guesses)


def rescaled(problem: FrictionContactProblem, alpha: float = 1.0, beta: float = 1.0):
    """``W -> alpha W``, ``q -> beta q``: the same problem in other units.

    Returns
    -------
    (FrictionContactProblem, transform)
        The copy and the ``transform`` record used by :func:`velocity_back`.
    """
    alpha, beta = float(alpha), float(beta)
    new = _copy(problem, problem.W * alpha, problem.q * beta, problem.mu,
                lambda r: r * (beta / alpha), lambda u: u * beta, f"W*{alpha:g},q*{beta:g}")
    return new, ("rescaled", beta)


def _contact_rows(contacts, dim):
    contacts = np.asarray(contacts, dtype=np.int64)
    return (contacts[:, None] * dim + np.arange(dim)).reshape(-1)


def permuted(problem: FrictionContactProblem, perm):
    """Contacts in the order ``perm`` (new contact ``k`` is old contact ``perm[k]``)."""
    perm = np.asarray(perm, dtype=np.int64)
    if sorted(perm.tolist()) != list(range(problem.n_contacts)):
        raise ValueError("perm must be a permutation of the contacts")
    idx = _contact_rows(perm, problem.dim)
    W = problem.W.tocsr()[idx][:, idx]
    new = _copy(problem, W, problem.q[idx], problem.mu[perm], lambda r: r[idx], lambda u: u[idx],
                "permuted")
    return new, ("permuted", idx)


def duplicated(problem: FrictionContactProblem, contacts):
    """Contacts ``contacts`` appended once more (copies at the end, in that order)."""
    d = problem.dim
    sel = np.concatenate([np.arange(problem.n_contacts), np.asarray(contacts, dtype=np.int64)])
    rows = _contact_rows(sel, d)
    E = sp.csr_matrix((np.ones(rows.size), (np.arange(rows.size), rows)),
                      shape=(rows.size, problem.m))
    W = (E @ problem.W @ E.T).tocsr()
    share = np.asarray(E.sum(axis=0)).reshape(-1)            # copies of each original row

    def split(r):
        return E @ (r / share)

    new = _copy(problem, W, E @ problem.q, problem.mu[sel], split, lambda u: E @ u, "duplicated")
    return new, ("duplicated", problem.m)


def contact_map(perm, angles, dim: int) -> sp.csr_matrix:
    """The orthogonal map ``T`` of the contact space that renumbers and turns contact frames.

    New contact ``k`` is old contact ``perm[k]`` with its tangent basis turned
    by ``angles[k]`` about the normal: ``(T x)_k = R(angles[k]) x_{perm[k]}``,
    ``R(θ) = diag(1, [[cos θ, -sin θ], [sin θ, cos θ]])`` in 3D.  In 2D the
    tangent line has two orientations only: ``R = diag(1, ±1)``, the sign of
    ``cos θ`` (``-1`` flips the tangent).  The normal component is kept, so
    each block maps the friction cone onto itself.

    Parameters
    ----------
    perm : array_like of int (n_contacts,)
        A permutation of the contacts.
    angles : array_like of float (n_contacts,)
    dim : int
        2 or 3.

    Returns
    -------
    scipy.sparse.csr_matrix (m, m)
        ``T``, with ``T^T T = I``.
    """
    perm = np.asarray(perm, dtype=np.int64)
    angles = np.asarray(angles, dtype=np.float64)
    nc = perm.shape[0]
    if sorted(perm.tolist()) != list(range(nc)) or angles.shape != (nc,):
        raise ValueError("perm must be a permutation of the contacts and angles one per contact")
    blocks = np.zeros((nc, dim, dim))
    blocks[:, 0, 0] = 1.0
    c, s = np.cos(angles), np.sin(angles)
    if dim == 2:
        blocks[:, 1, 1] = np.where(c >= 0.0, 1.0, -1.0)
    else:
        blocks[:, 1, 1], blocks[:, 1, 2] = c, -s
        blocks[:, 2, 1], blocks[:, 2, 2] = s, c
    return sp.bsr_matrix((blocks, perm, np.arange(nc + 1)), shape=(nc * dim, nc * dim)).tocsr()


def reframed(problem, perm, angles):
    """Contacts renumbered and their tangent bases turned, by ``T`` of :func:`contact_map`.

    A local problem becomes ``W' = T W T^T``, ``q' = T q``; a global one
    ``H' = H T^T``, ``w' = T w`` (``M``, ``f`` and ``v`` unchanged); ``mu' =
    mu[perm]``.  Stored solutions map as ``r' = T r``, ``u' = T u``.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    perm, angles
        As :func:`contact_map`.

    Returns
    -------
    (problem, transform)
        The copy and the ``transform`` record used by :func:`velocity_back`.
    """
    T = contact_map(perm, angles, problem.dim)
    if T.shape[0] != problem.m:
        raise ValueError(f"perm has {T.shape[0] // problem.dim} contacts, the problem "
                         f"{problem.n_contacts}")
    perm = np.asarray(perm, dtype=np.int64)
    sol, guesses = _map_solutions(problem, lambda r: T @ r, lambda u: T @ u, keep_v=True)
    meta = dict(source=problem.source, name=f"{problem.name}[reframed]", info=problem.info,
                solution=sol, guesses=guesses)
    if problem.is_global:
        new = GlobalFrictionContactProblem(problem.M, (problem.H @ T.T).tocsr(), problem.f,
                                           T @ problem.w, problem.mu[perm], problem.dim, **meta)
    else:
        new = FrictionContactProblem((T @ problem.W @ T.T).tocsr(), T @ problem.q,
                                     problem.mu[perm], problem.dim, **meta)
    return new, ("reframed", T)


def velocity_back(u_copy, transform) -> np.ndarray:
    """The copy's velocity ``u'`` in the original problem's units and order."""
    kind, data = transform
    u_copy = np.asarray(u_copy, dtype=np.float64)
    if kind == "rescaled":
        return u_copy / data
    if kind == "permuted":
        out = np.empty_like(u_copy)
        out[data] = u_copy
        return out
    if kind == "duplicated":
        return u_copy[:data]
    if kind == "reframed":
        return data.T @ u_copy
    raise ValueError(f"unknown transform {kind!r}")


__all__ = ["rescaled", "permuted", "contact_map", "reframed", "duplicated", "velocity_back"]

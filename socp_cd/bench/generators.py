"""Manufactured frictional contact problems with a known exact solution.

A manufactured problem is built backwards: first a pair ``(r*, u*)`` obeying
the Coulomb–Signorini law contact by contact is chosen (a mix of *separated*,
*sticking*, *sliding* and *grazing* contacts, see
:class:`socp_cd.ContactStatus`), then a Delassus operator
``W = H^T M^{-1} H`` is assembled from a random sparse contact Jacobian ``H``
(transposed, ``n_dofs x m``) and a diagonal mass matrix ``M``, and finally
``q = u* - W r*``.  Then ``u* = W r* + q`` and ``(r*, u*)`` solves the problem
exactly; it is stored as ``problem.solution``.

Two Jacobian structures are available:

``"tree"`` (``W`` symmetric positive definite)
    One body per contact; contact ``i`` touches body ``i`` and a body with a
    smaller index (or the fixed ground).  In body order ``H`` is block upper
    triangular with orthogonal ``dim x dim`` contact frames on the diagonal,
    hence nonsingular, so ``W`` is SPD and ``r*`` is the unique impulse giving
    ``u*``.
``"redundant"`` (``W`` only positive semidefinite)
    Fewer bodies than contacts, random body pairs: ``m > n_dofs`` so ``W`` is
    rank deficient (redundant contacts, as in real granular packings); ``u*``
    is then the meaningful quantity, ``r*`` is one solution among many.

Per-contact scaling ``W -> D W D``, ``q -> D q`` with ``D`` constant on each
contact block preserves the cones (``r = D r'``), which gives badly scaled
problems whose exact solution is still known (see ``contact_scale``).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..problem import FrictionContactProblem, Solution

#: Contact states a manufactured solution can mix (names of ContactStatus).
STATES = ("separated", "sticking", "sliding", "grazing")
#: Default proportions of the four states.
DEFAULT_MIX = (0.25, 0.35, 0.3, 0.1)


def _unit_tangents(rng, nc: int, dim: int) -> np.ndarray:
    """Random unit tangential directions, shape ``(nc, dim - 1)``."""
    if dim == 2:
        return rng.choice([-1.0, 1.0], size=(nc, 1))
    t = rng.standard_normal((nc, 2))
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def coulomb_pairs(n_contacts: int, dim: int = 3, mu=0.3, mix=DEFAULT_MIX, rng=None):
    """Pairs ``(r, u)`` satisfying the Coulomb–Signorini law contact by contact.

    Parameters
    ----------
    n_contacts : int
    dim : {2, 3}
    mu : float or array_like, shape (n_contacts,)
        Friction coefficients (``>= 0``).
    mix : sequence of 4 floats
        Proportions of separated, sticking, sliding and grazing contacts.
    rng : numpy.random.Generator or int, optional

    Returns
    -------
    r, u : ndarray, shape (n_contacts * dim,)
        Stacked impulses and velocities (normal first).
    states : ndarray of int, shape (n_contacts,)
        Index into :data:`STATES` of each contact.

    Notes
    -----
    separated: ``r = 0``, ``u_N > 0``; sticking: ``u = 0``,
    ``||r_T|| < mu r_N``; sliding: ``u_N = 0``, ``u_T != 0`` and
    ``r_T = -mu r_N u_T / ||u_T||``; grazing: ``r = 0`` and ``u = 0``.  With
    ``mu = 0`` a sticking contact degenerates to ``r_T = 0``, ``u = 0``.
    """
    rng = np.random.default_rng(rng)
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), (n_contacts,))
    p = np.asarray(mix, dtype=np.float64)
    states = rng.choice(len(STATES), size=n_contacts, p=p / p.sum())
    R = np.zeros((n_contacts, dim))
    U = np.zeros((n_contacts, dim))
    rn = rng.uniform(0.5, 2.0, n_contacts)
    t = _unit_tangents(rng, n_contacts, dim)
    speed = rng.uniform(0.2, 1.0, n_contacts)
    sep, stick, slide = states == 0, states == 1, states == 2
    U[sep, 0] = rng.uniform(0.1, 1.0, int(sep.sum()))
    U[sep, 1:] = 0.5 * rng.standard_normal((int(sep.sum()), dim - 1))
    frac = rng.uniform(0.0, 0.9, n_contacts)
    R[stick, 0] = rn[stick]
    R[stick, 1:] = (mu * rn * frac)[stick, None] * t[stick]
    R[slide, 0] = rn[slide]
    U[slide, 1:] = speed[slide, None] * t[slide]
    R[slide, 1:] = -(mu * rn)[slide, None] * t[slide]
    return R.reshape(-1), U.reshape(-1), states


def _frames(rng, nc: int, dim: int) -> np.ndarray:
    """Random orthogonal ``dim x dim`` contact frames, shape ``(nc, dim, dim)``."""
    Q, Rr = np.linalg.qr(rng.standard_normal((nc, dim, dim)))
    return Q * np.sign(np.diagonal(Rr, axis1=1, axis2=2))[:, None, :]


def _block_columns(frames, bodies, signs, n_bodies: int, dim: int) -> sp.csr_matrix:
    """Assemble ``H`` (``dim*n_bodies x dim*nc``) from per-contact body blocks.

    ``bodies`` and ``signs`` have shape ``(nc, k)``: contact ``i`` puts
    ``signs[i, j] * frames[i]`` on the rows of body ``bodies[i, j]``
    (a body index ``-1`` is the fixed ground and contributes nothing).
    """
    nc, k = bodies.shape
    a, b = np.meshgrid(np.arange(dim), np.arange(dim), indexing="ij")  # row a, col b in block
    rows = bodies[:, :, None, None] * dim + a[None, None]
    cols = (np.arange(nc)[:, None, None, None] * dim + b[None, None])
    vals = signs[:, :, None, None] * frames[:, None, :, :]
    cols = np.broadcast_to(cols, rows.shape)
    keep = np.broadcast_to(bodies[:, :, None, None] >= 0, rows.shape)
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(dim * n_bodies, dim * nc))


def delassus(n_contacts: int, dim: int = 3, structure: str = "tree", mass_ratio: float = 10.0,
             bodies_per_contact: float = 0.5, rng=None):
    """Random sparse Delassus operator ``W = H^T M^{-1} H``.

    Parameters
    ----------
    n_contacts : int
    dim : {2, 3}
    structure : {"tree", "redundant"}
        ``"tree"`` gives SPD ``W`` (one body per contact, tree coupling);
        ``"redundant"`` gives PSD, rank-deficient ``W`` with
        ``ceil(bodies_per_contact * n_contacts)`` bodies and random pairs.
    mass_ratio : float
        Body masses are log-uniform in ``[1, mass_ratio]``.
    bodies_per_contact : float
        Only for ``"redundant"`` (``< 1`` makes ``W`` singular).
    rng : numpy.random.Generator or int, optional

    Returns
    -------
    W : scipy.sparse.csr_matrix, shape (m, m)
    H : scipy.sparse.csr_matrix, shape (n_dofs, m)
    masses : ndarray, shape (n_bodies,)
    """
    rng = np.random.default_rng(rng)
    nc = int(n_contacts)
    if structure == "tree":
        nb = nc
        # parent of contact i: a body j < i, or the ground (-1) with probability 1/2
        # (grounding keeps the trees shallow and W well conditioned)
        parent = np.concatenate([[-1], rng.integers(0, np.arange(1, nc))]).astype(int)
        parent[rng.random(nc) < 0.5] = -1
        bodies = np.stack([np.arange(nc), parent], axis=1)
    elif structure == "redundant":
        nb = max(1, int(np.ceil(bodies_per_contact * nc)))
        first = rng.integers(0, nb, nc)
        second = rng.integers(-1, nb, nc)
        second = np.where(second == first, -1, second)
        bodies = np.stack([first, second], axis=1)
    else:
        raise ValueError(f"unknown structure {structure!r} (tree or redundant)")
    signs = np.tile([1.0, -1.0], (nc, 1))
    H = _block_columns(_frames(rng, nc, dim), bodies, signs, nb, dim)
    masses = np.exp(rng.uniform(0.0, np.log(max(mass_ratio, 1.0)), nb))
    Minv = sp.diags(np.repeat(1.0 / masses, dim))
    W = (H.T @ Minv @ H).tocsr()
    W = ((W + W.T) * 0.5).tocsr()   # exact symmetry despite round-off
    if W.nnz:  # drop cancellation round-off (e.g. 1e-17 where two paths cancel)
        W.data[np.abs(W.data) <= 1e-13 * np.max(np.abs(W.data))] = 0.0
    W.eliminate_zeros()
    return W, H, masses


def manufactured(n_contacts: int, dim: int = 3, mu=0.3, *, structure: str = "tree",
                 mix=DEFAULT_MIX, mass_ratio: float = 10.0, bodies_per_contact: float = 0.5,
                 contact_scale: float = 1.0, q_scale: float = 1.0, seed=0,
                 name: str | None = None) -> FrictionContactProblem:
    """A frictional contact problem with a known exact solution ``(r*, u*)``.

    Parameters
    ----------
    n_contacts : int
    dim : {2, 3}
    mu : float or array_like
        Friction coefficient(s).
    structure : {"tree", "redundant"}
        SPD (unique ``r*``) or rank-deficient ``W`` (see :func:`delassus`).
    mix : sequence of 4 floats
        Proportions of separated, sticking, sliding, grazing contacts.
    mass_ratio : float
        Ratio of the largest to the smallest body mass.
    bodies_per_contact : float
        Body/contact ratio for ``structure="redundant"``.
    contact_scale : float
        ``>= 1``: per-contact scale factors ``d_i`` log-uniform in
        ``[1/sqrt(s), sqrt(s)]`` applied as ``W -> D W D``, ``q -> D q``,
        ``r* -> r*/d``, ``u* -> d u*`` (entries of ``W`` then span about
        ``s`` more orders of magnitude).
    q_scale : float
        Global factor applied to ``q``, ``u*`` and ``r*`` (the law is
        positively homogeneous).
    seed : int or numpy.random.Generator
    name : str, optional

    Returns
    -------
    FrictionContactProblem
        With ``solution = Solution(r*, u*)`` and ``info`` listing the states.
    """
    rng = np.random.default_rng(seed)
    nc = int(n_contacts)
    mu_arr = np.broadcast_to(np.asarray(mu, dtype=np.float64), (nc,)).copy() if nc else np.zeros(0)
    W, _, _ = delassus(nc, dim, structure, mass_ratio, bodies_per_contact, rng)
    r, u, states = coulomb_pairs(nc, dim, mu_arr, mix, rng)
    if contact_scale != 1.0:
        half = 0.5 * np.log(contact_scale)
        d = np.repeat(np.exp(rng.uniform(-half, half, nc)), dim)
        W = (sp.diags(d) @ W @ sp.diags(d)).tocsr()
        r, u = r / d, u * d
    r, u = r * q_scale, u * q_scale
    q = u - W @ r
    counts = {s: int(np.sum(states == i)) for i, s in enumerate(STATES)}
    info = (f"manufactured {structure} nc={nc} dim={dim} mu={np.unique(mu_arr).tolist()[:3]} "
            f"mass_ratio={mass_ratio:g} contact_scale={contact_scale:g} q_scale={q_scale:g} "
            f"states={counts}")
    return FrictionContactProblem(W, q, mu_arr, dim, name=name or f"manufactured-{structure}-{dim}d-{nc}",
                                  info=info, solution=Solution(r=r, u=u))


#: Generated families the campaign knows by name: ``family -> (builder, defaults)``.
FAMILIES = {
    "manufactured": dict(structure="tree"),
    "manufactured_psd": dict(structure="redundant", bodies_per_contact=0.5),
}


def generate(family: str, n_contacts: int, dim: int = 3, seed: int = 0, **params):
    """Build one member of a named generated family (see :data:`FAMILIES`)."""
    if family not in FAMILIES:
        raise ValueError(f"unknown generated family {family!r}; known: {sorted(FAMILIES)}")
    kw = dict(FAMILIES[family])
    kw.update(params)
    return manufactured(n_contacts, dim, seed=seed,
                        name=f"{family}-{dim}d-{n_contacts}-s{seed}", **kw)


__all__ = ["STATES", "DEFAULT_MIX", "coulomb_pairs", "delassus", "manufactured", "generate",
           "FAMILIES"]

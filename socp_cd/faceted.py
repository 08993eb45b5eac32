"""Faceted (polyhedral) approximation of the Coulomb cone.

In 3D the Coulomb cone ``K_mu = {||r_T|| <= mu r_N}`` is replaced by the
polyhedral cone

    K_f = {r : r_N >= 0,  t_k . r_T <= mu_f r_N,  k = 0..n_f-1},

with ``n_f`` unit facet normals ``t_k = (cos θ_k, sin θ_k)``,
``θ_k = 2 π (k + ½) / n_f``, so that the polygon's vertices (edges of the
cone) sit at the angles ``φ_k = 2 π k / n_f`` (``φ = 0`` always a vertex:
polygons with ``n_f`` and ``2 n_f`` facets are nested), and a facet slope
``mu_f`` that places the polygon

* ``"inscribed"`` (default): vertices on the circle of radius ``mu r_N``,
  ``mu_f = mu cos(π / n_f)``; ``K_f ⊂ K_mu``, so every faceted reaction is
  admissible for the exact law (friction is under-estimated by at most a
  factor ``cos(π / n_f)``);
* ``"circumscribed"``: facets tangent to that circle, ``mu_f = mu``;
  ``K_mu ⊂ K_f`` (friction over-estimated by at most ``1 / cos(π / n_f)``).

In 2D the Coulomb "cone" is already the wedge ``|r_T| <= mu r_N``: it is
exactly ``K_f`` with the two facet normals ``t = ±1`` (``n_f`` and the
placement are then ignored and ``mu_f = mu``).

The faceted *law* is the associated law on ``K_f``: ``K_f* ∋ u ⊥ r ∈ K_f``,
i.e. ``r = P_{K_f}(r - u)``; :func:`faceted_error` measures it like Siconos'
relative error.  See ``formulations/faceted.md``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .cones import project_cone
from .errors import InvalidProblemError
from .residuals import checked_pair, relative_residual

PLACEMENTS = ("inscribed", "circumscribed")


#: default number of facets of the 3D faceted cone
DEFAULT_FACETS = 8


def check_facets(n_facets, placement="inscribed") -> tuple[int, str]:
    """Validate the number of facets (integer ``>= 3``) and the placement."""
    try:
        nf = int(n_facets)
    except (TypeError, ValueError):
        raise InvalidProblemError("facets", f"must be an integer >= 3, got {n_facets!r}") from None
    if nf != n_facets or nf < 3:
        raise InvalidProblemError("facets", f"must be an integer >= 3, got {n_facets!r}")
    if placement not in PLACEMENTS:
        raise InvalidProblemError("placement", f"must be one of {PLACEMENTS}, got {placement!r}")
    return nf, placement


def facet_normals(n_facets: int, dim: int = 3) -> np.ndarray:
    """Unit tangential facet normals ``t_k``, shape ``(n_f, dim - 1)``.

    In 2D these are ``(+1, -1)`` whatever ``n_facets``.
    """
    if dim == 2:
        return np.array([[1.0], [-1.0]])
    theta = 2.0 * np.pi * (np.arange(n_facets) + 0.5) / n_facets
    return np.column_stack([np.cos(theta), np.sin(theta)])


def facet_slope(mu, n_facets: int, placement: str = "inscribed", dim: int = 3) -> np.ndarray:
    """Facet slope ``mu_f`` per contact (``mu cos(π/n_f)`` inscribed, ``mu`` circumscribed)."""
    mu = np.asarray(mu, dtype=np.float64)
    if dim == 2 or placement == "circumscribed":
        return mu.copy()
    return mu * np.cos(np.pi / n_facets)


def cone_matrix(mu, dim: int = 3, n_facets: int = 8, placement: str = "inscribed") -> sp.csr_matrix:
    """Sparse ``C`` with ``K_f = {r : C r <= 0}``, built for all contacts at once.

    Per contact ``i`` the rows are, in order, ``-r_N <= 0`` then
    ``t_k . r_T - mu_f,i r_N <= 0`` for every facet ``k`` (``n_f = 2`` in 2D).

    Parameters
    ----------
    mu : array_like, shape (n_contacts,)
    dim : {2, 3}
    n_facets : int
        Number of facets in 3D (ignored in 2D).
    placement : {"inscribed", "circumscribed"}

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n_contacts * (1 + n_f), dim * n_contacts)
    """
    mu = np.asarray(mu, dtype=np.float64).reshape(-1)
    nc = mu.size
    T = facet_normals(n_facets, dim)                       # (nf, dim-1)
    nf = T.shape[0]
    mu_f = facet_slope(mu, n_facets, placement, dim)
    rows_per = 1 + nf
    # local block (rows_per x dim) per contact, then scattered by contact index
    block = np.zeros((nc, rows_per, dim))
    block[:, 0, 0] = -1.0
    block[:, 1:, 0] = -mu_f[:, None]
    block[:, 1:, 1:] = T[None, :, :]
    ii = np.arange(nc)[:, None, None]
    rows = ii * rows_per + np.arange(rows_per)[None, :, None]
    cols = ii * dim + np.arange(dim)[None, None, :]
    rows, cols = np.broadcast_to(rows, block.shape), np.broadcast_to(cols, block.shape)
    C = sp.csr_matrix((block.ravel(), (rows.ravel(), cols.ravel())), shape=(nc * rows_per, nc * dim))
    C.eliminate_zeros()
    return C


def project_faceted_cone(x, mu, dim: int = 3, n_facets: int = 8,
                         placement: str = "inscribed") -> np.ndarray:
    """Euclidean projection onto the faceted cone ``K_f`` (vectorized over contacts).

    In 2D this is the exact wedge projection :func:`socp_cd.cones.project_cone`.
    In 3D the projection is, per contact, the nearest *feasible* point among
    ``x`` itself, its projections on the ``n_f`` facet planes, on the ``n_f``
    edge rays and the apex (the true projection lies in the relative interior
    of exactly one of these faces). Cost ``O(n_contacts n_f^2)``.

    Parameters
    ----------
    x : array_like, shape (m,) or (n_contacts, dim)
    mu : array_like, shape (n_contacts,)

    Returns
    -------
    ndarray, same shape as ``x``
    """
    if dim == 2:
        return project_cone(x, mu, 2)
    xa = np.asarray(x, dtype=np.float64)
    X = xa.reshape(-1, 3)
    nc = X.shape[0]
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64).reshape(-1), (nc,))
    T = facet_normals(n_facets, 3)
    nf = T.shape[0]
    mu_f = facet_slope(mu, n_facets, placement, 3)
    # constraint normals a (rows of C for one contact): (nc, 1 + nf, 3)
    A = np.zeros((nc, 1 + nf, 3))
    A[:, 0, 0] = -1.0
    A[:, 1:, 0] = -mu_f[:, None]
    A[:, 1:, 1:] = T[None]
    Af = A[:, 1:, :]
    # facet planes: x - (a.x)/|a|^2 a
    ax = np.einsum("ikj,ij->ik", Af, X)
    faces = X[:, None, :] - (ax / np.einsum("ikj,ikj->ik", Af, Af))[:, :, None] * Af
    # edge rays between facets k and k+1: direction (1, rho_v (cos phi, sin phi))
    phi = 2.0 * np.pi * (np.arange(nf) + 1.0) / nf     # between normals k and k+1
    rho_v = mu_f / np.cos(np.pi / nf)
    E = np.empty((nc, nf, 3))
    E[:, :, 0] = 1.0
    E[:, :, 1] = rho_v[:, None] * np.cos(phi)[None]
    E[:, :, 2] = rho_v[:, None] * np.sin(phi)[None]
    ex = np.maximum(np.einsum("ikj,ij->ik", E, X), 0.0)
    edges = (ex / np.einsum("ikj,ikj->ik", E, E))[:, :, None] * E
    cand = np.concatenate([X[:, None, :], faces, edges, np.zeros((nc, 1, 3))], axis=1)
    viol = np.einsum("ilj,ikj->ilk", cand, A).max(axis=2)           # (nc, ncand)
    scale = np.linalg.norm(X, axis=1) * (1.0 + mu_f)
    feas = viol <= 1e-12 * scale[:, None] + 1e-300
    d2 = np.einsum("ilj,ilj->il", cand - X[:, None, :], cand - X[:, None, :])
    d2 = np.where(feas, d2, np.inf)
    best = np.argmin(d2, axis=1)
    P = cand[np.arange(nc), best]
    return P.reshape(xa.shape)


def faceted_error(problem, r, u=None, n_facets: int = 8, placement: str = "inscribed") -> float:
    """Relative residual of the faceted (associated, polyhedral) law.

    ``||r - P_{K_f}(r - u)|| / max(||q||, ||r||, ||u||)`` with ``u = W r + q``
    recomputed unless given — the analogue of Siconos' error for ``K_f``.
    """
    n_facets, placement = check_facets(n_facets, placement)
    r, u = checked_pair(problem, r, u)
    return relative_residual(problem, r, u, lambda rs, us, c: rs - project_faceted_cone(
        rs - us, problem.mu, problem.dim, n_facets, placement))


__all__ = ["PLACEMENTS", "check_facets", "facet_normals", "facet_slope", "cone_matrix",
           "project_faceted_cone", "faceted_error"]

"""Residuals of the contact laws other than exact Coulomb.

Each function returns a relative residual normalized like Siconos' error
(``max(||q||, ||r||, ||u||)``) so all laws are judged on one scale.

* ``coulomb``      — :func:`socp_cd.error` (natural map with û).
* ``associated``   — ``K* ∋ u ⊥ r ∈ K``: natural map with ``u`` instead of ``û``
  (the optimality system of ``min ½ rᵀWr + qᵀr, r ∈ K`` for symmetric W).
* ``frictionless`` — Signorini only: ``0 <= u_N ⊥ r_N >= 0`` and ``r_T = 0``
  (the Coulomb residual with ``mu = 0``).
* ``faceted``      — the associated law on a polyhedral cone inscribed in (or
  circumscribing) ``K_mu`` (:mod:`socp_cd.faceted`, parameters ``facets``, ``placement``).
* ``tresca``       — Signorini in the normal direction and, tangentially,
  ``r_T = P_{B(0, g)}(r_T - u_T)`` with a given threshold ``g`` per contact.
"""
from __future__ import annotations

import numpy as np

from .cones import project_cone
from .errors import InvalidProblemError
from .faceted import DEFAULT_FACETS, check_facets, faceted_error
from .residuals import checked_pair, error, relative_residual


def associated_error(problem, r, u=None) -> float:
    """Relative residual of the associated law ``K* ∋ u ⊥ r ∈ K``."""
    r, u = checked_pair(problem, r, u)
    return relative_residual(problem, r, u, lambda rs, us, c:
                             rs - project_cone(rs - us, problem.mu, problem.dim))


def frictionless_error(problem, r, u=None) -> float:
    """Relative residual of Signorini's law with ``r_T = 0``."""
    r, u = checked_pair(problem, r, u)
    zero = np.zeros(problem.n_contacts)
    return relative_residual(problem, r, u, lambda rs, us, c:
                             rs - project_cone(rs - us, zero, problem.dim))


def check_threshold(problem, threshold) -> np.ndarray:
    """Validate a Tresca threshold: finite, ``>= 0``, one per contact (scalar broadcast)."""
    g = np.asarray(threshold, dtype=np.float64).reshape(-1)
    if g.size == 1:
        g = np.full(problem.n_contacts, float(g[0]))
    if g.size != problem.n_contacts:
        raise InvalidProblemError("threshold", f"has {g.size} entries, expected {problem.n_contacts}",
                                  problem.source)
    if not np.all(np.isfinite(g)) or np.any(g < 0):
        raise InvalidProblemError("threshold", "must be finite and >= 0", problem.source)
    return g


def project_ball(x, radius) -> np.ndarray:
    """Project rows of ``x`` (shape ``(nc, k)``) onto balls of the given radii."""
    nrm = np.sqrt(np.einsum("ij,ij->i", x, x))
    scale = np.where(nrm > radius, radius / np.where(nrm > 0, nrm, 1.0), 1.0)
    return x * scale[:, None]


def tresca_error(problem, r, u=None, threshold=None) -> float:
    """Relative residual of Tresca's law with threshold ``g`` (per contact)."""
    if threshold is None:
        raise InvalidProblemError("threshold", "the Tresca law needs a friction threshold per contact",
                                  problem.source)
    g = check_threshold(problem, threshold)
    r, u = checked_pair(problem, r, u)

    def residual(rs, us, c):            # (g, a bound on ||r_T||, scales with r)
        R = rs.reshape(-1, problem.dim)
        U = us.reshape(-1, problem.dim)
        F = np.empty_like(R)
        F[:, 0] = R[:, 0] - np.maximum(R[:, 0] - U[:, 0], 0.0)
        F[:, 1:] = R[:, 1:] - project_ball(R[:, 1:] - U[:, 1:], g / c)
        return F.reshape(-1)

    return relative_residual(problem, r, u, residual)


def faceted_law_error(problem, r, u=None, facets=DEFAULT_FACETS, placement="inscribed") -> float:
    """Relative residual of the associated law on the faceted cone (see :mod:`socp_cd.faceted`)."""
    nf, placement = check_facets(facets, placement)
    return faceted_error(problem, r, u, nf, placement)


#: formulation name -> residual function ``f(problem, r, u=None, **params)``
LAW_RESIDUALS = {
    "coulomb": error,
    "associated": associated_error,
    "frictionless": frictionless_error,
    "tresca": tresca_error,
    "faceted": faceted_law_error,
}

#: formulation name -> names of its parameters (keyword arguments of its residual)
LAW_PARAMETERS = {"tresca": ("threshold",), "faceted": ("facets", "placement")}


def law_parameters(formulation, options) -> dict:
    """The entries of ``options`` that parametrize ``formulation``'s law."""
    return {k: options[k] for k in LAW_PARAMETERS.get(formulation, ()) if k in options}

__all__ = ["associated_error", "frictionless_error", "tresca_error", "faceted_law_error",
           "check_threshold", "project_ball", "LAW_RESIDUALS", "LAW_PARAMETERS", "law_parameters"]

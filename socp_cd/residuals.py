"""Residuals of a candidate solution, measured as Siconos measures them.

The reference measure is Siconos' relative error (``fc3d_compute_error``)::

    error(r) = ||F(r)|| / max(||q||, ||r||, ||u||),   u = W r + q recomputed,

with ``F`` the natural map (rho = 1, see :mod:`socp_cd.cones`). When the three
norms are all below machine epsilon the absolute value is returned, as Siconos
does. The 2D problems use the same formula with ``||u_T|| = |u_T|``.
"""
from __future__ import annotations

import numpy as np

from .cones import (fenchel_young_gap, in_cone_violation, natural_map,
                    normal_velocity_violation)

_EPS = np.finfo(float).eps


def checked_pair(problem, r, u=None):
    """``(r, u)`` validated against ``problem``; ``u = W r + q`` recomputed when not given."""
    r = problem.check_reaction(r)
    u = problem.velocity(r) if u is None else problem.check_reaction(u, "u")
    return r, u


def absolute_error(problem, r, u=None) -> float:
    """``||F(r)||`` (natural-map residual, not normalized).

    ``u`` is recomputed from ``r`` unless given.
    """
    r, u = checked_pair(problem, r, u)
    F = natural_map(r, u, problem.mu, problem.dim)
    return float(np.sqrt(np.dot(F, F)))


def error_normalization(problem, r, u) -> float:
    """``max(||q||, ||r||, ||u||)``; 1.0 when all three are below machine epsilon."""
    norm = max(float(np.linalg.norm(problem.q_local)), float(np.linalg.norm(r)),
               float(np.linalg.norm(u)))
    return norm if norm > _EPS else 1.0


def error(problem, r, u=None) -> float:
    """Siconos' relative error of ``r`` for ``problem`` (local or global).

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    r : array_like, shape (m,)
        Candidate contact impulses.
    u : array_like, optional
        Velocities to use instead of recomputing ``u = W r + q``.  Leave it
        out to get the independent, recomputed measure used for convergence.

    Returns
    -------
    float
        ``||r - P_K(r - û)|| / max(||q||, ||r||, ||u||)``.
    """
    r, u = checked_pair(problem, r, u)
    F = natural_map(r, u, problem.mu, problem.dim)
    return float(np.sqrt(np.dot(F, F))) / error_normalization(problem, r, u)


def contact_errors(problem, r, u=None) -> np.ndarray:
    """Per-contact norm of the natural map (absolute), shape ``(n_contacts,)``."""
    r, u = checked_pair(problem, r, u)
    F = natural_map(r, u, problem.mu, problem.dim).reshape(-1, problem.dim)
    return np.sqrt(np.einsum("ij,ij->i", F, F))


def feasibility(problem, r, u=None) -> dict:
    """Primal/dual feasibility: ``dist(r, K_mu)`` and ``max(0, -u_N)``.

    Returns
    -------
    dict
        ``{"cone": max distance of r to K_mu, "normal_velocity": max(0, -u_N)}``.
    """
    r, u = checked_pair(problem, r, u)
    return {
        "cone": float(np.max(in_cone_violation(r, problem.mu, problem.dim))),
        "normal_velocity": float(np.max(normal_velocity_violation(u, problem.dim))),
    }


def complementarity(problem, r, u=None) -> dict:
    """Complementarity measures of ``û ⊥ r`` (Fenchel–Young gaps).

    Returns
    -------
    dict
        ``{"max_gap": max_i |r_i·û_i|, "total_gap": sum_i r_i·û_i,
        "relative": total_gap / (||r|| ||u|| or 1)}``.
    """
    r, u = checked_pair(problem, r, u)
    g = fenchel_young_gap(r, u, problem.mu, problem.dim)
    denom = float(np.linalg.norm(r) * np.linalg.norm(u))
    return {
        "max_gap": float(np.max(np.abs(g))),
        "total_gap": float(np.sum(g)),
        "relative": float(np.sum(g)) / (denom if denom > 0 else 1.0),
    }


__all__ = ["error", "checked_pair", "absolute_error", "error_normalization", "contact_errors",
           "feasibility", "complementarity"]

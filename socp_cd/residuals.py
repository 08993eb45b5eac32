"""Residuals of a candidate solution, measured as Siconos measures them.

The reference measure is Siconos' relative error (``fc3d_compute_error``)::

    error(r) = ||F(r)|| / max(||q||, ||r||, ||u||),   u = W r + q recomputed,

with ``F`` the natural map (rho = 1, see :mod:`socp_cd.cones`). When the three
norms are all below machine epsilon the absolute value is returned, as Siconos
does. The 2D problems use the same formula with ``||u_T|| = |u_T|``.

That measure mixes the units of ``r`` and ``u`` (``rho = 1``, one common
denominator), so a problem written in unbalanced units can pass it with a
wrong ``r`` (``W`` and ``q`` times 1e8: loaded contacts that separate, hidden
by a huge ``||u||``).  :func:`balanced_error` is the same measure in balanced
units (:func:`contact_scales`: unit diagonal blocks of ``W``, ``q`` of unit RMS);
it does not depend on the units the problem was written in, and
:func:`socp_cd.solve` requires it too (:func:`guard`) before calling a result
converged.  See ``formulations/coulomb.md`` §9.
"""
from __future__ import annotations

import math

import numpy as np

from .cones import (fenchel_young_gap, in_cone_violation, natural_map,
                    normal_velocity_violation)

_EPS = float(np.finfo(float).eps)      # a Python float (guard_values works in Python floats)


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
    return relative_residual(problem, r, u,
                             lambda rs, us, c: natural_map(rs, us, problem.mu, problem.dim))


def relative_residual(problem, r, u, residual) -> float:
    """``||F|| / max(||q||, ||r||, ||u||)`` (:func:`error_normalization`) of a law's residual.

    ``residual(rs, us, c)`` returns ``F`` for the pair ``(rs, us) = (r, u) / c`` with the law's
    dimensioned parameters (a Tresca threshold) divided by ``c`` too.  It is called with
    ``c = 1``, and again with ``c = max|(r, u)|`` when a squared norm overflows (entries
    beyond ~1e154; the measure is the same for ``(c r, c u, c q)``, the natural maps being
    positively homogeneous): a finite pair never gives nan (nor, as an overflowed ``||r||``
    over a finite ``||F||`` would, 0).  Inf when ``u`` itself overflowed.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        F = residual(r, u, 1.0)
        f = float(np.sqrt(np.dot(F, F)))
        norm = error_normalization(problem, r, u)
    if math.isfinite(f) and math.isfinite(norm):
        return f / norm
    c = max(float(np.max(np.abs(r), initial=0.0)), float(np.max(np.abs(u), initial=0.0)))
    if not (math.isfinite(c) and c > 0.0):
        return math.inf
    rs, us = r / c, u / c
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        F = residual(rs, us, c)
        norm = max(float(np.linalg.norm(problem.q_local / c)), float(np.linalg.norm(rs)),
                   float(np.linalg.norm(us)))
        value = float(np.sqrt(np.dot(F, F))) / norm
    return value if math.isfinite(value) else math.inf


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


def _block_diagonal_scale(problem) -> np.ndarray:
    """Mean diagonal entry of each contact block of ``W`` (``(n_contacts,)``).

    Local problems read it from ``W``; global problems use the Jacobi estimate
    ``diag(H^T diag(M)^-1 H)`` (no factorization: a scale, not a solve).
    """
    if problem.is_global:
        dM = np.abs(problem.M.diagonal())
        with np.errstate(divide="ignore"):
            inv = np.where(dM > 0, 1.0 / dM, 0.0)
        H = problem.H.tocsr()
        diag = np.asarray(H.multiply(H).T @ inv).reshape(-1)
    else:
        diag = problem.W.diagonal()
    d = np.abs(diag).reshape(problem.n_contacts, problem.dim).mean(axis=1)
    good = np.isfinite(d) & (d > 0)
    if not np.all(good):   # a contact with no stiffness of its own: the typical scale
        fill = float(np.exp(np.mean(np.log(d[good])))) if np.any(good) else 1.0
        d = np.where(good, d, fill)
    return d


def contact_scales(problem) -> tuple[np.ndarray, np.ndarray]:
    """Per-contact unit factors that balance a problem: ``r = a r~``, ``u = b u~``.

    With ``d_i`` the mean diagonal entry of the block ``W_ii`` and
    ``s = 1/sqrt(d)``, ``sigma = ||s q|| / sqrt(m)`` (1 when zero),
    ``a_i = sigma s_i`` and ``b_i = sigma / s_i``; the balanced problem is
    ``u~ = W~ r~ + q~`` with ``W~ = S W S`` (unit mean diagonal per block,
    symmetric when ``W`` is) and ``q~ = S q / sigma`` (entries of unit root
    mean square: interior-point tolerances are absolute-ish, so entries of
    order one rather than a unit norm).

    One positive scalar per contact maps ``K_mu`` and ``K*_mu`` onto
    themselves and preserves ``û ⊥ r``, so the law, hence the solution set,
    is the same in both units.  The factors are equivariant: writing the
    problem in other units (``W -> alpha W``, ``q -> beta q``, or any positive
    per-contact rescaling) gives the same balanced problem up to rounding.

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem

    Returns
    -------
    a, b : ndarray, shape (m,)
        Factors of ``r`` and ``u``, repeated over each contact's components.
    """
    d = _block_diagonal_scale(problem)
    s = 1.0 / np.sqrt(d)
    sigma = float(np.linalg.norm(np.repeat(s, problem.dim) * problem.q_local)) / np.sqrt(problem.m)
    if not (np.isfinite(sigma) and sigma > 0):
        sigma = 1.0
    a = np.repeat(sigma * s, problem.dim)
    b = np.repeat(sigma / s, problem.dim)
    return a, b


class BalancedView:
    """A problem's ``q``, ``mu`` and ``dim`` in balanced units, for residuals given ``u``.

    ``q_local = q / b`` (:func:`contact_scales`); reactions are validated by
    the original problem.  It has no ``W``: the residuals read ``W`` only to
    recompute ``u``, so always pass ``u`` (in balanced units) with it.
    """

    is_global = False

    def __init__(self, problem, b):
        self._problem = problem
        self.q_local = problem.q_local / b
        self.mu, self.dim, self.source = problem.mu, problem.dim, problem.source
        self.n_contacts, self.m = problem.n_contacts, problem.m

    def check_reaction(self, r, name: str = "r") -> np.ndarray:
        """Validated by the original problem (length, finiteness)."""
        return self._problem.check_reaction(r, name)


def guard(problem, r, u=None, scales=None, law=None, **params) -> dict:
    """Scale-aware solution check: the law's residual in balanced units (and its parts).

    Parameters
    ----------
    problem : FrictionContactProblem or GlobalFrictionContactProblem
    r : array_like, shape (m,)
    u : array_like, optional
        ``W r + q`` (recomputed when not given).
    scales : tuple, optional
        ``(a, b)`` from :func:`contact_scales` (computed when not given).
    law : callable, optional
        Residual ``law(problem, r, u, **params)`` of the law solved (one of
        ``socp_cd.laws.LAW_RESIDUALS``); default Coulomb, :func:`error`.
    **params
        The law's parameters in the caller's units (a Tresca ``threshold``,
        a bound on ``||r_T||``, is divided by ``a`` like ``r``).

    Returns
    -------
    dict
        ``"error"``: the law's residual of ``r~ = r/a``, ``u~ = u/b`` on the
        balanced problem (:func:`contact_scales`), relative to the velocity
        scale ``V = max(||q~||, ||u~||)`` rather than Siconos'
        ``max(||q~||, ||r~||, ||u~||)``: in balanced units impulses and
        velocities are commensurate (``||r~|| / V`` lies between 2e-3 and 7
        for the NSGS and Clarabel answers of every shared local problem), so
        the two agree within that factor, except when ``r~`` is huge -- a
        component in the null space of ``W`` (redundant contacts), which
        must not hide an O(1) residual.  ``"rounding"``:
        ``eps ||r~|| / V``, the relative accuracy to which ``u = W r + q``
        can be computed at all from this ``r`` (``W~`` has a unit diagonal,
        so ``W~ r~`` carries an absolute rounding error of about
        ``eps ||r~||``).  ``"value"``: the larger of the two; the guard holds
        when it is ``<= tol``.  ``"balanced_siconos"``: the same residual with
        Siconos' normalization, what a backend given the balanced problem
        measures.  For Coulomb also the parts of the residual,
        relative to ``V``: ``"cone"`` (max distance of ``r~_i`` to
        ``K_mu``), ``"normal_velocity"`` (max ``-u~_N``),
        ``"complementarity"`` (``sum_i |r~_i · û~_i| / V^2``).
        None of them depends on the units the problem is written in.
    """
    r, u = checked_pair(problem, r, u)
    a, b = contact_scales(problem) if scales is None else scales
    if "threshold" in params and params["threshold"] is not None:
        params = dict(params, threshold=np.asarray(params["threshold"], dtype=np.float64)
                      / a[::problem.dim])
    rs, us = balanced_pair(r, u, a, b)
    if rs is None:
        return failed_guard()
    balanced = BalancedView(problem, b)
    with np.errstate(all="ignore"):      # overflow ends as inf below, never nan
        measured = (law or error)(balanced, rs, us, **params)
        out = guard_values(measured, float(np.linalg.norm(rs)), float(np.linalg.norm(us)),
                           float(np.linalg.norm(balanced.q_local)))
    if law is None or law is error:
        out.update(coulomb_parts(rs, us, problem, out["velocity_scale"]))
    return finite_guard(out)


def balanced_pair(r, u, a, b):
    """``(r / a, u / b)``, or ``(None, None)`` when either is not finite."""
    with np.errstate(all="ignore"):
        rs, us = r / a, u / b
    if not (np.isfinite(rs).all() and np.isfinite(us).all()):
        return None, None
    return rs, us


def failed_guard() -> dict:
    """:func:`guard`'s record when it cannot be evaluated (non-finite pair): every entry ``inf``."""
    return {"error": float("inf"), "rounding": float("inf"), "value": float("inf"),
            "balanced_siconos": float("inf")}


def guard_values(measured, r_norm, u_norm, q_norm) -> dict:
    """The entries ``error``, ``rounding``, ``value``, ``balanced_siconos`` of :func:`guard`.

    ``measured`` is the law's residual of the balanced pair with Siconos'
    normalization, ``r_norm, u_norm, q_norm`` the norms of ``r~, u~, q~``.
    ``"velocity_scale"`` (``V``) is returned too, for :func:`coulomb_parts`;
    :func:`finite_guard` drops it.
    """
    # Python floats: an overflow ends as inf, silently (no NumPy error state to manage)
    measured, r_norm, u_norm, q_norm = float(measured), float(r_norm), float(u_norm), float(q_norm)
    vel = max(q_norm, u_norm)
    vel = vel if vel > _EPS else 1.0
    siconos = max(q_norm, r_norm, u_norm)
    siconos = siconos if siconos > _EPS else 1.0
    # the law's residuals divide by Siconos' normalization: rescale to the velocity one
    out = {"error": measured * (siconos / vel), "balanced_siconos": measured,
           "rounding": _EPS * r_norm / vel}
    out["value"] = max(out["error"], out["rounding"])
    out["velocity_scale"] = vel
    return out


def finite_guard(out: dict) -> dict:
    """:func:`guard`'s record as returned: non-finite entries become ``inf``, no ``velocity_scale``."""
    return {k: (v if math.isfinite(v) else float("inf")) for k, v in out.items()
            if k != "velocity_scale"}


def coulomb_parts(rs, us, problem, norm) -> dict:
    """Feasibility and complementarity parts of the balanced Coulomb residual (see :func:`guard`).

    ``rs, us``: the balanced pair; ``norm``: the velocity scale ``V``.
    """
    with np.errstate(all="ignore"):
        gap = fenchel_young_gap(rs, us, problem.mu, problem.dim)
        return {
            "cone": float(np.max(in_cone_violation(rs, problem.mu, problem.dim))) / norm,
            "normal_velocity": float(np.max(normal_velocity_violation(us, problem.dim))) / norm,
            # norm * norm: a Python float overflows to inf (norm ** 2 raises OverflowError)
            "complementarity": float(np.sum(np.abs(gap))) / (norm * norm),
        }


def balanced_error(problem, r, u=None, scales=None) -> float:
    """Coulomb residual in balanced units, relative to the velocity scale (``guard(...)["error"]``)."""
    return guard(problem, r, u, scales)["error"]


__all__ = ["contact_scales", "BalancedView", "guard", "guard_values", "finite_guard", "balanced_pair", "failed_guard", "coulomb_parts", "balanced_error", "error", "relative_residual", "checked_pair", "absolute_error", "error_normalization", "contact_errors",
           "feasibility", "complementarity"]

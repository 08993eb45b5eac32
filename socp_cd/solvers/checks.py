"""The dispatcher's independent checks of a Coulomb answer, with the compiled kernels.

:func:`socp_cd.solve` recomputes Siconos' error of every answer and the units
guard (:func:`socp_cd.residuals.guard`).  For the Coulomb law it does so here
with the compiled twins of the NumPy references
(:func:`~socp_cd.solvers.kernels.cone.error_parts` /
:func:`~socp_cd.solvers.kernels.cone.relative_error`, held equal to
:func:`socp_cd.residuals.error` by ``tests/test_core.py``) and the
compiled twin :func:`~socp_cd.solvers.kernels.cone.coulomb_violations` of
:func:`socp_cd.residuals.coulomb_parts`, and the per-problem norms and unit
factors cached on the problem
(``q_norm``, ``balancing_scales``, ``balanced_q_norm``): on a one-contact
problem the NumPy references cost several times the solve itself.
``tests/test_checks.py`` holds these functions equal to the references.
"""
from __future__ import annotations

import math

import numpy as np

from ..residuals import balanced_pair, failed_guard, finite_guard, guard_values
from .kernels.cone import LAW_COULOMB, coulomb_violations, error_parts, relative_error


def _parts(problem, r, u):
    """``(||F||², ||r||², ||u||²)`` of the Coulomb natural map (``u`` given)."""
    return error_parts(r, u, problem.mu, np.zeros(problem.n_contacts), problem.dim, LAW_COULOMB)


def coulomb_error(problem, r, u) -> float:
    """Siconos' relative error of ``r`` with ``u = W r + q`` given (= :func:`socp_cd.residuals.error`).

    ``r`` and ``u``: finite float64 vectors of length ``problem.m``.
    """
    f2, r2, u2 = _parts(problem, r, u)
    return float(relative_error(f2, r2, u2, problem.q_norm))


def zero_error(problem):
    """Siconos' error of ``r = 0`` (None when a global problem's ``M`` is singular).

    Local problems: the compiled :func:`coulomb_error` with ``u = q`` (a few
    microseconds, not cached); global ones: the problem's cached
    :attr:`~socp_cd.problem.GlobalFrictionContactProblem.zero_error` (``u = Hᵀ M⁻¹ f + w``
    needs a solve with ``M``).
    """
    if problem.is_global:
        return problem.zero_error
    q = np.ascontiguousarray(problem.q, dtype=np.float64)
    return coulomb_error(problem, np.zeros(problem.m), q)


def coulomb_guard(problem, r, u) -> dict:
    """:func:`socp_cd.residuals.guard` for the Coulomb law, in the problem's own balanced units.

    ``r`` and ``u``: finite float64 vectors of length ``problem.m``; the
    scales are ``problem.balancing_scales``.
    """
    rs, us = balanced_pair(r, u, *problem.balancing_scales)
    if rs is None:
        return failed_guard()
    f2, r2, u2 = _parts(problem, rs, us)
    q_norm = problem.balanced_q_norm
    out = guard_values(float(relative_error(f2, r2, u2, q_norm)), math.sqrt(r2), math.sqrt(u2),
                       q_norm)
    cone, normal, gap = coulomb_violations(rs, us, problem.mu, problem.dim)
    vel = out["velocity_scale"]
    with np.errstate(all="ignore"):    # as coulomb_parts (the NumPy reference)
        out.update(cone=cone / vel, normal_velocity=normal / vel, complementarity=gap / vel ** 2)
    return finite_guard(out)


__all__ = ["coulomb_error", "coulomb_guard", "zero_error"]

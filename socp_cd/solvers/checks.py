"""The dispatcher's independent checks of a Coulomb answer, with the compiled kernels.

:func:`socp_cd.solve` recomputes Siconos' error of every answer and the units
guard (:func:`socp_cd.residuals.guard`).  For the Coulomb law it does so here
with the compiled twins of the NumPy references
(:func:`~socp_cd.solvers.kernels.cone.law_error`, held equal to
:func:`socp_cd.residuals.error` by ``tests/test_core.py``, beyond ~1e154 too) and the
compiled twins :func:`~socp_cd.solvers.kernels.cone.coulomb_violations` of
:func:`socp_cd.residuals.coulomb_parts` and
:func:`~socp_cd.solvers.kernels.scaling.balanced_guard` of the guard's
formulas (:func:`socp_cd.residuals.guard_values`), and the per-problem norms, unit
factors and error of ``r = 0`` computed once (the
:class:`~socp_cd.solvers.scaling.Balanced` record): on a one-contact problem
the NumPy references cost several times the solve itself.
``tests/test_checks.py`` holds these functions equal to the references.
"""
from __future__ import annotations

import numpy as np

from ..errors import InvalidProblemError
from ..problem import kernel_array
from ..residuals import failed_guard
from .kernels.cone import LAW_COULOMB, law_error
from .kernels.dense import csr_matvec_add
from .kernels.scaling import GUARD_KEYS, balanced_guard
from .scaling import balanced


def velocity(problem, r):
    """``u`` of ``r`` (float64 vector of length ``problem.m``): for a local problem the compiled
    twin of :meth:`~socp_cd.problem.FrictionContactProblem.velocity` (bit-identical, no scipy
    dispatch), for a global one the problem's own."""
    if problem.is_global:
        return problem.velocity(r)
    indptr, indices, data = problem.csr_parts
    return csr_matvec_add(indptr, indices, data, r, kernel_array(problem.q))


def coulomb_error(problem, r, u) -> float:
    """Siconos' relative error of ``r`` with ``u = W r + q`` given (= :func:`socp_cd.residuals.error`).

    ``r`` and ``u``: finite float64 vectors of length ``problem.m``.
    """
    return float(law_error(r, u, problem.mu, np.zeros(problem.n_contacts), problem.dim,
                           LAW_COULOMB, balanced(problem).raw_q_norm))


def zero_error(problem):
    """Siconos' error of ``r = 0`` (None when a global problem's ``M`` is singular).

    Compiled, once per problem, with the balancing
    (:func:`socp_cd.solvers.scaling.balanced`); equal to the problem's
    :attr:`~socp_cd.problem.FrictionContactProblem.zero_error` (for a global
    problem ``u = Hᵀ M⁻¹ f + w`` needs a solve with ``M``).
    """
    try:
        return balanced(problem).zero_error
    except InvalidProblemError:        # a global problem whose M is singular
        return None


def coulomb_guard(problem, r, u) -> dict:
    """:func:`socp_cd.residuals.guard` for the Coulomb law, in the problem's own balanced units.

    ``r`` and ``u``: finite float64 vectors of length ``problem.m``; the
    scales are those of :func:`socp_cd.solvers.scaling.balanced`; one
    compiled call (:func:`~socp_cd.solvers.kernels.scaling.balanced_guard`).
    """
    rec = balanced(problem)
    finite, out = balanced_guard(r, u, *rec.kernel_factors,
                                 np.ascontiguousarray(problem.mu, dtype=np.float64), problem.dim,
                                 rec.q_norm)
    return guard_record(finite, out)


def guard_record(finite, out) -> dict:
    """The guard's record from :func:`~socp_cd.solvers.kernels.scaling.balanced_guard`'s output."""
    if not finite:
        return failed_guard()
    return dict(zip(GUARD_KEYS, out.tolist()))


__all__ = ["coulomb_error", "coulomb_guard", "guard_record", "velocity", "zero_error"]

"""Dense condensation of a small global problem into its local form.

``W = Hᵀ M⁻¹ H`` and ``q = Hᵀ M⁻¹ f + w`` by one dense LU of ``M`` in compiled
code (:func:`socp_cd.solvers.kernels.dense.dense_condense`): same result as
:meth:`~socp_cd.problem.GlobalFrictionContactProblem.to_local` without the
sparse factorization and conversion overhead, which dominates a one-contact
solve.
"""
from __future__ import annotations

import numpy as np

from .problem import FrictionContactProblem
from .solvers.conic_data import dense_to_csr
from .solvers.kernels.dense import dense_condense

#: global problems with at most this many dofs are condensed densely
DENSE_CONDENSE_MAX = 200


def condense_dense(problem):
    """Local form of a small global problem (see the module docstring).

    A singular ``M`` falls back to ``to_local()`` (which raises
    :class:`~socp_cd.errors.InvalidProblemError`).
    """
    W, q, ok = dense_condense(np.ascontiguousarray(problem.M.toarray()),
                              np.ascontiguousarray(problem.H.toarray()),
                              np.ascontiguousarray(problem.f), np.ascontiguousarray(problem.w))
    if not ok:
        return problem.to_local()
    return FrictionContactProblem(dense_to_csr(W), q, problem.mu, problem.dim,
                                  source=problem.source, name=problem.name, info=problem.info)


__all__ = ["condense_dense", "DENSE_CONDENSE_MAX"]

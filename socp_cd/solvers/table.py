"""The explicit table of built-in solvers (each backend module defines its ``SPEC``).

Backends never import the dispatcher (:mod:`socp_cd.solvers.registry`); the
dispatcher reads this table.  A new solver: write its module with a ``SPEC``
(:class:`~socp_cd.solvers.spec.SolverSpec`) and add it here.
"""
from __future__ import annotations

from . import (auto, clarabel_backend, cvxpy_backend, lemke, newton, nsgs, projection,
               proxsuite_backend)

#: built-in solvers, in the order :func:`socp_cd.solvers` lists them
BUILTIN = (auto.SPEC, nsgs.SPEC, clarabel_backend.SPEC, newton.SPEC, cvxpy_backend.SPEC,
           proxsuite_backend.SPEC, projection.SPEC, lemke.SPEC)

__all__ = ["BUILTIN"]

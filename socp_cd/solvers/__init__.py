"""Solvers behind one :func:`solve` (the dispatcher :mod:`socp_cd.solvers.registry`).

Built-in solvers are listed in :mod:`socp_cd.solvers.table`; the common options
contract is :mod:`socp_cd.solvers.options`; compiled mathematics lives in
:mod:`socp_cd.solvers.kernels`.
"""
from .registry import FORMULATIONS, law_residual, register, solve, solvers, unregister
from .result import STATUSES, SolverResult
from .spec import SolverSpec

__all__ = ["solve", "solvers", "register", "unregister", "law_residual", "SolverResult",
           "SolverSpec", "STATUSES", "FORMULATIONS"]

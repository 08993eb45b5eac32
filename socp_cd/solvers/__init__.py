"""Solvers behind one :func:`solve` (see :mod:`socp_cd.solvers.registry`)."""
from .registry import FORMULATIONS, law_residual, register, solve, solvers
from .result import STATUSES, SolverResult

__all__ = ["solve", "solvers", "register", "law_residual", "SolverResult", "STATUSES", "FORMULATIONS"]

"""socp_cd — Moreau's Contact Dynamics in the language of convex analysis.

Discrete frictional contact problems (one Moreau–Jean time step each) are
loaded or built as :class:`FrictionContactProblem` (local, ``u = W r + q``) or
:class:`GlobalFrictionContactProblem` (``M v = H r + f``, ``u = H^T v + w``),
solved by :func:`solve` (NSGS, Clarabel SOCP fixed point, cvxpy, proxsuite),
and judged by :func:`error`, Siconos' relative error, and :func:`guard`, the same
residual in balanced units over the velocity scale (``solve`` accepts an answer
when both are within ``tol``).
"""
from .cones import (ContactStatus, bipotential, classify_contacts, desaxce_velocity,
                    fenchel_young_gap, natural_map, project_cone, project_dual_cone)
from .errors import (InvalidProblemError, ProblemFormatError, SocpCdError, SolverError,
                     UnsupportedError)
from .problem import FrictionContactProblem, GlobalFrictionContactProblem, Solution
from .residuals import absolute_error, complementarity, contact_errors, error, feasibility, guard
from .solvers import SolverResult, solve, solvers

__version__ = "0.1.0"


def read_problem(path, **kwargs):
    """Read a problem file, detecting its format (see :func:`socp_cd.io.read_problem`)."""
    from .io import read_problem as _read
    return _read(path, **kwargs)


def warmup(force: bool = False) -> float:
    """Load (or compile) every compiled kernel a solve may reach, once per process; returns
    seconds (see :func:`socp_cd.solvers.warm.warmup`).  Call it before timing solves or
    before the first call whose ``time_limit`` matters."""
    from .solvers.warm import warmup as _warmup
    return _warmup(force)


def write_fclib(problem, path, solution=None, **kwargs):
    """Write a problem to FCLib HDF5 (see :func:`socp_cd.io.write_fclib`)."""
    from .io import write_fclib as _write
    return _write(problem, path, solution=solution, **kwargs)


__all__ = [
    "FrictionContactProblem", "GlobalFrictionContactProblem", "Solution",
    "read_problem", "write_fclib", "solve", "solvers", "SolverResult", "warmup",
    "error", "guard", "absolute_error", "contact_errors", "feasibility", "complementarity",
    "project_cone", "project_dual_cone", "desaxce_velocity", "natural_map",
    "fenchel_young_gap", "bipotential", "classify_contacts", "ContactStatus",
    "SocpCdError", "InvalidProblemError", "ProblemFormatError", "UnsupportedError", "SolverError",
]

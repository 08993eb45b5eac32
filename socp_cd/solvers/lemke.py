"""Lemke's pivoting method on polyhedral laws written as LCPs (backend ``"lemke"``).

The exact Coulomb law in 2D and the frictionless law in 2D and 3D are linear complementarity
problems (:mod:`socp_cd.lcp`, ``formulations/lemke.md``): the friction "cone" of a 2D
contact is a wedge of two rays, so Signorini's and Coulomb's laws are sign conditions on
linear functions of ``(r_N, β⁺, β⁻, λ)``.  Lemke's complementary pivoting method solves such
an LCP in finitely many pivots, exactly up to rounding, with no tolerance, step or
iteration count to choose; Siconos' ``LEMKE`` (``fc2d_lexicolemke``) is the same method.
Where NSGS crawls on a small 2D problem (a slider crank: 367 sweeps) it takes a few pivots.

The tableau is dense, ``n x (2n + 1)`` with ``n = 4 nc`` (2D Coulomb) or ``nc``
(frictionless), and a pivot costs ``O(n²)``: a method for small problems.  Problems of
more than :data:`MAX_UNKNOWNS` LCP unknowns are refused before any work.

Options: none.  Common options: ``max_iter`` caps the pivots (default ``max(``
:data:`DEFAULT_MAX_ITER` ``, 20 n)``); ``time_limit`` is read every
:data:`~socp_cd.solvers.kernels.lemke.CLOCK_EVERY` pivots; ``r0`` is not used (pivoting
starts from the basis of ``w``); ``history``: not recorded; ``inner_settings``: rejected.
Status: ``converged`` (provisional: the dispatcher recomputes the error), ``numerical_error``
(a secondary ray: Lemke's method found no solution; the LCP may have none, or the method may
miss one: its matrix is copositive, not copositive-plus, and rounding can end the pivots on a
false ray at large ``μ``, ``formulations/lemke.md``), ``max_iter``, ``time_limit``.
``info``: ``pivots``, ``lcp_unknowns``, ``lemke`` (the outcome's name).
"""
from __future__ import annotations

import time

import numpy as np

from ..errors import UnsupportedError
from ..lcp import LEMKE_STATUS
from ..problem import kernel_array
from .kernels.clock import deadline_after
from .kernels.lemke import lemke, lemke_coulomb_2d
from .options import check_unknown
from .result import SolverResult
from .spec import SolverSpec

#: the least pivot cap when ``max_iter`` is None (the cap is ``max(this, 20 n)``)
DEFAULT_MAX_ITER = 1000
#: the largest LCP this backend builds (the tableau's ``n (2n + 1)`` floats, ``M`` and the
#: final solve's basis, ``n²`` each: ~82 MB at this size)
MAX_UNKNOWNS = 1600
#: outcome names (``info["lemke"]``) by code
_OUTCOMES = ("solved", "secondary ray", "pivot cap", "time limit")


def lcp_unknowns(problem, formulation) -> int:
    """The LCP's size ``n`` for ``problem`` under ``formulation``."""
    return problem.n_contacts * (4 if formulation == "coulomb" else 1)


def pivot_cap(n, max_iter) -> int:
    """The pivots allowed on an LCP of ``n`` unknowns: ``max_iter``, or when None
    ``max(DEFAULT_MAX_ITER, 20 n)``."""
    return max(DEFAULT_MAX_ITER, 20 * n) if max_iter is None else int(max_iter)


def check(problem, options, inner_settings) -> None:
    """Reject ``inner_settings`` and problems beyond :data:`MAX_UNKNOWNS` before any work."""
    if inner_settings:
        raise UnsupportedError("solver 'lemke': inner_settings does not apply (it has no "
                               "native settings)")
    nc = problem.n_contacts
    if nc > MAX_UNKNOWNS:           # (beyond the bound whatever the law: 1 or 4 per contact)
        raise UnsupportedError(f"solver 'lemke' builds a dense tableau: {nc} contacts is beyond "
                               f"its bound of {MAX_UNKNOWNS} LCP unknowns")


def lemke_backend(problem, formulation, *, tol, max_iter=None, r0=None, history=False,
                  time_limit=None, verbose=False, inner_settings=None,
                  **options) -> SolverResult:
    """Lemke backend for :func:`socp_cd.solve` (see the module docstring)."""
    check_unknown("lemke", options, {})
    check(problem, options, inner_settings)
    t0 = time.perf_counter()
    nc, d = problem.n_contacts, problem.dim
    if formulation == "coulomb" and d != 2:
        raise UnsupportedError("solver 'lemke' solves the exact Coulomb law in 2D only: the 3D "
                               "cone is round, not an LCP (use solver='auto', 'newton' or "
                               "'nsgs')")
    n = lcp_unknowns(problem, formulation)
    if n > MAX_UNKNOWNS:
        raise UnsupportedError(f"solver 'lemke' builds a dense tableau: {n} LCP unknowns "
                               f"({nc} contacts, {formulation!r}) is beyond its bound of "
                               f"{MAX_UNKNOWNS}")
    cap = pivot_cap(n, max_iter)
    deadline = deadline_after(time_limit)
    q = kernel_array(problem.q)
    if formulation == "coulomb":
        indptr, indices, data = problem.csr_parts
        r = np.empty(problem.m)
        code, pivots = lemke_coulomb_2d(indptr, indices, data, q, kernel_array(problem.mu), cap,
                                        deadline, r)
    else:                                           # frictionless: z = r_N, M = W_NN
        z = np.empty(n)
        code, pivots = lemke(kernel_array(problem.W[0::d, 0::d].toarray()),
                             kernel_array(q[0::d]), cap, deadline, z)
        r = np.zeros(problem.m)
        r[0::d] = z
    status = LEMKE_STATUS[code]
    info = {"pivots": int(pivots), "lcp_unknowns": n, "lemke": _OUTCOMES[code],
            "loop_time": time.perf_counter() - t0}
    message = {"secondary ray": "Lemke's method ended on a secondary ray: no solution found "
                                "(the LCP may have none, or the pivots missed one)",
               "pivot cap": f"{cap} pivots without a solution",
               "time limit": f"time_limit {time_limit!r} s reached after {pivots} pivots"
               }.get(info["lemke"], "")
    if verbose:
        print(f"lemke: {info['lemke']} after {pivots} pivots ({n} LCP unknowns)")
    return SolverResult(r=r, status=status, iterations=int(pivots), info=info, message=message)


SPEC = SolverSpec(
    "lemke", lemke_backend, ("coulomb", "frictionless"), dims=(2, 3),
    description="Lemke's complementary pivoting on the LCP of the law: exact Coulomb (2D), "
                "frictionless (2D/3D); dense tableau, small problems (numba)",
    default_max_iter=DEFAULT_MAX_ITER, options={},
    inner_settings="not applicable (rejected)", check=check)

__all__ = ["SPEC", "lemke_backend", "check", "lcp_unknowns", "pivot_cap", "DEFAULT_MAX_ITER",
           "MAX_UNKNOWNS"]

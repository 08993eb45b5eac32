"""Units balancing of a local problem before any backend runs (the dispatcher's apply/invert).

A problem written in mm·g·ms and the same problem in m·kg·s have the same
solution up to units, but a backend's internal tests (interior-point
tolerances, step sizes, Siconos' error with ``rho = 1``) are not unit-free.
:func:`socp_cd.solve` therefore hands every backend the *balanced* problem of
:func:`socp_cd.residuals.contact_scales` (``W~ = S W S``: unit mean diagonal
per contact block; ``q~ = S q / sigma``: unit root mean square) and maps the answer back:
``r = a r~``.  One positive scalar per contact keeps the cones and the law;
the factors are equivariant, so every written form of the problem reaches the
backend as the same balanced problem (up to rounding) and gets the same
answer.

Only local problems are balanced: a global problem solved natively by a
backend (``SolverSpec.global_native``) is passed as is (its ``M``, ``H`` would
need the matching change of ``v``); condensed ones are balanced as local
problems.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..problem import FrictionContactProblem, Solution
from ..residuals import contact_scales


@dataclass(frozen=True)
class Scaling:
    """Unit factors ``r = a r~``, ``u = b u~`` (each of length ``m``)."""

    a: np.ndarray
    b: np.ndarray
    dim: int

    def problem(self, problem: FrictionContactProblem) -> FrictionContactProblem:
        """The balanced problem ``u~ = (S W S) r~ + S q / sigma``."""
        s = np.sqrt(self.a / self.b)                    # s_i = 1/sqrt(d_i)
        Wc = problem.W.tocsr()
        rows = np.repeat(np.arange(problem.m), np.diff(Wc.indptr))
        W = sp.csr_matrix((Wc.data * (s[rows] * s[Wc.indices]), Wc.indices, Wc.indptr),
                          shape=Wc.shape)                # S W S, same sparsity, one copy
        return FrictionContactProblem(
            W, problem.q / self.b, problem.mu, problem.dim, source=problem.source,
            name=problem.name, info=problem.info,
            solution=None if problem.solution is None else self._solution(problem.solution),
            guesses=[self._solution(g) for g in problem.guesses])

    def _solution(self, sol: Solution) -> Solution:
        """A stored solution or guess in balanced units (``v`` is not a local quantity)."""
        return Solution(r=None if sol.r is None else sol.r / self.a,
                        u=None if sol.u is None else sol.u / self.b)

    def reaction_to_scaled(self, r):
        """``r~ = r / a`` (None stays None)."""
        return None if r is None else np.asarray(r, dtype=np.float64) / self.a

    def reaction_from_scaled(self, r):
        """``r = a r~`` (a wrong-sized or non-finite ``r~`` is passed on for the dispatcher to judge)."""
        r = np.asarray(r, dtype=np.float64).reshape(-1)
        if r.shape != self.a.shape:
            return r
        with np.errstate(all="ignore"):
            return r * self.a

    def threshold_to_scaled(self, g):
        """A per-contact bound on ``||r_T||`` (Tresca threshold) in balanced units."""
        return np.asarray(g, dtype=np.float64) / self.a[::self.dim]

    def describe(self) -> dict:
        """Short record for ``result.info["scaling"]``."""
        d = self.b[::self.dim] / self.a[::self.dim]          # = d_i (mean diagonal of W_ii)
        sigma = float(np.sqrt(self.a[0] * self.b[0]))
        return {"velocity_scale": sigma, "diag_min": float(d.min()), "diag_max": float(d.max())}


def balance(problem: FrictionContactProblem) -> Scaling:
    """The :class:`Scaling` of a local problem (:func:`~socp_cd.residuals.contact_scales`)."""
    a, b = contact_scales(problem)
    return Scaling(a, b, problem.dim)


__all__ = ["Scaling", "balance"]

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

from ..problem import FrictionContactProblem


@dataclass(frozen=True)
class Scaling:
    """Unit factors ``r = a r~``, ``u = b u~`` (each of length ``m``)."""

    a: np.ndarray
    b: np.ndarray
    dim: int

    def problem(self, problem: FrictionContactProblem) -> FrictionContactProblem:
        """The balanced problem ``u~ = (S W S) r~ + S q / sigma`` (:meth:`FrictionContactProblem.rescaled`).

        For the problem's own factors (:func:`balance`) it is the problem's
        cached ``balanced`` copy, built once.
        """
        a, b = problem.balancing_scales
        if self.a is a and self.b is b:
            return problem.balanced
        return problem.rescaled(self.a, self.b)

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
    """The :class:`Scaling` of a local problem (its cached ``balancing_scales``,
    :func:`~socp_cd.residuals.contact_scales`)."""
    a, b = problem.balancing_scales
    return Scaling(a, b, problem.dim)


__all__ = ["Scaling", "balance"]

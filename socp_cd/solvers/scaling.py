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

Everything per problem is computed once and kept on the problem object
(:meth:`~socp_cd.problem.FrictionContactProblem.derived`) as a :class:`Balanced`
record (:func:`balanced`), by compiled passes held equal to the NumPy reference
:func:`~socp_cd.residuals.contact_scales`: for a local problem
:func:`~socp_cd.solvers.kernels.scaling.balance_csr`, for a global one the
Jacobi estimate :func:`~socp_cd.solvers.kernels.scaling.jacobi_diagonal` and
:func:`~socp_cd.solvers.kernels.scaling.unit_factors`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..problem import FrictionContactProblem
from .kernels.scaling import (balance_csr, coulomb_zero_error, factor_summary, jacobi_diagonal,
                              times_factors, unit_factors)


@dataclass(frozen=True)
class Balanced:
    """What the dispatcher derives once per problem (:func:`balanced`).

    Attributes
    ----------
    a, b : ndarray (m,)
        Unit factors ``r = a r~``, ``u = b u~`` (:func:`socp_cd.residuals.contact_scales`;
        read-only).
    problem : FrictionContactProblem or None
        The balanced local problem ``u~ = (S W S) r~ + q / b`` handed to
        backends (its ``q`` read-only); None for a global problem.
    q_norm : float
        ``||q / b||`` (the units guard's normalization).
    raw_q_norm : float
        ``||q||`` of the problem as written (Siconos' normalization; ``q`` the
        local free velocity).
    zero_error : float
        Siconos' error of ``r = 0`` of the original problem (``u = q``, the
        local free velocity; compiled, equal to the problem's
        :attr:`~socp_cd.problem.FrictionContactProblem.zero_error`).
    kernel_factors : tuple
        Writable copies of ``(a, b)``, made once, for the compiled kernels that take the
        factors (numba compiles a kernel once more for read-only arrays:
        :func:`socp_cd.problem.kernel_array`); never written.
    """

    a: np.ndarray
    b: np.ndarray
    problem: Optional[FrictionContactProblem]
    q_norm: float
    raw_q_norm: float
    zero_error: float
    kernel_factors: tuple


def _compute(problem) -> Balanced:
    if problem.is_global:            # Jacobi estimate of diag(W) (a scale, not a solve)
        dM = np.abs(problem.M.diagonal())
        with np.errstate(divide="ignore"):
            inv = np.where(dM > 0, 1.0 / dM, 0.0)
        H = problem.H.tocsr()
        diag = jacobi_diagonal(H.indptr, H.indices, np.ascontiguousarray(H.data, dtype=np.float64),
                               inv, problem.m)
        q = np.ascontiguousarray(problem.q_local, dtype=np.float64)
        mu = np.ascontiguousarray(problem.mu, dtype=np.float64)
        a, b, _, q2, q_s2 = unit_factors(diag, q, problem.dim)
        q_norm = float(np.sqrt(q2))
        out = Balanced(a, b, None, float(np.sqrt(q_s2)), q_norm,
                       float(coulomb_zero_error(q, mu, problem.dim, q_norm)),
                       (a.copy(), b.copy()))
    else:
        indptr, indices, data = problem.csr_parts
        a, b, data_s, q_s, q_norm, q_s_norm, err0 = balance_csr(
            indptr, indices, data, np.ascontiguousarray(problem.q, dtype=np.float64),
            np.ascontiguousarray(problem.mu, dtype=np.float64), problem.dim)
        q_s.flags.writeable = False
        copy = problem.rescaled(a, b, W_data=data_s, q=q_s)
        factors = (a.copy(), b.copy())      # (writable: the kernels' one compiled version)
        units = factors + (float(q_norm),)
        copy.derived(_ORIGIN, lambda _: units)
        out = Balanced(a, b, copy, float(q_s_norm), float(q_norm), float(err0), factors)
    out.a.flags.writeable = False
    out.b.flags.writeable = False
    return out


#: ``derived`` key of a balanced copy's origin (:func:`origin`)
_ORIGIN = "solvers.scaling.origin"


def origin(problem):
    """``(a, b, ||q||)`` when ``problem`` is the balanced copy :func:`balanced` made of another
    (its unit factors, ``r = a r~``, ``u = b u~``, and ``||q||`` of the problem as
    written), else None.  A backend running on the copy can so stop on the dispatcher's
    own measure (:func:`socp_cd.solvers.kernels.scaling.origin_error`).  For a global
    problem condensed to a local one, "as written" means the condensed local problem
    (the dispatcher's Coulomb error of a global problem is measured on it too)."""
    return problem.derived(_ORIGIN, _none)


def _none(problem):
    return None


def balanced(problem) -> Balanced:
    """The problem's :class:`Balanced` record, computed once per problem object."""
    return problem.derived("solvers.scaling", _compute)


@dataclass(frozen=True)
class Scaling:
    """Unit factors ``r = a r~``, ``u = b u~`` (each of length ``m``; from :func:`balance`,
    the :class:`Balanced` record's ``kernel_factors``, which its methods pass to kernels)."""

    a: np.ndarray
    b: np.ndarray
    dim: int

    def problem(self, problem: FrictionContactProblem) -> FrictionContactProblem:
        """The balanced problem ``u~ = (S W S) r~ + S q / sigma`` (:meth:`FrictionContactProblem.rescaled`).

        For the problem's own factors (:func:`balance`) it is the balanced copy
        of its :class:`Balanced` record, built once.
        """
        rec = balanced(problem)
        if self.a is rec.kernel_factors[0] and self.b is rec.kernel_factors[1]:
            return rec.problem
        return problem.rescaled(self.a, self.b)

    def reaction_to_scaled(self, r):
        """``r~ = r / a`` (None stays None)."""
        return None if r is None else np.asarray(r, dtype=np.float64) / self.a

    def reaction_from_scaled(self, r):
        """``r = a r~`` (a wrong-sized or non-finite ``r~`` is passed on for the dispatcher to judge)."""
        r = np.asarray(r, dtype=np.float64).reshape(-1)
        if r.shape != self.a.shape:
            return r
        return times_factors(r, self.a)

    def threshold_to_scaled(self, g):
        """A per-contact bound on ``||r_T||`` (Tresca threshold) in balanced units."""
        return np.asarray(g, dtype=np.float64) / self.a[::self.dim]

    def describe(self) -> dict:
        """Short record for ``result.info["scaling"]``."""
        # d_i = b_i / a_i (mean diagonal of W_ii); one compiled pass
        sigma, d_min, d_max = factor_summary(self.a, self.b, self.dim)
        return {"velocity_scale": sigma, "diag_min": d_min, "diag_max": d_max}


def balance(problem: FrictionContactProblem) -> Scaling:
    """The :class:`Scaling` of a local problem (the factors of its :class:`Balanced` record)."""
    rec = balanced(problem)
    return Scaling(*rec.kernel_factors, problem.dim)


__all__ = ["Balanced", "Scaling", "balance", "balanced", "origin"]

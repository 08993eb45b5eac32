"""Traction across a cut through a granular sample, and its continuum counterpart.

A *cut* is a segment (2D) or a disc (3D) centred at ``point`` with unit
normal ``n``.  A contact *crosses* the cut when its branch segment — between
the two grain centres, or between the grain centre and the contact point for
a fixed obstacle — intersects it.  The traction is the resultant of the forces
exerted by the grains on the ``+n`` side on the grains on the ``-n`` side,
divided by the cut length (2D) or area (3D).  For a continuum with stress
``σ`` (tension positive) the same quantity is ``t = σ n``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidProblemError
from .state import GranularState

__all__ = ["cut_traction", "CutSweep", "cut_sweep", "continuum_traction",
           "cauchy_deviation"]


def _unit(normal, d):
    n = np.asarray(normal, dtype=float).reshape(-1)
    if n.shape != (d,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0:
        raise InvalidProblemError("normal", f"expected a nonzero vector of length {d}")
    return n / np.linalg.norm(n)


def _crossing(state: GranularState, point, n, length):
    """Signed weights (+1/-1/0) of each contact force in the cut resultant."""
    if not (np.isfinite(length) and length > 0):
        raise InvalidProblemError("length", f"must be positive, got {length!r}")
    x0 = np.asarray(point, dtype=float).reshape(-1)
    if x0.shape != (state.dim,):
        raise InvalidProblemError("point", f"expected a point of dimension {state.dim}")
    i, j = state.pairs[:, 0], state.pairs[:, 1]
    a = state.centers[i]
    b = np.where((j >= 0)[:, None], state.centers[np.maximum(j, 0)], state.points)
    sa = (a - x0) @ n
    sb = (b - x0) @ n
    # half-open convention so that an endpoint lying on the cut is counted once
    cross = ((sa < 0) & (sb >= 0)) | ((sb < 0) & (sa >= 0))
    denom = np.where(cross, sa - sb, 1.0)
    t = np.where(cross, sa / denom, 0.0)
    y = a + t[:, None] * (b - a) - x0
    y_t = y - np.outer(y @ n, n)                      # in-cut offset from the centre
    cross &= np.linalg.norm(y_t, axis=1) <= 0.5 * length
    # i on the - side receives +f from j (on the + side); otherwise the + side body is i
    return np.where(cross, np.where(sa < 0, 1.0, -1.0), 0.0)


def cut_traction(state: GranularState, point, normal, length) -> np.ndarray:
    """Traction vector across a cut: resultant of crossing contact forces per unit size.

    Parameters
    ----------
    state : GranularState
    point : array_like (d,)
        Centre of the cut.
    normal : array_like (d,)
        Cut normal ``n`` (normalised here).  The traction is the force exerted
        by the ``+n`` side on the ``-n`` side, so that ``t = σ n``.
    length : float
        2D: segment length.  3D: disc diameter (area ``π length² / 4``).

    Returns
    -------
    ndarray (d,)
    """
    n = _unit(normal, state.dim)
    w = _crossing(state, point, n, float(length))
    size = float(length) if state.dim == 2 else np.pi * float(length) ** 2 / 4
    return w @ state.forces / size


@dataclass(frozen=True)
class CutSweep:
    """Tractions across 2D cuts at angles θ (normal ``n = (cos θ, sin θ)``)."""

    angles: np.ndarray          #: θ, radians
    tractions: np.ndarray       #: (nθ, 2) traction vectors
    normal: np.ndarray          #: t · n
    shear: np.ndarray           #: t · τ, τ = (-sin θ, cos θ)
    n_crossing: np.ndarray      #: number of contacts crossing each cut


def cut_sweep(state: GranularState, point, length, angles=None) -> CutSweep:
    """Tractions across cuts through ``point`` for a set of normal angles (2D).

    Parameters
    ----------
    angles : array_like, optional
        Normal angles θ in radians (default 90 values over ``[0, π)``).
    """
    if state.dim != 2:
        raise InvalidProblemError("state", "cut_sweep is 2D; use cut_traction in 3D")
    th = np.linspace(0, np.pi, 90, endpoint=False) if angles is None else np.asarray(angles, float)
    N = np.stack([np.cos(th), np.sin(th)], axis=1)
    T = np.stack([-np.sin(th), np.cos(th)], axis=1)
    W = np.stack([_crossing(state, point, n, float(length)) for n in N])  # (nθ, nc)
    t = W @ state.forces / float(length)
    return CutSweep(angles=th, tractions=t, normal=np.einsum("kd,kd->k", t, N),
                    shear=np.einsum("kd,kd->k", t, T),
                    n_crossing=np.count_nonzero(W, axis=1))


def continuum_traction(sigma, angles):
    """Continuum tractions ``σ n(θ)`` and their normal/shear components (2D).

    Returns
    -------
    tractions : (nθ, 2), normal : (nθ,), shear : (nθ,)
        With ``A >= B`` the principal values and ``φ`` the angle of θ measured
        from the ``A`` direction: ``normal = (A+B)/2 + (A-B)/2 cos 2φ`` and
        ``shear = -(A-B)/2 sin 2φ`` (for the symmetric part of ``σ``).
    """
    S = np.asarray(sigma, dtype=float)
    th = np.asarray(angles, dtype=float)
    N = np.stack([np.cos(th), np.sin(th)], axis=1)
    T = np.stack([-np.sin(th), np.cos(th)], axis=1)
    t = N @ S.T
    return t, np.einsum("kd,kd->k", t, N), np.einsum("kd,kd->k", t, T)


def cauchy_deviation(sweep: CutSweep, sigma) -> float:
    """RMS over θ of ``|t_cut(θ) - σ n(θ)|`` relative to the mean stress ``|(A+B)/2|``."""
    t, _, _ = continuum_traction(sigma, sweep.angles)
    mean = abs(np.trace(np.asarray(sigma, float))) / 2
    rms = np.sqrt(np.mean(np.sum((sweep.tractions - t) ** 2, axis=1)))
    return float(rms / mean) if mean else float("inf")

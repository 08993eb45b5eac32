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
           "cauchy_deviation", "region_balance"]


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


def region_balance(state: GranularState, vertices):
    """Discrete ``div σ + f = 0`` on a convex polygonal region (2D).

    The boundary integral of the traction is the sum, over the polygon's
    edges, of :func:`cut_traction` times the edge length with the *outward*
    normal (force of the outside on the inside).  The load ``f`` is the body
    forces (gravity, inertia) of the grains whose centres lie inside plus the
    forces of fixed obstacles whose contact points lie inside (supports; none
    for a region away from the walls).  A branch segment leaving the region
    crosses its boundary once, one passing through it twice with opposite
    signs, so at equilibrium ``boundary + load = 0`` exactly (to the balance
    of each grain).

    Parameters
    ----------
    vertices : array_like (m, 2)
        Convex polygon, either orientation, ``m >= 3``.

    Returns
    -------
    boundary : ndarray (2,)
        Resultant of the contact forces exerted across the boundary on the inside.
    load : ndarray (2,)
        Body forces of the grains inside plus the obstacle forces applied inside.
    inside : ndarray of bool (nb,)
        Grains whose centre is inside.
    """
    if state.dim != 2:
        raise InvalidProblemError("state", "region_balance is 2D")
    P = np.asarray(vertices, dtype=float)
    if P.ndim != 2 or P.shape[0] < 3 or P.shape[1] != 2 or not np.all(np.isfinite(P)):
        raise InvalidProblemError("vertices", f"expected a finite (m >= 3, 2) polygon, got {P.shape}")
    E = np.roll(P, -1, axis=0) - P
    if np.any(np.hypot(E[:, 0], E[:, 1]) == 0):
        raise InvalidProblemError("vertices", "repeated vertex")
    area2 = float(np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]))
    if area2 == 0:
        raise InvalidProblemError("vertices", "degenerate polygon (zero area)")
    sgn = 1.0 if area2 > 0 else -1.0                 # counter-clockwise: outward = (ey, -ex)

    def within(X):
        cr = E[:, 0][None, :] * (X[:, 1][:, None] - P[:, 1][None, :]) \
            - E[:, 1][None, :] * (X[:, 0][:, None] - P[:, 0][None, :])
        return np.all(sgn * cr > 0, axis=1)

    inside = within(state.centers)
    boundary = np.zeros(2)
    for p, e in zip(P, E):
        length = float(np.hypot(*e))
        n_out = sgn * np.array([e[1], -e[0]]) / length
        boundary += cut_traction(state, p + e / 2, n_out, length) * length
    support = state.wall_contacts & within(state.points)
    load = state.body_forces()[inside].sum(axis=0) + state.forces[support].sum(axis=0)
    return boundary, load, inside

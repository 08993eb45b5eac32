"""Moreau's average stress tensor and the Love–Weber tensor.

Sign convention: continuum mechanics (tension positive), i.e. a compressed
sample has negative principal stresses.  Tensors are ``d x d`` arrays indexed
``[position, force]``: ``(c ⊗ f)_{ab} = c_a f_b``.

Moreau (internal moment)
    For a sample ``S`` of grains occupying a region of volume ``V`` (voids
    included),  ``σ̄ = (1/V) Σ_{B∈S} Σ_E c^{BE} ⊗ f^{BE}``  over every action
    ``E`` on grain ``B``: contacts (point ``c``, force ``f`` exerted on ``B``),
    gravity ``m_B g`` and inertia ``-m_B a_B`` at the centre of mass.
    Actions between two grains of ``S`` cancel pairwise (same point, opposite
    forces), so only the actions *external* to ``S`` remain (the discrete
    Gauss–Ostrogradsky identity ``∫σ = ∮ x⊗t + ∫ x⊗b``).

Weber (Love–Weber)
    ``σ_W = (1/V) Σ_{internal contacts} l^c ⊗ f^c`` with the branch vector
    ``l^c = x_j - x_i`` and ``f^c`` the force exerted by ``j`` on ``i`` (for a
    repulsive contact ``l`` and ``f`` are opposite: compression negative).

Decomposition (derived in formulations/stress.md)
    At equilibrium ``Σ_E f^{BE} = 0`` for each grain, so the moments may be
    taken about each grain's centre: ``σ̄ = σ_ext + σ_W`` with
    ``σ_ext = (1/V) Σ_{B∈S} Σ_{E external contact} (c^{BE} - x_B) ⊗ f^{BE}``
    (gravity and inertia act at ``x_B`` and drop out).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidProblemError
from .state import GranularState

__all__ = ["sample_mask", "internal_moment", "moreau_stress", "weber_stress",
           "external_stress", "StressReport", "stress_report", "principal",
           "asymmetry", "relative_difference"]


def sample_mask(state: GranularState, sample=None) -> np.ndarray:
    """Boolean mask over bodies for ``sample`` (None = all, bool mask or indices)."""
    nb = state.n_bodies
    if sample is None:
        return np.ones(nb, dtype=bool)
    s = np.asarray(sample)
    if s.dtype == bool:
        if s.shape != (nb,):
            raise InvalidProblemError("sample", f"mask shape {s.shape}, expected ({nb},)")
        return s
    if s.size and (s.min() < 0 or s.max() >= nb):
        raise InvalidProblemError("sample", f"body index out of range [0, {nb})")
    m = np.zeros(nb, dtype=bool)
    m[s.astype(np.int64)] = True
    return m


def _volume(volume) -> float:
    v = float(volume)
    if not np.isfinite(v) or v <= 0:
        raise InvalidProblemError("volume", f"must be a positive number, got {volume!r}")
    return v


def _sides(state: GranularState, inside: np.ndarray):
    """Per contact: is body i in S, is body j in S (False for walls)."""
    i, j = state.pairs[:, 0], state.pairs[:, 1]
    in_i = inside[i]
    in_j = np.zeros_like(in_i)
    body = j >= 0
    in_j[body] = inside[j[body]]
    return in_i, in_j


def internal_moment(state: GranularState, sample=None, origin=None) -> np.ndarray:
    """Moreau's internal moment ``M(S) = Σ_{B∈S} Σ_E (c^{BE} - o) ⊗ f^{BE}``.

    Every action on every grain of ``S`` is summed (contacts on both of their
    bodies, gravity and inertia at the centres), so that actions internal to
    ``S`` cancel exactly rather than by construction.

    Parameters
    ----------
    state : GranularState
    sample : None, bool mask (nb,) or index array
        Grains of ``S`` (default: all).
    origin : array_like (d,), optional
        Reference point ``o`` (default 0).  At equilibrium ``M`` does not
        depend on it (the total force on ``S`` vanishes).

    Returns
    -------
    ndarray, shape (d, d)
    """
    inside = sample_mask(state, sample)
    o = np.zeros(state.dim) if origin is None else np.asarray(origin, dtype=float)
    in_i, in_j = _sides(state, inside)
    rel = state.points - o
    # contact k acts with +f on i and -f on j: weight (+1 if i∈S) + (-1 if j∈S)
    w = in_i.astype(float) - in_j.astype(float)
    M = np.einsum("k,ka,kb->ab", w, rel, state.forces)
    fb = state.body_forces()[inside]
    M += np.einsum("ka,kb->ab", state.centers[inside] - o, fb)
    return M


def moreau_stress(state: GranularState, volume, sample=None, origin=None) -> np.ndarray:
    """Moreau's average stress ``σ̄ = M(S) / V`` (see :func:`internal_moment`).

    Parameters
    ----------
    volume : float
        Volume (area in 2D) of the region occupied by ``S``, voids included.
    """
    return internal_moment(state, sample, origin) / _volume(volume)


def _reference(state: GranularState, reference) -> np.ndarray:
    """Reference point of each grain: its centre, or the given ``(nb, d)`` points."""
    if reference is None:
        return state.centers
    ref = np.asarray(reference, dtype=float)
    if ref.shape != state.centers.shape or not np.all(np.isfinite(ref)):
        raise InvalidProblemError("reference", f"shape {ref.shape}, expected finite "
                                  f"{state.centers.shape}")
    return ref


def weber_stress(state: GranularState, volume, sample=None, reference=None) -> np.ndarray:
    """Love–Weber tensor ``(1/V) Σ_{c internal to S} l^c ⊗ f^c``.

    ``l^c = x_j - x_i`` (branch vector between the reference points of the
    two grains: their centres unless ``reference`` (nb, d) is given),
    ``f^c`` = force exerted by ``j`` on ``i``.  Not symmetric in general, and
    it depends on the reference points (Moreau's tensor does not).
    """
    inside = sample_mask(state, sample)
    x = _reference(state, reference)
    in_i, in_j = _sides(state, inside)
    k = in_i & in_j
    i, j = state.pairs[k, 0], state.pairs[k, 1]
    branch = x[j] - x[i]
    return np.einsum("ka,kb->ab", branch, state.forces[k]) / _volume(volume)


def external_stress(state: GranularState, volume, sample=None, reference=None) -> np.ndarray:
    """External-action term ``(1/V) Σ_{B∈S} Σ_{E ∉ S} (c^{BE} - x_B) ⊗ f^{BE}``.

    Contacts of grains of ``S`` with walls or grains outside ``S``, moments
    taken about the grain's reference point ``x_B`` (its centre unless
    ``reference`` is given; gravity and inertia act at the centre and add
    ``(x_centre - x_B) ⊗ (body force)``, zero for the centre).  For any
    reference points ``σ̄ = σ_ext + σ_W`` at equilibrium.
    """
    inside = sample_mask(state, sample)
    x = _reference(state, reference)
    in_i, in_j = _sides(state, inside)
    i, j = state.pairs[:, 0], state.pairs[:, 1]
    a = in_i & ~in_j                      # i in S, j outside / wall: +f on i
    b = in_j & ~in_i                      # j in S, i outside: -f on j
    M = np.einsum("ka,kb->ab", state.points[a] - x[i[a]], state.forces[a])
    M -= np.einsum("ka,kb->ab", state.points[b] - x[j[b]], state.forces[b])
    if reference is not None:
        M += np.einsum("ka,kb->ab", (state.centers - x)[inside], state.body_forces()[inside])
    return M / _volume(volume)


def asymmetry(tensor) -> float:
    """``||skew(T)|| / ||T||`` (Frobenius norms); 0 for a symmetric tensor."""
    T = np.asarray(tensor, dtype=float)
    n = np.linalg.norm(T)
    return 0.0 if n == 0 else float(np.linalg.norm(0.5 * (T - T.T)) / n)


def relative_difference(a, b) -> float:
    """``||a - b|| / ||a||`` (Frobenius)."""
    a = np.asarray(a, float)
    n = np.linalg.norm(a)
    return float(np.linalg.norm(a - np.asarray(b, float)) / n) if n else float(np.linalg.norm(b))


def principal(tensor):
    """Principal values and directions of the symmetric part of a tensor.

    Returns
    -------
    values : ndarray (d,)
        Eigenvalues in *decreasing* order (``A >= B`` in 2D; with the
        tension-positive convention ``B`` is the most compressive).
    vectors : ndarray (d, d)
        Columns are the matching unit eigenvectors.
    """
    T = np.asarray(tensor, dtype=float)
    w, v = np.linalg.eigh(0.5 * (T + T.T))
    order = np.argsort(w)[::-1]
    return w[order], v[:, order]


@dataclass(frozen=True)
class StressReport:
    """Moreau stress, its two-term decomposition and comparison numbers."""

    moreau: np.ndarray
    weber: np.ndarray
    external: np.ndarray
    volume: float
    #: ||σ̄ - σ_W|| / ||σ̄||
    weber_difference: float
    #: ||skew σ̄|| / ||σ̄||
    moreau_asymmetry: float
    #: ||skew σ_W|| / ||σ_W||
    weber_asymmetry: float
    #: ||σ̄ - (σ_ext + σ_W)|| / ||σ̄|| (zero at equilibrium)
    decomposition_residual: float
    #: max_B ||resultant on B|| / max contact force (equilibrium check)
    equilibrium_residual: float


def stress_report(state: GranularState, volume, sample=None) -> StressReport:
    """Compute σ̄ (Moreau), σ_W (Weber), σ_ext and their comparison numbers."""
    s = moreau_stress(state, volume, sample)
    w = weber_stress(state, volume, sample)
    e = external_stress(state, volume, sample)
    inside = sample_mask(state, sample)
    res = np.linalg.norm(state.resultants()[inside], axis=1)
    scale = max(np.abs(state.forces).max(initial=0.0),
                np.linalg.norm(state.body_forces(), axis=1).max(initial=0.0))
    return StressReport(
        moreau=s, weber=w, external=e, volume=_volume(volume),
        weber_difference=relative_difference(s, w), moreau_asymmetry=asymmetry(s),
        weber_asymmetry=asymmetry(w), decomposition_residual=relative_difference(s, e + w),
        equilibrium_residual=float(res.max(initial=0.0) / scale) if scale else 0.0)

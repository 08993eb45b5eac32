"""Contact statistics of a granular sample: coordination, force distribution, fabric."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidProblemError
from .state import GranularState
from .stress import sample_mask

__all__ = ["contact_counts", "rattlers", "coordination_number", "ForceDistribution",
           "force_distribution", "fabric_tensor"]


def _active(state: GranularState, threshold: float) -> np.ndarray:
    return np.linalg.norm(state.forces, axis=1) > threshold


def contact_counts(state: GranularState, threshold: float = 0.0, walls: bool = True) -> np.ndarray:
    """Number of active contacts (force norm ``> threshold``) of each body."""
    act = _active(state, threshold)
    if not walls:
        act &= state.pairs[:, 1] >= 0
    cnt = np.bincount(state.pairs[act, 0], minlength=state.n_bodies)
    j = state.pairs[act, 1]
    cnt += np.bincount(j[j >= 0], minlength=state.n_bodies)
    return cnt


def rattlers(state: GranularState, min_contacts: int | None = None,
             threshold: float = 0.0) -> np.ndarray:
    """Boolean mask of rattlers: grains with fewer than ``min_contacts`` active contacts.

    Removal is iterated (a grain that loses contacts when its rattler
    neighbours are removed may become a rattler).  Default ``min_contacts =
    d`` (2 in 2D, 3 in 3D): a frictional grain needs at least that many
    contacts to be held.  Wall contacts count.
    """
    k = state.dim if min_contacts is None else int(min_contacts)
    act = _active(state, threshold)
    i, j = state.pairs[:, 0], state.pairs[:, 1]
    rat = np.zeros(state.n_bodies, dtype=bool)
    while True:
        keep = act & ~rat[i] & ~((j >= 0) & rat[np.maximum(j, 0)])
        cnt = np.bincount(i[keep], minlength=state.n_bodies)
        cnt += np.bincount(j[keep & (j >= 0)], minlength=state.n_bodies)
        new = (cnt < k) & ~rat
        if not new.any():
            return rat
        rat |= new


def coordination_number(state: GranularState, sample=None, exclude_rattlers: bool = False,
                        walls: bool = False, threshold: float = 0.0) -> float:
    """Mean number of active contacts per grain of ``sample``.

    Parameters
    ----------
    exclude_rattlers : bool
        Drop rattlers (see :func:`rattlers`) from the count and the average.
    walls : bool
        Count contacts with fixed obstacles (default: grain–grain only, the
        usual ``z = 2 N_c / N_g``).
    """
    inside = sample_mask(state, sample)
    if exclude_rattlers:
        rat = rattlers(state, threshold=threshold)
        inside = inside & ~rat
        act = _active(state, threshold)
        j = state.pairs[:, 1]
        act &= ~rat[state.pairs[:, 0]] & ~((j >= 0) & rat[np.maximum(j, 0)])
        state = state.subset(act)
    n = int(inside.sum())
    if n == 0:
        raise InvalidProblemError("sample", "no grain left to average over")
    return float(contact_counts(state, threshold, walls=walls)[inside].sum() / n)


@dataclass(frozen=True)
class ForceDistribution:
    """Normal contact forces normalised by their mean."""

    mean: float                 #: <f_N> over active contacts
    fraction_above_mean: float  #: share of contacts with f_N > <f_N>
    share_of_strong: float      #: share of Σ f_N carried by the contacts above the mean
    edges: np.ndarray           #: histogram bin edges in units of <f_N>
    density: np.ndarray         #: probability density over those bins
    n_contacts: int


def force_distribution(state: GranularState, bins=None, walls: bool = False,
                       threshold: float = 0.0) -> ForceDistribution:
    """Distribution of normal forces ``f_N / <f_N>`` over active contacts.

    ``f_N = f · n`` when normals are known, ``|f|`` otherwise.
    """
    fn = state.normal_forces()
    keep = _active(state, threshold) & (fn > 0)
    if not walls:
        keep &= state.pairs[:, 1] >= 0
    fn = fn[keep]
    if fn.size == 0:
        raise InvalidProblemError("forces", "no active contact")
    mean = fn.mean()
    x = fn / mean
    edges = np.linspace(0, max(4.0, x.max()), 41) if bins is None else np.asarray(bins, float)
    dens, edges = np.histogram(x, bins=edges, density=True)
    strong = x > 1
    return ForceDistribution(mean=float(mean), fraction_above_mean=float(strong.mean()),
                             share_of_strong=float(fn[strong].sum() / fn.sum()),
                             edges=edges, density=dens, n_contacts=int(fn.size))


def fabric_tensor(state: GranularState, walls: bool = False, weighted: bool = False,
                  threshold: float = 0.0) -> np.ndarray:
    """Fabric tensor ``<n ⊗ n>`` over active contacts (trace 1).

    ``weighted=True`` weights each contact by its normal force (the
    force-weighted fabric).  Normals come from ``state.normals`` or, when
    absent, from the branch vector / force direction.
    """
    keep = _active(state, threshold)
    if not walls:
        keep &= state.pairs[:, 1] >= 0
    if state.normals is not None:
        n = state.normals[keep]
    else:
        i, j = state.pairs[keep, 0], state.pairs[keep, 1]
        n = np.where((j >= 0)[:, None], state.centers[i] - state.centers[np.maximum(j, 0)],
                     state.forces[keep])
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
    if n.shape[0] == 0:
        raise InvalidProblemError("forces", "no active contact")
    w = np.abs(state.normal_forces()[keep]) if weighted else np.ones(n.shape[0])
    return np.einsum("k,ka,kb->ab", w, n, n) / w.sum()

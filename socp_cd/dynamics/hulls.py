"""Padded array tables of convex polyhedra for the compiled narrow phase.

A :class:`HullTable` packs several :class:`~socp_cd.dynamics.geometry3d.Hull`
objects into fixed-width arrays (padding repeats the last valid entry and is
never read: every loop stops at the row's count).  :func:`world_hulls` maps
the body-frame table to world coordinates for given rotations and
translations; the kernels of :mod:`~socp_cd.dynamics.narrow3d` work on that.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class HullTable(NamedTuple):
    """Polyhedra as padded arrays (``P`` rows).

    Attributes
    ----------
    V : (P, vmax, 3) vertices; NV : (P,) counts
    FN : (P, fmax, 3) outward unit face normals; NF : (P,) counts
    FL : (P, fmax, kmax) face vertex loops (counter-clockwise from outside); FK : (P, fmax) loop lengths
    E : (P, emax, 2) edges (vertex pairs); EDIR : (P, emax) direction index; NE : (P,) counts
    D : (P, dmax, 3) distinct unit edge directions; ND : (P,) counts
    radius : (P,) bounding radius about the centroid
    """

    V: np.ndarray
    NV: np.ndarray
    FN: np.ndarray
    NF: np.ndarray
    FL: np.ndarray
    FK: np.ndarray
    E: np.ndarray
    EDIR: np.ndarray
    NE: np.ndarray
    D: np.ndarray
    ND: np.ndarray
    radius: np.ndarray

    @property
    def n(self) -> int:
        return int(self.NV.shape[0])


def pack_hulls(hulls) -> HullTable:
    """A :class:`HullTable` of a list of :class:`~socp_cd.dynamics.geometry3d.Hull`."""
    P = len(hulls)
    if P == 0:
        z3 = np.zeros((0, 1, 3))
        zi = np.zeros(0, np.int64)
        return HullTable(z3, zi, z3, zi, np.zeros((0, 1, 1), np.int64), np.zeros((0, 1), np.int64),
                         np.zeros((0, 1, 2), np.int64), np.zeros((0, 1), np.int64), zi, z3, zi, np.zeros(0))
    vmax = max(len(h.vertices) for h in hulls)
    fmax = max(len(h.faces) for h in hulls)
    kmax = max(len(f) for h in hulls for f in h.faces)
    emax = max(len(h.edges) for h in hulls)
    dmax = max(len(h.directions) for h in hulls)
    V = np.zeros((P, vmax, 3))
    FN = np.zeros((P, fmax, 3))
    FL = np.zeros((P, fmax, kmax), np.int64)
    FK = np.zeros((P, fmax), np.int64)
    E = np.zeros((P, emax, 2), np.int64)
    EDIR = np.zeros((P, emax), np.int64)
    D = np.zeros((P, dmax, 3))
    for p, h in enumerate(hulls):
        V[p, :len(h.vertices)] = h.vertices
        V[p, len(h.vertices):] = h.vertices[-1]
        FN[p, :len(h.faces)] = h.normals
        for f, loop in enumerate(h.faces):
            FL[p, f, :len(loop)] = loop
            FK[p, f] = len(loop)
        E[p, :len(h.edges)] = h.edges
        EDIR[p, :len(h.edges)] = h.edge_dir
        D[p, :len(h.directions)] = h.directions
    return HullTable(V, np.array([len(h.vertices) for h in hulls], np.int64), FN,
                     np.array([len(h.faces) for h in hulls], np.int64), FL, FK, E, EDIR,
                     np.array([len(h.edges) for h in hulls], np.int64), D,
                     np.array([len(h.directions) for h in hulls], np.int64),
                     np.array([h.bounding_radius for h in hulls]))


def world_hulls(table: HullTable, R: np.ndarray, t: np.ndarray) -> HullTable:
    """The table with vertices ``R x + t``, normals and directions ``R n`` (rows' ``R`` (P, 3, 3), ``t`` (P, 3))."""
    return table._replace(V=np.einsum("pij,pvj->pvi", R, table.V) + t[:, None, :],
                          FN=np.einsum("pij,pfj->pfi", R, table.FN),
                          D=np.einsum("pij,pdj->pdi", R, table.D))


def concat_tables(a: HullTable, b: HullTable) -> HullTable:
    """Rows of ``a`` then rows of ``b`` (re-padded to common widths)."""
    if a.n == 0:
        return b
    if b.n == 0:
        return a
    out = []
    for x, y in zip(a, b):
        if x.ndim > 1:
            w = [max(p, q) for p, q in zip(x.shape[1:], y.shape[1:])]
            out.append(np.concatenate([_pad(x, w), _pad(y, w)], axis=0))
        else:
            out.append(np.concatenate([x, y]))
    return HullTable(*out)


def _pad(x: np.ndarray, widths) -> np.ndarray:
    if list(x.shape[1:]) == list(widths):
        return x
    out = np.zeros((x.shape[0], *widths), dtype=x.dtype)
    out[tuple([slice(None)] + [slice(0, s) for s in x.shape[1:]])] = x
    return out


__all__ = ["HullTable", "pack_hulls", "world_hulls", "concat_tables"]

"""Contact detection: k-d tree broad phase and exact narrow phase.

:func:`detect` returns a :class:`Contacts` set for the current configuration
of a :class:`~socp_cd.dynamics.scene.System`.  Conventions, used everywhere in
:mod:`socp_cd.dynamics`:

* a contact joins body ``i`` (always a dynamic body) and ``j`` (a body index,
  or ``-1`` for a fixed obstacle, whose index is then in ``obstacle``);
* ``normal`` is the unit normal pointing from ``j`` into ``i``;
* ``gap`` is the signed distance (``< 0``: penetration);
* ``point`` is the midpoint of the two surfaces' closest points;
* ``key`` is a persistent identity (pair + geometric feature), used to warm
  start the next step from this step's impulses.

Supported pairs: disk–disk, disk–line, disk–polygon, polygon–polygon (up to
two points, by separating axes and clipping), polygon–line, and their
fixed-obstacle variants; sphere–sphere, sphere–plane in 3D.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .narrow import disk_poly, poly_poly

_FID_BITS = 16


@dataclass
class Contacts:
    """A set of contacts (all arrays share the first dimension ``nc``).

    Attributes
    ----------
    i, j : ndarray (nc,) int
        Dynamic body, and other body or ``-1`` for an obstacle.
    obstacle : ndarray (nc,) int
        Index in ``scene.obstacles`` (``-1`` for body–body contacts).
    point, normal : ndarray (nc, d)
    gap : ndarray (nc,)
    key : ndarray (nc,) int64
    mu, e : ndarray (nc,)
        Friction and restitution coefficients.
    """

    i: np.ndarray
    j: np.ndarray
    obstacle: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    key: np.ndarray
    mu: np.ndarray
    e: np.ndarray

    @property
    def n(self) -> int:
        return int(self.i.shape[0])

    def subset(self, mask) -> "Contacts":
        """The contacts selected by a boolean mask or index array."""
        return Contacts(*(getattr(self, f)[mask] for f in self.__dataclass_fields__))

    @staticmethod
    def empty(d: int) -> "Contacts":
        z = np.zeros(0)
        zi = np.zeros(0, dtype=np.int64)
        return Contacts(zi, zi, zi, np.zeros((0, d)), np.zeros((0, d)), z, zi, z, z)


def _combine(a, b, default):
    v = np.fmin(a, b)            # NaN (unset) values are ignored by fmin
    return np.where(np.isnan(v), default, v)


class _Parts:
    """Accumulates narrow-phase results of each pair type, then concatenates."""

    def __init__(self, sys):
        self.sys = sys
        self.cols = []

    def add(self, i, j, obst, point, normal, gap, fid):
        if len(i):
            self.cols.append((np.asarray(i, np.int64), np.asarray(j, np.int64), np.asarray(obst, np.int64),
                              point, normal, gap, np.asarray(fid, np.int64)))

    def build(self) -> Contacts:
        s = self.sys
        if not self.cols:
            return Contacts.empty(s.dim)
        i, j, ob, pt, nr, g, fid = (np.concatenate(c) for c in zip(*self.cols))
        n_all = s.n_bodies + s.n_obstacles
        other = np.where(j >= 0, j, s.n_bodies + ob)
        key = ((i * n_all + other) << _FID_BITS) + fid
        # materials: body values, obstacle values (NaN = unset), scene default
        mu_o = np.full(s.n_obstacles, np.nan)
        e_o = np.full(s.n_obstacles, np.nan)
        for tab in (s.halfspaces, s.fixed_round):
            mu_o[tab[4]] = tab[2]
            e_o[tab[4]] = tab[3]
        mu_o[s.fixed_poly[6]] = s.fixed_poly[4]
        e_o[s.fixed_poly[6]] = s.fixed_poly[5]
        mu_j = np.where(j >= 0, s.mu_body[np.maximum(j, 0)], mu_o[np.maximum(ob, 0)] if s.n_obstacles else np.nan)
        e_j = np.where(j >= 0, s.e_body[np.maximum(j, 0)], e_o[np.maximum(ob, 0)] if s.n_obstacles else np.nan)
        mu = _combine(s.mu_body[i], mu_j, s.mu_default)
        e = _combine(s.e_body[i], e_j, s.e_default)
        return Contacts(i, j, ob, pt, nr, g, key, mu, e)


def _round_round(ci, ri, cj, rj):
    dv = ci - cj
    dist = np.linalg.norm(dv, axis=1)
    safe = dist > 0
    n = np.zeros_like(dv)
    n[safe] = dv[safe] / dist[safe, None]
    n[~safe, -1] = 1.0
    gap = dist - ri - rj
    point = cj + n * (rj + 0.5 * gap)[:, None]
    return gap, n, point


def broad_phase(sys, margin: float):
    """Candidate pairs by bounding spheres (k-d tree).

    Returns
    -------
    dyn_pairs : (k, 2) int
        Body–body pairs ``(a, b)``, ``a < b``.
    fix_pairs : (k2, 2) int
        ``(body, fixed object row)``; rows index the fixed round objects first,
        then the fixed polygons.
    """
    pos, R = sys.pos, sys.radius
    n = sys.n_bodies
    tree = cKDTree(pos)
    rmax = float(R.max())
    dyn = tree.query_pairs(2 * rmax + margin, output_type="ndarray").reshape(-1, 2)
    if len(dyn):
        d = np.linalg.norm(pos[dyn[:, 0]] - pos[dyn[:, 1]], axis=1)
        dyn = dyn[d <= R[dyn[:, 0]] + R[dyn[:, 1]] + margin]
    fc = [sys.fixed_round[0]]
    fr = [sys.fixed_round[1]]
    if sys.dim == 2:
        fc.append(sys.fixed_poly[2])
        fr.append(sys.fixed_poly[3])
    fc = np.concatenate(fc)
    fr = np.concatenate(fr)
    if fc.shape[0] == 0:
        return dyn, np.zeros((0, 2), dtype=np.int64)
    ftree = cKDTree(fc)
    sdm = tree.sparse_distance_matrix(ftree, rmax + float(fr.max()) + margin, output_type="ndarray")
    pairs = np.c_[sdm["i"], sdm["j"]].astype(np.int64)
    keep = sdm["v"] <= R[pairs[:, 0]] + fr[pairs[:, 1]] + margin
    # sparse_distance_matrix drops zero distances (coincident centres): add them back
    d0 = ftree.query_ball_point(pos, 0.0)
    extra = [(a, b) for a, lst in enumerate(d0) for b in lst] if any(len(x) for x in d0) else []
    pairs = pairs[keep]
    if extra:
        pairs = np.unique(np.vstack([pairs, np.array(extra, dtype=np.int64)]), axis=0)
    return dyn, pairs


def detect(sys, margin: float = 0.0) -> Contacts:
    """All contacts with ``gap <= margin`` in the current configuration.

    Parameters
    ----------
    sys : System
    margin : float
        Detection distance (>= 0).

    Returns
    -------
    Contacts
    """
    parts = _Parts(sys)
    d = sys.dim
    pos, R = sys.pos, sys.radius
    n = sys.n_bodies
    rnd = ~sys.is_poly
    PVb = sys.poly_world() if sys.is_poly.any() else None
    # ----------------------------------------------------------- half-spaces
    hp, hn, _, _, hidx = sys.halfspaces
    if len(hidx):
        ib = np.flatnonzero(rnd)
        if ib.size:
            g = np.einsum("bkd,kd->bk", pos[ib, None, :] - hp[None], hn) - R[ib, None]
            b, k = np.nonzero(g <= margin)
            gg = g[b, k]
            nn = hn[k]
            parts.add(ib[b], -np.ones_like(b), hidx[k], pos[ib[b]] - nn * (R[ib[b]] + 0.5 * gg)[:, None],
                      nn, gg, np.zeros_like(b))
        if PVb is not None:
            ip = np.flatnonzero(sys.is_poly)
            g = np.einsum("pvkd,kd->pkv", PVb[:, :, None, :] - hp[None, None], hn)
            vmask = np.arange(PVb.shape[1])[None, :] < sys.poly_nv[:, None]
            p, k, v = np.nonzero((g <= margin) & vmask[:, None, :])
            gg = g[p, k, v]
            nn = hn[k]
            parts.add(ip[p], -np.ones_like(p), hidx[k], PVb[p, v] - 0.5 * gg[:, None] * nn, nn, gg, v)
    # ----------------------------------------------------------- body–body
    if n > 1 or sys.fixed_round[1].size or sys.fixed_poly[1].size:
        dyn, fix = broad_phase(sys, margin)
        a, b = dyn[:, 0], dyn[:, 1]
        rr = rnd[a] & rnd[b]
        if rr.any():
            aa, bb = a[rr], b[rr]
            g, nn, pt = _round_round(pos[aa], R[aa], pos[bb], R[bb])
            m = g <= margin
            parts.add(aa[m], bb[m], -np.ones(m.sum()), pt[m], nn[m], g[m], np.zeros(m.sum()))
        if PVb is not None:
            prow = sys.poly_of_body
            # disk (round) – polygon body: the disk is member i
            for da, pb_ in ((a, b), (b, a)):
                sel = rnd[da] & sys.is_poly[pb_]
                if sel.any():
                    dd, pp = da[sel], pb_[sel]
                    g, nn, pt = disk_poly(pos[dd], R[dd], PVb, sys.poly_nv, prow[pp])
                    m = g <= margin
                    parts.add(dd[m], pp[m], -np.ones(m.sum()), pt[m], nn[m], g[m], np.zeros(m.sum()))
            sel = sys.is_poly[a] & sys.is_poly[b]
            if sel.any():
                aa, bb = a[sel], b[sel]
                valid, g, nn, pt, fid = poly_poly(PVb, sys.poly_nv, prow[aa], prow[bb], margin)
                q, s = np.nonzero(valid)
                parts.add(aa[q], bb[q], -np.ones(q.size), pt[q, s], nn[q, s], g[q, s], fid[q, s])
        if fix is not None and len(fix):
            _fixed_contacts(sys, parts, fix, margin, PVb)
    return parts.build()


def _fixed_contacts(sys, parts, fix, margin, PVb):
    pos, R = sys.pos, sys.radius
    rnd = ~sys.is_poly
    fcen, frad, _, _, fidx = sys.fixed_round
    nfr = frad.size
    body, row = fix[:, 0], fix[:, 1]
    # body vs fixed round obstacle
    sel = row < nfr
    if sel.any():
        bb, rr = body[sel], row[sel]
        s = rnd[bb]
        if s.any():
            g, nn, pt = _round_round(pos[bb[s]], R[bb[s]], fcen[rr[s]], frad[rr[s]])
            m = g <= margin
            parts.add(bb[s][m], -np.ones(m.sum()), fidx[rr[s]][m], pt[m], nn[m], g[m], np.zeros(m.sum()))
        s = ~rnd[bb]
        if s.any():
            # polygon body vs fixed disk: kernel normal points into the disk -> negate
            g, nn, pt = disk_poly(fcen[rr[s]], frad[rr[s]], PVb, sys.poly_nv, sys.poly_of_body[bb[s]])
            m = g <= margin
            parts.add(bb[s][m], -np.ones(m.sum()), fidx[rr[s]][m], pt[m], -nn[m], g[m], np.zeros(m.sum()))
    sel = row >= nfr
    if sel.any():
        FV, FN, _, _, _, _, pidx = sys.fixed_poly
        bb, rr = body[sel], row[sel] - nfr
        s = rnd[bb]
        if s.any():
            g, nn, pt = disk_poly(pos[bb[s]], R[bb[s]], FV, FN, rr[s])
            m = g <= margin
            parts.add(bb[s][m], -np.ones(m.sum()), pidx[rr[s]][m], pt[m], nn[m], g[m], np.zeros(m.sum()))
        s = ~rnd[bb]
        if s.any():
            # one table holding the moving polygons then the fixed ones
            tab = np.concatenate([PVb, _pad_to(FV, PVb.shape[1])], axis=0) if PVb.shape[1] >= FV.shape[1] \
                else np.concatenate([_pad_to(PVb, FV.shape[1]), FV], axis=0)
            nv = np.concatenate([sys.poly_nv, FN])
            npb = PVb.shape[0]
            valid, g, nn, pt, fid = poly_poly(tab, nv, sys.poly_of_body[bb[s]], npb + rr[s], margin)
            q, k = np.nonzero(valid)
            parts.add(bb[s][q], -np.ones(q.size), pidx[rr[s]][q], pt[q, k], nn[q, k], g[q, k], fid[q, k])


def _pad_to(V, vmax):
    if V.shape[1] == vmax:
        return V
    out = np.repeat(V[:, -1:, :], vmax, axis=1)
    out[:, :V.shape[1]] = V
    return out


__all__ = ["Contacts", "detect", "broad_phase"]

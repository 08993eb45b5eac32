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
fixed-obstacle variants; in 3D sphere–sphere, sphere–plane, and for convex
polyhedra (boxes) polyhedron–plane (vertices), polyhedron–polyhedron (up to
four points per face pair, :mod:`~socp_cd.dynamics.narrow3d`),
sphere–polyhedron, and the fixed-obstacle variants.

Keys are ``((i * (n_bodies + n_obstacles) + other) << 26) + feature``; they
fit in int64 up to about 3·10⁵ bodies.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from .hulls import concat_tables, world_hulls
from .narrow import disk_poly, poly_poly
from .narrow3d import hull_hull, sphere_hull

_FID_BITS = 26


class CandidatePairs(NamedTuple):
    """Broad-phase output.

    Attributes
    ----------
    bodies : (k, 2) int
        Body–body pairs ``(a, b)``, ``a < b``.
    fixed : (k2, 2) int
        ``(body, fixed row)``; rows index the fixed round objects first, then
        the fixed polygons (2D) or fixed polyhedra (3D).
    """

    bodies: np.ndarray
    fixed: np.ndarray


class NarrowResult(NamedTuple):
    """Contacts of one pair type before assembly into :class:`Contacts`."""

    i: np.ndarray
    j: np.ndarray
    obstacle: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    fid: np.ndarray


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


def _combine(a, b, default, pair=None):
    """Pair-table value where listed, else the min of the members' values, else the default."""
    v = np.fmin(a, b)            # NaN (unset) values are ignored by fmin
    if pair is not None:
        v = np.where(np.isnan(pair), v, pair)
    return np.where(np.isnan(v), default, v)


class _Parts:
    """Accumulates narrow-phase results of each pair type, then concatenates."""

    def __init__(self, sys):
        self.sys = sys
        self.cols = []

    def add(self, i, j, obst, point, normal, gap, fid):
        if len(i):
            self.cols.append(NarrowResult(np.asarray(i, np.int64), np.asarray(j, np.int64),
                                          np.asarray(obst, np.int64), point, normal, gap,
                                          np.asarray(fid, np.int64)))

    def build(self) -> Contacts:
        s = self.sys
        if not self.cols:
            return Contacts.empty(s.dim)
        cat = NarrowResult(*(np.concatenate(c) for c in zip(*self.cols)))
        i, j, ob = cat.i, cat.j, cat.obstacle
        n_all = s.n_bodies + s.n_obstacles
        other = np.where(j >= 0, j, s.n_bodies + ob)
        key = ((i * n_all + other) << _FID_BITS) + cat.fid
        # materials: pair table, else member values (NaN = unset), else scene default
        hasj = j >= 0
        jj, oo = np.maximum(j, 0), np.maximum(ob, 0)
        if s.n_obstacles:
            mu_j = np.where(hasj, s.mu_body[jj], s.mu_obstacle[oo])
            e_j = np.where(hasj, s.e_body[jj], s.e_obstacle[oo])
            mat_j = np.where(hasj, s.mat_body[jj], s.mat_obstacle[oo])
        else:
            mu_j, e_j, mat_j = s.mu_body[jj], s.e_body[jj], s.mat_body[jj]
        pmu = pe = None
        if s.mat_mu.size:
            mi = s.mat_body[i]
            ok = (mi >= 0) & (mat_j >= 0)
            a, b = np.maximum(mi, 0), np.maximum(mat_j, 0)
            pmu = np.where(ok, s.mat_mu[a, b], np.nan)
            pe = np.where(ok, s.mat_e[a, b], np.nan)
        mu = _combine(s.mu_body[i], mu_j, s.mu_default, pmu)
        e = _combine(s.e_body[i], e_j, s.e_default, pe)
        return Contacts(i, j, ob, cat.point, cat.normal, cat.gap, key, mu, e)


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


def broad_phase(sys, margin: float) -> CandidatePairs:
    """Candidate pairs by bounding spheres (k-d tree); see :class:`CandidatePairs`."""
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
        fc.append(sys.fixed_poly.center)
        fr.append(sys.fixed_poly.radius)
    else:
        fc.append(sys.fixed_hull.center)
        fr.append(sys.fixed_hull.table.radius)
    fc = np.concatenate(fc)
    fr = np.concatenate(fr)
    if fc.shape[0] == 0:
        return CandidatePairs(dyn, np.zeros((0, 2), dtype=np.int64))
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
    return CandidatePairs(dyn, pairs)


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
    pos, R = sys.pos, sys.radius
    n = sys.n_bodies
    rnd = sys.is_round
    PVb = sys.poly_world() if sys.is_poly.any() else None
    HT = world_hull_table(sys) if sys.has_hulls else None
    # ----------------------------------------------------------- half-spaces
    hs = sys.halfspaces
    hp, hn, hidx = hs.point, hs.normal, hs.index
    if len(hidx):
        ib = np.flatnonzero(rnd)
        if ib.size:
            g = np.einsum("bkd,kd->bk", pos[ib, None, :] - hp[None], hn) - R[ib, None]
            b, k = np.nonzero(g <= margin)
            gg = g[b, k]
            nn = hn[k]
            parts.add(ib[b], -np.ones_like(b), hidx[k], pos[ib[b]] - nn * (R[ib[b]] + 0.5 * gg)[:, None],
                      nn, gg, np.zeros_like(b))
        for body_mask, VW, nv in ((sys.is_poly, PVb, sys.poly_nv),
                                  (sys.is_hull, None if HT is None else HT.V[:sys.hulls.n], sys.hulls.NV)):
            if VW is None or not body_mask.any():
                continue
            ip = np.flatnonzero(body_mask)
            g = np.einsum("pvkd,kd->pkv", VW[:, :, None, :] - hp[None, None], hn)
            vmask = np.arange(VW.shape[1])[None, :] < nv[:, None]
            p, k, v = np.nonzero((g <= margin) & vmask[:, None, :])
            gg = g[p, k, v]
            nn = hn[k]
            parts.add(ip[p], -np.ones_like(p), hidx[k], VW[p, v] - 0.5 * gg[:, None] * nn, nn, gg, v)
    # ----------------------------------------------------------- body–body
    if n > 1 or sys.fixed_round.radius.size or sys.fixed_poly.nv.size or sys.fixed_hull.rot.shape[0]:
        cand = broad_phase(sys, margin)
        a, b = cand.bodies[:, 0], cand.bodies[:, 1]
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
        if HT is not None:
            hrow = sys.hull_of_body
            for da, pb_ in ((a, b), (b, a)):
                sel = rnd[da] & sys.is_hull[pb_]
                if sel.any():
                    dd, pp = da[sel], pb_[sel]
                    g, nn, pt = sphere_hull_contacts(HT, pos[dd], R[dd], hrow[pp])
                    m = g <= margin
                    parts.add(dd[m], pp[m], -np.ones(m.sum()), pt[m], nn[m], g[m], np.zeros(m.sum()))
            sel = sys.is_hull[a] & sys.is_hull[b]
            if sel.any():
                aa, bb = a[sel], b[sel]
                valid, g, nn, pt, fid = hull_pair_contacts(HT, hrow[aa], hrow[bb], margin)
                q, s = np.nonzero(valid)
                parts.add(aa[q], bb[q], -np.ones(q.size), pt[q, s], nn[q, s], g[q, s], fid[q, s])
        if len(cand.fixed):
            _fixed_contacts(sys, parts, cand.fixed, margin, PVb, HT)
    return parts.build()


def world_hull_table(sys):
    """World-frame table: moving hull bodies' rows, then the fixed polyhedra's."""
    mov = sys.is_hull
    Rm = sys.rotations()[mov] if mov.any() else np.zeros((0, 3, 3))
    moving = world_hulls(sys.hulls, Rm, sys.pos[mov])
    fh = sys.fixed_hull
    return concat_tables(moving, world_hulls(fh.table, fh.rot, fh.center))


def hull_pair_contacts(HT, ia, ib, margin):
    """:func:`~socp_cd.dynamics.narrow3d.hull_hull` on a world table (rows ``ia``, ``ib``)."""
    return hull_hull(HT.V, HT.NV, HT.FN, HT.NF, HT.FL, HT.FK, HT.E, HT.EDIR, HT.NE, HT.D, HT.ND,
                     np.ascontiguousarray(ia, np.int64), np.ascontiguousarray(ib, np.int64), float(margin))


def sphere_hull_contacts(HT, C, Rs, ih):
    """:func:`~socp_cd.dynamics.narrow3d.sphere_hull` on a world table (hull rows ``ih``)."""
    return sphere_hull(np.ascontiguousarray(C), np.ascontiguousarray(Rs, np.float64), HT.V, HT.NV, HT.FN,
                       HT.NF, HT.FL, HT.FK, HT.E, HT.NE, np.ascontiguousarray(ih, np.int64))


def _fixed_contacts(sys, parts, fix, margin, PVb, HT):
    pos, R = sys.pos, sys.radius
    rnd = sys.is_round
    fr_ = sys.fixed_round
    fcen, frad, fidx = fr_.center, fr_.radius, fr_.index
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
        s = sys.is_poly[bb]
        if s.any():
            # polygon body vs fixed disk: kernel normal points into the disk -> negate
            g, nn, pt = disk_poly(fcen[rr[s]], frad[rr[s]], PVb, sys.poly_nv, sys.poly_of_body[bb[s]])
            m = g <= margin
            parts.add(bb[s][m], -np.ones(m.sum()), fidx[rr[s]][m], pt[m], -nn[m], g[m], np.zeros(m.sum()))
        s = sys.is_hull[bb]
        if s.any():
            # hull body vs fixed sphere: kernel normal points into the sphere -> negate
            g, nn, pt = sphere_hull_contacts(HT, fcen[rr[s]], frad[rr[s]], sys.hull_of_body[bb[s]])
            m = g <= margin
            parts.add(bb[s][m], -np.ones(m.sum()), fidx[rr[s]][m], pt[m], -nn[m], g[m], np.zeros(m.sum()))
    sel = row >= nfr
    if sel.any() and sys.dim == 3:
        bb, rr = body[sel], row[sel] - nfr
        hidx = sys.fixed_hull.index
        nmov = sys.hulls.n
        s = rnd[bb]
        if s.any():
            g, nn, pt = sphere_hull_contacts(HT, pos[bb[s]], R[bb[s]], nmov + rr[s])
            m = g <= margin
            parts.add(bb[s][m], -np.ones(m.sum()), hidx[rr[s]][m], pt[m], nn[m], g[m], np.zeros(m.sum()))
        s = sys.is_hull[bb]
        if s.any():
            valid, g, nn, pt, fid = hull_pair_contacts(HT, sys.hull_of_body[bb[s]], nmov + rr[s], margin)
            q, k = np.nonzero(valid)
            parts.add(bb[s][q], -np.ones(q.size), hidx[rr[s]][q], pt[q, k], nn[q, k], g[q, k], fid[q, k])
    elif sel.any():
        fp = sys.fixed_poly
        FV, FN, pidx = fp.vertices, fp.nv, fp.index
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


__all__ = ["Contacts", "detect", "broad_phase", "CandidatePairs", "NarrowResult", "world_hull_table",
           "hull_pair_contacts", "sphere_hull_contacts"]

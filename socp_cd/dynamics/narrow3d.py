"""Exact narrow phase for 3D convex polyhedra (numba, batched over pairs).

Polyhedra come as a world-frame :class:`~socp_cd.dynamics.hulls.HullTable`.
Conventions as in :mod:`~socp_cd.dynamics.narrow`: gap = signed distance
(negative = penetration), unit normal pointing *into the first member* of the
pair, contact point = midpoint of the two surfaces' closest points.

Polyhedron–polyhedron (:func:`hull_hull`) is the separating-axis test (SAT)
over the face normals of both members and the cross products of their edge
directions, followed by

* face contact: the *reference* face is the face of the best face axis, the
  *incident* face the other member's face most anti-parallel to it; the
  incident polygon is clipped (Sutherland–Hodgman) by the side planes of the
  reference face, points deeper than ``margin`` are dropped and at most
  :data:`MAX_POINTS` = 4 kept (deepest, farthest from it, then largest
  triangle and quadrilateral area) — a stable contact manifold;
* edge contact (an edge axis separates more than every face axis by more than
  a relative tolerance): one point, closest points of the two supporting
  edges.

Each manifold point carries a feature id independent of the order in which it
was produced: the two *boundary lines* meeting at it (incident-face edges or
reference-face sides), plus the reference face and which member owns it.
Small motions that keep the same faces in contact keep the same ids, so the
warm start of the next step finds last step's impulses.  Exactly aligned faces
(a stack of equal boxes) put incident vertices *on* the side planes, where
round-off would flip them in and out: a vertex within ``_CLIP_SLACK`` (10⁻⁴)
× size outside a side plane is kept as a vertex (its contact point then lies
at most that far outside the reference face).

Sphere–polyhedron (:func:`sphere_hull`) is the exact closest point.
"""
from __future__ import annotations

import numpy as np
from numba import njit

MAX_POINTS = 4
EDGE_FLAG = np.int64(1) << 24     # feature ids of edge–edge contacts
_FACE_BIAS = 1e-4                 # prefer faces over edges within this × size
_REF_BIAS = 1e-4                  # prefer member a's face within this × size
_CLIP_SLACK = 1e-4                # incident vertices this × size outside a side plane are kept


@njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _face_axis(V, NV, FN, NF, FL, a, b):
    """Best face axis of member ``a`` against ``b``: (separation, face)."""
    best, fb = -np.inf, 0
    for f in range(NF[a]):
        n = FN[a, f]
        d = _dot(n, V[a, FL[a, f, 0]])
        s = np.inf
        for j in range(NV[b]):
            x = _dot(n, V[b, j]) - d
            if x < s:
                s = x
        if s > best:
            best, fb = s, f
    return best, fb


@njit(cache=True)
def _edge_axis(V, NV, D, ND, a, b):
    """Best edge-cross axis: (separation, axis (3,) pointing from a to b, dir of a, dir of b)."""
    best, da, db = -np.inf, -1, -1
    ax = np.zeros(3)
    bestax = np.zeros(3)
    for i in range(ND[a]):
        for k in range(ND[b]):
            u, w = D[a, i], D[b, k]
            ax[0] = u[1] * w[2] - u[2] * w[1]
            ax[1] = u[2] * w[0] - u[0] * w[2]
            ax[2] = u[0] * w[1] - u[1] * w[0]
            L = np.sqrt(_dot(ax, ax))
            if L < 1e-6:
                continue
            ax /= L
            mina, maxa, minb, maxb = np.inf, -np.inf, np.inf, -np.inf
            for j in range(NV[a]):
                x = _dot(ax, V[a, j])
                mina = min(mina, x)
                maxa = max(maxa, x)
            for j in range(NV[b]):
                x = _dot(ax, V[b, j])
                minb = min(minb, x)
                maxb = max(maxb, x)
            s1, s2 = minb - maxa, mina - maxb       # along +ax (a below b), along -ax
            if s1 >= s2 and s1 > best:
                best, da, db = s1, i, k
                bestax[:] = ax
            elif s2 > s1 and s2 > best:
                best, da, db = s2, i, k
                bestax[:] = -ax
    return best, bestax, da, db


@njit(cache=True)
def _support_edge(V, E, EDIR, NE, p, d, ax, sign):
    """Edge of row ``p`` with direction ``d`` extreme along ``sign * ax``."""
    best, eb = -np.inf, 0
    for e in range(NE[p]):
        if EDIR[p, e] != d:
            continue
        x = sign * (_dot(ax, V[p, E[p, e, 0]]) + _dot(ax, V[p, E[p, e, 1]]))
        if x > best:
            best, eb = x, e
    return eb


@njit(cache=True)
def segment_closest(p1, q1, p2, q2):
    """Closest points ``(c1, c2)`` of segments ``[p1, q1]`` and ``[p2, q2]``."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = _dot(d1, d1), _dot(d2, d2), _dot(d2, r)
    c, b = _dot(d1, r), _dot(d1, d2)
    den = a * e - b * b
    s = 0.0
    if den > 1e-14 * a * e:
        s = min(1.0, max(0.0, (b * f - c * e) / den))
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(1.0, max(0.0, -c / a))
    elif t > 1.0:
        t = 1.0
        s = min(1.0, max(0.0, (b - c) / a))
    return p1 + s * d1, p2 + t * d2


@njit(cache=True)
def _better(x, best, lab, blab, tol):
    """``x`` beats ``best`` by more than ``tol``, or ties within ``tol`` with a smaller label."""
    return x > best + tol or (x >= best - tol and lab < blab)


@njit(cache=True)
def _reduce(P, depth, lab, cnt, keep, scale):
    """Choose at most MAX_POINTS of ``cnt`` manifold points: indices into ``keep``, returns their count.

    Deepest point, the point farthest from it, the one spanning the largest
    triangle, the one adding the most area.  Comparisons tie within a
    relative tolerance and ties go to the smallest feature label, so round-off
    (a resting face) never changes the choice from one step to the next.
    """
    if cnt <= MAX_POINTS:
        for k in range(cnt):
            keep[k] = k
        return cnt
    tl = 1e-5 * scale
    k0 = 0
    for k in range(1, cnt):
        if _better(-depth[k], -depth[k0], lab[k], lab[k0], tl):
            k0 = k
    keep[0] = k0
    k1 = -1
    best = 0.0
    for k in range(cnt):
        if k == k0:
            continue
        d = P[k] - P[k0]
        x = np.sqrt(_dot(d, d))
        if k1 < 0 or _better(x, best, lab[k], lab[k1], tl):
            best, k1 = x, k
    keep[1] = k1
    k2 = -1
    for k in range(cnt):
        if k == k0 or k == k1:
            continue
        c = np.cross(P[k1] - P[k0], P[k] - P[k0])
        x = np.sqrt(_dot(c, c))
        if k2 < 0 or _better(x, best, lab[k], lab[k2], tl * scale):
            best, k2 = x, k
    keep[2] = k2
    # fourth: the point adding the largest area to the triangle (outside one of its edges)
    k3 = -1
    nrm = np.cross(P[k1] - P[k0], P[k2] - P[k0])
    nrm /= max(np.sqrt(_dot(nrm, nrm)), 1e-300)
    for k in range(cnt):
        if k == k0 or k == k1 or k == k2:
            continue
        x = 0.0
        for (ia, ib) in ((k0, k1), (k1, k2), (k2, k0)):
            c = np.cross(P[ib] - P[ia], P[k] - P[ia])
            x = max(x, -_dot(c, nrm))
        if x > tl * scale and (k3 < 0 or _better(x, best, lab[k], lab[k3], tl * scale)):
            best, k3 = x, k
    if k3 < 0:
        return 3
    keep[3] = k3
    return 4


@njit(cache=True)
def hull_hull(V, NV, FN, NF, FL, FK, E, EDIR, NE, D, ND, ia, ib, margin):
    """Polyhedron–polyhedron contact manifolds (world-frame table, rows ``ia[p]``, ``ib[p]``).

    Returns
    -------
    valid (m, 4) bool, gap (m, 4), normal (m, 4, 3) into member a, point (m, 4, 3),
    fid (m, 4) int64 feature ids (``flip<<23 | ref_face<<14 | in_line<<7 | out_line``
    for face contacts, ``EDGE_FLAG | dir_a<<8 | dir_b`` for an edge contact).
    """
    m = ia.shape[0]
    valid = np.zeros((m, MAX_POINTS), dtype=np.bool_)
    gap = np.zeros((m, MAX_POINTS))
    normal = np.zeros((m, MAX_POINTS, 3))
    point = np.zeros((m, MAX_POINTS, 3))
    fid = np.zeros((m, MAX_POINTS), dtype=np.int64)
    kmax = FL.shape[2]
    cap = 2 * kmax + 8
    poly = np.zeros((cap, 3))
    plab = np.zeros(cap, dtype=np.int64)       # label of the edge from poly[k] to poly[k+1]
    tmp = np.zeros((cap, 3))
    tlab = np.zeros(cap, dtype=np.int64)
    depth = np.zeros(cap)
    keep = np.zeros(MAX_POINTS, dtype=np.int64)
    pid = np.zeros(cap, dtype=np.int64)
    for p in range(m):
        a, b = ia[p], ib[p]
        sa, fa = _face_axis(V, NV, FN, NF, FL, a, b)
        if sa > margin:
            continue
        sb, fb = _face_axis(V, NV, FN, NF, FL, b, a)
        if sb > margin:
            continue
        se, ax, da, db = _edge_axis(V, NV, D, ND, a, b)
        if se > margin:
            continue
        scale = 0.0
        for j in range(NV[a]):
            scale = max(scale, np.sqrt(_dot(V[a, j] - V[a, 0], V[a, j] - V[a, 0])))
        sf = max(sa, sb)
        if da >= 0 and se > sf + _FACE_BIAS * scale:
            ea = _support_edge(V, E, EDIR, NE, a, da, ax, 1.0)
            eb = _support_edge(V, E, EDIR, NE, b, db, ax, -1.0)
            c1, c2 = segment_closest(V[a, E[a, ea, 0]], V[a, E[a, ea, 1]], V[b, E[b, eb, 0]], V[b, E[b, eb, 1]])
            valid[p, 0] = True
            gap[p, 0] = se
            normal[p, 0] = -ax
            point[p, 0] = 0.5 * (c1 + c2)
            fid[p, 0] = EDGE_FLAG | (np.int64(da & 255) << 8) | np.int64(db & 255)
            continue
        flip = sb > sa + _REF_BIAS * scale
        if flip:
            r, fr, q = b, fb, a
        else:
            r, fr, q = a, fa, b
        nref = FN[r, fr]
        # incident face: most anti-parallel to the reference normal
        fi, dmin = 0, np.inf
        for f in range(NF[q]):
            x = _dot(FN[q, f], nref)
            if x < dmin:
                dmin, fi = x, f
        cnt = FK[q, fi]
        for k in range(cnt):
            poly[k] = V[q, FL[q, fi, k]]
            plab[k] = k
        kr = FK[r, fr]
        for s in range(kr):
            v1 = V[r, FL[r, fr, s]]
            v2 = V[r, FL[r, fr, (s + 1) % kr]]
            e = v2 - v1
            sn = np.cross(e, nref)           # outward normal of the side plane
            sn /= np.sqrt(_dot(sn, sn))
            off = _dot(sn, v1)
            slack = _CLIP_SLACK * scale      # aligned faces keep their vertex ids under round-off
            nt = 0
            for k in range(cnt):
                P0, P1 = poly[k], poly[(k + 1) % cnt]
                lab = plab[k]
                d0 = _dot(sn, P0) - off
                d1 = _dot(sn, P1) - off
                if d0 <= slack:
                    if d1 <= slack:          # in -> in: P1, reached along the same line
                        tmp[nt] = P1
                        tlab[nt] = lab
                        nt += 1
                    else:                    # in -> out: crossing point, reached along the same line
                        tmp[nt] = P0 + min(1.0, max(0.0, d0 / (d0 - d1))) * (P1 - P0)
                        tlab[nt] = lab
                        nt += 1
                elif d1 <= slack:            # out -> in: crossing reached along the side plane, then P1
                    tmp[nt] = P0 + min(1.0, max(0.0, d0 / (d0 - d1))) * (P1 - P0)
                    tlab[nt] = 64 + s
                    nt += 1
                    tmp[nt] = P1
                    tlab[nt] = lab
                    nt += 1
            # tlab[k] labels the edge *arriving* at tmp[k]; convert to "leaving" labels
            cnt = nt
            if cnt == 0:
                break
            for k in range(cnt):
                poly[k] = tmp[k]
                plab[k] = tlab[(k + 1) % cnt]
        if cnt == 0:
            continue
        dref = _dot(nref, V[r, FL[r, fr, 0]])
        nk = 0
        for k in range(cnt):
            sep = _dot(nref, poly[k]) - dref
            if sep <= margin:
                tmp[nk] = poly[k]
                depth[nk] = sep
                # point id: lines arriving at and leaving poly[k]
                pid[nk] = (plab[(k - 1 + cnt) % cnt] << 7) | plab[k]
                nk += 1
        if nk == 0:
            continue
        nsel = _reduce(tmp, depth, pid, nk, keep, scale)
        sgn = 1.0 if flip else -1.0
        for s in range(nsel):
            k = keep[s]
            valid[p, s] = True
            gap[p, s] = depth[k]
            normal[p, s] = sgn * nref
            point[p, s] = tmp[k] - 0.5 * depth[k] * nref
            fid[p, s] = (np.int64(flip) << 23) | (np.int64(fr & 511) << 14) | pid[k]
    return valid, gap, normal, point, fid


@njit(cache=True)
def sphere_hull(C, Rs, V, NV, FN, NF, FL, FK, E, NE, ih):
    """Sphere–polyhedron gap, normal (from the polyhedron into the sphere) and point.

    Parameters
    ----------
    C : (m, 3) sphere centres; Rs : (m,) radii
    V ... NE : world-frame hull table fields; ih : (m,) hull rows
    """
    m = C.shape[0]
    gap = np.zeros(m)
    normal = np.zeros((m, 3))
    point = np.zeros((m, 3))
    for p in range(m):
        h = ih[p]
        c = C[p]
        smax, fmax = -np.inf, 0
        for f in range(NF[h]):
            s = _dot(FN[h, f], c - V[h, FL[h, f, 0]])
            if s > smax:
                smax, fmax = s, f
        if smax <= 0.0:                      # centre inside: deepest face
            n = FN[h, fmax].copy()
            dist = smax
            q = c - smax * n
        else:
            dist = np.inf
            q = np.zeros(3)
            for f in range(NF[h]):           # faces whose plane the centre is above and inside of
                n = FN[h, f]
                s = _dot(n, c - V[h, FL[h, f, 0]])
                if s <= 0.0 or s >= dist:
                    continue
                x = c - s * n
                inside = True
                k = FK[h, f]
                for j in range(k):
                    v1 = V[h, FL[h, f, j]]
                    v2 = V[h, FL[h, f, (j + 1) % k]]
                    if _dot(np.cross(v2 - v1, n), x - v1) > 0.0:
                        inside = False
                        break
                if inside:
                    dist, q = s, x
            for e in range(NE[h]):
                a = V[h, E[h, e, 0]]
                b = V[h, E[h, e, 1]]
                d = b - a
                t = min(1.0, max(0.0, _dot(c - a, d) / _dot(d, d)))
                x = a + t * d
                L = np.sqrt(_dot(c - x, c - x))
                if L < dist:
                    dist, q = L, x
            n = (c - q) / dist if dist > 0 else FN[h, fmax].copy()
        gap[p] = dist - Rs[p]
        normal[p] = n
        point[p] = 0.5 * (q + c - Rs[p] * n)
    return gap, normal, point


__all__ = ["hull_hull", "sphere_hull", "segment_closest", "MAX_POINTS", "EDGE_FLAG"]

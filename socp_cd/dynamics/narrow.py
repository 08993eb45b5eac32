"""Exact narrow-phase kernels for convex polygons (numba, batched over pairs).

Conventions: polygons are counter-clockwise, stored padded as ``(P, vmax, 2)``
with vertex counts ``nv``; the outward normal of edge ``k`` (from vertex ``k`` to
``k+1``) is ``(e_y, -e_x)/|e|``.  Every kernel returns, per pair, the gap
(signed distance, negative = penetration), the unit normal pointing *into the
first member* of the pair, and the contact point (midpoint of the two
surfaces' closest points).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _edge_normal(V, k, n):
    a = V[k]
    b = V[(k + 1) % n]
    ex, ey = b[0] - a[0], b[1] - a[1]
    L = np.sqrt(ex * ex + ey * ey)
    return ey / L, -ex / L


@njit(cache=True)
def _max_separation(A, na, B, nb):
    best, kbest = -np.inf, 0
    for k in range(na):
        nx, ny = _edge_normal(A, k, na)
        s = np.inf
        for j in range(nb):
            d = nx * (B[j, 0] - A[k, 0]) + ny * (B[j, 1] - A[k, 1])
            if d < s:
                s = d
        if s > best:
            best, kbest = s, k
    return best, kbest


@njit(cache=True)
def poly_poly(PV, PN, ia, ib, margin):
    """Polygon–polygon contacts by separating axes and reference-edge clipping.

    Parameters
    ----------
    PV : (P, vmax, 2) world vertices; PN : (P,) counts
    ia, ib : (npairs,) polygon rows of the two members
    margin : float
        Contacts with gap > margin are dropped.

    Returns
    -------
    valid (npairs, 2) bool, gap (npairs, 2), normal (npairs, 2, 2) into member a,
    point (npairs, 2, 2), fid (npairs, 2) int64 feature id
    (``flip<<15 | ref_edge<<8 | incident_edge<<1 | slot``).
    """
    m = ia.shape[0]
    valid = np.zeros((m, 2), dtype=np.bool_)
    gap = np.zeros((m, 2))
    normal = np.zeros((m, 2, 2))
    point = np.zeros((m, 2, 2))
    fid = np.zeros((m, 2), dtype=np.int64)
    cp = np.zeros((2, 2))
    tmp = np.zeros((2, 2))
    for p in range(m):
        A, na = PV[ia[p]], PN[ia[p]]
        B, nb = PV[ib[p]], PN[ib[p]]
        sa, ea = _max_separation(A, na, B, nb)
        if sa > margin:
            continue
        sb, eb = _max_separation(B, nb, A, na)
        if sb > margin:
            continue
        scale = 0.0
        for k in range(na):
            scale = max(scale, abs(A[k, 0] - A[0, 0]) + abs(A[k, 1] - A[0, 1]))
        flip = sb > sa + 1e-6 * scale
        if flip:
            R, nr, er, I, ni = B, nb, eb, A, na
        else:
            R, nr, er, I, ni = A, na, ea, B, nb
        nx, ny = _edge_normal(R, er, nr)
        # incident edge: most anti-parallel to the reference normal
        ki, dmin = 0, np.inf
        for k in range(ni):
            mx, my = _edge_normal(I, k, ni)
            d = mx * nx + my * ny
            if d < dmin:
                dmin, ki = d, k
        v1 = R[er]
        v2 = R[(er + 1) % nr]
        tx, ty = v2[0] - v1[0], v2[1] - v1[1]
        tl = np.sqrt(tx * tx + ty * ty)
        tx, ty = tx / tl, ty / tl
        cp[0, 0], cp[0, 1] = I[ki, 0], I[ki, 1]
        cp[1, 0], cp[1, 1] = I[(ki + 1) % ni, 0], I[(ki + 1) % ni, 1]
        # clip against the two side planes  t·x >= t·v1  and  t·x <= t·v2
        ok = True
        for side in range(2):
            if side == 0:
                sx, sy, off = -tx, -ty, -(tx * v1[0] + ty * v1[1])
            else:
                sx, sy, off = tx, ty, tx * v2[0] + ty * v2[1]
            d0 = sx * cp[0, 0] + sy * cp[0, 1] - off
            d1 = sx * cp[1, 0] + sy * cp[1, 1] - off
            cnt = 0
            if d0 <= 0:
                tmp[cnt, 0], tmp[cnt, 1] = cp[0, 0], cp[0, 1]
                cnt += 1
            if d1 <= 0:
                tmp[cnt, 0], tmp[cnt, 1] = cp[1, 0], cp[1, 1]
                cnt += 1
            if cnt < 2 and d0 * d1 <= 0 and d0 != d1:
                a = d0 / (d0 - d1)
                tmp[cnt, 0] = cp[0, 0] + a * (cp[1, 0] - cp[0, 0])
                tmp[cnt, 1] = cp[0, 1] + a * (cp[1, 1] - cp[0, 1])
                cnt += 1
            if cnt < 2:
                ok = False
                break
            cp[:, :] = tmp[:, :]
        if not ok:
            continue
        # normal into member a: -n if a is the reference, +n if b is
        sgn = 1.0 if flip else -1.0
        for s in range(2):
            sep = nx * (cp[s, 0] - v1[0]) + ny * (cp[s, 1] - v1[1])
            if sep <= margin:
                valid[p, s] = True
                gap[p, s] = sep
                normal[p, s, 0], normal[p, s, 1] = sgn * nx, sgn * ny
                point[p, s, 0] = cp[s, 0] - 0.5 * sep * nx
                point[p, s, 1] = cp[s, 1] - 0.5 * sep * ny
                fid[p, s] = (np.int64(flip) << 15) | (np.int64(er & 127) << 8) | (np.int64(ki & 127) << 1) | s
    return valid, gap, normal, point, fid


@njit(cache=True)
def disk_poly(C, Rd, PV, PN, ip):
    """Disk–polygon gap, normal (from the polygon into the disk) and contact point.

    Parameters
    ----------
    C : (npairs, 2) disk centres; Rd : (npairs,) radii
    PV, PN : polygon table; ip : (npairs,) polygon rows
    """
    m = C.shape[0]
    gap = np.zeros(m)
    normal = np.zeros((m, 2))
    point = np.zeros((m, 2))
    for p in range(m):
        V, n = PV[ip[p]], PN[ip[p]]
        cx, cy = C[p, 0], C[p, 1]
        smax, kmax = -np.inf, 0
        for k in range(n):
            nx, ny = _edge_normal(V, k, n)
            s = nx * (cx - V[k, 0]) + ny * (cy - V[k, 1])
            if s > smax:
                smax, kmax = s, k
        if smax <= 0.0:     # centre inside: deepest face
            nx, ny = _edge_normal(V, kmax, n)
            dist = smax
            px, py = cx - smax * nx, cy - smax * ny
        else:               # closest boundary point
            dist = np.inf
            px = py = nx = ny = 0.0
            for k in range(n):
                ax, ay = V[k, 0], V[k, 1]
                bx, by = V[(k + 1) % n, 0], V[(k + 1) % n, 1]
                ex, ey = bx - ax, by - ay
                t = ((cx - ax) * ex + (cy - ay) * ey) / (ex * ex + ey * ey)
                t = min(1.0, max(0.0, t))
                qx, qy = ax + t * ex, ay + t * ey
                d = np.sqrt((cx - qx) ** 2 + (cy - qy) ** 2)
                if d < dist:
                    dist, px, py = d, qx, qy
            if dist > 0:
                nx, ny = (cx - px) / dist, (cy - py) / dist
            else:
                nx, ny = _edge_normal(V, kmax, n)
        gap[p] = dist - Rd[p]
        normal[p, 0], normal[p, 1] = nx, ny
        point[p, 0] = 0.5 * (px + cx - Rd[p] * nx)
        point[p, 1] = 0.5 * (py + cy - Rd[p] * ny)
    return gap, normal, point


__all__ = ["poly_poly", "disk_poly"]

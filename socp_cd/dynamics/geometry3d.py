"""3D rigid-body geometry: unit quaternions, convex hulls and their mass properties.

Quaternions are ``(w, x, y, z)`` with ``w`` the scalar part; a body's
orientation ``q`` maps body-frame vectors to the world frame, ``x_w = R(q) x_b``.
Angular velocities ``omega`` are world-frame vectors, so the kinematics is
``dq/dt = ½ (0, omega) ⊗ q`` and one step of the θ-scheme is the exact
exponential update ``q⁺ = exp(½ h ω_m) ⊗ q`` with ``ω_m = θ ω⁺ + (1-θ) ω⁻``
(:func:`quat_integrate`), renormalized.

A convex polyhedron is described by :class:`Hull`: its vertices (body frame,
centroid at the origin), its faces as vertex loops counter-clockwise seen from
outside (coplanar hull triangles merged), outward unit normals, its edges and
their distinct directions (for the separating-axis test).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidProblemError

# ----------------------------------------------------------------------------- quaternions


def quat_normalize(q, name: str = "orientation") -> np.ndarray:
    """Validate and normalize quaternion(s) ``(..., 4)``; raises on zero or non-finite input."""
    q = np.asarray(q, dtype=np.float64)
    if q.shape[-1] != 4 or not np.all(np.isfinite(q)):
        raise InvalidProblemError(name, f"must be a finite (w, x, y, z) quaternion, got {q!r}")
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise InvalidProblemError(name, "quaternion has zero norm")
    return q / n


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of unit quaternions ``(..., 4)``."""
    q = np.asarray(q, dtype=np.float64)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return R


def quat_multiply(a, b) -> np.ndarray:
    """Hamilton product ``a ⊗ b`` (broadcast over leading axes)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + np.cross(av, bv)
    return np.concatenate([w, v], axis=-1)


def quat_from_rotvec(phi) -> np.ndarray:
    """Unit quaternions ``exp(½ φ)`` of rotation vectors ``φ`` (..., 3) (angle ``|φ|`` about ``φ/|φ|``)."""
    phi = np.asarray(phi, dtype=np.float64)
    ang = np.linalg.norm(phi, axis=-1, keepdims=True)
    half = 0.5 * ang
    # sin(|φ|/2)/|φ| with its Taylor series near 0
    s = np.where(ang > 1e-8, np.sin(half) / np.where(ang > 1e-8, ang, 1.0), 0.5 - ang ** 2 / 48.0)
    return np.concatenate([np.cos(half), s * phi], axis=-1)


def quat_integrate(q, omega, dt: float) -> np.ndarray:
    """``exp(½ dt ω) ⊗ q`` for world-frame angular velocities ``ω`` (n, 3), renormalized."""
    out = quat_multiply(quat_from_rotvec(dt * np.asarray(omega, dtype=np.float64)), q)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


# ----------------------------------------------------------------------------- hulls
@dataclass
class Hull:
    """A convex polyhedron (see the module docstring).

    Attributes
    ----------
    vertices : ndarray (nv, 3)
    faces : list of ndarray
        Vertex-index loops, counter-clockwise seen from outside.
    normals : ndarray (nf, 3)
        Outward unit normals.
    edges : ndarray (ne, 2) int
        Each undirected edge once.
    edge_dir : ndarray (ne,) int
        Index of each edge's direction in ``directions``.
    directions : ndarray (nd, 3)
        Distinct edge directions (up to sign), unit.
    """

    vertices: np.ndarray
    faces: list
    normals: np.ndarray
    edges: np.ndarray
    edge_dir: np.ndarray
    directions: np.ndarray

    @property
    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices, axis=1)))


def convex_hull(points, name: str = "vertices") -> Hull:
    """The convex hull of ``points`` (k >= 4, not coplanar) as a :class:`Hull`.

    Coplanar hull triangles (normals within 1e-9) are merged into one face, so
    a box has 6 quadrilateral faces, 12 edges and 3 edge directions.

    Raises
    ------
    InvalidProblemError
        Wrong shape, non-finite, fewer than 4 points or a flat point set.
    """
    from scipy.spatial import ConvexHull, QhullError

    P = np.asarray(points, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 4 or not np.all(np.isfinite(P)):
        raise InvalidProblemError(name, f"must be a (k >= 4, 3) finite array, got shape {P.shape}")
    try:
        ch = ConvexHull(P)
    except QhullError:
        raise InvalidProblemError(name, "points are coplanar or degenerate (no 3D hull)") from None
    keep = np.sort(ch.vertices)
    remap = -np.ones(P.shape[0], dtype=np.int64)
    remap[keep] = np.arange(keep.size)
    V = P[keep]
    scale = float(np.max(np.ptp(V, axis=0)))
    groups: list[tuple[np.ndarray, set]] = []
    for simplex, eq in zip(ch.simplices, ch.equations):
        n = eq[:3] / np.linalg.norm(eq[:3])
        off = eq[3] / np.linalg.norm(eq[:3])
        for gn, gv in groups:
            if gn[0] @ n > 1 - 1e-9 and abs(gn[1] - off) < 1e-9 * scale:
                gv.update(remap[simplex].tolist())
                break
        else:
            groups.append(((n, off), set(remap[simplex].tolist())))
    faces, normals = [], []
    for (n, _), vs in groups:
        idx = np.array(sorted(vs), dtype=np.int64)
        c = V[idx].mean(axis=0)
        a = V[idx[0]] - c
        a /= np.linalg.norm(a)
        b = np.cross(n, a)
        ang = np.arctan2((V[idx] - c) @ b, (V[idx] - c) @ a)
        faces.append(idx[np.argsort(ang)])      # counter-clockwise about the outward normal
        normals.append(n)
    edges = sorted({(min(a, b), max(a, b)) for f in faces for a, b in zip(f, np.roll(f, -1))})
    E = np.array(edges, dtype=np.int64)
    D = V[E[:, 1]] - V[E[:, 0]]
    D /= np.linalg.norm(D, axis=1)[:, None]
    dirs: list[np.ndarray] = []
    edir = np.zeros(len(E), dtype=np.int64)
    for k, d in enumerate(D):
        for m, u in enumerate(dirs):
            if abs(u @ d) > 1 - 1e-9:
                edir[k] = m
                break
        else:
            edir[k] = len(dirs)
            dirs.append(d)
    return Hull(V, faces, np.array(normals), E, edir, np.array(dirs))


def hull_mass_properties(hull: Hull) -> tuple[float, np.ndarray, np.ndarray]:
    """Volume, centroid and unit-density inertia tensor (about the centroid) of a hull.

    Tetrahedra ``(o, a, b, c)`` from an interior point ``o`` to each face
    triangle; a tetrahedron with vertices ``0, a, b, c`` (relative to ``o``)
    has ``∫ x xᵀ dV = V/20 (a aᵀ + b bᵀ + c cᵀ + s sᵀ)``, ``s = a + b + c``.
    The inertia tensor is ``tr(C) I - C`` with ``C`` the second-moment tensor.

    Returns
    -------
    volume : float
    centroid : ndarray (3,)
    J : ndarray (3, 3)
        Inertia tensor per unit density; multiply by the density (or by
        ``mass / volume``).
    """
    V = hull.vertices
    o = V.mean(axis=0)
    vol, mom, C = 0.0, np.zeros(3), np.zeros((3, 3))
    for f in hull.faces:
        for k in range(1, len(f) - 1):
            a, b, c = V[f[0]] - o, V[f[k]] - o, V[f[k + 1]] - o
            v = np.dot(a, np.cross(b, c)) / 6.0
            s = a + b + c
            vol += v
            mom += v * s / 4.0
            C += v / 20.0 * (np.outer(a, a) + np.outer(b, b) + np.outer(c, c) + np.outer(s, s))
    cen = mom / vol
    C = C - vol * np.outer(cen, cen)          # parallel axis: about the centroid
    J = np.trace(C) * np.eye(3) - C
    return float(vol), cen + o, 0.5 * (J + J.T)


def box_vertices(size) -> np.ndarray:
    """The 8 corners of an axis-aligned box of edge lengths ``size`` centred at the origin."""
    half = 0.5 * np.asarray(size, dtype=np.float64)
    s = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
    return s * half


__all__ = ["quat_normalize", "quat_to_matrix", "quat_multiply", "quat_from_rotvec", "quat_integrate",
           "Hull", "convex_hull", "hull_mass_properties", "box_vertices"]

"""Surface meshes of bodies and obstacles, for ParaView output and 3D rendering.

A :class:`BodyMeshes` holds, per body, the vertices in its own frame and its
faces: in 2D one closed polygon (the outline; disks are 32-gons), in 3D
triangles (spheres: an icosphere; boxes and polyhedra: the convex hull).
:meth:`BodyMeshes.world` places them with a frame's positions and
orientations (2D ``angle``; 3D ``orientation`` quaternions when the frame has
them, the identity otherwise, e.g. for spheres).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rotations import quat_to_matrix

DISK_SIDES = 32


def icosphere(subdivisions: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere: vertices ``(k, 3)`` and outward triangles ``(t, 3)``."""
    p = (1 + 5 ** 0.5) / 2
    V = [[-1, p, 0], [1, p, 0], [-1, -p, 0], [1, -p, 0], [0, -1, p], [0, 1, p], [0, -1, -p], [0, 1, -p],
         [p, 0, -1], [p, 0, 1], [-p, 0, -1], [-p, 0, 1]]
    F = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
         [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11],
         [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    V = [np.array(v, float) / np.linalg.norm(v) for v in V]
    for _ in range(subdivisions):
        mid: dict = {}

        def m(a, b):
            key = (min(a, b), max(a, b))
            if key not in mid:
                v = V[a] + V[b]
                V.append(v / np.linalg.norm(v))
                mid[key] = len(V) - 1
            return mid[key]
        F = [t for a, b, c in F for t in ([a, m(a, b), m(c, a)], [b, m(b, c), m(a, b)],
                                          [c, m(c, a), m(b, c)], [m(a, b), m(b, c), m(c, a)])]
    return np.array(V), np.array(F, dtype=np.int64)


def hull_triangles(V) -> np.ndarray:
    """Outward triangles of the convex hull of points ``V`` (k, 3)."""
    from scipy.spatial import ConvexHull

    V = np.asarray(V, dtype=np.float64)
    hull = ConvexHull(V)
    F = hull.simplices.copy()
    c = V.mean(0)
    nrm = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    flip = np.einsum("ij,ij->i", nrm, V[F[:, 0]] - c) < 0
    F[flip] = F[flip][:, [0, 2, 1]]
    return F


def hull_faces(V) -> list:
    """Planar faces of the convex hull of ``V`` (k, 3): one index array per face, in order
    around it (coplanar hull triangles merged; used to draw boxes without diagonals)."""
    from scipy.spatial import ConvexHull

    V = np.asarray(V, dtype=np.float64)
    hull = ConvexHull(V)
    scale = float(np.max(np.abs(V))) or 1.0
    faces: dict = {}
    for simplex, eq in zip(hull.simplices, hull.equations):
        key = tuple(np.round(np.r_[eq[:3], eq[3] / scale], 6))
        faces.setdefault(key, set()).update(simplex.tolist())
    out = []
    for key, idx in faces.items():
        idx = np.array(sorted(idx))
        n = np.array(key[:3])
        P = V[idx] - V[idx].mean(0)
        a = np.eye(3)[np.argmin(np.abs(n))]
        e1 = np.cross(n, a)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        out.append(idx[np.argsort(np.arctan2(P @ e2, P @ e1))])
    return out


def box_corners(size) -> np.ndarray:
    """The 8 corners of a box of edge lengths ``size`` centred at the origin."""
    h = 0.5 * np.asarray(size, dtype=np.float64)
    return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * h


def _disk(radius: float) -> np.ndarray:
    a = 2 * np.pi * np.arange(DISK_SIDES) / DISK_SIDES
    return radius * np.c_[np.cos(a), np.sin(a)]


def local_mesh(obj, dim: int) -> tuple[np.ndarray, np.ndarray | None]:
    """Vertices in the object's frame and faces (None in 2D: one outline polygon).

    Works for bodies and fixed obstacles alike: round objects (``radius``),
    2D polygons (``vertices``), 3D boxes (``size``) and polyhedra (``vertices``).
    """
    if dim == 2:
        if hasattr(obj, "vertices"):
            V = np.asarray(obj.vertices, dtype=np.float64)
            return V, None
        return _disk(float(obj.radius)), None
    if hasattr(obj, "radius") and not hasattr(obj, "size") and not hasattr(obj, "vertices"):
        V, F = icosphere(1)
        return float(obj.radius) * V, F
    V = np.asarray(obj.vertices, dtype=np.float64) if hasattr(obj, "vertices") else box_corners(obj.size)
    return V, hull_triangles(V)


def place(V, position, angle=0.0, orientation=None) -> np.ndarray:
    """World coordinates of local vertices ``V`` (2D: rotation by ``angle``; 3D: by a quaternion)."""
    V = np.asarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        c, s = np.cos(angle), np.sin(angle)
        return V @ np.array([[c, s], [-s, c]]) + np.asarray(position)
    if orientation is None:
        return V + np.asarray(position)
    return V @ quat_to_matrix(orientation).T + np.asarray(position)


@dataclass
class BodyMeshes:
    """Local meshes of a scene's bodies (see the module docstring)."""

    dim: int
    local: list
    faces: list

    @classmethod
    def of(cls, bodies, dim: int) -> "BodyMeshes":
        meshes = [local_mesh(b, dim) for b in bodies]
        return cls(dim, [m[0] for m in meshes], [m[1] for m in meshes])

    def world(self, frame) -> list:
        """World vertices of every body at ``frame`` (needs ``pos``; ``angle`` in 2D, optional
        ``orientation`` (n, 4) in 3D)."""
        q = getattr(frame, "orientation", None)
        if self.dim == 2:
            return [place(V, frame.pos[k], frame.angle[k]) for k, V in enumerate(self.local)]
        return [place(V, frame.pos[k], orientation=None if q is None else q[k]) for k, V in enumerate(self.local)]


def obstacle_meshes(obstacles, dim: int, extent: float) -> list:
    """World meshes ``(vertices, faces, kind)`` of fixed obstacles.

    Half-spaces are drawn as a segment (2D, ``kind="line"``) or a square (3D) of
    side ``2 extent`` centred at their point; others as their outline/surface.
    """
    out = []
    for o in obstacles:
        if hasattr(o, "normal"):
            p, n = np.asarray(o.point, dtype=np.float64), np.asarray(o.normal, dtype=np.float64)
            if dim == 2:
                t = np.array([-n[1], n[0]])
                out.append((np.array([p - extent * t, p + extent * t]), None, "line"))
            else:
                a = np.eye(3)[np.argmin(np.abs(n))]
                t1 = np.cross(n, a)
                t1 /= np.linalg.norm(t1)
                t2 = np.cross(n, t1)
                C = np.array([p + extent * (s1 * t1 + s2 * t2) for s1, s2 in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
                out.append((C, np.array([[0, 1, 2], [0, 2, 3]]), "surface"))
            continue
        if dim == 2 and hasattr(o, "vertices"):      # FixedPolygon: world vertices
            out.append((np.asarray(o.vertices, dtype=np.float64), None, "polygon"))
            continue
        V, F = local_mesh(o, dim)
        q = getattr(o, "orientation", None) if dim == 3 else None
        out.append((place(V, o.position, orientation=q), F, "polygon" if dim == 2 else "surface"))
    return out


__all__ = ["BodyMeshes", "obstacle_meshes", "local_mesh", "place", "icosphere", "hull_triangles", "hull_faces",
           "box_corners"]

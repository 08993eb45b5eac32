"""Unit quaternions ``(w, x, y, z)`` for the orientations of 3D scene entries.

(When ``socp_cd.dynamics`` gains its own quaternion helpers with the 3D
polyhedra, these should become imports of those.)
"""
from __future__ import annotations

import math

import numpy as np

def quat_from_axis_angle(axis, angle: float) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation by ``angle`` (rad) about ``axis``."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    return np.r_[math.cos(angle / 2), math.sin(angle / 2) * a]


def quat_mul(p, q) -> np.ndarray:
    """Hamilton product ``p q`` of quaternions ``(w, x, y, z)``."""
    w1, x1, y1, z1 = p
    w2, x2, y2, z2 = q
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion ``(w, x, y, z)``."""
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def quat_from_euler(rx: float, ry: float, rz: float) -> np.ndarray:
    """Quaternion of ``R = Rz(rz) Ry(ry) Rx(rx)`` (radians; extrinsic x, y, z)."""
    e = np.eye(3)
    return quat_mul(quat_from_axis_angle(e[2], rz), quat_mul(quat_from_axis_angle(e[1], ry),
                                                             quat_from_axis_angle(e[0], rx)))


__all__ = ["quat_from_axis_angle", "quat_mul", "quat_to_matrix", "quat_from_euler"]

"""Scene-file orientations (axis–angle, Euler angles) as unit quaternions ``(w, x, y, z)``.

The quaternion algebra itself (product, rotation matrix, rotation vector) is
the dynamics' (:mod:`socp_cd.dynamics.geometry3d`); this module only turns the
ways a scene file may write an orientation into it.
"""
from __future__ import annotations

import numpy as np

from ..dynamics.geometry3d import quat_from_rotvec, quat_multiply, quat_normalize
from ..dynamics.geometry3d import quat_to_matrix as _unit_quat_to_matrix


def quat_from_axis_angle(axis, angle: float) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation by ``angle`` (rad) about ``axis``."""
    a = np.asarray(axis, dtype=np.float64)
    return quat_from_rotvec(a / np.linalg.norm(a) * float(angle))


def quat_mul(p, q) -> np.ndarray:
    """Hamilton product ``p q`` of quaternions ``(w, x, y, z)``."""
    return quat_multiply(p, q)


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrix of a quaternion ``(w, x, y, z)`` (normalized first)."""
    return _unit_quat_to_matrix(quat_normalize(q))


def quat_from_euler(rx: float, ry: float, rz: float) -> np.ndarray:
    """Quaternion of ``R = Rz(rz) Ry(ry) Rx(rx)`` (radians; extrinsic x, y, z)."""
    e = np.eye(3)
    return quat_mul(quat_from_axis_angle(e[2], rz), quat_mul(quat_from_axis_angle(e[1], ry),
                                                             quat_from_axis_angle(e[0], rx)))


__all__ = ["quat_from_axis_angle", "quat_mul", "quat_to_matrix", "quat_from_euler"]

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


def random_quaternion(rng) -> np.ndarray:
    """A unit quaternion ``(w, x, y, z)`` drawn uniformly over the rotations.

    Shoemake's method: three uniform numbers ``u1, u2, u3`` in ``[0, 1)`` give
    ``(sqrt(u1) cos 2πu3, sqrt(1 - u1) sin 2πu2, sqrt(1 - u1) cos 2πu2, sqrt(u1) sin 2πu3)``,
    uniform on the unit 3-sphere (no rejection).

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the three numbers.

    Returns
    -------
    ndarray, shape (4,)
    """
    u1, u2, u3 = rng.uniform(0.0, 1.0, 3)
    a, b = np.sqrt(1.0 - u1), np.sqrt(u1)
    return np.array([b * np.cos(2 * np.pi * u3), a * np.sin(2 * np.pi * u2),
                     a * np.cos(2 * np.pi * u2), b * np.sin(2 * np.pi * u3)])


__all__ = ["quat_from_axis_angle", "quat_mul", "quat_to_matrix", "quat_from_euler",
           "random_quaternion"]

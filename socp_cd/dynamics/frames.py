"""Records of a run: per-step statistics, contact data and state frames.

These are plain containers shared by :mod:`~socp_cd.dynamics.stepper` (which
fills them) and :mod:`~socp_cd.dynamics.trajectory` (which stores them), so
neither module imports the other.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass
class StepStats:
    """Statistics of one step (``time_*`` in seconds, wall clock).

    ``time_projection`` is the post-step position projection (detection at the
    new positions and, when needed, its frictionless problem); 0 when off.
    """

    t: float
    n_detected: int
    n_active: int
    solver: str = ""
    status: str = "no_contact"
    converged: bool = True
    error: float = 0.0
    iterations: int = 0
    time_detection: float = 0.0
    time_assembly: float = 0.0
    time_solve: float = 0.0
    time_projection: float = 0.0


@dataclass
class ContactFrame:
    """Contact data of one step in the global frame.

    Attributes
    ----------
    pairs : (nc, 2) int
        ``(i, j)``; ``j = -1`` for fixed obstacles (index in ``obstacle``).
    obstacle : (nc,) int
    point, normal : (nc, d)
        Contact point; unit normal from ``j`` into ``i``.
    gap : (nc,)
        Gap at the beginning of the step.
    r : (nc, dim)
        Local impulse (normal first) applied to ``i`` (``-`` on ``j``).
    force : (nc, d)
        Global force on ``i``: ``(E^T r) / h``.
    key : (nc,) int64
        Persistent contact identity.
    """

    pairs: np.ndarray
    obstacle: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    r: np.ndarray
    force: np.ndarray
    key: np.ndarray

    @property
    def n(self) -> int:
        return int(self.pairs.shape[0])

    @property
    def normal_force(self) -> np.ndarray:
        """Normal force magnitude ``r_N / h`` per contact."""
        return np.einsum("cd,cd->c", self.force, self.normal)

    @staticmethod
    def empty(d: int) -> "ContactFrame":
        z = np.zeros
        return ContactFrame(z((0, 2), np.int64), z(0, np.int64), z((0, d)), z((0, d)), z(0), z((0, d)),
                            z((0, d)), z(0, np.int64))


@dataclass
class Frame:
    """State at time ``t`` and the contacts of the step that led to it.

    Attributes
    ----------
    t : float
    pos : (n, d) centres of mass
    angle : (n,) orientation angles (2D; zeros in 3D)
    vel : (n, ndof) velocities ``(v, omega)``, ``omega`` world-frame
    contacts : ContactFrame
    orientation : (n, 4) unit quaternions ``(w, x, y, z)`` (3D), None in 2D
    """

    t: float
    pos: np.ndarray
    angle: np.ndarray
    vel: np.ndarray
    contacts: ContactFrame
    orientation: Optional[np.ndarray] = None


__all__ = ["StepStats", "ContactFrame", "Frame"]

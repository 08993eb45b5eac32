"""Adapters from :mod:`socp_cd.dynamics` objects to :class:`~.state.GranularState`.

The simulator's :class:`~socp_cd.dynamics.stepper.ContactFrame` already uses
the convention of :mod:`socp_cd.granular.state`: ``pairs = (i, j)`` with
``j = -1`` for obstacles, ``force`` = global force on ``i`` (``r / h``
mapped to the global frame), ``normal`` from ``j`` into ``i``.  This module
depends on :mod:`.state`, never the reverse.
"""
from __future__ import annotations

import numpy as np

from ..errors import InvalidProblemError
from .state import GranularState

__all__ = ["body_volumes", "from_simulation", "from_trajectory", "from_hdf5"]


def _poly_areas(local):
    """Shoelace areas of padded polygons ``(P, vmax, 2)`` (padding repeats the last vertex)."""
    x, y = local[..., 0], local[..., 1]
    # repeated padding vertices add zero-length edges, so the closed roll is exact
    cr = x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y
    return 0.5 * cr.sum(axis=1)


def body_volumes(is_poly, radius, poly_local, poly_of_body, dim: int) -> np.ndarray:
    """Areas (2D) / volumes (3D) of the bodies: disks/spheres from radii, polygons exactly."""
    is_poly = np.asarray(is_poly, bool)
    r = np.asarray(radius, float)
    vol = np.pi * r**2 if dim == 2 else 4.0 / 3.0 * np.pi * r**3
    if is_poly.any():
        areas = _poly_areas(np.asarray(poly_local, float))
        vol = vol.copy()
        vol[is_poly] = areas[np.asarray(poly_of_body)[is_poly]]
    return vol


def _world_polys(is_poly, poly_local, poly_nv, poly_of_body, pos, angle):
    shapes = [None] * len(is_poly)
    for b in np.flatnonzero(is_poly):
        k = poly_of_body[b]
        V = poly_local[k, :poly_nv[k]]
        c, s = np.cos(angle[b]), np.sin(angle[b])
        shapes[b] = V @ np.array([[c, s], [-s, c]]) + pos[b]
    return shapes


def _state(pos, angle, vel, prev_vel, dt, contacts, mass, vol, gravity, geom, source):
    d = pos.shape[1]
    acc = None
    if prev_vel is not None:
        acc = (vel[:, :d] - prev_vel[:, :d]) / dt
    shapes = None
    if d == 2 and np.any(geom["is_poly"]):
        shapes = _world_polys(geom["is_poly"], geom["poly_local"], geom["poly_nv"],
                              geom["poly_of_body"], pos, angle)
    return GranularState(centers=pos, masses=mass, volumes=vol, pairs=contacts.pairs,
                         points=contacts.point, forces=contacts.force, normals=contacts.normal,
                         gravity=gravity, accelerations=acc, radii=geom["radius"], shapes=shapes,
                         source=source)


def from_simulation(sim, prev_vel=None, inertia: bool = True) -> GranularState:
    """Snapshot of a running :class:`~socp_cd.dynamics.stepper.Simulation`.

    Parameters
    ----------
    sim : Simulation
        After at least one :meth:`step`; contacts are those of the last step.
    prev_vel : ndarray (n, ndof), optional
        Velocities *before* the last step.  When given (and ``inertia``), the
        accelerations ``(v⁺ - v⁻)/h`` enter as inertia forces, which makes the
        state balanced exactly (Moreau–Jean impulse balance
        ``m (v⁺ - v⁻) = h m g + Σ r``).  User loads (``Force``/``Spring``)
        are not included: keep the bodies they act on outside the sample.
    """
    s = sim.sys
    geom = {"is_poly": s.is_poly, "radius": s.radius, "poly_local": s.poly_local,
            "poly_nv": s.poly_nv, "poly_of_body": s.poly_of_body}
    vol = body_volumes(s.is_poly, s.radius, s.poly_local, s.poly_of_body, s.dim)
    return _state(s.pos.copy(), s.angle.copy(), s.vel.copy(), prev_vel if inertia else None, sim.h,
                  sim.last_contacts, s.mass, vol, s.gravity, geom, f"simulation t={sim.t:.6g}")


def from_trajectory(traj, frame: int = -1, gravity=None, inertia: bool = True) -> GranularState:
    """Snapshot of frame ``frame`` of a :class:`~socp_cd.dynamics.trajectory.Trajectory`.

    Gravity is the one the trajectory recorded (``traj.meta["gravity"]``);
    ``gravity`` overrides it (needed only for files without it).  Inertia
    forces are added when the previous frame is one time step earlier
    (``record_every=1``).

    Raises
    ------
    InvalidProblemError
        ``frame`` out of range, or gravity neither recorded nor given.
    """
    nf = len(traj.frames)
    if not -nf <= frame < nf:
        raise InvalidProblemError("frame", f"index {frame} out of range for {nf} frames")
    k = frame % nf
    g = traj.geometry
    d = int(traj.meta["dim"])
    if gravity is None:
        gravity = traj.meta.get("gravity")
        if gravity is None:
            raise InvalidProblemError("gravity", "not recorded in the trajectory: pass gravity=")
    gravity = np.asarray(gravity, dtype=float).reshape(-1)
    if gravity.shape != (d,):
        raise InvalidProblemError("gravity", f"expected {d} components, got {gravity.shape}")
    F = traj.frames[k]
    prev = None
    h = float(traj.meta["h"])
    if inertia and k > 0 and np.isclose(F.t - traj.frames[k - 1].t, h, rtol=1e-6):
        prev = traj.frames[k - 1].vel
    geom = {"is_poly": g["is_poly"], "radius": g["radius"], "poly_local": g["poly_vertices"],
            "poly_nv": g["poly_nv"], "poly_of_body": g["poly_of_body"]}
    vol = body_volumes(g["is_poly"], g["radius"], g["poly_vertices"], g["poly_of_body"], d)
    return _state(F.pos, F.angle, F.vel, prev, h, F.contacts, g["mass"], vol, gravity, geom,
                  f"trajectory frame {k}")


def from_hdf5(path, frame: int = -1, gravity=None, inertia: bool = True) -> GranularState:
    """Read a trajectory HDF5 file and return the state of one frame (see :func:`from_trajectory`)."""
    from ..dynamics.trajectory import Trajectory
    return from_trajectory(Trajectory.load(path), frame, gravity=gravity, inertia=inertia)

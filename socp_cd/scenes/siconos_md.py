"""The same small scene integrated by socp_cd and by Siconos' own Moreau–Jean.

:func:`run_both` takes a scene file's text, integrates it with
:class:`socp_cd.dynamics.Simulation` and, in a subprocess of the system
interpreter that has ``siconos.kernel``, with Siconos' ``MoreauJeanOSI`` +
``FrictionContact`` (worker: ``_siconos_md_worker.py``), and returns both
trajectories.  Siconos' side models each contact as a linear relation with a
fixed normal and fixed arms (see :func:`siconos_job`), so only scenes whose
contact geometry does not change are allowed (columns, round bodies on flat or
inclined supports, blocks sliding without rotating).
"""
from __future__ import annotations

import json
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import SolverError, UnsupportedError


@dataclass
class SideBySide:
    """Trajectories of both integrators, on the same time grid.

    Attributes
    ----------
    t : (F,)
    pos_ours, pos_siconos : (F, n, d)
        Centre positions.
    vel_ours, vel_siconos : (F, n, ndof)
        Velocities (translation then rotation; locked rotations are 0).
    active_ours, active_siconos : (F,)
        Contacts in each step's problem.
    """

    t: np.ndarray
    pos_ours: np.ndarray
    pos_siconos: np.ndarray
    vel_ours: np.ndarray
    vel_siconos: np.ndarray
    active_ours: np.ndarray
    active_siconos: np.ndarray

    def position_difference(self) -> np.ndarray:
        """``max_bodies ||x_ours - x_siconos||_inf`` per frame."""
        return np.abs(self.pos_ours - self.pos_siconos).max(axis=(1, 2))

    def velocity_difference(self) -> np.ndarray:
        """``max_bodies ||v_ours - v_siconos||_inf`` per frame."""
        return np.abs(self.vel_ours - self.vel_siconos).max(axis=(1, 2))


def worker_path() -> Path:
    return Path(__file__).with_name("_siconos_md_worker.py")


def siconos_job(scene, sim, steps: int, distance: float = 0.0, tol: float = 1e-10,
                max_iter: int = 100000) -> dict:
    """The worker's job for a socp_cd ``scene`` integrated as ``sim`` (same h, θ, margin).

    The contacts are those socp_cd detects within ``distance`` in the initial
    configuration, each frozen as a linear relation: its normal, and its arms
    (contact point minus centre: ``∓R n`` for disks/spheres, the detected point
    for polygons) stay those of the start.  That is exact for round bodies on
    flat supports and in straight columns, and for polygons that neither rotate
    nor slide on one another (a block sliding on an incline, a stack sliding as
    one block).

    Parameters
    ----------
    scene : socp_cd.dynamics.Scene
        Disks, spheres or polygons with ``Line``/``Plane`` obstacles.
    sim : socp_cd.dynamics.Simulation
    steps : int
    distance : float
        Detection distance for the contacts declared to Siconos (bodies that
        will touch later must be closer than this at the start).
    """
    from ..dynamics import detect

    s = sim.sys
    d = s.dim
    for k, b in enumerate(scene.bodies):
        if b.kind not in ("disk", "polygon"):
            raise UnsupportedError(f"bodies[{k}]: the Siconos side handles disks, spheres and polygons only")
    for k, o in enumerate(scene.obstacles):
        if o.kind != "halfspace":
            raise UnsupportedError(f"obstacles[{k}]: the Siconos side handles lines and planes only")
    bodies = []
    for k, b in enumerate(scene.bodies):
        q0 = np.r_[s.pos[k], np.zeros(1 if d == 2 else 3)]
        bodies.append({"mass": float(s.mass[k]), "inertia": float(s.inertia[k]), "q0": q0.tolist(),
                       "v0": s.vel[k].tolist(), "rotation": not b.fixed_rotation})

    def arm(body: int, point, normal, sign: float) -> list:
        if scene.bodies[body].kind == "disk":
            return (sign * scene.bodies[body].radius * normal).tolist()
        return (point - s.pos[body]).tolist()

    C = detect(s, max(distance, sim.margin))
    cs = []
    for c in range(C.n):
        i, j, n, p = int(C.i[c]), int(C.j[c]), C.normal[c], C.point[c]
        cs.append({"i": i, "j": j, "normal": n.tolist(), "gap0": float(C.gap[c]), "arm_i": arm(i, p, n, -1.0),
                   "arm_j": arm(j, p, n, 1.0) if j >= 0 else [0.0] * d, "mu": float(C.mu[c]),
                   "e": float(C.e[c])})
    return {"dim": d, "h": sim.h, "theta": sim.theta, "steps": int(steps), "tol": tol, "max_iter": max_iter,
            "gravity": np.asarray(s.gravity).tolist(), "activation_threshold": sim.margin, "bodies": bodies,
            "contacts": cs}


def run_siconos(job: dict, timeout: float = 600) -> dict:
    """Run the worker on ``job``; returns its arrays (``t, q, v, n_active, rotation``)."""
    from ..bench.siconos_peer import siconos_python

    with tempfile.TemporaryDirectory(prefix="socp_cd_md_") as tmp:
        jp, op = Path(tmp) / "job.json", Path(tmp) / "out.npz"
        jp.write_text(json.dumps(job))
        done = subprocess.run([siconos_python(), str(worker_path()), str(jp), str(op)], capture_output=True,
                              text=True, timeout=timeout)
        if done.returncode != 0 or not op.exists():
            raise SolverError(f"Siconos Moreau–Jean worker failed (exit {done.returncode}): "
                              f"{done.stderr.strip()[-800:]}")
        with np.load(op) as z:
            return {k: z[k] for k in z.files}


def run_both(scene_text: str, steps: int, distance: float = 0.0, *, tol: float = 1e-10,
             source: str = "<scene>", solver: str | None = None) -> SideBySide:
    """Integrate a scene (TOML text) ``steps`` steps with socp_cd and with Siconos.

    socp_cd uses ``solver`` (None: the file's, whose default is ``"auto"``) with ``tol``;
    Siconos its NSGS with ``tol``; ``distance``: see :func:`siconos_job`.
    """
    import tomllib

    from ..dynamics import Simulation
    from .builder import build_scene, simulation_options
    from .schema import validate_scene

    spec = validate_scene(tomllib.loads(scene_text), source=source)
    scene = build_scene(spec)
    opts = simulation_options(spec)
    opts["tol"] = tol
    if solver is not None:
        opts["solver"] = solver
    sim = Simulation(scene, opts.pop("h"), **opts)
    job = siconos_job(scene, sim, steps, distance, tol=tol)
    d, n = sim.sys.dim, sim.sys.n_bodies
    pos, vel, act = [sim.sys.pos.copy()], [sim.sys.vel.copy()], [0]
    for _ in range(steps):
        st = sim.step()
        pos.append(sim.sys.pos.copy())
        vel.append(sim.sys.vel.copy())
        act.append(st.n_active)
    sic = run_siconos(job)
    qs, vs = sic["q"], sic["v"]
    ndof = sim.sys.ndof
    vel_s = np.zeros((qs.shape[0], n, ndof))
    for k in range(n):
        m = ndof if sic["rotation"][k] else d
        vel_s[:, k, :m] = vs[:, k, :m]
    return SideBySide(t=np.asarray(sic["t"]), pos_ours=np.array(pos), pos_siconos=qs[:, :, :d],
                      vel_ours=np.array(vel), vel_siconos=vel_s, active_ours=np.array(act),
                      active_siconos=np.asarray(sic["n_active"]))


__all__ = ["SideBySide", "siconos_job", "run_siconos", "run_both", "worker_path"]

"""Moreau–Jean time stepping (θ-scheme, velocity-level contact law).

One step from ``(q_k, v_k, t_k)`` (see ``formulations/moreau_jean.md``):

1. detection of every contact whose gap could close during the step;
2. free velocity ``v_free = v_k + M̂⁻¹ h (f_θ - K (q_k + hθ v_k))`` with the
   iteration matrix ``M̂ = M + h²θ² K`` (``K``: spring stiffness, springs are
   implicit), ``f_θ = θ f(t_{k+1}) + (1-θ) f(t_k)``-type loads;
3. activation: a contact enters the step's problem iff its gap
   ``g <= margin`` or its predicted gap ``g + h(θ u_N^free + (1-θ) u_N^k) <= margin``
   (it closes during the step);
4. the local problem ``u = W r + q`` with ``W = Hᵀ M̂⁻¹ H``,
   ``q = Hᵀ v_free + s``; the normal shift ``s_N`` is Newton's ``e u_N^k`` for
   contacts predicted to close with ``u_N^k < 0`` and ``e > 0`` (impact law ``u_N⁺ + e u_N⁻ ≥ 0``) and the
   gap correction ``max(0, g + h(1-θ) u_N^k)/(hθ) ≥ 0`` otherwise (a contact
   activated early through the margin cannot act at a distance);
5. solve with :func:`socp_cd.solve` (warm start from the previous step's
   impulses matched by persistent contact keys), ``v⁺ = v_free + M̂⁻¹ H r``,
   ``q⁺ = q + h(θ v⁺ + (1-θ) v)``.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidProblemError
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem
from .assembly import assemble_H, contact_frames, delassus, local_velocity, mass_matrix
from .detection import Contacts, detect
from .scene import Scene, compile_scene


@dataclass
class StepStats:
    """Statistics of one step (``time_*`` in seconds, wall clock)."""

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
    """State at time ``t`` and the contacts of the step that led to it."""

    t: float
    pos: np.ndarray
    angle: np.ndarray
    vel: np.ndarray
    contacts: ContactFrame


class Simulation:
    """A Moreau–Jean integrator for a :class:`~socp_cd.dynamics.scene.Scene`.

    Parameters
    ----------
    scene : Scene
    h : float
        Time step.
    theta : float
        θ of the position update ``q⁺ = q + h(θ v⁺ + (1-θ) v)`` (0.5 default, 1 =
        backward Euler); the contact law is always fully implicit in velocity.
    solver : str
        Backend name for :func:`socp_cd.solve` (``"nsgs"`` default, ``"clarabel"``...).
    formulation : str, optional
        Contact law; default ``"coulomb"``, or ``"frictionless"`` when every
        contact has ``mu = 0``.
    tol : float
        Solver tolerance (Siconos relative error).
    max_iter : int, optional
    margin : float, optional
        Activation safety margin on the gap and predicted gap (>= 0); default
        ``1e-3 ×`` the smallest body radius.
    warm_start : bool
        Start the solver from the previous step's impulses (matched by key).
    form : {"local", "global"}
        Pass the solver the condensed problem (``W``, ``q``) or the global one
        (``M̂``, ``H``, ``f``, ``w``).
    solver_options : dict, optional
        Extra keyword options for the backend.
    t0 : float
    """

    def __init__(self, scene: Scene, h: float, *, theta: float = 0.5, solver: str = "nsgs",
                 formulation: Optional[str] = None, tol: float = 1e-8, max_iter: Optional[int] = None,
                 margin: Optional[float] = None, warm_start: bool = True, form: str = "local",
                 solver_options: Optional[dict] = None, t0: float = 0.0):
        if not (np.isfinite(h) and h > 0):
            raise InvalidProblemError("h", f"must be a positive time step, got {h!r}")
        if not (0.0 < theta <= 1.0):
            raise InvalidProblemError("theta", f"must lie in (0, 1], got {theta!r}")
        sys_ = compile_scene(scene)
        if margin is None:
            margin = 1e-3 * float(sys_.radius.min())
        if not (np.isfinite(margin) and margin >= 0):
            raise InvalidProblemError("margin", f"must be >= 0, got {margin!r}")
        if form not in ("local", "global"):
            raise InvalidProblemError("form", f"must be 'local' or 'global', got {form!r}")
        self.scene = scene
        self.sys = sys_
        self.h, self.theta, self.t = float(h), float(theta), float(t0)
        self.solver, self.formulation, self.tol, self.max_iter = solver, formulation, tol, max_iter
        self.margin, self.warm_start, self.form = float(margin), bool(warm_start), form
        self.solver_options = dict(solver_options or {})
        self.stats: list[StepStats] = []
        self.last_contacts = ContactFrame.empty(self.sys.dim)
        self.last_result = None
        self._ws_keys = np.zeros(0, np.int64)
        self._ws_r = np.zeros((0, self.sys.dim))
        s = self.sys
        # spring stiffness per body (translational), iteration matrix M̂ = M + h²θ²K
        self._k = np.zeros(s.n_bodies)
        for sp_ in s.springs:
            self._k[sp_.body] += sp_.stiffness
        inv = s.inv_mass_diag.reshape(s.n_bodies, s.ndof).copy()
        inv[:, :s.dim] = 1.0 / (s.mass + self.h ** 2 * self.theta ** 2 * self._k)[:, None]
        self.inv_mhat = inv.reshape(-1)

    # ------------------------------------------------------------------ loads
    def _spring_pull(self, t: float) -> np.ndarray:
        """``Σ k x_driver(t)`` per body, (n, d)."""
        s = self.sys
        out = np.zeros((s.n_bodies, s.dim))
        for sp_ in s.springs:
            out[sp_.body] += sp_.stiffness * np.asarray(sp_.driver(t), dtype=np.float64).reshape(s.dim)
        return out

    def _user_forces(self, t: float) -> np.ndarray:
        s = self.sys
        out = np.zeros((s.n_bodies, s.ndof))
        for f in s.forces:
            val = np.asarray(f.func(t), dtype=np.float64).reshape(-1)
            if val.size not in (s.dim, s.ndof) or not np.all(np.isfinite(val)):
                raise InvalidProblemError("Force.func", f"returned {val!r}; expected {s.dim} or {s.ndof} finite numbers")
            out[f.body, :val.size] += val
        return out

    def free_velocity(self) -> np.ndarray:
        """Velocity at the end of the step without contact impulses."""
        s, h, th = self.sys, self.h, self.theta
        imp = np.zeros((s.n_bodies, s.ndof))
        imp[:, :s.dim] = s.mass[:, None] * s.gravity[None]
        imp += self._user_forces(self.t + th * h)
        if s.springs:
            pull = th * self._spring_pull(self.t + h) + (1 - th) * self._spring_pull(self.t)
            v = s.vel[:, :s.dim]
            imp[:, :s.dim] += pull - self._k[:, None] * (s.pos + h * th * v)
        return s.vel.reshape(-1) + self.inv_mhat * (h * imp.reshape(-1))

    # ------------------------------------------------------------------ step
    def _detection_distance(self) -> float:
        s = self.sys
        speed = np.linalg.norm(s.vel[:, :s.dim], axis=1) + np.linalg.norm(
            s.vel[:, s.dim:], axis=1) * s.radius
        vmax = float(speed.max()) + self.h * float(np.linalg.norm(s.gravity))
        return self.margin + 2.0 * self.h * 2.0 * vmax

    def _formulation(self, mu) -> str:
        if self.formulation is not None:
            return self.formulation
        return "frictionless" if not np.any(mu > 0) else "coulomb"

    def step(self) -> StepStats:
        """Advance one time step; returns its :class:`StepStats`."""
        from ..solvers import solve

        s, h, th = self.sys, self.h, self.theta
        d, dim = s.dim, s.dim
        t0 = _time.perf_counter()
        C = detect(s, self._detection_distance())
        t1 = _time.perf_counter()
        v0 = s.vel.reshape(-1).copy()
        vfree = self.free_velocity()
        st = StepStats(t=self.t + h, n_detected=C.n, n_active=0)
        dv = np.zeros_like(v0)
        frame = ContactFrame.empty(d)
        if C.n:
            E = contact_frames(C.normal)
            uN0 = local_velocity(s, C, v0, E)[:, 0]
            uNf = local_velocity(s, C, vfree, E)[:, 0]
            closing = C.gap + h * (th * uNf + (1 - th) * uN0) <= self.margin
            active = closing | (C.gap <= self.margin)
            if active.any():
                A = C.subset(active)
                Ha, Ea = assemble_H(s, A)
                u0 = uN0[active]
                impact = (u0 < 0) & (A.e > 0) & closing[active]
                shift = np.where(impact, A.e * u0, np.maximum(0.0, A.gap + h * (1 - th) * u0) / (h * th))
                w = np.zeros(A.n * dim)
                w[::dim] = shift
                r0 = self._warm(A.key) if self.warm_start else None
                form = self._formulation(A.mu)
                if self.form == "local":
                    W = delassus(Ha, self.inv_mhat)
                    prob = FrictionContactProblem(W, Ha.T @ vfree + w, A.mu, dim, name=f"step t={self.t:.6g}")
                else:
                    prob = self._global_problem(Ha, vfree, w, A.mu)
                t2 = _time.perf_counter()
                res = solve(prob, solver=self.solver, formulation=form, tol=self.tol,
                            max_iter=self.max_iter, r0=r0, **self.solver_options)
                t3 = _time.perf_counter()
                r = res.r.reshape(-1, dim)
                dv = self.inv_mhat * (Ha @ res.r)
                self._ws_keys, order = np.sort(A.key), np.argsort(A.key)
                self._ws_r = r[order]
                force = np.einsum("ckd,ck->cd", Ea, r) / h
                frame = ContactFrame(np.c_[A.i, A.j], A.obstacle, A.point, A.normal, A.gap, r, force, A.key)
                st.n_active = A.n
                st.solver, st.status, st.converged = res.solver, res.status, res.converged
                st.error, st.iterations = res.error, res.iterations
                st.time_assembly, st.time_solve = t2 - t1, t3 - t2
                self.last_result = res
            else:
                self._ws_keys, self._ws_r = np.zeros(0, np.int64), np.zeros((0, dim))
                st.time_assembly = _time.perf_counter() - t1
        else:
            self._ws_keys, self._ws_r = np.zeros(0, np.int64), np.zeros((0, dim))
        st.time_detection = t1 - t0
        vnew = vfree + dv
        V0 = v0.reshape(s.n_bodies, s.ndof)
        V1 = vnew.reshape(s.n_bodies, s.ndof)
        vm = th * V1 + (1 - th) * V0
        s.pos = s.pos + h * vm[:, :d]
        if d == 2:
            s.angle = s.angle + h * vm[:, 2]
        s.vel = V1.copy()
        self.t += h
        self.last_contacts = frame
        self.stats.append(st)
        return st

    def _warm(self, keys: np.ndarray) -> Optional[np.ndarray]:
        if self._ws_keys.size == 0:
            return None
        idx = np.searchsorted(self._ws_keys, keys)
        idx = np.minimum(idx, self._ws_keys.size - 1)
        hit = self._ws_keys[idx] == keys
        if not hit.any():
            return None
        r0 = np.zeros((keys.size, self.sys.dim))
        r0[hit] = self._ws_r[idx[hit]]
        return r0.reshape(-1)

    def _global_problem(self, Ha, vfree, w, mu) -> GlobalFrictionContactProblem:
        """Global form ``M̂ v = H r + f``, ``u = Hᵀ v + w`` (locked dofs held at v_free)."""
        s = self.sys
        locked = self.inv_mhat == 0
        M = mass_matrix(self.inv_mhat)
        f = M @ vfree
        Hg = Ha
        if locked.any():
            keep = (~locked).astype(np.float64)
            Hg = (sp.diags(keep) @ Ha).tocsr()
            w = w + (Ha - Hg).T @ vfree
        return GlobalFrictionContactProblem(M, Hg, f, w, mu, s.dim, name=f"step t={self.t:.6g}")

    # ------------------------------------------------------------------ output
    def frame(self) -> Frame:
        """Current state and the last step's contacts."""
        s = self.sys
        return Frame(self.t, s.pos.copy(), s.angle.copy(), s.vel.copy(), self.last_contacts)

    def energy(self) -> float:
        """Kinetic + gravity + spring potential energy (springs' driver at the current time)."""
        s = self.sys
        invm = s.inv_mass_diag.reshape(s.n_bodies, s.ndof)
        mdiag = np.where(invm > 0, 1.0 / np.where(invm > 0, invm, 1.0), 0.0)
        ek = 0.5 * float(np.sum(mdiag * s.vel ** 2))
        ep = -float(np.sum(s.mass[:, None] * s.gravity[None] * s.pos))
        for sp_ in s.springs:
            dx = s.pos[sp_.body] - np.asarray(sp_.driver(self.t))
            ep += 0.5 * sp_.stiffness * float(dx @ dx)
        return ek + ep

    def run(self, n_steps: Optional[int] = None, *, t_end: Optional[float] = None, record_every: int = 1,
            progress: Optional[bool] = None, path=None, callback=None):
        """Integrate and record a :class:`~socp_cd.dynamics.trajectory.Trajectory`.

        Parameters
        ----------
        n_steps : int, optional
            Number of steps (or give ``t_end``).
        t_end : float, optional
        record_every : int
            Record one frame every that many steps (the initial state is frame 0).
        progress : bool or None
            tqdm progress bar (None: only on a terminal).
        path : str or Path, optional
            Save the trajectory to this HDF5 file at the end.
        callback : callable, optional
            ``callback(sim, stats)`` after every step.

        Returns
        -------
        Trajectory
        """
        from tqdm.auto import tqdm

        from .trajectory import Trajectory

        if n_steps is None:
            if t_end is None:
                raise InvalidProblemError("n_steps", "give n_steps or t_end")
            n_steps = int(round((t_end - self.t) / self.h))
        traj = Trajectory.start(self)
        disable = None if progress is None else (not progress)
        for k in tqdm(range(int(n_steps)), disable=disable, leave=False, desc="moreau-jean"):
            st = self.step()
            if callback is not None:
                callback(self, st)
            if (k + 1) % record_every == 0:
                traj.append(self.frame())
        traj.stats = list(self.stats)
        if path is not None:
            traj.save(path)
        return traj


__all__ = ["Simulation", "StepStats", "Frame", "ContactFrame"]

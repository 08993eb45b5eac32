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
   ``q⁺ = q + h(θ v⁺ + (1-θ) v)`` (3D orientations: ``q⁺ = exp(½ h ω_m) ⊗ q``);
6. position projection (``projection=True``): if a detected contact's predicted
   end gap ``g + h(θ u_N⁺ + (1-θ) u_N⁻)`` is below ``-projection_tol``, the
   positions are moved by ``Δq = M̂⁻¹ H λ`` with ``λ`` the solution of the
   frictionless problem ``0 ≤ λ ⊥ g_end + W λ ≥ 0`` (the mass-weighted
   closest non-penetrating configuration, linearized), velocities untouched.

3D polyhedra have a full inertia tensor: ``M`` is block diagonal with
``I_w = R I_body Rᵀ`` evaluated at the start of the step; the gyroscopic
torque ``-ω × I_w ω`` is explicit (evaluated at ``t_k``).

Public hooks: after :meth:`Simulation.step`, ``sim.last_problem`` holds the
step's :class:`~socp_cd.problem.FrictionContactProblem` (or the global one),
``sim.last_result`` the solver result, ``sim.last_active`` the active
:class:`~socp_cd.dynamics.detection.Contacts` (``None`` for all three when no
contact was active); :meth:`Simulation.get_state` / :meth:`Simulation.set_state`
save and restore the kinematic state together with the warm start.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidProblemError
from ..problem import FrictionContactProblem, GlobalFrictionContactProblem
from .assembly import (assemble_H, block_inverse_mass, contact_frames, delassus, local_velocity, mass_matrix,
                       world_inertia, world_inverse_inertia)
from .detection import Contacts, detect
from .frames import ContactFrame, Frame, StepStats
from .geometry3d import quat_integrate
from .overlap import warn_initial_overlaps
from .scene import Scene, compile_scene
from .trajectory import Trajectory


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
        Backend name for :func:`socp_cd.solve` (``"auto"`` default, as ``solve``'s;
        ``"nsgs"``, ``"clarabel"``...).  On 19 whole simulations ``"nsgs"`` ended 1 277 of
        25 576 steps unconverged, ``"auto"`` 1 (``validation/results/scene_solvers_s49.md``).
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
    projection : bool, optional
        Post-step position projection removing penetrations deeper than
        ``projection_tol`` (see the module docstring); velocities are not changed.
        Default (None): on for scenes with 3D polyhedra, off otherwise, so that
        existing disk/polygon/sphere trajectories are unchanged; pass ``True``
        to hold non-penetration in any scene.
    projection_tol : float, optional
        Default ``10⁻⁴ ×`` the smallest body radius.
    check_overlap : bool
        Warn (:class:`~socp_cd.dynamics.overlap.OverlapWarning`) when bodies
        overlap at the start by more than ``10⁻⁶ ×`` the smallest radius.
    """

    def __init__(self, scene: Scene, h: float, *, theta: float = 0.5, solver: str = "auto",
                 formulation: Optional[str] = None, tol: float = 1e-8, max_iter: Optional[int] = None,
                 margin: Optional[float] = None, warm_start: bool = True, form: str = "local",
                 solver_options: Optional[dict] = None, t0: float = 0.0, projection: Optional[bool] = None,
                 projection_tol: Optional[float] = None, check_overlap: bool = True):
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
        if projection_tol is None:
            projection_tol = 1e-4 * float(sys_.radius.min())
        if not (np.isfinite(projection_tol) and projection_tol >= 0):
            raise InvalidProblemError("projection_tol", f"must be >= 0, got {projection_tol!r}")
        if projection is None:
            projection = bool(sys_.dim == 3 and sys_.has_hulls)
        self.projection, self.projection_tol = bool(projection), float(projection_tol)
        self.stats: list[StepStats] = []
        self.last_contacts = ContactFrame.empty(self.sys.dim)
        self.last_result = None
        self.last_problem = None
        self.last_active: Optional[Contacts] = None
        self.n_projections = 0
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
        self._locked = inv[:, s.dim:].max(axis=1) == 0 if s.dim == 3 else None
        if check_overlap:
            warn_initial_overlaps(scene, sys_, 1e-6 * float(sys_.radius.min()))

    # ------------------------------------------------------------------ mass
    def inverse_mass(self):
        """``M̂⁻¹`` at the current configuration: diagonal ndarray, or sparse block-diagonal with polyhedra."""
        s = self.sys
        if s.dim == 2 or not s.is_hull.any():
            return self.inv_mhat
        inv = self.inv_mhat.reshape(s.n_bodies, s.ndof)
        return block_inverse_mass(inv[:, 0], world_inverse_inertia(s.rotations(), s.inertia_body, self._locked))

    @staticmethod
    def _apply(minv, x: np.ndarray) -> np.ndarray:
        return minv @ x if sp.issparse(minv) else minv * x

    # ------------------------------------------------------------------ state
    def use_solver(self, solver, *, tol: Optional[float] = None, max_iter: Optional[int] = None,
                   form: Optional[str] = None, time_limit: Optional[float] = None,
                   options: Optional[dict] = None) -> None:
        """Solver settings of the next steps (e.g. a tight final step after a loose transient).

        Parameters
        ----------
        solver : str or callable
            Passed to :func:`socp_cd.solve`.
        tol : float, optional
            New tolerance (kept when None).
        max_iter : int, optional
            Iteration cap; None: the solver's own default (caps differ between
            solvers: NSGS sweeps, Newton's outer iterations, ``auto``'s stages).
        form : {"local", "global"}, optional
            Kept when None.
        time_limit : float, optional
            Seconds per step (``time_limit`` of :func:`socp_cd.solve`); None:
            no limit.
        options : dict, optional
            Solver-specific options of the new solver (those of the previous
            one are dropped: they may not exist for this one).

        Raises
        ------
        InvalidProblemError
            A ``tol`` or ``time_limit`` that is not a positive number, a
            ``max_iter`` that is not a positive integer, or an unknown ``form``.
        """
        def positive(name, value):
            try:
                v = float(value)
            except (TypeError, ValueError):
                v = float("nan")
            if not (np.isfinite(v) and v > 0):
                raise InvalidProblemError(name, f"must be a positive number, got {value!r}")
            return v

        tol = None if tol is None else positive("tol", tol)
        time_limit = None if time_limit is None else positive("time_limit", time_limit)
        if max_iter is not None and (isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer))
                                     or max_iter < 1):
            raise InvalidProblemError("max_iter", f"must be a positive integer, got {max_iter!r}")
        if form is not None and form not in ("local", "global"):
            raise InvalidProblemError("form", f"must be 'local' or 'global', got {form!r}")
        self.solver, self.max_iter = solver, None if max_iter is None else int(max_iter)
        if tol is not None:
            self.tol = tol
        if form is not None:
            self.form = form
        opts = dict(options or {})
        if time_limit is not None:
            opts["time_limit"] = time_limit
        self.solver_options = opts

    def get_state(self) -> dict:
        """Copy of everything :meth:`step` depends on: time, kinematics and warm start.

        Returns
        -------
        dict
            ``t``, ``pos`` (n, d), ``angle`` (n,), ``vel`` (n, ndof), ``orientation``
            (n, 4) or None, ``ws_keys`` (k,) and ``ws_r`` (k, dim) (impulses of the
            last step's active contacts by persistent key).
        """
        s = self.sys
        return {"t": self.t, "pos": s.pos.copy(), "angle": s.angle.copy(), "vel": s.vel.copy(),
                "orientation": None if s.orientation is None else s.orientation.copy(),
                "ws_keys": self._ws_keys.copy(), "ws_r": self._ws_r.copy()}

    def set_state(self, state: dict) -> None:
        """Restore a state from :meth:`get_state` (same scene); missing warm-start keys clear it.

        Raises
        ------
        InvalidProblemError
            A field with the wrong shape or non-finite values.
        """
        s = self.sys

        def arr(name, shape, dtype=np.float64):
            a = np.asarray(state[name], dtype=dtype)
            if a.shape != shape or (dtype == np.float64 and not np.all(np.isfinite(a))):
                raise InvalidProblemError(f"state[{name!r}]", f"must be finite with shape {shape}, got {a.shape}")
            return a.copy()

        t = float(state["t"])
        pos, angle = arr("pos", s.pos.shape), arr("angle", s.angle.shape)
        vel = arr("vel", s.vel.shape)
        quat = None
        if s.orientation is not None and state.get("orientation") is not None:
            quat = arr("orientation", s.orientation.shape)
            quat /= np.linalg.norm(quat, axis=1)[:, None]
        keys = np.asarray(state.get("ws_keys", np.zeros(0)), dtype=np.int64).reshape(-1)
        ws_r = np.asarray(state.get("ws_r", np.zeros((0, s.dim))), dtype=np.float64).reshape(-1, s.dim)
        if ws_r.shape[0] != keys.size:
            raise InvalidProblemError("state['ws_r']", f"has {ws_r.shape[0]} rows for {keys.size} keys")
        order = np.argsort(keys)
        self.t, s.pos, s.angle, s.vel = t, pos, angle, vel
        if quat is not None:
            s.orientation = quat
        self._ws_keys, self._ws_r = keys[order], ws_r[order]

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

    def free_velocity(self, minv=None) -> np.ndarray:
        """Velocity at the end of the step without contact impulses (``minv``: :meth:`inverse_mass`)."""
        s, h, th = self.sys, self.h, self.theta
        imp = np.zeros((s.n_bodies, s.ndof))
        imp[:, :s.dim] = s.mass[:, None] * s.gravity[None]
        imp += self._user_forces(self.t + th * h)
        if s.springs:
            pull = th * self._spring_pull(self.t + h) + (1 - th) * self._spring_pull(self.t)
            v = s.vel[:, :s.dim]
            imp[:, :s.dim] += pull - self._k[:, None] * (s.pos + h * th * v)
        minv = self.inverse_mass() if minv is None else minv
        if minv is not self.inv_mhat:      # polyhedra: explicit gyroscopic torque -ω × I_w ω
            w = s.vel[:, 3:]
            Iw = world_inertia(s.rotations(), s.inertia_body)
            gyro = -np.cross(w, np.einsum("bij,bj->bi", Iw, w))
            gyro[self._locked] = 0.0
            imp[:, 3:] += gyro
        return s.vel.reshape(-1) + self._apply(minv, h * imp.reshape(-1))

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
        minv = self.inverse_mass()
        vfree = self.free_velocity(minv)
        st = StepStats(t=self.t + h, n_detected=C.n, n_active=0)
        dv = np.zeros_like(v0)
        frame = ContactFrame.empty(d)
        self.last_problem = self.last_result = self.last_active = None
        A = None
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
                    W = delassus(Ha, minv)
                    prob = FrictionContactProblem(W, Ha.T @ vfree + w, A.mu, dim, name=f"step t={self.t:.6g}")
                else:
                    prob = self._global_problem(Ha, vfree, w, A.mu, minv)
                t2 = _time.perf_counter()
                res = solve(prob, solver=self.solver, formulation=form, tol=self.tol,
                            max_iter=self.max_iter, r0=r0, **self.solver_options)
                t3 = _time.perf_counter()
                r = res.r.reshape(-1, dim)
                dv = self._apply(minv, Ha @ res.r)
                self._ws_keys, order = np.sort(A.key), np.argsort(A.key)
                self._ws_r = r[order]
                force = np.einsum("ckd,ck->cd", Ea, r) / h
                frame = ContactFrame(np.c_[A.i, A.j], A.obstacle, A.point, A.normal, A.gap, r, force, A.key)
                st.n_active = A.n
                st.solver, st.status, st.converged = res.solver, res.status, res.converged
                st.error, st.iterations = res.error, res.iterations
                st.time_assembly, st.time_solve = t2 - t1, t3 - t2
                self.last_result, self.last_problem, self.last_active = res, prob, A
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
        self._move(h * vm)
        s.vel = V1.copy()
        if self.projection:
            t4 = _time.perf_counter()
            self._project_penetrations()
            st.time_projection = _time.perf_counter() - t4
        self.t += h
        self.last_contacts = frame
        self.stats.append(st)
        return st

    def _move(self, dq: np.ndarray) -> None:
        """Displace every body by ``dq`` (n, ndof): translation, then rotation (angle or quaternion)."""
        s, d = self.sys, self.sys.dim
        s.pos = s.pos + dq[:, :d]
        if d == 2:
            s.angle = s.angle + dq[:, 2]
        else:
            s.orientation = quat_integrate(s.orientation, dq[:, 3:], 1.0)

    def _project_penetrations(self, max_rounds: int = 3) -> None:
        """Post-step projection on the gaps detected at the new positions (see the module docstring).

        Each round detects contacts within ``margin``; if one penetrates deeper
        than ``projection_tol`` (depth ``δ``), every pair within ``margin + 2δ``
        (those the correction could close) is constrained and the positions
        move by ``Δq = M̂⁻¹ H λ`` with
        ``0 ≤ λ ⊥ g + tol/2 + W λ ≥ 0`` (frictionless, NSGS, tol 1e-10).  The
        gaps are linear in ``Δq`` only to first order (rotations), hence up to
        ``max_rounds`` rounds.
        """
        from ..solvers import solve

        s, dim = self.sys, self.sys.dim
        for _ in range(max_rounds):
            D = detect(s, self.margin)
            if D.n == 0 or D.gap.min() >= -self.projection_tol:
                return
            # pairs the displacement (at most ~ the depth) could close are constrained too
            D = detect(s, self.margin - 2.0 * float(D.gap.min()))
            minv = self.inverse_mass()
            Hp, _ = assemble_H(s, D)
            W = delassus(Hp, minv)
            q = np.zeros(W.shape[0])
            q[::dim] = D.gap + 0.5 * self.projection_tol     # leave half the tolerance: no chatter
            prob = FrictionContactProblem(W, q, np.zeros(D.n), dim, name=f"projection t={self.t:.6g}")
            res = solve(prob, solver="nsgs", formulation="frictionless", tol=1e-10)
            self._move(self._apply(minv, Hp @ res.r).reshape(s.n_bodies, s.ndof))
            self.n_projections += 1

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

    def _global_problem(self, Ha, vfree, w, mu, minv) -> GlobalFrictionContactProblem:
        """Global form ``M̂ v = H r + f``, ``u = Hᵀ v + w`` (locked dofs held at v_free)."""
        s = self.sys
        locked = self.inv_mhat == 0
        M = mass_matrix(minv)
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
        quat = None if s.orientation is None else s.orientation.copy()
        return Frame(self.t, s.pos.copy(), s.angle.copy(), s.vel.copy(), self.last_contacts, quat)

    def energy(self) -> float:
        """Kinetic + gravity + spring potential energy (springs' driver at the current time)."""
        s = self.sys
        invm = s.inv_mass_diag.reshape(s.n_bodies, s.ndof)
        mdiag = np.where(invm > 0, 1.0 / np.where(invm > 0, invm, 1.0), 0.0)
        if s.dim == 3:      # full inertia tensors (locked rotations carry no kinetic energy)
            mdiag[:, 3:] = 0.0
            w = s.vel[:, 3:]
            Iw = world_inertia(s.rotations(), s.inertia_body)
            erot = 0.5 * np.einsum("bi,bij,bj->b", w, Iw, w)
            ek = 0.5 * float(np.sum(mdiag * s.vel ** 2)) + float(erot[~self._locked].sum())
        else:
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

#!/usr/bin/env python3
"""Siconos worker: integrates a small rigid-body scene with Siconos' own Moreau–Jean.

Run by the system interpreter that has ``siconos.kernel``
(``/usr/bin/python3 _siconos_md_worker.py JOB.json OUT.npz``); it must not
import socp_cd.  The venv side is :mod:`socp_cd.scenes.siconos_md`.

JOB (JSON)::

    {"dim": 2 | 3, "h": float, "theta": float, "steps": int, "tol": float, "max_iter": int,
     "gravity": [..d..], "activation_threshold": float,
     "bodies": [{"mass": m, "inertia": I, "q0": [...], "v0": [...], "rotation": bool}, ...],
     "contacts": [{"i": int, "j": int (-1: fixed), "normal": [..d..], "gap0": float,
                   "arm_i": [..d..], "arm_j": [..d..], "mu": float, "e": float}, ...]}

Bodies are ``LagrangianLinearTIDS`` with generalised coordinates
``(x, y, angle)`` in 2D and ``(x, y, z, rx, ry, rz)`` in 3D (translation only
when ``rotation`` is false); the rotation coordinates of round bodies never
enter the geometry.  Each contact is a ``LagrangianLinearTIR`` ``y = C q + e``
with a *fixed* normal: ``y_N = n·(x_i - x_j) + gap0 - n·(x_i0 - x_j0)`` and
tangential rows giving the relative velocity of the contact points
(``arm``: contact point minus centre), with a ``NewtonImpactFrictionNSL(e, 0,
mu)``; so the scenes must keep their normals (columns, flat or inclined
supports).  Integration: ``MoreauJeanOSI(theta)`` (a contact enters the step's
problem when ``y + h ẏ / 2 <= activation_threshold``), ``FrictionContact`` with
NSGS, ``TimeStepping``.

OUT (npz): ``t (F,)``, ``q (F, n, ndof)``, ``v (F, n, ndof)``,
``n_active (F,)`` (interactions in the contact problem of each step), ``status``.
"""
import json
import sys

import numpy as np


def _skew_rows(t, arm, dim):
    """Row of the tangential (or normal) velocity ``t·(v + ω × arm)`` for one body."""
    if dim == 2:
        return np.r_[t, t[0] * (-arm[1]) + t[1] * arm[0]]
    return np.r_[t, np.cross(arm, t)]          # t·(ω × a) = ω·(a × t)


def _frame(n):
    n = np.asarray(n, float)
    if n.size == 2:
        return [n, np.array([-n[1], n[0]])]
    a = np.eye(3)[np.argmin(np.abs(n))]
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return [n, t1, np.cross(n, t1)]


def main(job_path, out_path):
    import siconos.kernel as sk
    import siconos.numerics as sn

    job = json.load(open(job_path))
    d = job["dim"]
    h, theta, steps = job["h"], job["theta"], job["steps"]
    T = h * steps
    nsds = sk.NonSmoothDynamicalSystem(0.0, T)
    dss, ndofs, rot = [], [], []
    g = np.asarray(job["gravity"], float)
    for b in job["bodies"]:
        rotation = b.get("rotation", True)
        nr = (1 if d == 2 else 3) if rotation else 0
        nd = d + nr
        M = np.diag([b["mass"]] * d + [b["inertia"]] * nr)
        ds = sk.LagrangianLinearTIDS(np.asarray(b["q0"], float)[:nd], np.asarray(b["v0"], float)[:nd], M)
        fext = np.zeros(nd)
        fext[:d] = b["mass"] * g
        ds.setFExtPtr(fext)
        nsds.insertDynamicalSystem(ds)
        dss.append(ds)
        ndofs.append(nd)
        rot.append(rotation)
    for c in job["contacts"]:
        n = np.asarray(c["normal"], float)
        E = _frame(n)
        i, j = c["i"], c["j"]
        rows_i = np.array([_skew_rows(t, np.asarray(c["arm_i"], float), d)[:ndofs[i]] for t in E])
        blocks = [rows_i]
        q_i0 = np.asarray(job["bodies"][i]["q0"], float)[:d]
        e_off = c["gap0"] - n @ q_i0
        if j >= 0:
            rows_j = np.array([_skew_rows(t, np.asarray(c["arm_j"], float), d)[:ndofs[j]] for t in E])
            blocks.append(-rows_j)
            e_off += n @ np.asarray(job["bodies"][j]["q0"], float)[:d]
        C = np.hstack(blocks)
        e = np.zeros(d)
        e[0] = e_off
        rel = sk.LagrangianLinearTIR(C, e)
        nsl = sk.NewtonImpactFrictionNSL(c["e"], 0.0, c["mu"], d)
        inter = sk.Interaction(nsl, rel)
        if j >= 0:
            nsds.link(inter, dss[i], dss[j])
        else:
            nsds.link(inter, dss[i])
    osi = sk.MoreauJeanOSI(theta)
    osi.setConstraintActivationThreshold(job.get("activation_threshold", 0.0))
    td = sk.TimeDiscretisation(0.0, h)
    if d == 3:
        osnspb = sk.FrictionContact(3, sn.SICONOS_FRICTION_3D_NSGS)
    else:
        osnspb = sk.FrictionContact(2, sn.SICONOS_FRICTION_2D_NSGS)
    so = osnspb.numericsSolverOptions()
    so.iparam[sn.SICONOS_IPARAM_MAX_ITER] = job["max_iter"]
    so.dparam[sn.SICONOS_DPARAM_TOL] = job["tol"]
    sim = sk.TimeStepping(nsds, td, osi, osnspb)
    nmax = max(ndofs)
    ts, Q, V, act = [0.0], [], [], [0]

    def record():
        q = np.zeros((len(dss), nmax))
        v = np.zeros((len(dss), nmax))
        for k, ds in enumerate(dss):
            q[k, :ndofs[k]] = ds.q()
            v[k, :ndofs[k]] = ds.velocity()
        Q.append(q)
        V.append(v)

    record()
    k = 0
    while sim.hasNextEvent() and k < steps:
        sim.computeOneStep()
        k += 1
        ts.append(sim.nextTime())
        act.append(len(sim.indexSet(1).interactions()))
        record()
        sim.nextStep()
    np.savez(out_path, t=np.array(ts), q=np.array(Q), v=np.array(V), n_active=np.array(act),
             rotation=np.array(rot))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])

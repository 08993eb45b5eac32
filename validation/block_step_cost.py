"""Cost of one Moreau–Jean step for 100, 1 000 and 5 000 3D blocks (boxes).

Scene: walls of stacks, 5 boxes of 10 cm per stack, on a plane, each box with
a small random yaw (±0.05 rad) and offset (±2 mm), so every interface is a
clipped face–face manifold (4 points); ``mu = 0.5``, ``h = 2e-3``, NSGS tol
1e-6.  After 10 warm-up steps (numba compiled, warm start primed) ``--steps``
steps are timed; the table gives the min and median over steps of the split
reported by :class:`~socp_cd.dynamics.StepStats` (detection, assembly, solve).

Same run, same problem: the last timed step's local problem
(``sim.last_problem``) is solved again by socp_cd NSGS and by Siconos 4.4
``fc3d_nsgs`` (subprocess bridge), both from the warm start the stepper used,
to the same tolerance (error judged by :func:`socp_cd.error`).

Narrow phase, compiled SAT + clipping vs coal: the polyhedron pairs of the
1 000-block scene are run through our batched kernel
(:func:`socp_cd.dynamics.narrow3d.hull_hull`) and, when a Python with
``coal`` is given (``--coal-python``; coal is *not* a project dependency),
through ``coal.collide`` + ``coal.computeContactPatch`` pair by pair.

Writes ``validation/results/block_step_cost.md``.  Timings on a shared
2-core machine are noisy: min of repeats is the figure to compare.
Usage: ``python validation/block_step_cost.py [--sizes 100,1000,5000] [--steps 10] [--coal-python PATH]``
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.dynamics import Box, Plane, Scene, Simulation
from socp_cd.dynamics.detection import broad_phase, hull_pair_contacts, world_hull_table
from socp_cd.dynamics.geometry3d import quat_from_rotvec

RES = Path(__file__).resolve().parent / "results"
L, H_STEP, MU, TOL, PER_STACK = 0.1, 2e-3, 0.5, 1e-6, 5


def block_walls(n: int, seed: int = 0) -> Scene:
    """``n`` boxes in stacks of 5 on a square grid (spacing 1.5 L), small random yaw and offset."""
    rng = np.random.default_rng(seed)
    stacks = int(np.ceil(n / PER_STACK))
    side = int(np.ceil(np.sqrt(stacks)))
    bodies = []
    for k in range(n):
        s, lev = divmod(k, PER_STACK)
        x, y = 1.5 * L * (s % side), 1.5 * L * (s // side)
        off = rng.uniform(-2e-3, 2e-3, 2)
        bodies.append(Box((L, L, L), (x + off[0], y + off[1], L / 2 + lev * L),
                          orientation=quat_from_rotvec([0.0, 0.0, rng.uniform(-0.05, 0.05)]), density=1000.0))
    return Scene(bodies, [Plane()], mu=MU)


def warm_guess(state: dict, keys: np.ndarray, dim: int = 3):
    """The stepper's warm start for contacts ``keys`` from a :meth:`Simulation.get_state` dict."""
    ks, rs = state["ws_keys"], state["ws_r"]
    r0 = np.zeros((keys.size, dim))
    if ks.size:
        idx = np.minimum(np.searchsorted(ks, keys), ks.size - 1)
        hit = ks[idx] == keys
        r0[hit] = rs[idx[hit]]
    return r0.reshape(-1)


def time_steps(n: int, steps: int):
    sim = Simulation(block_walls(n), H_STEP, solver="nsgs", tol=TOL, max_iter=2000)
    for _ in range(10):
        sim.step()
    rows = []
    for _ in range(steps):
        state = sim.get_state()
        t0 = time.perf_counter()
        st = sim.step()
        rows.append((st.time_detection, st.time_assembly, st.time_solve, st.time_projection,
                     time.perf_counter() - t0, st.iterations, st.n_active, st.error))
    return sim, state, np.array(rows)


def same_problem(sim, state):
    """Our NSGS and Siconos NSGS on the last step's problem, same warm start."""
    from socp_cd.bench.siconos_peer import siconos_available, siconos_solve

    prob = sim.last_problem
    r0 = warm_guess(state, sim.last_active.key)
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        res = socp_cd.solve(prob, solver="nsgs", tol=TOL, max_iter=2000, r0=r0)
        best = min(best, time.perf_counter() - t0)
    out = {"ours_s": best, "ours_it": res.iterations, "ours_err": socp_cd.error(prob, res.r)}
    if siconos_available():
        s = min((siconos_solve(prob, "nsgs", tol=TOL, max_iter=2000, r0=r0) for _ in range(3)),
                key=lambda d: d.get("time", np.inf))
        out.update(sic_s=s.get("time", np.nan), sic_it=s.get("iterations", -1),
                   sic_err=socp_cd.error(prob, s["r"]) if s.get("r") is not None else np.nan,
                   sic_status=s["status"])
    return out


_COAL_SCRIPT = r"""
import json, sys, time
import numpy as np, coal
d = np.load(sys.argv[1])
A, B = d["A"], d["B"]           # (m, 4, 4) homogeneous transforms of the two boxes
half = float(d["size"])
box = coal.Box(half, half, half)
req = coal.CollisionRequest(); req.num_max_contacts = 4; req.security_margin = float(d["margin"])
preq = coal.ContactPatchRequest()
res = coal.CollisionResult(); pres = coal.ContactPatchResult()
Ta = [coal.Transform3s(a[:3, :3], a[:3, 3]) for a in A]
Tb = [coal.Transform3s(b[:3, :3], b[:3, 3]) for b in B]
best, npts = np.inf, 0
for rep in range(5):
    npts = 0
    t0 = time.perf_counter()
    for ta, tb in zip(Ta, Tb):
        res.clear(); pres.clear()
        coal.collide(box, ta, box, tb, req, res)
        if res.isCollision():
            coal.computeContactPatch(box, ta, box, tb, res, preq, pres)
            for k in range(pres.numContactPatches()):
                npts += pres.getContactPatch(k).size()
    best = min(best, time.perf_counter() - t0)
print(json.dumps({"seconds": best, "pairs": len(Ta), "points": npts, "version": coal.__version__}))
"""


def narrow_phase(coal_python):
    """Per-pair cost of our batched hull kernel vs coal on the 1 000-block scene's candidate pairs."""
    from socp_cd.dynamics.scene import compile_scene

    sysm = compile_scene(block_walls(1000))
    margin = 1e-3
    cand = broad_phase(sysm, margin).bodies
    HT = world_hull_table(sysm)
    ia, ib = sysm.hull_of_body[cand[:, 0]], sysm.hull_of_body[cand[:, 1]]
    hull_pair_contacts(HT, ia[:2], ib[:2], margin)
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        valid = hull_pair_contacts(HT, ia, ib, margin)[0]
        best = min(best, time.perf_counter() - t0)
    out = {"pairs": int(cand.shape[0]), "ours_us": 1e6 * best / cand.shape[0], "ours_points": int(valid.sum())}
    if coal_python:
        R = sysm.rotations()
        T = np.zeros((sysm.n_bodies, 4, 4))
        T[:, :3, :3], T[:, :3, 3], T[:, 3, 3] = R, sysm.pos, 1.0
        with tempfile.TemporaryDirectory() as d:
            np.savez(Path(d) / "pairs.npz", A=T[cand[:, 0]], B=T[cand[:, 1]], size=L, margin=margin)
            (Path(d) / "run.py").write_text(_COAL_SCRIPT)
            p = subprocess.run([coal_python, str(Path(d) / "run.py"), str(Path(d) / "pairs.npz")],
                               capture_output=True, text=True, timeout=600)
        if p.returncode == 0:
            c = json.loads(p.stdout.strip().splitlines()[-1])
            out.update(coal_us=1e6 * c["seconds"] / c["pairs"], coal_points=c["points"], coal_version=c["version"])
        else:
            out["coal_error"] = p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "failed"
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="100,1000,5000")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--coal-python", default=None, help="a Python with coal installed (comparison only)")
    ap.add_argument("--out", default=str(RES / "block_step_cost.md"))
    args = ap.parse_args(argv)
    lines = ["# Step cost of 3D blocks (Moreau–Jean, NSGS)", "",
             "Generated by `validation/block_step_cost.py`. Walls of 5-box stacks (10 cm boxes, small random "
             f"yaw/offset), mu = {MU}, h = {H_STEP}, NSGS tol {TOL:g}; after 10 warm-up steps, {args.steps} steps "
             "timed: min / median ms per step. Shared 2-core machine: timings are noisy, min is the figure to compare.",
             "Assembly includes the free velocity (block inverse mass, gyroscopic term); projection is the post-step "
             "detection at the new positions (and a frictionless solve when something penetrates).",
             "", "| blocks | active contacts | detection ms | assembly ms | solve ms | projection ms | whole step ms "
             "| NSGS sweeps |", "|---|---|---|---|---|---|---|---|"]
    same = []
    for n in [int(x) for x in args.sizes.split(",")]:
        print(f"N = {n} ...", flush=True)
        sim, state, R = time_steps(n, args.steps)
        ms = 1e3 * R[:, :5]
        lines.append(f"| {n} | {int(np.median(R[:, 6]))} | " + " | ".join(
            f"{ms[:, k].min():.2f} / {np.median(ms[:, k]):.2f}" for k in range(5)) + f" | {int(np.median(R[:, 5]))} |")
        same.append((n, same_problem(sim, state)))
        print(lines[-1], flush=True)
    lines += ["", "## Same step problem, socp_cd NSGS vs Siconos 4.4 fc3d_nsgs", "",
              "The last timed step's local problem, both from the stepper's warm start, tol "
              f"{TOL:g} (Siconos: solver call alone; ours: `socp_cd.solve`, min of 3).", "",
              "| blocks | ours ms | ours sweeps | ours error | Siconos ms | Siconos sweeps | Siconos error |",
              "|---|---|---|---|---|---|---|"]
    for n, o in same:
        sic = (f"{1e3 * o['sic_s']:.2f} | {o['sic_it']} | {o['sic_err']:.1e}" if "sic_s" in o
               else "n/a | n/a | n/a")
        lines.append(f"| {n} | {1e3 * o['ours_s']:.2f} | {o['ours_it']} | {o['ours_err']:.1e} | {sic} |")
    nar = narrow_phase(args.coal_python)
    lines += ["", "## Narrow phase: compiled SAT + clipping vs coal", "",
              f"Candidate box pairs of the 1 000-block scene ({nar['pairs']} pairs), min of 5 runs.", "",
              "| implementation | µs per pair | manifold points |", "|---|---|---|",
              f"| socp_cd `narrow3d.hull_hull` (numba, batched) | {nar['ours_us']:.2f} | {nar['ours_points']} |"]
    if "coal_us" in nar:
        lines.append(f"| coal {nar['coal_version']} `collide` + `computeContactPatch` (Python loop) | "
                     f"{nar['coal_us']:.2f} | {nar['coal_points']} |")
    elif "coal_error" in nar:
        lines.append(f"| coal | failed: {nar['coal_error']} | |")
    else:
        lines.append("| coal | not measured (no `--coal-python`) | |")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Moreau's talus: tractions in a heap of polygons poured on a rough slope.

Random convex polygons (5–8 sides, radii ±30 %), friction 0.3, restitution 0,
are poured in small batches near a vertical wall onto a rough bed (a row of fixed
disks) descending at ``--slope`` degrees, below the repose angle.  The heap
grows against the wall by successive avalanches; after the last batch the
heap is left to settle.  Measured on the settled heap:

* the free-surface angle α (least-squares line through the highest vertex
  in each one-diameter bin, away from the wall and the toe);
* the traction across cuts parallel to the free surface (below it, inside
  the heap): angle to the vertical (Moreau: vertical);
* the traction across vertical cuts: angle to the free surface
  (Moreau: parallel to it).

Outputs: validation/results/talus.png, talus_cuts.csv, granular_talus.json,
and (re)writes validation/results/granular.md.

Usage: python validation/talus.py [--n 200] [--slope 10] [--quick]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from socp_cd.granular import coordination_number, cut_traction, from_simulation, stress_report
from socp_cd.granular.plot import draw_force_network, draw_grains
from socp_cd.granular.samples import TalusGrains, feed_batch, talus_bed, talus_simulation
from tqdm.auto import tqdm

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"


STATES = RESULTS / "states"          # heavy checkpoints and states: git-ignored


def _save_checkpoint(path, grains, meta, rng):
    """Write the pour/settle state atomically to HDF5 (grains, counters, RNG state)."""
    import h5py
    tmp = Path(str(path) + ".tmp")
    with h5py.File(tmp, "w") as f:
        for k in ("local", "nv", "pos", "angle", "vel", "mass", "inertia"):
            f[k] = getattr(grains, k)
        f.attrs["meta"] = json.dumps(meta)
        f.attrs["rng"] = json.dumps(rng.bit_generator.state)
    os.replace(tmp, path)


def _load_checkpoint(path):
    import h5py
    with h5py.File(path, "r") as f:
        grains = TalusGrains(*(np.asarray(f[k]) for k in ("local", "nv", "pos", "angle", "vel",
                                                          "mass", "inertia")))
        meta = json.loads(f.attrs["meta"])
        rng = np.random.default_rng()
        rng.bit_generator.state = json.loads(f.attrs["rng"])
    return grains, meta, rng


def _prune(tal, grains, d, bed_length):
    """Drop grains that left the bed (beyond its end or fallen below it)."""
    x, y = grains.pos[:, 0], grains.pos[:, 1]
    keep = (x < bed_length - d) & (y > tal.bed_y(x) - 2 * d)
    return grains.take(keep), int((~keep).sum())


def run(n, slope, seed, h, *, batch=30, steps_per_batch=150, feed_width=8.0, bed_length=120.0,
        settle_max=8000, v_tol=2e-3, tol=1e-4, max_iter=300, settle_iter=600, final_steps=5,
        final_tol=1e-6, final_iter=20000, budget_s=np.inf, checkpoint=None, resume=False):
    """Pour, settle and finish the talus; resumable from ``checkpoint`` (HDF5).

    Phases: ``pour`` (batches of ``batch`` grains every ``steps_per_batch``
    steps until ``n`` grains are on the bed), ``settle`` (until the heap's
    grains move slower than ``v_tol``, ``settle_max`` steps or the wall-time
    ``budget_s``), ``final`` (``final_steps`` steps at ``final_tol``: the
    state analysed is the last of them, with its inertia forces).
    """
    tal = talus_bed(slope_deg=slope, length=bed_length, mu=0.3)
    d = 1.0
    if resume and checkpoint is not None and Path(checkpoint).exists():
        grains, meta, rng = _load_checkpoint(checkpoint)
        print(f"resumed {checkpoint}: phase {meta['phase']}, {grains.n} grains", flush=True)
    else:
        grains, rng = TalusGrains.empty(), np.random.default_rng(seed)
        meta = dict(n=n, slope=slope, h=h, batch=batch, steps_per_batch=steps_per_batch,
                    feed_width=feed_width, bed_length=bed_length, tol=tol, max_iter=max_iter,
                    phase="pour", fed=0, lost=0, steps_pour=0, steps_settle=0, wall_pour=0.0,
                    wall_settle=0.0, unconverged_pour=0, unconverged_settle=0, sim_time=0.0)
    t_start = time.perf_counter()
    kw = dict(tol=tol, solver="nsgs", max_iter=max_iter)

    def save():
        if checkpoint is not None:
            _save_checkpoint(checkpoint, grains, meta, rng)

    if meta["phase"] == "pour":
        bar = tqdm(total=n, initial=grains.n, desc="talus pour", unit="grain", mininterval=10)
        while grains.n < n:
            t0 = time.perf_counter()
            grains, lost = _prune(tal, grains, d, bed_length)
            k = min(batch, n - grains.n)
            grains = feed_batch(tal, grains, k, rng, feed_width=feed_width)
            sim = talus_simulation(tal, grains, h, kw)
            for _ in range(steps_per_batch):
                st = sim.step()
                meta["unconverged_pour"] += int(not st.converged)
            grains = TalusGrains.from_simulation(sim)
            meta["fed"] += k
            meta["lost"] += lost
            meta["steps_pour"] += steps_per_batch
            meta["sim_time"] += steps_per_batch * h
            meta["wall_pour"] += time.perf_counter() - t0
            bar.update(grains.n - bar.n)
            bar.set_postfix(contacts=st.n_active, it=st.iterations,
                            ms_step=f"{1e3 * meta['wall_pour'] / meta['steps_pour']:.0f}")
            save()
        bar.close()
        meta["phase"] = "settle"
        save()
    grains, lost = _prune(tal, grains, d, bed_length)
    meta["lost"] += lost
    tal.n_grains = grains.n
    sim = talus_simulation(tal, grains, h, dict(kw, max_iter=settle_iter))
    if meta["phase"] == "settle":
        bar = tqdm(total=settle_max, initial=meta["steps_settle"], desc="talus settle",
                   mininterval=10)
        vmax = np.inf
        t0 = time.perf_counter()
        k0 = meta["steps_settle"]
        while meta["steps_settle"] < settle_max:
            st = sim.step()
            meta["steps_settle"] += 1
            meta["unconverged_settle"] += int(not st.converged)
            meta["sim_time"] += h
            if meta["steps_settle"] % 50 == 0:
                x, y = sim.sys.pos[:, 0], sim.sys.pos[:, 1]
                on = np.flatnonzero((x < bed_length) & (y > tal.bed_y(x) - d))
                heap = on[heap_grains(x[on], d)]
                vmax = float(np.linalg.norm(sim.sys.vel[heap, :2], axis=1).max())
                bar.update(meta["steps_settle"] - bar.n)
                bar.set_postfix(vmax=f"{vmax:.2e}", contacts=st.n_active, it=st.iterations)
                if meta["steps_settle"] % 500 == 0:
                    meta["wall_settle"] += time.perf_counter() - t0
                    t0 = time.perf_counter()
                    grains = TalusGrains.from_simulation(sim)
                    save()
                if vmax < v_tol or time.perf_counter() - t_start > budget_s:
                    break
        bar.close()
        meta["wall_settle"] += time.perf_counter() - t0
        meta["settle_vmax"] = vmax
        meta["settle_reached_v_tol"] = bool(vmax < v_tol)
        meta["settled_steps_run_here"] = meta["steps_settle"] - k0
        meta["phase"] = "final"
        grains = TalusGrains.from_simulation(sim)
        save()
    # final steps at tight tolerance; the analysed state is the last one, inertia included
    sim.tol, sim.max_iter = final_tol, final_iter
    t0 = time.perf_counter()
    final = []
    for _ in range(final_steps):
        prev = sim.sys.vel.copy()
        st = sim.step()
        final.append(dict(converged=bool(st.converged), error=float(st.error),
                          iterations=int(st.iterations), contacts=int(st.n_active)))
    meta["wall_final"] = time.perf_counter() - t0
    meta["final_steps"] = final
    meta["final_tol"] = final_tol
    state = from_simulation(sim, prev_vel=prev)
    speed = np.linalg.norm(sim.sys.vel[:, :2], axis=1)
    heap = heap_grains(sim.sys.pos[:, 0], d)
    meta.update(max_speed=float(speed[heap].max()), speed_p99=float(np.percentile(speed[heap], 99)),
                n_moving=int(np.sum(speed[heap] > v_tol)), n_contacts=int(state.n_contacts),
                steps=meta["steps_pour"] + meta["steps_settle"] + final_steps,
                wall_time=meta["wall_pour"] + meta["wall_settle"] + meta["wall_final"],
                n_grains=grains.n)
    meta["ms_per_step_pour"] = 1e3 * meta["wall_pour"] / max(meta["steps_pour"], 1)
    meta["ms_per_step_settle"] = 1e3 * meta["wall_settle"] / max(meta["steps_settle"], 1)
    meta["phase"] = "done"
    save()
    return state, tal, sim, meta


def save_state(path, state, info, n, slope):
    """Store the settled heap (grain polygons in world coordinates, contacts, info)."""
    shapes = np.full((state.n_bodies, 8, 2), np.nan)
    for b, V in enumerate(state.shapes):
        shapes[b, :len(V)] = V
    np.savez_compressed(path, centers=state.centers, masses=state.masses, volumes=state.volumes,
                        pairs=state.pairs, points=state.points, forces=state.forces,
                        normals=state.normals, gravity=state.gravity,
                        accelerations=state.accelerations, radii=state.radii, shapes=shapes,
                        n=n, slope=slope, info=json.dumps(info))


def load_state(path):
    from socp_cd.granular import GranularState
    z = np.load(path)
    shapes = [V[~np.isnan(V[:, 0])] for V in z["shapes"]]
    state = GranularState(shapes=shapes, **{k: z[k] for k in (
        "centers", "masses", "volumes", "pairs", "points", "forces", "normals", "gravity",
        "accelerations", "radii")})
    return state, json.loads(str(z["info"])), int(z["n"]), float(z["slope"])


def heap_grains(x, d):
    """Grains of the contiguous heap: centres before the first gap wider than 2 d."""
    order = np.argsort(x)
    gaps = np.flatnonzero(np.diff(x[order]) > 2 * d)
    return order[:gaps[0] + 1] if gaps.size else order


def free_surface(state, d, x_min, x_max):
    """Fit y = a + b x through the highest vertex in bins of width d within [x_min, x_max]."""
    top_x, top_y = [], []
    for V in state.shapes:
        k = np.argmax(V[:, 1])
        top_x.append(V[k, 0])
        top_y.append(V[k, 1])
    top_x, top_y = np.array(top_x), np.array(top_y)
    edges = np.arange(x_min, x_max + 1e-9, d)
    bx, by = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        m = (top_x >= a) & (top_x < b)
        if m.any():
            k = np.argmax(np.where(m, top_y, -np.inf))
            bx.append(top_x[k])
            by.append(top_y[k])
    bx, by = np.array(bx), np.array(by)
    if bx.size < 2:
        return np.nan, np.nan, bx, by
    b1, a0 = np.polyfit(bx, by, 1)
    return a0, b1, bx, by


def signed_angle(u, v):
    """Signed angle (deg) from vector v to vector u."""
    return float(np.degrees(np.arctan2(v[0] * u[1] - v[1] * u[0], v @ u)))


def line_angle(u, v):
    """Angle (deg) between vector u and the *line* along v, in (-90, 90]."""
    a = signed_angle(u, v)
    return float((a + 90) % 180 - 90)


def measure(state, tal, d, depth_d=(2.0, 3.0), cut_len_d=4.0):
    toe = float(state.centers[heap_grains(state.centers[:, 0], d), 0].max())
    # the measuring zone: from 2 d off the wall to where the heap is still >= 3 d thick
    _, _, tx, ty = free_surface(state, d, 0.0, toe)
    thick = tx[ty - (tal.bed_y(tx) + tal.bed_radius) >= 3 * d]
    x0, x1 = 2 * d, float(thick.max()) if thick.size else toe - 2 * d
    a0, b1, bx, by = free_surface(state, d, x0, x1)
    alpha = float(np.degrees(-np.arctan(b1)))            # surface descends to the right
    s = np.array([1.0, b1]) / np.hypot(1.0, b1)          # along the surface, downslope
    n_s = np.array([-s[1], s[0]])                        # outward (upward) surface normal
    L = cut_len_d * d
    bed_y = tal.bed_y
    rows = []
    # surface-parallel cuts: centres along the surface, at depths below it
    for depth in depth_d:
        for xc in np.arange(x0 + L / 2, x1 - L / 2 + 1e-9, L / 2):
            p = np.array([xc, a0 + b1 * xc]) - depth * d * n_s
            ends = [p - s * L / 2, p + s * L / 2]
            if any(e[1] < bed_y(e[0]) + 1.0 * d for e in ends):
                continue
            t = cut_traction(state, p, n_s, L)
            rows.append(("surface", p[0], p[1], depth, *t, signed_angle(t, np.array([0.0, -1.0]))))
    # vertical cuts (normal +x), from the bed + 1 d to the surface - 1 d
    for xc in np.arange(x0 + d, x1 - d + 1e-9, d):
        ytop, ybot = a0 + b1 * xc - 1.0 * d, bed_y(xc) + 1.0 * d
        if ytop - ybot < 2 * d:
            continue
        p = np.array([xc, 0.5 * (ytop + ybot)])
        t = cut_traction(state, p, [1.0, 0.0], ytop - ybot)
        rows.append(("vertical", p[0], p[1], ytop - ybot, *t, line_angle(t, s)))
    surf = [r for r in rows if r[0] == "surface"]
    vert = [r for r in rows if r[0] == "vertical"]
    ts = np.sum([[r[4], r[5]] for r in surf], axis=0) if surf else np.full(2, np.nan)
    tv = np.sum([[r[4], r[5]] for r in vert], axis=0) if vert else np.full(2, np.nan)
    heap = heap_grains(state.centers[:, 0], d)          # without grains rolling away
    rep = stress_report(state, 1.0, sample=heap)        # volume irrelevant for the ratios
    res = dict(
        repose_angle_deg=alpha, slope_deg=float(np.degrees(tal.slope_angle)),
        surface_cut_angle_deg=signed_angle(ts, np.array([0.0, -1.0])),
        surface_cut_angle_mean_deg=float(np.mean([r[6] for r in surf])) if surf else np.nan,
        surface_cut_angle_std_deg=float(np.std([r[6] for r in surf])) if surf else np.nan,
        n_surface_cuts=len(surf),
        vertical_cut_angle_deg=line_angle(tv, s),
        vertical_cut_angle_mean_deg=float(np.mean([r[6] for r in vert])) if vert else np.nan,
        vertical_cut_angle_std_deg=float(np.std([r[6] for r in vert])) if vert else np.nan,
        n_vertical_cuts=len(vert),
        heap_x_range=[x0, x1], toe=toe, mean_diameter=d, cut_length=L,
        moreau_asymmetry=rep.moreau_asymmetry, weber_difference_pct=100 * rep.weber_difference,
        equilibrium_residual=rep.equilibrium_residual,
        coordination=coordination_number(state, sample=heap), n_heap=int(heap.size))
    return res, rows, (a0, b1, bx, by)


def figure(state, tal, rows, fit, res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    a0, b1, bx, by = fit
    fig, ax = plt.subplots(figsize=(14, 6.5))
    draw_grains(ax, state, np.arange(tal.n_grains))
    xs = np.linspace(0, res["toe"] + 3, 10)
    ax.fill_between(xs, -np.tan(tal.slope_angle) * xs - 2, -np.tan(tal.slope_angle) * xs,
                    color="0.6", lw=0)
    for o in tal.obstacles[1:]:
        ax.add_patch(Circle(o.position, o.radius, fc="0.45", ec="none"))
    draw_force_network(ax, state, max_width=5.0)
    ax.axvline(0, color="k", lw=2)
    xx = np.array(res["heap_x_range"])
    ax.plot(xx, a0 + b1 * xx, "b--", lw=1.2, label=f"fitted free surface, α = {res['repose_angle_deg']:.1f}°")
    ax.plot(bx, by, "b.", ms=4)
    scale = 1.5 / max([np.hypot(r[4], r[5]) for r in rows] + [1e-300])
    for kind, x, y, _, tx, ty, _ in rows:
        col = "tab:green" if kind == "surface" else "tab:purple"
        ax.annotate("", xy=(x + scale * tx, y + scale * ty), xytext=(x, y),
                    arrowprops=dict(arrowstyle="->", color=col, lw=1.5))
    ax.plot([], [], color="tab:green", label=f"traction, surface-parallel cuts: "
            f"{res['surface_cut_angle_deg']:.1f}° from vertical")
    ax.plot([], [], color="tab:purple", label=f"traction, vertical cuts: "
            f"{res['vertical_cut_angle_deg']:.1f}° from the surface")
    ax.set_aspect("equal")
    ax.set_xlim(-1, res["toe"] + 3)
    ymax = max(s[:, 1].max() for s in state.shapes) + 1
    ax.set_ylim(-np.tan(tal.slope_angle) * (res["toe"] + 3) - 1, ymax)
    ax.legend(loc="upper right", fontsize=9)
    ax.set_title(f"Talus: {tal.n_grains} polygons (5–8 sides), μ = 0.3, e = 0, "
                 f"rough bed at {res['slope_deg']:.0f}°; red: force network (width ∝ |f|)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--slope", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--h", type=float, default=4e-3)
    ap.add_argument("--bed-length", type=float, default=120.0)
    ap.add_argument("--batch", type=int, default=30)
    ap.add_argument("--steps-per-batch", type=int, default=150)
    ap.add_argument("--settle-max", type=int, default=8000, help="settling steps (at most)")
    ap.add_argument("--budget-min", type=float, default=np.inf,
                    help="stop settling after this many minutes of wall time (this invocation)")
    ap.add_argument("--tag", default=None, help="run name (default talus<n>_s<slope>)")
    ap.add_argument("--resume", action="store_true", help="continue from the run's checkpoint")
    ap.add_argument("--quick", action="store_true", help="60 grains on a short bed (smoke run)")
    ap.add_argument("--reanalyse", action="store_true",
                    help="reuse the run's settled state instead of simulating")
    args = ap.parse_args(argv)
    if args.quick:
        args.n, args.bed_length, args.batch, args.steps_per_batch = 60, 30.0, 20, 100
        args.settle_max = min(args.settle_max, 1500)
    n = args.n
    tag = args.tag or f"talus{n}_s{args.slope:g}" + ("_quick" if args.quick else "")
    STATES.mkdir(parents=True, exist_ok=True)
    npz = STATES / f"{tag}.npz"
    if args.reanalyse:
        state, info, n, slope = load_state(npz)
        args.slope = slope
    else:
        state, tal, sim, info = run(n, args.slope, args.seed, args.h, batch=args.batch,
                                    steps_per_batch=args.steps_per_batch,
                                    bed_length=args.bed_length, settle_max=args.settle_max,
                                    budget_s=60 * args.budget_min,
                                    checkpoint=STATES / f"{tag}.h5", resume=args.resume)
        save_state(npz, state, info, info["n_grains"], args.slope)
    tal = talus_bed(slope_deg=args.slope, length=info["bed_length"], mu=0.3)
    tal.n_grains = n = state.n_bodies
    d = float(2 * np.mean([np.sqrt(v / np.pi) for v in state.volumes]))  # area-equivalent diameter
    res, rows, fit = measure(state, tal, d)
    res.update(info, n=n, h=args.h)
    res["notes"] = [
        f"{n} random convex polygons (5–8 sides, circumradius 0.5 ± 30 %), μ = 0.3, e = 0, "
        f"rough bed of fixed disks (radius 0.25) at {args.slope:g}°, vertical wall at x = 0; "
        f"h = {args.h:g}, NSGS tol 1e-6.",
        f"poured in batches of 8 dropped 1 d above the heap within 4 d of the wall, "
        f"150 steps per batch, then settled: {info['steps']} steps in all "
        f"(t = {info['sim_time']:.2f}, {info['wall_time']:.0f} s wall), final max speed "
        f"{info['max_speed']:.2e} (grain at x = {info.get('x_fastest', np.nan):.1f}; "
        f"{info.get('n_moving', -1)} heap grains faster than 2e-3, 99th percentile speed "
        f"{info.get('speed_p99', np.nan):.1e}), {info['n_contacts']} contacts, "
        f"unconverged steps while settling {info['unconverged_steps_settling']}.",
        f"free surface fitted on x ∈ [{res['heap_x_range'][0]:.1f}, {res['heap_x_range'][1]:.1f}] "
        f"(2 d from the wall to where the heap is 3 d thick; toe at x = {res['toe']:.1f}; "
        f"area-equivalent diameter d = {d:.2f}): α = {res['repose_angle_deg']:.1f}°.",
        f"{res['n_surface_cuts']} surface-parallel cuts ({res['cut_length'] / d:.0f} d long, 2–3 d "
        f"deep): resultant traction {res['surface_cut_angle_deg']:.1f}° from the vertical "
        f"(per cut: mean {res['surface_cut_angle_mean_deg']:.1f}°, std "
        f"{res['surface_cut_angle_std_deg']:.1f}°).",
        f"{res['n_vertical_cuts']} vertical cuts (bed + 1 d to surface − 1 d): resultant traction "
        f"{res['vertical_cut_angle_deg']:.1f}° from the free-surface direction (per cut: mean "
        f"{res['vertical_cut_angle_mean_deg']:.1f}°, std {res['vertical_cut_angle_std_deg']:.1f}°).",
        f"heap ({res['n_heap']} grains, without those rolling away): Moreau moment asymmetry "
        f"{res['moreau_asymmetry']:.1e}, grain equilibrium residual "
        f"{res['equilibrium_residual']:.1e}, z = {res['coordination']:.2f}.",
        "Figure: `talus.png` (grains, force network, fitted surface, traction arrows); "
        "data `talus_cuts.csv`."]
    for k in ("repose_angle_deg", "surface_cut_angle_deg", "surface_cut_angle_std_deg",
              "vertical_cut_angle_deg", "vertical_cut_angle_std_deg", "n_surface_cuts",
              "n_vertical_cuts", "steps", "wall_time", "max_speed", "moreau_asymmetry"):
        print(f"{k:28s} {res[k]}")
    if args.quick:
        figure(state, tal, rows, fit, res, Path("/tmp") / "talus_quick.png")
    else:
        RESULTS.mkdir(parents=True, exist_ok=True)
        figure(state, tal, rows, fit, res, RESULTS / "talus.png")
        with open(RESULTS / "talus_cuts.csv", "w") as f:
            f.write("kind,x,y,depth_or_length,tx,ty,angle_deg\n")
            for r in rows:
                f.write(",".join([r[0]] + [f"{v:.6g}" for v in r[1:]]) + "\n")
        (RESULTS / "granular_talus.json").write_text(json.dumps(res, indent=1))
        import sys
        sys.path.insert(0, str(HERE))
        from cauchy_cuts import write_summary
        print("wrote", write_summary())
    return res


if __name__ == "__main__":
    main()

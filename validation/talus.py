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
  (Moreau: parallel to it);

* the reciprocal-cuts lemma n·T′ = n′·T on the pairs (surface-parallel,
  vertical) of cuts through the same point;
* div σ + f = 0 on random rectangles inside the heap (:func:`region_balance`).

Outputs: validation/results/talus.{png,md,json}, talus_cuts.csv, talus_regions.json.
The run is resumable: checkpoints (HDF5) and the analysed state go to
validation/results/states/ (git-ignored); ``--resume`` continues an interrupted
run, ``--reanalyse`` redoes the analysis only.

Usage: python validation/talus.py [--n 2000] [--slope 10] [--budget-min M] [--resume] [--quick]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from socp_cd.granular import (coordination_number, cut_traction, from_simulation, region_balance,
                              stress_report)
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


def _airborne_in_feed(sim, feed_x):
    """Number of grains of the feed zone without any contact in the last step (still falling)."""
    p = sim.last_contacts.pairs
    touching = np.zeros(sim.sys.n_bodies, bool)
    touching[p[:, 0]] = True
    touching[p[p[:, 1] >= 0, 1]] = True
    return int(np.sum(~touching & (sim.sys.pos[:, 0] < feed_x)))


def _heap_speed(sim, tal, d, bed_length):
    """Largest speed of a heap grain (grains on the bed, the heap's toe excluded)."""
    x, y = sim.sys.pos[:, 0], sim.sys.pos[:, 1]
    on = np.flatnonzero((x < bed_length) & (y > tal.bed_y(x) - d))
    heap = on[heap_grains(x[on], d)]
    return float(np.linalg.norm(sim.sys.vel[heap, :2], axis=1).max())


def run(n, slope, seed, h, *, batch=32, steps_per_batch=100, max_wait=600, v0=2.0,
        feed_width=12.0, bed_length=120.0,
        settle_max=8000, v_tol=2e-3, tol=1e-4, max_iter=300, settle_iter=600, quench=100,
        quench_tol=1e-6, quench_iter=2000, final_tol=1e-8, final_iter=50000, final_solver="auto",
        quench_solver="auto", quench_exact=3, step_time_limit=120.0, budget_s=np.inf, checkpoint=None, resume=False,
        resettle=False, damp_every=0):
    """Pour, settle and finish the talus; resumable from ``checkpoint`` (HDF5).

    Phases: ``pour`` (batches of ``batch`` grains, falling at ``v0`` from one
    diameter above the heap within ``feed_width`` diameters of the wall; the
    next batch comes after ``steps_per_batch`` steps once no grain of the feed
    zone is airborne (at most ``max_wait`` more steps), until ``n`` grains are
    on the bed), ``settle`` (until the heap's
    grains move slower than ``v_tol``, ``settle_max`` steps or the wall-time
    ``budget_s``), ``final``: ``quench`` steps each started from zero
    velocities at ``quench_tol`` (kinetic energy removed, gravity kept: the
    heap comes to rest), then one static step from zero velocities at
    ``final_tol``, the analysed state (its inertia forces, reported, measure
    how far it is from rest).  A checkpoint in phase ``final`` or ``done``
    redoes only this last phase.  ``damp_every`` > 0: during ``settle``, all
    velocities are set to zero every ``damp_every`` steps (kinetic damping, a
    dynamic-relaxation device: it removes the surface flow's kinetic energy so
    the heap reaches a static state; the speed test then measures what one
    ``damp_every``-step interval from rest builds up).
    """
    tal = talus_bed(slope_deg=slope, length=bed_length, mu=0.3)
    d = 1.0
    if resume and checkpoint is not None and Path(checkpoint).exists():
        grains, meta, rng = _load_checkpoint(checkpoint)
        print(f"resumed {checkpoint}: phase {meta['phase']}, {grains.n} grains", flush=True)
        if resettle and meta["phase"] in ("final", "done"):
            meta["phase"] = "settle"             # settle longer, then quench and analyse again
    else:
        grains, rng = TalusGrains.empty(), np.random.default_rng(seed)
        meta = dict(n=n, slope=slope, h=h, batch=batch, steps_per_batch=steps_per_batch,
                    feed_width=feed_width, v0=v0, bed_length=bed_length, tol=tol, max_iter=max_iter,
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
            grains = feed_batch(tal, grains, k, rng, feed_width=feed_width, v0=v0)
            sim = talus_simulation(tal, grains, h, kw)
            done = 0
            while done < steps_per_batch + max_wait:
                st = sim.step()
                done += 1
                meta["unconverged_pour"] += int(not st.converged)
                if done >= steps_per_batch and done % 25 == 0 and \
                        _airborne_in_feed(sim, (feed_width + 1) * d) == 0:
                    break
            grains = TalusGrains.from_simulation(sim)
            meta["fed"] += k
            meta["lost"] += lost
            meta["steps_pour"] += done
            meta["sim_time"] += done * h
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
        t0 = time.perf_counter()
        k0 = meta["steps_settle"]
        if damp_every and "damped_from_step" not in meta:
            meta.update(damp_every=damp_every, damped_from_step=meta["steps_settle"])
        while meta["steps_settle"] < settle_max:
            if damp_every and meta["steps_settle"] % damp_every == 0:
                sim.sys.vel[:] = 0.0             # kinetic damping: the flow's energy removed
            st = sim.step()
            meta["steps_settle"] += 1
            meta["unconverged_settle"] += int(not st.converged)
            meta["sim_time"] += h
            if meta["steps_settle"] % 50 == 0:
                vmax = _heap_speed(sim, tal, d, bed_length)
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
        vmax = _heap_speed(sim, tal, d, bed_length)     # also when no step ran here (resumed)
        meta["settle_vmax"] = vmax
        meta["settle_reached_v_tol"] = bool(vmax < v_tol)
        meta["settled_steps_run_here"] = meta["steps_settle"] - k0
        meta["phase"] = "final"
        grains = TalusGrains.from_simulation(sim)
        save()
    # quench, then the static step at tight tolerance (the analysed state, inertia included)
    t0 = time.perf_counter()
    sim.tol, sim.max_iter = quench_tol, quench_iter
    unconv = 0
    for k in tqdm(range(quench), desc="talus quench", mininterval=10):
        if k == quench - quench_exact and quench_solver != "nsgs":
            # NSGS at a few thousand sweeps leaves the reactions of a deep heap short
            # of its weight (grains sag a little every step): the last quench steps
            # use a solver that reaches quench_tol
            sim.use_solver(quench_solver, time_limit=step_time_limit)
        sim.sys.vel[:] = 0.0
        unconv += int(not sim.step().converged)
    # the analysed step: solver "auto" (Newton / Clarabel chain) reaches final_tol where NSGS
    # stalls near 1e-6 on a heap of thousands of contacts
    if final_solver == "nsgs":
        sim.use_solver("nsgs", tol=final_tol, max_iter=final_iter)
    else:                            # its own iteration caps, bounded in time
        sim.use_solver(final_solver, tol=final_tol, time_limit=step_time_limit)
    sim.sys.vel[:] = 0.0
    prev = sim.sys.vel.copy()
    st = sim.step()
    meta["wall_final"] = time.perf_counter() - t0
    meta.update(quench_steps=quench, quench_tol=quench_tol, quench_solver=quench_solver,
                quench_exact=quench_exact, unconverged_quench=unconv,
                final_tol=final_tol, final_solver=final_solver, final_converged=bool(st.converged), final_error=float(st.error),
                final_iterations=int(st.iterations))
    state = from_simulation(sim, prev_vel=prev)
    speed = np.linalg.norm(sim.sys.vel[:, :2], axis=1)
    heap = heap_grains(sim.sys.pos[:, 0], d)
    meta.update(max_speed=float(speed[heap].max()), speed_p99=float(np.percentile(speed[heap], 99)),
                n_moving=int(np.sum(speed[heap] > v_tol)), n_contacts=int(state.n_contacts),
                steps=meta["steps_pour"] + meta["steps_settle"] + quench + 1,
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


def _stats(values):
    """Mean, spread (standard deviation over the cuts), median and count."""
    v = np.asarray(values, float)
    if v.size == 0:
        return dict(mean=float("nan"), spread=float("nan"), median=float("nan"), n=0)
    return dict(mean=float(v.mean()), spread=float(v.std()), median=float(np.median(v)), n=int(v.size))


def measure(state, tal, d, depth_d=(3.0, 5.0, 8.0, 12.0), cut_len_d=4.0, wall_gap_d=5.0):
    """Free surface, the two families of cuts, reciprocal pairs and the region balances.

    Cuts are centred on a grid of points at ``depth_d`` (measured along the
    surface normal) below the fitted free surface, every ``cut_len_d / 2``
    along it, from ``wall_gap_d`` diameters off the wall to where the cut would
    come within one diameter of the bed.  At each point: a cut parallel to the
    surface (normal n = outward surface normal) and a vertical cut (normal
    n' = +x), both ``cut_len_d`` long; their tractions T, T' give the
    free-surface law (angle of T to the vertical), the vertical-cut law (angle
    of T' to the surface direction) and the reciprocal-cuts lemma
    ``n·T' = n'·T`` (relative difference ``|n·T' − n'·T| / ((|T| + |T'|)/2)``).
    """
    heap = heap_grains(state.centers[:, 0], d)
    toe = float(state.centers[heap, 0].max())
    # the straight part of the surface: from the wall gap to where the heap is >= 3 d thick
    _, _, tx, ty = free_surface(state, d, 0.0, toe)
    thick = tx[ty - (tal.bed_y(tx) + tal.bed_radius) >= 3 * d]
    x0, x1 = wall_gap_d * d, float(thick.max()) if thick.size else toe - 2 * d
    a0, b1, bx, by = free_surface(state, d, x0, x1)
    alpha = float(np.degrees(-np.arctan(b1)))            # surface descends to the right
    resid = by - (a0 + b1 * bx)
    b_err = float(np.sqrt(np.sum(resid ** 2) / max(bx.size - 2, 1) / np.sum((bx - bx.mean()) ** 2)))
    # local slopes over windows of 8 d (spread of the angle along the surface)
    local = []
    for xa in np.arange(x0, x1 - 8 * d + 1e-9, 4 * d):
        m = (bx >= xa) & (bx < xa + 8 * d)
        if m.sum() >= 4:
            local.append(float(np.degrees(-np.arctan(np.polyfit(bx[m], by[m], 1)[0]))))
    s = np.array([1.0, b1]) / np.hypot(1.0, b1)          # along the surface, downslope
    n_s = np.array([-s[1], s[0]])                        # outward (upward) surface normal
    L = cut_len_d * d
    ex, down = np.array([1.0, 0.0]), np.array([0.0, -1.0])
    bed_y = tal.bed_y
    rows = []
    for depth in depth_d:
        for xc in np.arange(x0 + L / 2, x1 + 1e-9, L / 2):
            p = np.array([xc, a0 + b1 * xc]) - depth * d * n_s
            ends = [p - s * L / 2, p + s * L / 2, p - np.array([0, L / 2])]
            if any(e[1] < bed_y(e[0]) + tal.bed_radius + 1.0 * d for e in ends) or p[0] - L / 2 < x0 - L:
                continue
            T = cut_traction(state, p, n_s, L)
            Tv = cut_traction(state, p, ex, L)
            recip = abs(n_s @ Tv - ex @ T) / (0.5 * (np.linalg.norm(T) + np.linalg.norm(Tv)))
            rows.append(dict(x=float(p[0]), y=float(p[1]), depth_d=depth, dist_wall_d=float(p[0] / d),
                             T=T.tolist(), Tv=Tv.tolist(),
                             surface_angle_deg=signed_angle(T, down),
                             vertical_angle_deg=line_angle(Tv, s), reciprocal_rel=float(recip)))
    surf = [r["surface_angle_deg"] for r in rows]
    vert = [r["vertical_angle_deg"] for r in rows]
    rec = [r["reciprocal_rel"] for r in rows]
    T_sum = np.sum([r["T"] for r in rows], axis=0) if rows else np.full(2, np.nan)
    Tv_sum = np.sum([r["Tv"] for r in rows], axis=0) if rows else np.full(2, np.nan)
    by_depth = {f"{dp:g}": dict(surface=_stats([r["surface_angle_deg"] for r in rows if r["depth_d"] == dp]),
                                vertical=_stats([r["vertical_angle_deg"] for r in rows if r["depth_d"] == dp]),
                                reciprocal=_stats([r["reciprocal_rel"] for r in rows if r["depth_d"] == dp]))
                for dp in depth_d}
    rep = stress_report(state, 1.0, sample=heap)        # volume irrelevant for the ratios
    res = dict(
        n_grains=int(state.n_bodies), n_heap=int(heap.size),
        repose_angle_deg=alpha, repose_angle_fit_stderr_deg=float(np.degrees(b_err) / (1 + b1 ** 2)),
        repose_angle_local_deg=_stats(local), slope_deg=float(np.degrees(tal.slope_angle)),
        free_surface_law_deg=_stats(surf), free_surface_law_resultant_deg=signed_angle(T_sum, down),
        vertical_cut_deg=_stats(vert), vertical_cut_resultant_deg=line_angle(Tv_sum, s),
        reciprocal_cuts_rel=dict(_stats(rec), max=float(np.max(rec)) if rec else float("nan")),
        by_depth=by_depth, n_cut_points=len(rows),
        heap_x_range=[x0, x1], toe=toe, mean_diameter=d, cut_length=L, depths_d=list(depth_d),
        moreau_asymmetry=rep.moreau_asymmetry, weber_difference=rep.weber_difference,
        equilibrium_residual=rep.equilibrium_residual,
        coordination=coordination_number(state, sample=heap))
    return res, rows, (a0, b1, bx, by)


def region_balances(state, tal, fit, res, d, n_regions=40, seed=0):
    """``div σ + f = 0`` on random rectangles (sides along / across the surface) inside the heap.

    Returns per region: grains inside, ``|boundary + load| / |load|`` with the
    exact load (gravity + inertia of the static step) and with gravity only.
    """
    a0, b1, _, _ = fit
    s = np.array([1.0, b1]) / np.hypot(1.0, b1)
    n_s = np.array([-s[1], s[0]])
    x0, x1 = res["heap_x_range"]
    rng = np.random.default_rng(seed)
    static = replace(state, accelerations=None)
    out = []
    tries = 0
    while len(out) < n_regions and tries < 50 * n_regions:
        tries += 1
        w, hgt = rng.uniform(3, 12) * d, rng.uniform(2, 8) * d
        xc = rng.uniform(x0, x1)
        top = np.array([xc, a0 + b1 * xc]) - rng.uniform(1.0, 6.0) * d * n_s
        P = np.array([top - s * w / 2, top + s * w / 2, top + s * w / 2 - n_s * hgt,
                      top - s * w / 2 - n_s * hgt])
        if np.any(P[:, 1] < tal.bed_y(P[:, 0]) + tal.bed_radius + 0.5 * d) or P[:, 0].min() < 0.5 * d:
            continue
        P = P[::-1]                                       # counter-clockwise
        bnd, load, inside = region_balance(state, P)
        if inside.sum() < 5:
            continue
        bnd_s, load_s, _ = region_balance(static, P)
        out.append(dict(n_inside=int(inside.sum()),
                        exact_rel=float(np.linalg.norm(bnd + load) / np.linalg.norm(load)),
                        gravity_only_rel=float(np.linalg.norm(bnd_s + load_s) / np.linalg.norm(load_s)),
                        vertices=P.tolist()))
    return out


def figure(state, tal, rows, fit, res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    a0, b1, bx, by = fit
    x_end = res["toe"] + 3
    ymax = max(sh[:, 1].max() for sh in state.shapes) + 1
    ymin = tal.bed_y(x_end) - 1
    width = 20.0
    fig, ax = plt.subplots(figsize=(width, max(4.0, width * (ymax - ymin) / (x_end + 1) + 1.2)))
    draw_grains(ax, state, np.arange(state.n_bodies), linewidth=0.2)
    xs = np.linspace(0, x_end, 10)
    ax.fill_between(xs, tal.bed_y(xs) - 2, tal.bed_y(xs), color="0.6", lw=0)
    for o in tal.obstacles[1:]:
        if o.position[0] <= x_end:
            ax.add_patch(Circle(o.position, o.radius, fc="0.45", ec="none"))
    draw_force_network(ax, state, max_width=3.0, threshold=0.02)
    ax.axvline(0, color="k", lw=2)
    xx = np.array(res["heap_x_range"])
    ax.plot(xx, a0 + b1 * xx, "b--", lw=1.0,
            label=f"fitted free surface, α = {res['repose_angle_deg']:.1f}°")
    T = np.array([r["T"] for r in rows])
    Tv = np.array([r["Tv"] for r in rows])
    tmax = np.linalg.norm(np.r_[T, Tv], axis=1).max() if rows else 1.0
    scale = 2.0 * res["mean_diameter"] / max(tmax, 1e-300)
    for r, t, tv in zip(rows, T, Tv):
        ax.annotate("", xy=(r["x"] + scale * t[0], r["y"] + scale * t[1]), xytext=(r["x"], r["y"]),
                    arrowprops=dict(arrowstyle="->", color="tab:green", lw=1.0))
        ax.annotate("", xy=(r["x"] + scale * tv[0], r["y"] + scale * tv[1]), xytext=(r["x"], r["y"]),
                    arrowprops=dict(arrowstyle="->", color="tab:purple", lw=1.0))
    fs, vc = res["free_surface_law_deg"], res["vertical_cut_deg"]
    ax.plot([], [], color="tab:green", label=f"traction on cuts parallel to the surface: "
            f"{fs['mean']:.1f}° ± {fs['spread']:.1f}° from the vertical")
    ax.plot([], [], color="tab:purple", label=f"traction on vertical cuts: "
            f"{vc['mean']:.1f}° ± {vc['spread']:.1f}° from the surface direction")
    ax.plot([], [], color="crimson", label="contact forces (width ∝ |f|)")
    ax.set_aspect("equal")
    ax.set_xlim(-1, x_end)
    ax.set_ylim(ymin, ymax)
    ax.legend(loc="upper right", fontsize=10)
    ax.set_title(f"Talus: {state.n_bodies} polygons (5–8 sides, ±30 %), μ = 0.3, e = 0, rough bed at "
                 f"{res['slope_deg']:.0f}°; arrows: tractions on {res['cut_length'] / res['mean_diameter']:.0f} d "
                 f"cuts at depths {', '.join(f'{x:g}' for x in res['depths_d'])} d")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--slope", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--h", type=float, default=5e-3)
    ap.add_argument("--bed-length", type=float, default=120.0)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--steps-per-batch", type=int, default=100, help="minimum steps between batches")
    ap.add_argument("--feed-width", type=float, default=16.0, help="feed zone width (diameters)")
    ap.add_argument("--v0", type=float, default=3.0, help="speed of the fed grains")
    ap.add_argument("--settle-max", type=int, default=8000, help="settling steps (at most)")
    ap.add_argument("--budget-min", type=float, default=np.inf,
                    help="stop settling after this many minutes of wall time (this invocation)")
    ap.add_argument("--tag", default=None, help="run name (default talus<n>_s<slope>)")
    ap.add_argument("--resume", action="store_true", help="continue from the run's checkpoint")
    ap.add_argument("--settle-more", action="store_true",
                    help="with --resume: settle a finished run again (up to --settle-max steps in all)")
    ap.add_argument("--damp-every", type=int, default=0,
                    help="settle with all velocities zeroed every K steps (kinetic damping; 0: off)")
    ap.add_argument("--quick", action="store_true",
                    help="120 grains on a short bed, shallow short cuts, output in /tmp/talus_quick")
    ap.add_argument("--reanalyse", action="store_true",
                    help="reuse the run's settled state instead of simulating")
    args = ap.parse_args(argv)
    if args.quick:
        args.n, args.bed_length, args.batch, args.steps_per_batch = 120, 25.0, 16, 60
        args.feed_width = 8.0
        args.settle_max = min(args.settle_max, 1000)
    n = args.n
    tag = args.tag or f"talus{n}_s{args.slope:g}" + ("_quick" if args.quick else "")
    STATES.mkdir(parents=True, exist_ok=True)
    npz = STATES / f"{tag}.npz"
    if args.reanalyse:
        state, info, n, slope = load_state(npz)
        args.slope = slope
    else:
        state, tal, sim, info = run(n, args.slope, args.seed, args.h, batch=args.batch,
                                    steps_per_batch=args.steps_per_batch, v0=args.v0,
                                    feed_width=args.feed_width,
                                    bed_length=args.bed_length, settle_max=args.settle_max,
                                    budget_s=60 * args.budget_min,
                                    checkpoint=STATES / f"{tag}.h5", resume=args.resume,
                                    resettle=args.settle_more, damp_every=args.damp_every,
                                    quench=30 if args.quick else 60)
        save_state(npz, state, info, info["n_grains"], args.slope)
    tal = talus_bed(slope_deg=args.slope, length=info["bed_length"], mu=0.3)
    tal.n_grains = n = state.n_bodies
    d = float(2 * np.mean([np.sqrt(v / np.pi) for v in state.volumes]))  # area-equivalent diameter
    geometry = dict(depth_d=(1.5, 2.5), cut_len_d=3.0, wall_gap_d=2.0) if args.quick else {}
    res, rows, fit = measure(state, tal, d, **geometry)
    regions = region_balances(state, tal, fit, res, d)
    ex = [r["exact_rel"] for r in regions]
    gr = [r["gravity_only_rel"] for r in regions]
    res["div_balance"] = dict(n_regions=len(regions), exact_rel_max=float(max(ex, default=np.nan)),
                              gravity_only_rel_max=float(max(gr, default=np.nan)),
                              gravity_only_rel_median=float(np.median(gr)) if gr else np.nan,
                              grains_inside_min=int(min((r["n_inside"] for r in regions), default=0)),
                              grains_inside_max=int(max((r["n_inside"] for r in regions), default=0)))
    res["run"] = info
    for k in ("n_grains", "repose_angle_deg", "repose_angle_local_deg", "free_surface_law_deg",
              "vertical_cut_deg", "reciprocal_cuts_rel", "div_balance", "moreau_asymmetry"):
        print(f"{k:24s} {res[k]}")
    out = Path("/tmp/talus_quick") if args.quick else RESULTS
    out.mkdir(parents=True, exist_ok=True)
    figure(state, tal, rows, fit, res, out / "talus.png")
    with open(out / "talus_cuts.csv", "w") as f:
        f.write("x,y,depth_d,dist_wall_d,Tx,Ty,Tvx,Tvy,surface_angle_deg,vertical_angle_deg,"
                "reciprocal_rel\n")
        for r in rows:
            f.write(",".join(f"{v:.6g}" for v in (r["x"], r["y"], r["depth_d"], r["dist_wall_d"],
                                                 *r["T"], *r["Tv"], r["surface_angle_deg"],
                                                 r["vertical_angle_deg"], r["reciprocal_rel"])) + "\n")
    (out / "talus.json").write_text(json.dumps(res, indent=1))
    (out / "talus_regions.json").write_text(json.dumps(regions, indent=1))
    (out / "talus.md").write_text(report(res))
    print("wrote", out / "talus.md")
    return res


def report(res):
    """The talus table (markdown)."""
    run = res["run"]
    fs, vc, rc = res["free_surface_law_deg"], res["vertical_cut_deg"], res["reciprocal_cuts_rel"]
    loc, db = res["repose_angle_local_deg"], res["div_balance"]
    d = res["mean_diameter"]
    lines = [
        f"# Moreau's talus at {res['n_grains']} grains",
        "",
        f"{res['n_grains']} random convex polygons (5–8 sides, circumradius 0.5 ± 30 %), μ = 0.3, "
        f"e = 0, fed {run['batch']} at a time (falling at {run.get('v0', 0):g} from 1 d above the heap, "
        f"the next batch once the previous one has landed, at least {run['steps_per_batch']} steps "
        f"apart; h = {run['h']:g}) within {run['feed_width']:g} d of a vertical wall onto a rough bed "
        f"of fixed disks at "
        f"{res['slope_deg']:g}° ({run['fed']} fed, {run['lost']} ran off the bed end); feeding stopped, "
        f"the heap settled ({run['steps_settle']} steps"
        + (f", velocities zeroed every {run['damp_every']} steps from step "
           f"{run['damped_from_step']} on (kinetic damping)" if run.get('damp_every') else "")
        + f"), then {run['quench_steps']} quench steps from zero velocities "
        f"(NSGS, the last {run.get('quench_exact', 0)} with {run.get('quench_solver', 'nsgs')}; tol "
        f"{run['quench_tol']:g}) and one static step at tol {run['final_tol']:g}, solver "
        f"{run.get('final_solver', 'nsgs')} (analysed: error "
        f"{run['final_error']:.1e}, {'converged' if run['final_converged'] else 'NOT converged'}). "
        f"Generated by `validation/talus.py`; figure `talus.png`, per-cut data `talus_cuts.csv`.",
        "",
        "| quantity | value | Moreau |",
        "|---|---|---|",
        f"| repose angle of the free surface (fit over x ∈ [{res['heap_x_range'][0]:.0f}, "
        f"{res['heap_x_range'][1]:.0f}]) | {res['repose_angle_deg']:.1f}° ± "
        f"{res['repose_angle_fit_stderr_deg']:.1f}° (fit s.e.); local 8 d windows "
        f"{loc['mean']:.1f}° ± {loc['spread']:.1f}° ({loc['n']}) | above the bed's {res['slope_deg']:g}° |",
        f"| traction on cuts parallel to the surface: angle from the vertical, per cut | "
        f"{fs['mean']:.1f}° ± {fs['spread']:.1f}° (median {fs['median']:.1f}°, {fs['n']} cuts); "
        f"resultant {res['free_surface_law_resultant_deg']:.1f}° | 0° (vertical) |",
        f"| traction on vertical cuts: angle from the surface direction, per cut | "
        f"{vc['mean']:.1f}° ± {vc['spread']:.1f}° (median {vc['median']:.1f}°, {vc['n']} cuts); "
        f"resultant {res['vertical_cut_resultant_deg']:.1f}° | 0° (parallel) |",
        f"| reciprocal cuts, ‖n·T′ − n′·T‖ / mean(‖T‖, ‖T′‖) per pair | mean {rc['mean']:.3f}, "
        f"median {rc['median']:.3f}, max {rc['max']:.3f} ({rc['n']} pairs) | 0 |",
        f"| div σ + f = 0 on {db['n_regions']} rectangles ({db['grains_inside_min']}–"
        f"{db['grains_inside_max']} grains): ‖boundary + load‖ / ‖load‖ | exact load: max "
        f"{db['exact_rel_max']:.1e}; gravity only: max {db['gravity_only_rel_max']:.1e} | 0 |",
        f"| Moreau tensor of the heap: asymmetry | {res['moreau_asymmetry']:.1e} | 0 |",
        f"| Weber vs Moreau, whole heap | {100 * res['weber_difference']:.1f} % | |",
        "",
        f"Cuts are {res['cut_length'] / d:.0f} d long (d = {d:.2f}, area-equivalent), centred at "
        f"depths {', '.join(f'{x:g}' for x in res['depths_d'])} d below the fitted surface, every "
        f"{res['cut_length'] / d / 2:.0f} d along it, from {res['heap_x_range'][0] / d:.0f} d off the "
        "wall to where the cut comes within 1 d of the bed.",
        "",
        "| depth | surface-parallel cuts: angle from vertical | vertical cuts: angle from surface | "
        "reciprocal rel. |",
        "|---|---|---|---|"]
    for dp, v in res["by_depth"].items():
        lines.append(f"| {dp} d | {v['surface']['mean']:.1f}° ± {v['surface']['spread']:.1f}° ({v['surface']['n']}) | "
                     f"{v['vertical']['mean']:.1f}° ± {v['vertical']['spread']:.1f}° | "
                     f"{v['reciprocal']['mean']:.3f} |")
    lines += ["", f"Run: {run['steps']} steps, {run['wall_time']:.0f} s wall "
              f"(pour {run['ms_per_step_pour']:.0f} ms/step, settle {run['ms_per_step_settle']:.0f} "
              f"ms/step, one process, NUMBA_NUM_THREADS=1, machine shared), settling "
              f"{'reached' if run.get('settle_reached_v_tol') else 'did NOT reach'} max heap speed "
              f"< 2e-3 (last {run.get('settle_vmax', float('nan')):.1e}); after the static step max speed "
              f"{run['max_speed']:.1e}, {run['n_contacts']} contacts.", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    main()

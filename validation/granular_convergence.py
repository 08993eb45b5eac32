"""Moreau's cut experiment and the Weber–Moreau comparison as functions of the sample size N.

For each N (default 200, 500, 1000, 2000, 5000) and each grain shape (disks;
random convex polygons of 5–8 sides), a biaxial box (friction 0.3, e = 0, no
gravity, pressure-controlled right/top walls with P_y = 2 P_x, see
:func:`socp_cd.granular.samples.biaxial_box_scene`) is

1. compressed by Moreau–Jean steps at a coarse NSGS tolerance (``--tol``, 100
   sweeps) until both walls move slower than 2e-2 (then the quench finishes the job),
2. quenched: ``--quench`` steps each started from zero velocities (kinetic
   energy removed, walls still loaded), which takes the packing to rest,
3. solved once more from zero velocities at the tight tolerance ``--final-tol``:
   this static step is the analysed state (its inertia ``m v⁺/h`` is reported:
   the state is at rest when it is negligible).

Measured on the grains (the walls are outside the sample; volume = inner box):

* Moreau's exact mean stress σ̄ (internal moment / area): its asymmetry and its
  change with the origin of moments (both zero at equilibrium);
* Weber's tensor σ_W with branch vectors between grain centres: relative
  difference ||σ̄ − σ_W|| / ||σ̄||, its asymmetry, and its change when each grain's
  reference point is moved at random inside the grain (half its radius);
* tractions across cuts through the box centre at 180 normal angles and at
  five offsets along the normal, compared with the continuum σ̄ n: RMS of the
  normal and shear parts relative to the mean pressure |tr σ̄|/2; and the same
  at offset 0 for cut lengths from 0.2 to 0.9 of the box side.

Outputs (validation/results/): cuts_convergence.json (list of rows), cuts_convergence_fits.json,
cuts_convergence.md,
cuts_convergence.png, weber_moreau_convergence.png.  States (HDF5, git-ignored):
validation/results/states/biaxial_<shape><N>.h5; a case whose state exists is
not simulated again (delete it or pass ``--redo``), so an interrupted run resumes
at the first missing case, and inside it from the compression checkpoint
``biaxial_<shape><N>.ckpt.h5`` (HDF5) written every 100 steps.

Usage: python validation/granular_convergence.py [--quick] [--n 200 500 ...]
       [--shapes disk polygon] [--redo] [--analyse-only]
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from socp_cd.dynamics.stepper import Simulation
from socp_cd.granular import (GranularState, asymmetry, continuum_traction, cut_traction,
                              external_stress, from_simulation, moreau_stress, relative_difference,
                              stress_report, weber_stress)
from socp_cd.granular.samples import biaxial_box_scene

RESULTS = Path(__file__).resolve().parent / "results"
STATES = RESULTS / "states"
PRESSURE = (10.0, 20.0)
OFFSETS = (-0.2, -0.1, 0.0, 0.1, 0.2)          # cut offsets along the normal / min(W, H)
MAIN_LENGTH = 0.5                               # cut length / min(W, H) for the offset family
LENGTHS = (0.2, 0.35, 0.5, 0.7, 0.9)            # cut lengths / min(W, H) at offset 0
N_ANGLES = 180


# ---------------------------------------------------------------- simulation
def make_sample(n, shape, *, seed=0, h=8e-3, max_steps=3000, quench=200, tol=1e-3, max_iter=100,
                quench_tol=1e-6, quench_iter=2000,
                final_tol=1e-8, final_iter=50000, final_solver="auto", final_form="local",
                final_time_limit=900.0,
                v_wall=2e-2, label="", checkpoint=None, checkpoint_every=100):
    """Compress, quench and finish one biaxial sample; returns (state, W, H, info).

    With ``checkpoint`` (an HDF5 path) the compression writes the simulation state
    there every ``checkpoint_every`` steps and resumes from it when the file exists.
    """
    box = biaxial_box_scene(n=n, pressure=PRESSURE, seed=seed, loose=1.05, mu_wall=0.3,
                            shape=shape)
    sim = Simulation(box.scene, h=h, tol=tol, solver="nsgs", max_iter=max_iter)
    t0 = time.perf_counter()
    unconv, steps, vmax, vw, spent, resumed_at = 0, 0, np.inf, np.inf, 0.0, 0
    settings = dict(n=n, shape=shape, seed=seed, h=h, tol=tol, max_iter=max_iter, v_wall=v_wall)
    jammed = False
    if checkpoint is not None and Path(checkpoint).exists():      # resume the compression
        steps, unconv, spent, vmax, vw, jammed = load_checkpoint(checkpoint, sim, settings)
        resumed_at = steps
        t0 -= spent
        print(f"{label}: resumed the compression at step {steps} ({spent:.0f} s spent"
              f"{', box jammed' if jammed else ''})", flush=True)
    bar = tqdm(total=max_steps, initial=steps, desc=f"compress {label}", mininterval=10, leave=False)
    while steps < max_steps and not jammed:
        st = sim.step()
        steps += 1
        unconv += int(not st.converged)
        if checkpoint is not None and steps % checkpoint_every == 0:
            save_checkpoint(checkpoint, sim, settings, steps, unconv,
                            time.perf_counter() - t0, vmax, vw, False)
        if steps % 50 == 0:
            p = sim.last_contacts.pairs
            loaded = np.intersect1d(np.arange(n), p[p >= 0])
            vmax = float(np.linalg.norm(sim.sys.vel[loaded, :2], axis=1).max()) if loaded.size else 0.0
            vw = float(np.abs(sim.sys.vel[[box.right_wall, box.top_wall], :2]).max())
            bar.update(50)
            bar.set_postfix(vmax=f"{vmax:.2e}", vwall=f"{vw:.1e}", contacts=st.n_active,
                            it=st.iterations)
            if steps >= 300 and vw < v_wall:      # walls stopped: the box is jammed
                jammed = True
                break
    bar.close()
    wall_compress = time.perf_counter() - t0
    if checkpoint is not None:       # a rerun after a crash later on does not compress further
        save_checkpoint(checkpoint, sim, settings, steps, unconv, wall_compress, vmax, vw, jammed)
    t1 = time.perf_counter()
    sim.tol, sim.max_iter = quench_tol, quench_iter
    for _ in range(quench):
        sim.sys.vel[:] = 0.0
        st = sim.step()
        unconv += int(not st.converged)
    wall_quench = time.perf_counter() - t1
    t2 = time.perf_counter()
    if final_solver == "nsgs":
        sim.use_solver("nsgs", tol=final_tol, max_iter=final_iter, form=final_form)
    else:                            # its own iteration caps, bounded in time
        sim.use_solver(final_solver, tol=final_tol, form=final_form, time_limit=final_time_limit)
    sim.sys.vel[:] = 0.0
    prev = sim.sys.vel.copy()
    st = sim.step()
    wall_final = time.perf_counter() - t2
    state = from_simulation(sim, prev_vel=prev)
    W = float(sim.sys.pos[box.right_wall, 0] - box.wall_thickness / 2)
    H = float(sim.sys.pos[box.top_wall, 1] - box.wall_thickness / 2)
    v_after = np.linalg.norm(sim.sys.vel[:n, :2], axis=1)
    info = dict(n_grains=n, shape=shape, seed=seed, h=h, tol=tol, max_iter=max_iter,
                compress_steps=steps, resumed_at_step=resumed_at, compress_vmax=vmax, compress_vwall=vw, quench_steps=quench,
                final_tol=final_tol, final_solver=final_solver, final_form=final_form,
                final_converged=bool(st.converged),
                final_error=float(st.error), final_iterations=int(st.iterations),
                final_max_displacement=float(v_after.max() * h),
                unconverged_steps=unconv, wall_compress=wall_compress, wall_quench=wall_quench,
                wall_final=wall_final,
                ms_per_step=1e3 * (wall_compress + wall_quench) / (steps + quench),
                n_contacts=int(state.n_contacts))
    return state, W, H, info


def sample_state(states, n, shape, *, seed=0, redo=False, label=None, **kw):
    """The state of one sample: read from ``states`` or simulated (:func:`make_sample`).

    ``biaxial_<shape><N>.h5`` for seed 0, ``biaxial_<shape><N>_s<seed>.h5`` for
    the others; a simulation checkpoints its compression next to it and
    resumes from that checkpoint (``redo``: simulate again from scratch).
    ``kw`` are :func:`make_sample`'s protocol arguments.  Returns
    ``(state, W, H, info)``.
    """
    path = Path(states) / (f"biaxial_{shape}{n}.h5" if seed == 0
                           else f"biaxial_{shape}{n}_s{seed}.h5")
    if path.exists() and not redo:
        return load_state(path)
    ck = path.with_suffix(".ckpt.h5")
    if redo:
        ck.unlink(missing_ok=True)
    out = make_sample(n, shape, seed=seed, label=label or path.stem[len("biaxial_"):],
                      checkpoint=ck, **kw)
    save_state(path, *out)
    ck.unlink(missing_ok=True)
    return out


def save_checkpoint(path, sim, settings, steps, unconv, spent, vmax, vw, jammed):
    """Write the compression's simulation state (``Simulation.get_state``) to HDF5, atomically.

    ``settings`` (the sample's arguments but ``max_steps``, which a resume may
    raise) are stored so that a resume with other ones is refused; ``jammed``
    marks a compression stopped by the walls (a rerun after a crash in the
    quench or the static step goes straight to the quench).
    """
    import h5py
    tmp = Path(str(path) + ".tmp")
    with h5py.File(tmp, "w") as f:
        for k, v in sim.get_state().items():
            if v is not None:
                f[f"state/{k}"] = v
        f.attrs["settings"] = json.dumps(settings)
        for k, v in dict(steps=steps, unconv=unconv, spent=spent, vmax=vmax, vw=vw,
                         jammed=jammed).items():
            f.attrs[k] = v
    os.replace(tmp, path)


def load_checkpoint(path, sim, settings):
    """Restore :func:`save_checkpoint`'s state into ``sim``.

    Returns ``(steps, unconv, spent, vmax, vw, jammed)``; refuses (SystemExit)
    a checkpoint written with other settings.
    """
    import h5py
    with h5py.File(path, "r") as f:
        saved = json.loads(f.attrs["settings"])
        if saved != json.loads(json.dumps(settings)):
            raise SystemExit(f"{path}: checkpoint of another run ({saved}); this run: {settings}. "
                             "Delete it or pass --redo.")
        sim.set_state({k: f["state"][k][()] for k in f["state"]})
        a = f.attrs
        return (int(a["steps"]), int(a["unconv"]), float(a["spent"]), float(a["vmax"]),
                float(a["vw"]), bool(a["jammed"]))


def save_state(path, state, W, H, info):
    """The analysed state (HDF5): contacts, grains, box size and run information."""
    import h5py
    tmp = Path(str(path) + ".tmp")
    with h5py.File(tmp, "w") as f:
        for k in ("centers", "masses", "volumes", "pairs", "points", "forces", "normals", "gravity",
                  "accelerations", "radii"):
            f[k] = getattr(state, k)
        f.attrs["W"], f.attrs["H"] = W, H
        f.attrs["info"] = json.dumps(info)
    os.replace(tmp, path)


def load_state(path):
    import h5py
    with h5py.File(path, "r") as f:
        state = GranularState(**{k: np.asarray(f[k]) for k in (
            "centers", "masses", "volumes", "pairs", "points", "forces", "normals", "gravity",
            "accelerations", "radii")}, source=str(path))
        return state, float(f.attrs["W"]), float(f.attrs["H"]), json.loads(f.attrs["info"])


# ---------------------------------------------------------------- analysis
def cut_rms(state, sig, center, length, offsets, angles):
    """RMS over (θ, offset) of the normal and shear traction errors, and mean crossings."""
    _, cn, cs = continuum_traction(sig, angles)
    en, es = [], []
    for off in offsets:
        for a, c_n, c_s in zip(angles, cn, cs):
            n = np.array([np.cos(a), np.sin(a)])
            t = cut_traction(state, center + off * n, n, length)
            en.append(t @ n - c_n)
            es.append(t @ np.array([-n[1], n[0]]) - c_s)
    return float(np.sqrt(np.mean(np.square(en)))), float(np.sqrt(np.mean(np.square(es))))


def analyse(state, W, H, info, rng_seed=1):
    """All the numbers of one sample (see the module docstring)."""
    n = info["n_grains"]
    grains = np.arange(n)
    V = W * H
    rep = stress_report(state, V, sample=grains)
    sig = rep.moreau
    p = abs(np.trace(sig)) / 2
    s_norm = np.linalg.norm(sig)
    origin_change = max(relative_difference(sig, moreau_stress(state, V, grains, origin=o))
                        for o in ([3 * W, -2 * H], [-W, 5 * H]))
    static = GranularState(centers=state.centers, masses=state.masses, volumes=state.volumes,
                           pairs=state.pairs, points=state.points, forces=state.forces,
                           gravity=state.gravity)
    fmean = float(np.linalg.norm(state.forces, axis=1).mean())
    inertia = float(np.linalg.norm(state.body_forces()[grains], axis=1).max() / fmean)
    static_res = float(np.linalg.norm(static.resultants()[grains], axis=1).max() / fmean)
    # Weber with reference points moved at random inside each grain (|δ| <= r/2)
    rng = np.random.default_rng(rng_seed)
    ref_change, ref_decomp = [], []
    for _ in range(3):
        rad = 0.5 * state.radii * np.sqrt(rng.uniform(0, 1, state.n_bodies))
        ang = rng.uniform(0, 2 * np.pi, state.n_bodies)
        ref = state.centers + rad[:, None] * np.c_[np.cos(ang), np.sin(ang)]
        w_ref = weber_stress(state, V, grains, reference=ref)
        ref_change.append(float(np.linalg.norm(w_ref - rep.weber) / s_norm))
        ref_decomp.append(relative_difference(sig, w_ref + external_stress(state, V, grains, ref)))
    d = float(np.mean(2 * np.sqrt(state.volumes[grains] / np.pi)))    # area-equivalent diameter
    side = min(W, H)
    center = np.array([W / 2, H / 2])
    th = np.linspace(0, np.pi, N_ANGLES, endpoint=False)
    rn, rs = cut_rms(state, sig, center, MAIN_LENGTH * side, [o * side for o in OFFSETS], th)
    by_length = []
    for f in LENGTHS:
        a, b = cut_rms(state, sig, center, f * side, [0.0], th)
        by_length.append(dict(length_over_d=f * side / d, rms_normal=a / p, rms_shear=b / p))
    return dict(
        n_grains=n, shape=info["shape"], W=W, H=H, mean_diameter=d,
        cut_length_over_d=MAIN_LENGTH * side / d, solid_fraction=float(state.volumes[grains].sum() / V),
        pressure=p, rms_normal=rn / p, rms_shear=rs / p,
        weber_moreau_rel=rep.weber_difference, weber_asymmetry=rep.weber_asymmetry,
        weber_reference_change_mean=float(np.mean(ref_change)),
        weber_reference_change_max=float(np.max(ref_change)),
        decomposition_residual_any_reference=float(max(ref_decomp + [rep.decomposition_residual])),
        moreau_asymmetry=rep.moreau_asymmetry, moreau_origin_change=origin_change,
        balance_residual=rep.equilibrium_residual, inertia_over_mean_force=inertia,
        static_residual_over_mean_force=static_res, by_length=by_length,
        final_solver=info.get("final_solver", "nsgs"),
        **{k: info[k] for k in ("final_converged", "final_error", "final_tol", "final_iterations",
                                "final_max_displacement", "compress_steps", "compress_vmax",
                                "quench_steps", "unconverged_steps", "ms_per_step", "wall_compress",
                                "wall_quench", "wall_final", "n_contacts", "h", "tol")})


# ---------------------------------------------------------------- reports
def fit_exponent(N, y):
    """Least-squares slope and prefactor of log y = log c + k log N."""
    k, c = np.polyfit(np.log(N), np.log(y), 1)
    return float(k), float(np.exp(c))


def _n_ticks(ax, rows):
    """Ticks at the sample sizes, plain numbers (no log-axis minor labels)."""
    from matplotlib.ticker import NullFormatter
    ns = sorted({r["n_grains"] for r in rows})
    ax.set_xticks(ns)
    ax.set_xticklabels([str(n) for n in ns])
    ax.xaxis.set_minor_formatter(NullFormatter())


def figures(rows, out_dir, suffix=""):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fits = {}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    ax = axes[0]
    for shape, mk in (("disk", "o"), ("polygon", "s")):
        R = sorted([r for r in rows if r["shape"] == shape], key=lambda r: r["n_grains"])
        if len(R) < 2:
            continue
        N = np.array([r["n_grains"] for r in R], float)
        for key, col in (("rms_normal", "tab:blue"), ("rms_shear", "tab:red")):
            y = np.array([r[key] for r in R])
            k, c = fit_exponent(N, y)
            fits[f"{shape}_{key}"] = k
            ax.loglog(N, y, mk, color=col, mfc="none" if shape == "polygon" else col,
                      label=f"{shape}s, {key.split('_')[1]}: slope {k:.2f}")
            ax.loglog(N, c * N ** k, "-", color=col, lw=0.8, alpha=0.6)
    if rows:
        r0 = min(rows, key=lambda r: r["n_grains"])
        N0 = np.array([r0["n_grains"], max(r["n_grains"] for r in rows)], float)
        ax.loglog(N0, r0["rms_normal"] * (N0 / N0[0]) ** -0.25, "k:", lw=1,
                  label="N^(-1/4) (independent crossings)")
    _n_ticks(ax, rows)
    ax.set_xlabel("grains N")
    ax.set_ylabel("RMS(cut traction − σ̄n) / |tr σ̄/2|")
    ax.set_title("Cut tractions vs the continuum, 180 angles × 5 offsets")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax = axes[1]
    for shape, mk in (("disk", "o"), ("polygon", "s")):
        R = [r for r in rows if r["shape"] == shape]
        for key, col in (("rms_normal", "tab:blue"), ("rms_shear", "tab:red")):
            x = [b["length_over_d"] for r in R for b in r["by_length"]]
            y = [b[key] for r in R for b in r["by_length"]]
            if x:
                ax.loglog(x, y, mk, color=col, ms=4, alpha=0.7,
                          mfc="none" if shape == "polygon" else col,
                          label=f"{shape}s, {key.split('_')[1]}")
    x = [b["length_over_d"] for r in rows for b in r["by_length"]]
    y = [b[k] for r in rows for b in r["by_length"] for k in ("rms_normal", "rms_shear")]
    if x:
        k, c = fit_exponent(np.repeat(x, 2), y)
        fits["length_all"] = k
        L0 = np.array([min(x), max(x)])
        ax.loglog(L0, c * L0 ** k, "k-", lw=1, label=f"fit, all: slope {k:.2f}")
    ax.set_xlabel("cut length / mean grain diameter")
    from matplotlib.ticker import NullFormatter
    ax.xaxis.set_minor_formatter(NullFormatter())      # minor labels overlapped
    ax.set_ylabel("RMS / |tr σ̄/2| (offset 0, 180 angles)")
    ax.set_title("Same, against the cut length")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_dir / f"cuts_convergence{suffix}.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(10, 5.2))
    for shape, mk in (("disk", "o"), ("polygon", "s")):
        R = sorted([r for r in rows if r["shape"] == shape], key=lambda r: r["n_grains"])
        if not R:
            continue
        N = np.array([r["n_grains"] for r in R], float)
        for key, col, lab in (("weber_moreau_rel", "tab:blue", "||σ̄ − σ_W|| / ||σ̄||"),
                              ("weber_asymmetry", "tab:green", "asymmetry of σ_W"),
                              ("weber_reference_change_mean", "tab:orange",
                               "σ_W change, reference points moved ≤ r/2"),
                              ("moreau_asymmetry", "0.3", "asymmetry of σ̄"),
                              ("moreau_origin_change", "0.6", "σ̄ change with the origin")):
            y = np.array([max(r[key], 1e-17) for r in R])
            ax.loglog(N, y, mk + "-", color=col, mfc="none" if shape == "polygon" else col,
                      label=f"{lab} ({shape}s)")
            if key == "weber_moreau_rel" and len(R) >= 2:
                k, c = fit_exponent(N, y)
                fits[f"{shape}_weber_moreau_rel"] = k
                # N at which the fitted difference falls to 3 % and to 1 %
                fits[f"{shape}_weber_moreau_N_at_3pct"] = float((0.03 / c) ** (1 / k)) if k < 0 else float("inf")
                fits[f"{shape}_weber_moreau_N_at_1pct"] = float((0.01 / c) ** (1 / k)) if k < 0 else float("inf")
    ax.axhline(0.03, color="k", ls=":", lw=1, label="3 %")
    _n_ticks(ax, rows)
    ax.set_xlabel("grains N")
    ax.set_ylabel("relative size")
    ax.set_title("Weber vs Moreau in the biaxial box")
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_dir / f"weber_moreau_convergence{suffix}.png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return fits


def table(rows, fits):
    lines = ["# Moreau's cut experiment and Weber vs Moreau as functions of N",
             "",
             "Biaxial boxes (μ = 0.3, e = 0, no gravity, P_y = 2 P_x applied through two frictionless moving walls, the two fixed walls μ = 0.3), "
             "compressed at NSGS tol 1e-3 (100 sweeps, h = 8e-3) until the walls stop (at most 3 000 steps), quenched (200 steps from zero velocities), then one static step from zero velocities at "
             "the final tolerance (analysed). Cut tractions: 180 normal angles × 5 offsets "
             "(−0.2…0.2 of the box side) of cuts 0.5 box side long through the centre; RMS "
             "relative to the mean pressure |tr σ̄|/2. Generated by "
             "`validation/granular_convergence.py`.",
             "",
             "| shape | N | contacts | cut length / d | RMS normal | RMS shear | ‖σ̄−σ_W‖/‖σ̄‖ | "
             "asym σ_W | σ_W ref. change | asym σ̄ | σ̄ origin change | static residual / ⟨f⟩ | "
             "inertia / ⟨f⟩ | final step: error (tol), solver, iterations | ms/step | wall s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["shape"], r["n_grains"])):
        lines.append(
            f"| {r['shape']} | {r['n_grains']} | {r['n_contacts']} | {r['cut_length_over_d']:.1f} | "
            f"{100 * r['rms_normal']:.1f} % | {100 * r['rms_shear']:.1f} % | "
            f"{100 * r['weber_moreau_rel']:.2f} % | {100 * r['weber_asymmetry']:.2f} % | "
            f"{100 * r['weber_reference_change_mean']:.2f} % | {r['moreau_asymmetry']:.1e} | "
            f"{r['moreau_origin_change']:.1e} | {r['static_residual_over_mean_force']:.1e} | "
            f"{r['inertia_over_mean_force']:.1e} | {r['final_error']:.1e} ({r['final_tol']:.0e}), "
            f"{r['final_solver']}, {r['final_iterations']} | {r['ms_per_step']:.0f} | "
            f"{r['wall_compress'] + r['wall_quench'] + r['wall_final']:.0f} |")
    lines += ["", "Fits (RMS ∝ N^k, Weber–Moreau difference ∝ N^k, RMS ∝ (L/d)^k; N where the fitted "
              "Weber–Moreau difference reaches 3 % / 1 %): " +
              ", ".join(f"{k} {v:.3g}" for k, v in sorted(fits.items())), "",
              "## Cut length (offset 0, 180 angles): RMS normal / shear", "",
              "| shape | N | " + " | ".join(f"L = {f:g} side" for f in LENGTHS) + " |",
              "|---|---|" + "---|" * len(LENGTHS)]
    for r in sorted(rows, key=lambda r: (r["shape"], r["n_grains"])):
        lines.append(f"| {r['shape']} | {r['n_grains']} | " + " | ".join(
            f"{b['length_over_d']:.0f} d: {100 * b['rms_normal']:.0f} / {100 * b['rms_shear']:.0f} %"
            for b in r["by_length"]) + " |")
    lines.append("")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[200, 500, 1000, 2000, 5000])
    ap.add_argument("--shapes", nargs="+", default=["disk", "polygon"])
    ap.add_argument("--h", type=float, default=8e-3)
    ap.add_argument("--max-steps", type=int, default=3000, help="compression steps (at most)")
    ap.add_argument("--quench", type=int, default=200)
    ap.add_argument("--tol", type=float, default=1e-3)
    ap.add_argument("--final-tol", type=float, default=1e-8)
    ap.add_argument("--final-solver", default="auto",
                    help="solver of the analysed static step (NSGS stalls near 1e-6 on "
                         "thousands of contacts; 'auto' chains Newton and Clarabel)")
    ap.add_argument("--redo", action="store_true", help="simulate even if the state exists")
    ap.add_argument("--analyse-only", action="store_true", help="only the cases already simulated")
    ap.add_argument("--quick", action="store_true", help="N = 60, 120 (smoke run, results in /tmp)")
    args = ap.parse_args(argv)
    if args.quick:
        args.n, args.max_steps, args.quench = [60, 120], 1000, 100
    out_dir = Path("/tmp/granular_convergence_quick") if args.quick else RESULTS
    states = out_dir / "states" if args.quick else STATES
    states.mkdir(parents=True, exist_ok=True)
    rows = []
    for n in sorted(args.n):                 # smallest first: an interrupted run keeps them
        for shape in args.shapes:
            if args.analyse_only and not (states / f"biaxial_{shape}{n}.h5").exists():
                continue
            state, W, H, info = sample_state(
                states, n, shape, redo=args.redo and not args.analyse_only, h=args.h,
                max_steps=args.max_steps, quench=args.quench, tol=args.tol,
                final_tol=args.final_tol, final_solver=args.final_solver)
            r = analyse(state, W, H, info)
            rows.append(r)
            print(f"{shape:8s} N={n:5d} rms_n={100 * r['rms_normal']:.1f}% "
                  f"rms_s={100 * r['rms_shear']:.1f}% weber={100 * r['weber_moreau_rel']:.2f}% "
                  f"asym={r['moreau_asymmetry']:.1e} static_res={r['static_residual_over_mean_force']:.1e} "
                  f"final_err={r['final_error']:.1e} ms/step={r['ms_per_step']:.0f}", flush=True)
    fits = figures(rows, out_dir)
    (out_dir / "cuts_convergence.json").write_text(json.dumps(rows, indent=1))
    (out_dir / "cuts_convergence_fits.json").write_text(json.dumps(fits, indent=1))
    (out_dir / "cuts_convergence.md").write_text(table(rows, fits))
    print("wrote", out_dir / "cuts_convergence.md")
    return rows, fits


if __name__ == "__main__":
    main()

"""Which step solver a scene file should run by default: every step of whole simulations.

A scene file's ``simulation.solver`` chooses the solver of every Moreau–Jean step
(``docs/scenes.md``).  This script runs each given scene file once per solver, all other
settings as the file writes them (its ``tol``, ``max_iter``, steps, warm starts from the
previous step), and records every step with contacts: active contacts, the solver's
status, Siconos' relative error (``StepStats.error``, recomputed by the solver layer) and
the solve's wall time.  The trajectories of two solvers part once a step's answer differs,
so the steps compared are those of each solver's own run, not the same problems.

Writes ``<out>.md`` (per scene and solver: steps with contacts, steps unconverged, the
largest and median error, solve time in all, median per step), ``<out>.csv`` (every step)
and ``<out>.png`` (the error of every step against simulated time, one panel per scene,
the tolerance dashed)::

    .venv/bin/python validation/scene_solvers.py examples/*.toml \\
        --solvers nsgs auto --out validation/results/scene_solvers_s49

``--steps N`` caps every run at ``N`` steps (a quick look; the record says so).
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.reports import emit
from socp_cd.scenes import load_scene_file, simulate


def run_scene(path, solver: str, steps: int | None = None) -> tuple[dict, list[dict]]:
    """Simulate the scene file ``path`` with ``solver`` (every other setting the file's), as
    ``socp-cd simulate --solver`` does (:func:`socp_cd.scenes.simulate`).

    Returns ``(setting, rows)``: the file's stem (``name``; scene names repeat across
    collections), ``tol``, ``max_iter`` and step count, and one
    row per step with contacts (``step``, ``t``, ``contacts``, ``status``,
    ``converged``, ``error``, ``time_solve``)."""
    spec = load_scene_file(path)
    s = spec.simulation
    n = s["steps"] if steps is None else min(int(steps), s["steps"])
    run = simulate(path, steps=n, every=max(n, 1), quiet=True, solver=solver)
    rows = [{"step": k, "t": st.t, "contacts": st.n_active, "status": st.status,
             "converged": bool(st.converged), "error": float(st.error),
             "time_solve": float(st.time_solve)}
            for k, st in enumerate(run["trajectory"].stats, start=1) if st.n_active]
    return {"name": Path(path).stem, "dim": spec.dim, "tol": s["tol"], "max_iter": s["max_iter"],
            "steps": n}, rows


def summary(setting: dict, solver: str, rows: list[dict], wall: float) -> dict:
    """One line of the table: counts, errors and times of one run."""
    err = np.array([r["error"] for r in rows]) if rows else np.zeros(0)
    ts = np.array([r["time_solve"] for r in rows]) if rows else np.zeros(0)
    bad = [r for r in rows if not r["converged"]]
    return {"scene": setting["name"], "dim": setting["dim"], "solver": solver,
            "steps": setting["steps"], "tol": setting["tol"], "with_contacts": len(rows),
            "max_contacts": max((r["contacts"] for r in rows), default=0),
            "unconverged": len(bad), "max_error": float(err.max()) if err.size else 0.0,
            "median_error": float(np.median(err)) if err.size else 0.0,
            "solve_s": float(ts.sum()), "median_solve_ms": 1e3 * float(np.median(ts)) if ts.size else 0.0,
            "wall_s": wall,
            "statuses": ", ".join(f"{s} {sum(r['status'] == s for r in bad)}"
                                  for s in sorted({r["status"] for r in bad}))}


def table(lines: list[dict], argv: str, capped: int | None) -> list[str]:
    """The Markdown record's lines."""
    head = ["# Scene files: the step solver, whole simulations", "",
            f"`python validation/scene_solvers.py {argv}` (socp_cd {socp_cd.__version__}; one run "
            "per scene and solver, warm starts as the stepper makes them; times are wall clock "
            "on this machine, one process)."
            + (f" **Every run capped at {capped} steps.**" if capped else ""), "",
            "| scene file | dim | solver | steps (with contacts) | max contacts | tol | unconverged "
            "| max error | median error | solve time [s] | median per step [ms] | wall [s] |",
            "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for s in lines:
        unc = f"{s['unconverged']}" + (f" ({s['statuses']})" if s["unconverged"] else "")
        head.append(f"| {s['scene']} | {s['dim']} | `{s['solver']}` | {s['steps']} ({s['with_contacts']}) "
                    f"| {s['max_contacts']} | {s['tol']:.0e} | {unc} | {s['max_error']:.1e} "
                    f"| {s['median_error']:.1e} | {s['solve_s']:.2f} | {s['median_solve_ms']:.2f} "
                    f"| {s['wall_s']:.1f} |")
    return head


def figure(runs: list[tuple[dict, str, list[dict]]], path: Path) -> None:
    """Per scene, every step's error against simulated time, one line per solver."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(dict.fromkeys(setting["name"] for setting, _, _ in runs))
    cols = min(3, len(scenes))
    nrow = -(-len(scenes) // cols)
    fig, axes = plt.subplots(nrow, cols, figsize=(5.2 * cols, 3.4 * nrow), squeeze=False)
    for ax, name in zip(axes.flat, scenes):
        tol = None
        for setting, solver, rows in runs:
            if setting["name"] != name or not rows:
                continue
            tol = setting["tol"]
            t = [r["t"] for r in rows]
            e = [max(r["error"], 1e-17) for r in rows]
            bad = sum(not r["converged"] for r in rows)
            ax.semilogy(t, e, ".", ms=2, label=f"{solver}: {bad} of {len(rows)} unconverged")
        if tol is not None:
            ax.axhline(tol, color="k", ls="--", lw=0.8)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("step error (Siconos' measure)")
        ax.legend(fontsize=8, markerscale=4)
    for ax in list(axes.flat)[len(scenes):]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+", help="TOML scene files")
    ap.add_argument("--solvers", nargs="+", default=["nsgs", "auto"])
    ap.add_argument("--steps", type=int, default=None, help="cap every run at this many steps")
    ap.add_argument("--out", default="validation/results/scene_solvers",
                    help="output stem (.md, .csv, .png)")
    args = ap.parse_args(argv)
    socp_cd.warmup()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    runs, lines = [], []
    with open(out.with_suffix(".csv"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["scene", "solver", "step", "t", "contacts", "status", "converged", "error",
                    "time_solve"])
        for path in args.scenes:
            for solver in args.solvers:
                t0 = time.perf_counter()
                setting, rows = run_scene(path, solver, args.steps)
                wall = time.perf_counter() - t0
                runs.append((setting, solver, rows))
                lines.append(summary(setting, solver, rows, wall))
                for r in rows:
                    w.writerow([setting["name"], solver, r["step"], f"{r['t']:.6g}", r["contacts"],
                                r["status"], int(r["converged"]), f"{r['error']:.3e}",
                                f"{r['time_solve']:.6f}"])
                fh.flush()
                s = lines[-1]
                print(f"{s['scene']} {solver}: {s['unconverged']} of {s['with_contacts']} unconverged, "
                      f"max error {s['max_error']:.1e}, solve {s['solve_s']:.2f} s, wall {wall:.1f} s",
                      flush=True)
    cmd = " ".join(args.scenes) + " --solvers " + " ".join(args.solvers) + \
        (f" --steps {args.steps}" if args.steps else "") + f" --out {args.out}"
    emit(table(lines, cmd, args.steps), out.with_suffix(".md"))
    figure(runs, out.with_suffix(".png"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

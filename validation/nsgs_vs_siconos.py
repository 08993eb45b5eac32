"""socp_cd NSGS against Siconos 4.4 ``fc3d_nsgs`` / ``fc2d_nsgs`` on the shared local problems.

Both solvers start from ``r = 0`` with ``tol = 1e-8`` and ``max_iter = 1e5``
(sweeps).  Siconos runs with its default NSGS options (one-contact
Alart–Curnier Newton ``FC3D_ONECONTACT_NSN_GP_HYBRID`` local solver, error
evaluation ``LIGHT_WITH_FULL_FINAL``), all its runs in *one* worker process
(:func:`socp_cd.bench.siconos_peer.siconos_batch`); socp_cd NSGS runs with its
defaults.  Timing: the numba compilation is done (and timed) first by
:func:`socp_cd.solvers.nsgs.warmup`; every solve is repeated (at least
``--repeat`` times, up to 200 while the calls take under 0.05 s, on both sides) and
the minimum kept; socp_cd's time is the whole ``solve`` call on a new problem object
(balancing and block storage rebuilt every run, Python overhead included),
Siconos' the ``*_driver`` call (``.dat`` files in their own storage, FCLib
HDF5 problems in sparse-block storage).  Every final
``r`` is judged by :func:`socp_cd.error` and by Siconos' own error function.

Writes ``validation/results/nsgs_vs_siconos.csv`` and ``.md`` and prints the
table.  Usage: ``python validation/nsgs_vs_siconos.py [--only NAME ...] [--repeat 3]``
"""
from __future__ import annotations

import argparse
import copy
import csv
import sys
import time
from pathlib import Path

import numpy as np

import socp_cd
# calls per problem on each side, stopped once they have taken REPEAT_BUDGET seconds (the
# Siconos worker's rule), the fastest kept
from socp_cd.bench.siconos_peer import REPEAT_BUDGET
from socp_cd.bench.siconos_peer import REPEAT_CALLS as SICONOS_REPEAT
from socp_cd.bench.siconos_peer import siconos_available, siconos_batch
from socp_cd.data import shared_problems_dir
from socp_cd.solvers.nsgs import warmup

OUT = Path(__file__).resolve().parent / "results"
TOL = 1e-8
MAX_ITER = 100_000

COLUMNS = ["problem", "dim", "contacts", "status", "sic_status", "iters", "sic_iters",
           "iter_ratio", "cpu", "sic_cpu", "cpu_sweep_us", "sic_cpu_sweep_us", "cpu_sweep_ratio",
           "time", "sic_time", "sweep_us", "sic_sweep_us", "sweep_ratio",
           "loop_sweep_us", "error", "error_by_siconos", "sic_error", "sic_own_error"]


def run_ours(problem, repeat):
    """Min (CPU time) of at least ``repeat`` socp_cd NSGS solves, up to SICONOS_REPEAT while
    the calls have taken under 0.05 s (as the Siconos worker repeats its driver call); the
    block storage is rebuilt each time."""
    best, wall, spent, k = None, np.inf, 0.0, 0
    while k < repeat or (k < SICONOS_REPEAT and spent < REPEAT_BUDGET):
        k += 1
        # a new problem object: its block storage and balanced copy are built again
        # (they are kept on the object, FrictionContactProblem.derived)
        target = copy.copy(problem)
        c0 = time.process_time()
        res = socp_cd.solve(target, "nsgs", tol=TOL, max_iter=MAX_ITER)
        # the whole call's CPU time (a plain call runs NSGS through the compiled route,
        # which records no loop times of its own)
        res.info["cpu_time"] = time.process_time() - c0
        spent += res.time
        wall = min(wall, res.time)
        if best is None or res.info["cpu_time"] < best.info["cpu_time"]:
            best = res
    best.time = wall
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="problem file names")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--time-limit", type=float, default=900.0, help="per Siconos task (s)")
    args = ap.parse_args(argv)
    data = shared_problems_dir()
    if data is None:
        print("shared problems not found (set SOCP_CD_DATA)")
        return 1
    if not siconos_available():
        print("Siconos not available for /usr/bin/python3")
        return 1

    compile_time = warmup()
    print(f"numba warm-up (compile or cache load): {compile_time:.2f} s")

    problems = []
    for path in sorted(data.iterdir()):
        if args.only and path.name not in args.only:
            continue
        if path.name.startswith(("MANIFEST", "README")):
            continue
        p = socp_cd.read_problem(path)
        if not p.is_global:
            problems.append((path, p))

    ours = {}
    for path, p in problems:
        res = run_ours(p, args.repeat)
        ours[path.name] = res
        print(f"socp_cd  {path.name:45s} {res.status:10s} it={res.iterations:6d} "
              f"err={res.error:.2e} t={res.time:.4f}s cpu={res.info['cpu_time']:.4f}s", flush=True)

    tasks = []
    for path, p in problems:
        # one task, the driver called up to SICONOS_REPEAT times in it (the worker stops
        # after 0.05 s of calls) and the fastest call kept: separate tasks would each time
        # a cold first call (~60 µs on one contact, 20x its warm cost)
        tasks.append({"task": "solve", "problem": str(path), "solver": "nsgs", "tol": TOL,
                      "max_iter": MAX_ITER, "time_limit": args.time_limit,
                      "repeat": max(args.repeat, SICONOS_REPEAT)})
        tasks.append({"task": "error", "problem": str(path), "rs": ours[path.name].r})
    t0 = time.perf_counter()
    sic = siconos_batch(tasks)
    print(f"Siconos batch: {time.perf_counter() - t0:.1f} s")

    rows = []
    k = 0
    for path, p in problems:
        runs = sic[k:k + 1]
        err_task = sic[k + 1]
        k += 2
        res = ours[path.name]
        ok = [s for s in runs if s.get("status") == "ok"]
        row = {"problem": path.name, "dim": p.dim, "contacts": p.n_contacts,
               "status": res.status, "iters": res.iterations, "time": res.time,
               "cpu": res.info["cpu_time"],
               "cpu_sweep_us": 1e6 * res.info["cpu_time"] / max(res.iterations, 1),
               "sweep_us": 1e6 * res.time / max(res.iterations, 1),
               "loop_sweep_us": 1e6 * res.info.get("loop_time", np.nan) / max(res.iterations, 1),
               "error": socp_cd.error(p, res.r)}
        ebs = err_task.get("errors") if err_task.get("status") == "ok" else None
        row["error_by_siconos"] = float(np.asarray(ebs)[0]) if ebs is not None else np.nan
        if ok:
            s = min(ok, key=lambda x: x["cpu_time"])
            se = socp_cd.error(p, s["r"])
            nit = max(int(s["iterations"]), 1)
            row.update(sic_iters=int(s["iterations"]), sic_time=min(float(x["time"]) for x in ok),
                       sic_cpu=float(s["cpu_time"]), sic_cpu_sweep_us=1e6 * float(s["cpu_time"]) / nit,
                       sic_sweep_us=1e6 * min(float(x["time"]) for x in ok) / nit,
                       sic_error=se, sic_own_error=float(s.get("error", np.nan)),
                       sic_status=("converged" if se <= TOL else
                                   "max_iter" if int(s["iterations"]) >= MAX_ITER else "not_converged"))
            row["iter_ratio"] = row["iters"] / max(row["sic_iters"], 1)
            row["sweep_ratio"] = row["sweep_us"] / row["sic_sweep_us"]
            row["cpu_sweep_ratio"] = row["cpu_sweep_us"] / row["sic_cpu_sweep_us"]
        else:
            row.update(sic_status=runs[0].get("status", "?"), sic_iters=np.nan, sic_time=np.nan,
                       sic_sweep_us=np.nan, sic_cpu=np.nan, sic_cpu_sweep_us=np.nan,
                       cpu_sweep_ratio=np.nan, sic_error=np.nan, sic_own_error=np.nan,
                       iter_ratio=np.nan, sweep_ratio=np.nan)
        rows.append(row)

    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "nsgs_vs_siconos.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for row in rows:
            w.writerow({c: (f"{row[c]:.6g}" if isinstance(row[c], float) else row[c])
                        for c in COLUMNS})
    md = render_markdown(rows, compile_time, args.repeat)
    (OUT / "nsgs_vs_siconos.md").write_text(md)
    print(md)
    return 0


SETTINGS = (
    "Settings. Siconos: `SolverOptions(SICONOS_FRICTION_3D_NSGS)` (2D: `_2D_NSGS`) defaults "
    "except tol/max_iter — local solver FC3D_ONECONTACT_NSN_GP_HYBRID (Alart–Curnier STD, "
    "split-spectral-norm rho, Goldstein–Price line search, 10 Newton iterations, local tol "
    "1e-14, NSN then PLI–NSN loop with 100 projection iterations), error evaluation "
    "LIGHT_WITH_FULL_FINAL (light error ||r_k+1 - r_k||/||r_k+1|| every sweep, full "
    "`fc3d_compute_error` when it drops below tol, tolerance tightened on a false alarm). "
    "socp_cd: defaults (3D `ac_newton`, 2D `exact`, light error every sweep + full error "
    "every 10 sweeps, see formulations/nsgs.md). Siconos' 2D driver gets a dense W for "
    "CSparse files (the bridge densifies them), which explains its cost on "
    "fc2d_granularflowonwall. On FC2D_SliderCrank Siconos runs all 1e5 sweeps (its own "
    "criterion is not met) while its r is already a solution by socp_cd.error; the "
    "per-sweep ratio there compares 367 sweeps plus fixed Python overhead with 1e5 cheap "
    "sweeps and is not meaningful.")


def _fmt(x, spec):
    if isinstance(x, float) and not np.isfinite(x):
        return "—"
    return format(x, spec)


def render_markdown(rows, compile_time, repeat) -> str:
    head = ("| problem | d | nc | status (ours / Siconos) | sweeps ours | sweeps Siconos | "
            "sweep ratio | CPU ours [s] | CPU Siconos [s] | CPU µs/sweep ours | "
            "CPU µs/sweep Siconos | CPU/sweep ratio | wall/sweep ratio | error ours | "
            "ours by Siconos | Siconos r by socp_cd | Siconos own |")
    lines = [head, "|" + "---|" * 17]
    for r in rows:
        lines.append(
            f"| {r['problem']} | {r['dim']} | {r['contacts']} | {r['status']} / {r['sic_status']} | "
            f"{r['iters']} | {_fmt(float(r['sic_iters']), '.0f')} | {_fmt(r['iter_ratio'], '.2f')} | "
            f"{r['cpu']:.4g} | {_fmt(r['sic_cpu'], '.4g')} | {r['cpu_sweep_us']:.3g} | "
            f"{_fmt(r['sic_cpu_sweep_us'], '.3g')} | {_fmt(r['cpu_sweep_ratio'], '.2f')} | "
            f"{_fmt(r['sweep_ratio'], '.2f')} | "
            f"{r['error']:.2e} | {_fmt(r['error_by_siconos'], '.2e')} | {_fmt(r['sic_error'], '.2e')} | "
            f"{_fmt(r['sic_own_error'], '.2e')} |")
    out = ["# socp_cd NSGS vs Siconos 4.4 NSGS", "",
           f"tol = {TOL:g}, max_iter = {MAX_ITER} sweeps, r0 = 0, min of {repeat}–{SICONOS_REPEAT} "
           f"calls on each side (repeating stops after {REPEAT_BUDGET:g} s of calls), "
           f"numba warm-up {compile_time:.2f} s (not included). Machine: 2 cores shared with "
           "other jobs, so timings carry noise.", "",
           "Time per sweep = solver time / sweeps (socp_cd: the whole `solve` call on a new "
           "problem object, balancing, block-storage build and Python overhead included; "
           "Siconos: the driver call, `.dat` files in their own storage, FCLib HDF5 problems "
           "in sparse-block storage). The headline uses CPU "
           "(process) time, which a loaded machine inflates much less than wall time; the "
           "wall-time ratio is given too. Ratios are ours / Siconos.", "",
           SETTINGS, ""]
    out += lines
    out.append("")
    for d in (3, 2):
        sel = [r for r in rows if r["dim"] == d and np.isfinite(r["cpu_sweep_ratio"])]
        if not sel:
            continue
        both = [r for r in sel if r["sic_status"] == "converged"]
        missed = [r["problem"] for r in both if r["status"] != "converged"]
        out.append(f"**{d}D** ({len(sel)} problems): median CPU time/sweep ratio "
                   f"{np.median([r['cpu_sweep_ratio'] for r in sel]):.2f} (wall "
                   f"{np.median([r['sweep_ratio'] for r in sel]):.2f}), median sweep-count ratio "
                   f"{np.median([r['iter_ratio'] for r in sel]):.2f} "
                   f"(max {max(r['iter_ratio'] for r in sel):.2f}); "
                   f"Siconos converged on {len(both)}, socp_cd converged on "
                   f"{sum(r['status'] == 'converged' for r in sel)}"
                   + (f"; socp_cd missed: {', '.join(missed)}" if missed else "") + ".")
        out.append("")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    sys.exit(main())

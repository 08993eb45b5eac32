"""What each piece of the De Saxcé fixed point buys (Clarabel inner solver).

Variants, run on every shared 3D problem (local and global) at tol 1e-8:

* ``plain``      — fixed inner tolerance ``min(1e-10, tol/100)``, no acceleration, no polish;
* ``+adaptive``  — inner tolerance follows the outer error (loose early, tight late);
* ``+anderson``  — Anderson acceleration (memory 5, safeguarded) of the shift;
* ``+anderson+adaptive`` — both;
* ``plain+polish`` — the semismooth-Newton polish on the natural map alone;
* ``+anderson+polish (default)`` — what ``solve(p, "clarabel")`` does;
* ``+anderson+adaptive+polish`` — everything.

Columns: outer iterations (SOCP solves), Clarabel interior-point iterations,
Newton polish steps (one sparse LU each), wall time, final Siconos error.

Usage::

    .venv/bin/python validation/desaxce_ablation.py

Writes ``validation/results/desaxce_ablation.csv`` and ``.md``.
"""
from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

from socp_cd.data import shared_problems_dir
from socp_cd.io import read_problem
from socp_cd.residuals import error
from socp_cd.solvers import solve

OUT = Path(__file__).resolve().parent / "results"
TOL = 1e-8
VARIANTS = {
    "plain": dict(accel=None, adaptive_tol=False, polish=None),
    "+adaptive": dict(accel=None, adaptive_tol=True, polish=None),
    "+anderson": dict(accel="anderson", adaptive_tol=False, polish=None),
    "+anderson+adaptive": dict(accel="anderson", adaptive_tol=True, polish=None),
    "plain+polish": dict(accel=None, adaptive_tol=False, polish="newton"),
    "+anderson+polish (default)": dict(accel="anderson", adaptive_tol=False, polish="newton"),
    "+anderson+adaptive+polish": dict(accel="anderson", adaptive_tol=True, polish="newton"),
}


def main():
    d = shared_problems_dir()
    if d is None:
        print("shared problems not found (set SOCP_CD_DATA)")
        return 1
    probs = []
    for f in sorted(x for x in d.iterdir() if x.suffix in (".dat", ".hdf5")):
        p = read_problem(f)
        if p.dim == 3:
            probs.append((f.name, p))
    solve(probs[0][1], "clarabel", "coulomb", tol=TOL)  # warm-up (imports)
    rows = []
    for name, p in probs:
        for var, opts in VARIANTS.items():
            res = solve(p, "clarabel", "coulomb", tol=TOL, max_iter=200, **opts)
            rows.append({"problem": name, "variant": var, "status": res.status,
                         "error": error(p, res.r), "outer_it": res.iterations,
                         "clarabel_it": res.info.get("inner_iterations", 0),
                         "polish_it": res.info.get("polish_iterations", 0), "time": res.time})
            r = rows[-1]
            print(f"{name[:40]:40s} {var:27s} {r['status']:10s} err={r['error']:.2e} "
                  f"outer={r['outer_it']:3d} ipm={r['clarabel_it']:5d} newton={r['polish_it']:3d} "
                  f"t={r['time']:.3f}", flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    cols = list(rows[0])
    with open(OUT / "desaxce_ablation.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, cols)
        w.writeheader()
        w.writerows(rows)
    lines = ["# De Saxcé fixed point: ablation (Clarabel inner solver)", "",
             f"{len(probs)} shared 3D problems (local and global), tol {TOL:g} on Siconos' error, "
             "max 200 outer iterations, stall after 8 outer iterations without 10 % gain. "
             "Totals over all problems; times on 2 shared cores.", "",
             "| variant | converged | outer it | Clarabel it | Newton steps | time s | "
             "median error | max error |", "|---|---|---|---|---|---|---|---|"]
    for var in VARIANTS:
        rs = [r for r in rows if r["variant"] == var]
        errs = np.array([r["error"] for r in rs])
        lines.append(f"| {var} | {sum(r['status'] == 'converged' for r in rs)}/{len(rs)} | "
                     f"{sum(r['outer_it'] for r in rs)} | {sum(r['clarabel_it'] for r in rs)} | "
                     f"{sum(r['polish_it'] for r in rs)} | {sum(r['time'] for r in rs):.2f} | "
                     f"{np.median(errs):.1e} | {errs.max():.1e} |")
    lines += ["", "Per problem (error / outer it / time s):", "",
              "| problem | " + " | ".join(VARIANTS) + " |", "|---|" + "---|" * len(VARIANTS)]
    for name, _ in probs:
        cells = []
        for var in VARIANTS:
            r = next(x for x in rows if x["problem"] == name and x["variant"] == var)
            cells.append(f"{r['error']:.0e} / {r['outer_it']} / {r['time']:.2f}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    (OUT / "desaxce_ablation.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[:12]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

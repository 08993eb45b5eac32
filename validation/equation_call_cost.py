"""Per-call time of ``solver="newton"`` with each equation of the law on small problems.

Session 36 moved the natural map and Fischer–Burmeister's equation into the compiled loops
(they ran the Python loop before).  This script times ``socp_cd.solve(p, "newton",
equation=...)`` on the small shared local problems (global ones condensed by the solver)
and on manufactured ones, JIT warmed, min over repeats, and writes a Markdown table::

    python validation/equation_call_cost.py --out results/equation_call_cost_s36.md

Run it once per checkout (that checkout first on ``PYTHONPATH``) with ``--json``, then
``--merge BEFORE AFTER --out ...`` puts the two side by side.  Every call passes ``equation``,
so every call takes the dispatcher's general path (~47 µs on one contact, against ~12 µs for
``solve(p, "newton")`` without options, its compiled route): the ratios compare the
equations on the same path.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.generators import manufactured
from socp_cd.data import shared_problems

EQUATIONS = ("alart_curnier", "natural_map", "fischer_burmeister")
SHARED = ["FrictionContact3D_1c.dat", "Rover11035.dat", "FC3D_Example1.dat", "Rover1039.dat",
          "Confeti-ex13-4contact-Fc3D-SBM.dat", "Rover3865.dat", "NESpheres_10_1.dat",
          "OneObject-i1028-138.hdf5.dat"]


def problems():
    by_file = {s.file: s.path for s in shared_problems()}
    out = [(name, socp_cd.read_problem(by_file[name])) for name in SHARED if name in by_file]
    for nc, mu in ((5, 0.3), (20, 0.5), (30, 1.0)):
        out.append((f"manufactured 3D {nc} contacts mu {mu:g}", manufactured(nc, 3, mu, seed=nc)))
    return out


def per_call(p, equation, repeats, budget=0.2):
    """Min over ``repeats`` of the mean time of a batch of calls (batch ~``budget`` s)."""
    res = socp_cd.solve(p, "newton", equation=equation)
    t = time.perf_counter()
    socp_cd.solve(p, "newton", equation=equation)
    one = max(time.perf_counter() - t, 1e-7)
    n = max(1, int(budget / one))
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(n):
            socp_cd.solve(p, "newton", equation=equation)
        best = min(best, (time.perf_counter() - t) / n)
    return best, res.status, res.error


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", type=Path, help="write the raw times here")
    ap.add_argument("--merge", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                    help="two --json files: write the before/after table")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    if a.merge:
        before, after = (json.loads(f.read_text()) for f in a.merge)
        lines = ["# Per-call time of `solver=\"newton\"` by equation, before and after session 36",
                 "", "`python validation/equation_call_cost.py` with each checkout (min over "
                 "repeats of batches, JIT warmed, µs per call; ratio = the equation over "
                 "Alart–Curnier's in the same run). Before: the natural map and FB on the "
                 "Python loop; after: on the compiled loops.", "",
                 "| problem | AC before | AC after | NM before (ratio) | NM after (ratio) | "
                 "FB before (ratio) | FB after (ratio) |", "|---|---:|---:|---:|---:|---:|---:|"]
        for name in after:
            b, f = before[name], after[name]
            cells = [f"{b['alart_curnier'][0] * 1e6:.1f}", f"{f['alart_curnier'][0] * 1e6:.1f}"]
            for eq in EQUATIONS[1:]:
                for side in (b, f):
                    cells.append(f"{side[eq][0] * 1e6:.1f} (×{side[eq][0] / side['alart_curnier'][0]:.2f})")
            lines.append(f"| {name} | " + " | ".join(cells) + " |")
        a.out.write_text("\n".join(lines) + "\n")
        print("\n".join(lines))
        return 0
    socp_cd.warmup()
    rows = {}
    for name, p in problems():
        rows[name] = {eq: per_call(p, eq, a.repeats) for eq in EQUATIONS}
        print(name, {eq: f"{v[0] * 1e6:.1f} us {v[1]}" for eq, v in rows[name].items()}, flush=True)
    if a.json:
        a.json.write_text(json.dumps(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

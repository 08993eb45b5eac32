"""Per-call time of ``solver="newton"`` with each equation of the law on small problems.

Session 36 moved the natural map and Fischer–Burmeister's equation into the compiled loops
(they ran the Python loop before).  This script times ``socp_cd.solve(p, "newton",
equation=...)`` on the small shared local problems (global ones condensed by the solver)
and on manufactured ones, JIT warmed, min over repeats, and writes a Markdown table::

    python validation/equation_call_cost.py --out results/equation_call_cost_s36.md

Run it once per checkout (that checkout first on ``PYTHONPATH``) with ``--json``, then
``--merge BEFORE AFTER --out ...`` puts the two side by side.  ``--ab OTHER_CHECKOUT``
times Alart–Curnier's calls only, without options (the compiled route) and with
``equation="alart_curnier"`` (the general path), in processes alternating between the other
checkout and this one (``--rounds``), min over rounds::

    python validation/equation_call_cost.py --ab /path/to/before --out results/equation_call_cost_ab_s36.md
  Every call passes ``equation``,
so every call takes the dispatcher's general path (~47 µs on one contact, against ~12 µs for
``solve(p, "newton")`` without options, its compiled route): the ratios compare the
equations on the same path.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
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


def ac_only(repeats):
    """``{problem: (route time, general-path time)}`` of Alart–Curnier's calls."""
    out = {}
    for name, p in problems():
        best = [np.inf, np.inf]
        for k, kw in enumerate(({}, {"equation": "alart_curnier"})):
            socp_cd.solve(p, "newton", **kw)
            n = max(1, int(0.2 / max(_one(p, kw), 1e-7)))
            for _ in range(repeats):
                t = time.perf_counter()
                for _ in range(n):
                    socp_cd.solve(p, "newton", **kw)
                best[k] = min(best[k], (time.perf_counter() - t) / n)
        out[name] = best
    return out


def _one(p, kw):
    t = time.perf_counter()
    socp_cd.solve(p, "newton", **kw)
    return time.perf_counter() - t


def ab(other, rounds, out_path):
    """Alternate processes between ``other`` (before) and this checkout (after)."""
    here = str(Path(__file__).resolve().parents[1])
    best = {"before": {}, "after": {}}
    for _ in range(rounds):
        for side, root in (("before", str(other)), ("after", here)):
            with tempfile.NamedTemporaryFile(suffix=".json") as tmp:
                env = dict(os.environ, PYTHONPATH=root)
                subprocess.run([sys.executable, str(Path(__file__).resolve()), "--ac-only",
                                "--json", tmp.name], env=env, check=True, cwd=tempfile.gettempdir())
                got = json.loads(Path(tmp.name).read_text())
            for name, times in got.items():
                prev = best[side].get(name, [np.inf, np.inf])
                best[side][name] = [min(a, b) for a, b in zip(prev, times)]
    lines = ["# Alart–Curnier's per-call time before and after session 36's compiled equations",
             "", f"`python validation/equation_call_cost.py --ab ... --rounds {rounds}`: "
             "processes alternating between the two checkouts, min over rounds of the min over "
             "repeats of batches, JIT warmed; µs per call.", "",
             "| problem | no options: before | after | ratio | `equation=` given: before | "
             "after | ratio |", "|---|---:|---:|---:|---:|---:|---:|"]
    for name in best["after"]:
        if name not in best["before"]:
            continue
        b, a = best["before"][name], best["after"][name]
        lines.append(f"| {name} | {b[0] * 1e6:.1f} | {a[0] * 1e6:.1f} | ×{a[0] / b[0]:.2f} | "
                     f"{b[1] * 1e6:.1f} | {a[1] * 1e6:.1f} | ×{a[1] / b[1]:.2f} |")
    out_path.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", type=Path, help="write the raw times here")
    ap.add_argument("--merge", nargs=2, type=Path, metavar=("BEFORE", "AFTER"),
                    help="two --json files: write the before/after table")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--ab", type=Path, metavar="OTHER_CHECKOUT")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--ac-only", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.ab:
        ab(a.ab, a.rounds, a.out)
        return 0
    if a.ac_only:
        socp_cd.warmup()
        a.json.write_text(json.dumps(ac_only(a.repeats)))
        return 0
    if a.merge:
        before, after = (json.loads(f.read_text()) for f in a.merge)
        lines = ["# Per-call time of `solver=\"newton\"` by equation, before and after session 36",
                 "", "`python validation/equation_call_cost.py` with each checkout (min over "
                 "repeats of batches, JIT warmed, µs per call; ratio = the equation over "
                 "Alart–Curnier's in the same run). Before: the natural map and FB on the "
                 "Python loop; after: on the compiled loops.", "",
                 "| problem | AC before | AC after | NM before (ratio) | NM after (ratio) | "
                 "FB before (ratio) | FB after (ratio) |", "|---|---:|---:|---:|---:|---:|---:|"]
        for name in [n for n in after if n in before]:
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

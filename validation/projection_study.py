"""The projection method against NSGS and ``auto``, and what Siconos' projection solvers' wins are.

Siconos' ``EG`` and ``FPP`` (projection methods with a self-adaptive step) were
the fastest Siconos solvers on the PerioBox family in ``newton_vs_siconos.py``
(1.6 ms where ``auto`` took 24-417 ms).  This study asks whether our projection
method (``solver="projection"``, ``formulations/projection.md``) would serve
``auto`` there:

1. our ``projection``, ``nsgs`` and ``auto`` on shared/ (3D and 2D local, at most
   ``--max-contacts``) and a random sample of ``--n-eval`` evaluation-set cases of
   ``--split`` (no parameter of the method was tuned: its constants are the
   literature's), tol 1e-8, ``--time-limit`` per call, min of 3 wall times (one run
   above 0.05 s), JIT warmed; solved = ``converged`` (the dispatcher's recomputed
   error and units guard);
2. from ``validation/results/newton_vs_siconos.csv`` (no Siconos run here): how many
   of each Siconos solver's "solved" answers (Siconos' error <= tol) fail the units
   guard (the residual relative to the velocity scale, which ``converged`` also
   requires), and the guard values of its answers on PerioBox.

Usage::

    .venv/bin/python validation/projection_study.py [--split holdout] [--n-eval 60]

Writes ``validation/results/projection_study.{csv,md}``.
"""
from __future__ import annotations

import argparse
import csv
import math
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.reports import shifted_geometric_mean
from socp_cd.solvers import newton, nsgs, projection

from auto_probe import items, min_wall_time

OUT = Path(__file__).resolve().parent / "results"
SOLVERS = ("projection", "nsgs", "auto")
SICONOS = ("siconos:eg", "siconos:fpp", "siconos:vi_eg", "siconos:vi_fpp", "siconos:prox",
           "siconos:nsgs", "siconos:nsn_ac", "siconos:nsn_fb")


def problems(args):
    shared = [x for x in items("tune", args.max_contacts, 0, sets=("shared",))]
    cases = items(args.split, args.max_contacts, 0, sets=("eval",))
    rng = np.random.default_rng(args.seed)
    pick = sorted(rng.choice(len(cases), min(args.n_eval, len(cases)), replace=False))
    return [("shared",) + x[1:] for x in shared] + [(args.split,) + cases[i][1:] for i in pick]


def run(args):
    projection.warmup()
    nsgs.warmup()
    newton.warmup()
    rows = []
    for group, name, p in problems(args):
        for s in SOLVERS:
            t, res = min_wall_time(p, lambda x, s=s: socp_cd.solve(
                x, solver=s, tol=args.tol, time_limit=args.time_limit), 3)
            rows.append(dict(group=group, problem=name, nc=p.n_contacts, dim=p.dim, solver=s,
                             status=res.status, error=res.error, iterations=res.iterations,
                             time=t))
        print(name[-50:], p.n_contacts, " ".join(
            f"{r['solver']}:{r['status'][:4]}:{r['time']:.1e}" for r in rows[-3:]), flush=True)
    return rows


def siconos_guard_table(path, tol):
    """``{solver: (claimed solved, of which the guard also <= tol)}`` and the PerioBox rows."""
    counts, perio = defaultdict(lambda: [0, 0]), []
    if not path.exists():
        return counts, perio
    for r in csv.DictReader(open(path)):
        if r["side"] != "siconos" or r["solver"] not in SICONOS or float(r["tol"]) != tol \
                or r["kind"] != "local3" or r["status"] != "ok":
            continue
        try:
            e, g = float(r["error"]), float(r["guard"])
        except ValueError:
            continue
        if e <= tol:
            counts[r["solver"]][0] += 1
            counts[r["solver"]][1] += g <= tol
            if "PerioBox" in r["problem"] and r["solver"] in ("siconos:eg", "siconos:fpp",
                                                               "siconos:prox"):
                perio.append((r["problem"].split("/")[-1], r["solver"], e, g, float(r["time"])))
    return counts, perio


def write(rows, args):
    OUT.mkdir(exist_ok=True)
    with open(OUT / "projection_study.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    table = defaultdict(dict)
    for r in rows:
        table[(r["group"], r["problem"])][r["solver"]] = r
    lines = ["# The projection method against NSGS and auto (`validation/projection_study.py`)", "",
             f"tol {args.tol:g}, time limit {args.time_limit:g} s a call, min of 3 wall times; "
             f"shared/ local problems of at most {args.max_contacts} contacts and {args.n_eval} "
             f"random `{args.split}` cases of the evaluation set.  Solved: `converged` (the "
             "dispatcher's recomputed error and units guard).", "",
             "| group | problems | solver | solved | sgm (1 ms shift) over all | fastest of the three |",
             "|---|---|---|---|---|---|"]
    for group in sorted({g for g, _ in table}):
        keys = [k for k in table if k[0] == group]
        for s in SOLVERS:
            ts = [table[k][s]["time"] if table[k][s]["status"] == "converged" else 10 * args.time_limit
                  for k in keys]
            fastest = sum(1 for k in keys if table[k][s]["status"] == "converged" and all(
                table[k][s]["time"] <= (table[k][o]["time"] if table[k][o]["status"] == "converged"
                                        else math.inf) for o in SOLVERS))
            solved = sum(table[k][s]["status"] == "converged" for k in keys)
            lines.append(f"| {group} | {len(keys)} | {s} | {solved} | "
                         f"{shifted_geometric_mean(ts, 1e-3):.2e} s | {fastest} |")
    lines += ["", "Where `projection` beats `auto` (both solved):", ""]
    wins = [(k, table[k]) for k in table if table[k]["projection"]["status"] == "converged" and (
        table[k]["auto"]["status"] != "converged"
        or table[k]["projection"]["time"] < table[k]["auto"]["time"])]
    for k, d in wins:
        lines.append(f"- {k[1]} ({d['auto']['nc']} contacts): projection "
                     f"{d['projection']['time']:.2e} s, auto {d['auto']['time']:.2e} s "
                     f"({d['auto']['status']})")
    if not wins:
        lines.append("- none")
    counts, perio = siconos_guard_table(OUT / "newton_vs_siconos.csv", args.tol)
    lines += ["", "## Siconos' solved answers under the units guard",
              "", "From `newton_vs_siconos.csv` (3D local, tol 1e-8): answers with Siconos' error "
              "<= tol, and how many of them also have the units guard <= tol (the residual over "
              "the velocity scale `max(||q||, ||u||)`; Siconos' error also divides by `||r||`, "
              "which dominates where W's diagonal is small, e.g. 1e-5 on PerioBox).", "",
              "| Siconos solver | solved by its error | of which guard <= tol |", "|---|---|---|"]
    for s in SICONOS:
        if s in counts:
            lines.append(f"| {s} | {counts[s][0]} | {counts[s][1]} |")
    lines += ["", "PerioBox family (Siconos' error, units guard, time):", ""]
    for name, s, e, g, t in perio:
        lines.append(f"- {name} {s}: error {e:.1e}, guard {g:.1e}, {t * 1e3:.2f} ms")
    (OUT / "projection_study.md").write_text("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", default="holdout", choices=("tune", "holdout"))
    ap.add_argument("--n-eval", type=int, default=60)
    ap.add_argument("--max-contacts", type=int, default=400)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    write(run(args), args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

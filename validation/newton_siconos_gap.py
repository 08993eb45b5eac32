"""Where Siconos' plain semismooth Newton (NSN_AC) solves and our ``newton`` / ``auto`` do not.

A diagnosis set of its own (issue #10): exact solutions manufactured
(:func:`socp_cd.bench.evalset.manufacture`) on the real operators of the
rank-deficient 3D local files of ``shared/`` (Capsules, the LMGC rock box,
Kapla tower, box stack, OneObject), seeds 100..139, never used before.  Seed
``s`` takes the mix ``MIXES[s % 4]`` and ``mu = MUS[s % 5]`` (``MUS`` = 0.1, 0.3,
0.5, 1, 2), so each block of 20 consecutive seeds holds every (mix, mu) pair
once per file.  Seeds 100..119 (``--part diag``) were looked at to diagnose and
choose; seeds 120..139 (``--part final``) were run once, at the end.

For each case: our solvers (``socp_cd.solve``; ``newton`` variants by option,
``auto``) and Siconos 4.4 NSN_AC, NSN_FB and PROX (one worker process, each task
killed past its time limit), tol 1e-8.  Solved = recomputed
``socp_cd.error <= tol`` *and* the units guard of ``socp_cd.solve``
(:func:`socp_cd.solvers.checks.coulomb_guard`, the error in balanced units)
``<= tol``: on a rank-deficient ``W`` the impulses ``r`` are not unique and a
Newton method can run off along the null space of ``W``, where Siconos'
error, divided by ``max(||q||, ||r||, ||u||)``, becomes small with ``||r||``
huge and ``u`` wrong.  ``u_err`` = ``||u - u*|| / ||u*||`` (``u`` is unique).  One run per call on a shared 2-core machine: times
are indicative (shifted geometric mean, 10 ms shift, unsolved = 2 x limit).

Usage::

    NUMBA_NUM_THREADS=1 .venv/bin/python validation/newton_siconos_gap.py --part diag
    NUMBA_NUM_THREADS=1 .venv/bin/python validation/newton_siconos_gap.py --part final
    ... --ours newton newton:plain --no-siconos     # re-run ours, keep Siconos' csv
    ... --report-only

Writes ``validation/results/newton_siconos_gap_<part>.csv`` (ours),
``newton_siconos_gap_<part>_siconos.csv`` and regenerates
``validation/results/newton_siconos_gap.md`` from the csv files present.
"""
from __future__ import annotations

import argparse
import csv
import math
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.evalset import MIXES, manufacture
from socp_cd.bench import reports
from socp_cd.bench.reports import shifted_geometric_mean
from socp_cd.data import shared_problems_dir

OUT = Path(__file__).resolve().parent / "results"
#: rank-deficient 3D local files of shared/ (``p.summary()["rank_deficient"]``)
FILES = ("Capsules-i122-1617.dat", "Capsules-i125-1213.hdf5",
         "LMGC_100_PR_PerioBox-i00361-60-03000.hdf5", "KaplasTower-i1061-4.hdf5.dat",
         "BoxesStack1-i100000-32.hdf5.dat", "OneObject-i1028-138.hdf5.dat")
MUS = (0.1, 0.3, 0.5, 1.0, 2.0)
PARTS = {"diag": range(100, 120), "final": range(120, 140)}
#: our solver variants: label -> (solver, options)
VARIANTS = {
    "newton": ("newton", {}),
    "newton:hybrid": ("newton", {"policy": "hybrid"}),
    "newton:plain": ("newton", {"policy": "plain"}),
    "auto": ("auto", {}),
}
SICONOS = ("nsn_ac", "nsn_fb", "prox")
FIELDS = ("part", "case", "file", "nc", "mu", "mix", "seed", "solver", "error", "guard", "u_err",
          "solved", "time", "status", "iterations", "path")


def judge(p, r, tol):
    """``(error, guard, u_err, solved)`` of impulses ``r`` (see the module docstring)."""
    from socp_cd.bench.evalset import exact_error
    from socp_cd.solvers.checks import coulomb_guard
    r = np.asarray(r, dtype=np.float64).reshape(-1)
    if r.shape != (p.m,) or not np.all(np.isfinite(r)):
        return math.inf, math.inf, math.inf, False
    err = float(socp_cd.error(p, r))
    g = float(coulomb_guard(p, r, p.velocity(r))["value"])
    return err, g, exact_error(p, r), bool(err <= tol and g <= tol)


def cases(part, files=FILES):
    """``(case_id, file, mu, mix, seed, problem)`` of one part."""
    from socp_cd.io import read_problem
    mixes = list(MIXES)
    data = Path(shared_problems_dir())
    for name in files:
        base = read_problem(data / name)
        for seed in PARTS[part]:
            mix, mu = mixes[seed % len(mixes)], MUS[seed % len(MUS)]
            p = manufacture(base, mu, MIXES[mix], seed)
            cid = f"gap/{name}/mu{mu:g}-{mix}-s{seed}"
            p.name = cid
            yield cid, name, mu, mix, seed, p


def run_ours(part, items, labels, tol, time_limit, tag=""):
    warm = min(items, key=lambda t: t[5].n_contacts)[5]
    for lab in labels:
        solver, opts = VARIANTS[lab]
        socp_cd.solve(warm, solver, tol=1e-4, **opts)
    rows = []
    for cid, name, mu, mix, seed, p in items:
        for lab in labels:
            solver, opts = VARIANTS[lab]
            t0 = time.perf_counter()
            res = socp_cd.solve(p, solver, tol=tol, time_limit=time_limit, **opts)
            dt = time.perf_counter() - t0
            err, g, uerr, ok = judge(p, res.r, tol)
            path = ";".join(f"{x['method']}:{x['error']:.1e}:{x['time']:.2f}"
                            for x in res.info.get("path", []))
            rows.append(dict(part=part, case=cid, file=name, nc=p.n_contacts, mu=mu, mix=mix,
                             seed=seed, solver=lab + tag, error=err, guard=g, u_err=uerr, solved=ok,
                            time=dt,
                             status=res.status, iterations=res.iterations, path=path))
        print(cid, " ".join(f"{r['solver']}:{r['error']:.0e}/{r['time']:.2f}s"
                            for r in rows if r["case"] == cid), flush=True)
    return rows


def run_siconos(part, items, tol, time_limit, max_iter):
    from socp_cd.bench.siconos_peer import siconos_batch
    tasks, keys = [], []
    for it in items:
        for s in SICONOS:
            tasks.append({"task": "solve", "problem": it[5], "solver": s, "tol": tol,
                          "max_iter": max_iter, "time_limit": time_limit})
            keys.append((it, s))
    rows = []
    for (it, s), r in zip(keys, siconos_batch(tasks)):
        cid, name, mu, mix, seed, p = it
        err = g = uerr = math.inf
        ok = False
        if r.get("status") == "ok" and r.get("r") is not None:
            err, g, uerr, ok = judge(p, r["r"], tol)
        t = float(r.get("time") or math.inf) if r.get("status") == "ok" else math.inf
        rows.append(dict(part=part, case=cid, file=name, nc=p.n_contacts, mu=mu, mix=mix,
                         seed=seed, solver=f"siconos:{s}", error=err, guard=g, u_err=uerr,
                         solved=ok,
                         time=t, status=r.get("status"), iterations=r.get("iterations"),
                         path=""))
    return rows


def write_csv(path, rows, merge_key=("case", "solver")):
    """Write ``rows``, keeping rows of other (case, solver) pairs already in the file."""
    old = read_csv(path) if path.exists() else []
    new = {tuple(r[k] for k in merge_key) for r in rows}
    kept = [r for r in old if tuple(r[k] for k in merge_key) not in new]
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(kept + rows)


def read_csv(path):
    return reports.read_rows(path, floats=("error", "guard", "u_err", "time"))


def part_lines(part, rows, tol, time_limit):
    by_solver = defaultdict(list)
    for r in rows:
        by_solver[r["solver"]].append(r)
    ncase = len({r["case"] for r in rows})
    lines = [f"## part `{part}` ({ncase} cases)", "",
             "| solver | solved | error <= tol, guard > tol | sgm time (s, unsolved = 2 x limit) "
             "| median error of unsolved |", "|---|---|---|---|---|"]
    for s in sorted(by_solver):
        rs = by_solver[s]
        t = [r["time"] if r["solved"] else 2 * time_limit for r in rs]
        bad = [r["error"] for r in rs if not r["solved"]]
        fooled = sum(r["error"] <= tol and not r["solved"] for r in rs)
        lines.append(f"| {s} | {sum(r['solved'] for r in rs)}/{len(rs)} | {fooled} | "
                     f"{shifted_geometric_mean(t, 0.01):.4f} | "
                     f"{(f'{np.median(bad):.1e}' if bad else '-')} |")
    solved_by = defaultdict(set)
    err = {}
    for r in rows:
        if r["solved"]:
            solved_by[r["case"]].add(r["solver"])
        err[(r["case"], r["solver"])] = r["error"]
    ours = sorted({r["solver"] for r in rows if not r["solver"].startswith("siconos:")})
    by_siconos = [cid for cid in sorted(solved_by)
                  if any(s.startswith("siconos:") for s in solved_by[cid])]
    lines += ["", f"Solved by at least one Siconos solver: {len(by_siconos)}; of those, not "
              "solved by: " + ", ".join(f"`{s}` {sum(s not in solved_by[c] for c in by_siconos)}"
                                        for s in ours) + ".", "",
              "Those `auto` does not solve (errors of ours; `-` = not run):", ""]
    lines += ["| case | " + " | ".join(ours) + " | Siconos solving |", "|---" * (len(ours) + 2) + "|"]
    gap = [cid for cid in by_siconos if "auto" not in solved_by[cid]]
    for cid in gap:
        sic = sorted(s for s in solved_by[cid] if s.startswith("siconos:"))
        cells = [f"{err[(cid, s)]:.1e}" if (cid, s) in err else "-" for s in ours]
        lines.append(f"| `{cid}` | " + " | ".join(cells) + " | " + ", ".join(sic) + " |")
    if not gap:
        lines.append("| none |" + " |" * (len(ours) + 1))
    return lines


def write_report(tol, time_limit):
    parts = ["# newton / auto vs Siconos' plain semismooth Newton (issue #10)", "",
             "Generated by `validation/newton_siconos_gap.py` (see its docstring): exact "
             "solutions manufactured on the rank-deficient 3D local operators of shared/, "
             f"seeds 100..119 (`diag`: diagnosis and choice) and 120..139 (`final`: run once), "
             f"tol {tol:g}, time limit {time_limit:g} s per call, Siconos max_iter 1000; one run "
             "per call on a shared 2-core machine (times indicative).", ""]
    for part in PARTS:
        ours = OUT / f"newton_siconos_gap_{part}.csv"
        sic = OUT / f"newton_siconos_gap_{part}_siconos.csv"
        rows = (read_csv(ours) if ours.exists() else []) + (read_csv(sic) if sic.exists() else [])
        if rows:
            parts += part_lines(part, rows, tol, time_limit) + [""]
    (OUT / "newton_siconos_gap.md").write_text("\n".join(parts))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--part", choices=tuple(PARTS), default="diag")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=3.0)
    ap.add_argument("--ours", nargs="*", default=["newton", "auto"], choices=tuple(VARIANTS))
    ap.add_argument("--no-siconos", action="store_true")
    ap.add_argument("--siconos-max-iter", type=int, default=1000)
    ap.add_argument("--files", nargs="*", default=list(FILES))
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--tag", default="",
                    help="suffix of our solver labels, e.g. '@before' for a run of the code "
                         "before this study (PYTHONPATH pointing at an export of it)")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    if not args.report_only:
        items = list(cases(args.part, args.files))
        print(f"{len(items)} cases", flush=True)
        if not args.no_siconos:
            rows = run_siconos(args.part, items, args.tol, args.time_limit, args.siconos_max_iter)
            write_csv(OUT / f"newton_siconos_gap_{args.part}_siconos.csv", rows)
            print("siconos done", flush=True)
        if args.ours:
            rows = run_ours(args.part, items, args.ours, args.tol, args.time_limit, args.tag)
            write_csv(OUT / f"newton_siconos_gap_{args.part}.csv", rows)
    write_report(args.tol, args.time_limit)
    print((OUT / "newton_siconos_gap.md").read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

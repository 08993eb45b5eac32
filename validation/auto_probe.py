"""``auto``'s NSGS probe on large local problems: how many sweeps (``auto.PROBE_SWEEPS``)?

Local exact-Coulomb problems with more than ``auto.SMALL_NC`` contacts used to
start with Newton.  Problems dumped from simulations are often solved by NSGS
in a few sweeps, where Newton's set-up and factorizations cost ten times
more; a short NSGS *probe* first costs little when it fails (its iterate is
handed to Newton).  This study runs ``auto`` with each probe length on:

``--split tune`` (where the value is chosen)
    the manufactured cases of the evaluation set's tune split and the shared
    problems with more than ``SMALL_NC`` contacts, and the simulation
    collections built for tuning (``build_sim_collections.py --tune``:
    other scenes than the benchmark's);
``--split holdout`` (run once, to report)
    the evaluation set's holdout cases of that size and the benchmark's
    simulation collections (``validation/evalset_sim``).

Every call solves a new problem object (a shallow copy of the problem as
read), tol 1e-8, ``--time-limit`` per call, min of ``--repeats`` wall times
(one run when a call takes over 0.5 s), JIT warmed.  No Siconos in this run:
it is an ablation of our own portfolio; ``newton_vs_siconos.py`` is the
benchmark against Siconos.

Usage::

    .venv/bin/python validation/auto_probe.py --split tune [--sweeps 0 10 30 100]

Writes ``validation/results/auto_probe_<split>.{csv,md}``.
"""
from __future__ import annotations

import argparse
import copy
import csv
import math
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.evalset import collection_cases, manufactured_cases, reframed_cases
from socp_cd.bench.reports import shifted_geometric_mean
from socp_cd.data import shared_problems_dir
from socp_cd.solvers import auto

HERE = Path(__file__).resolve().parent
OUT = HERE / "results"
SIMS = {"tune": [HERE / "evalset_sim_tune"], "holdout": [HERE / "evalset_sim"]}


def items(split, max_contacts, min_contacts, sets=("shared", "eval", "sim"), sims=None):
    data = Path(shared_problems_dir())
    out = []

    def keep(p):
        return (not p.is_global and min_contacts < p.n_contacts <= max_contacts
                and float(np.max(p.mu)) > 0.0)
    if split == "tune" and "shared" in sets:        # shared/ may be looked at while choosing
        for path in sorted(data.iterdir()):
            if path.name != "MANIFEST.tsv":
                p = socp_cd.read_problem(path)
                if keep(p):
                    out.append(("shared", path.name, p))
    evals = ((manufactured_cases(data, max_contacts=max_contacts) if "eval" in sets else [])
             + (reframed_cases(data, max_contacts=max_contacts) if "reframed" in sets else []))
    for c in evals:
        if c.split == split and not c.is_global and c.n_contacts > min_contacts:
            p = c.problem()
            if keep(p):
                out.append((c.family, c.case_id, p))
    for root in ((sims or SIMS[split]) if "sim" in sets else ()):
        for sub in sorted({q.parent for q in root.rglob("*.hdf5")}):
            for c in collection_cases(sub):
                p = c.problem()
                if keep(p):
                    out.append(("sim", c.case_id, p))
    return out


def min_wall_time(p, solve, repeats):
    """``(min wall time, last result)`` of ``solve(target)`` over ``repeats`` runs, each on a
    new problem object (a shallow copy of ``p``, made outside the timer); one run when a
    call takes over 0.5 s.  Every compiled kernel is loaded first (:func:`socp_cd.warmup`,
    once per process; since session 33: a call that reached a kernel first had its
    compilation, or its cache load, timed)."""
    socp_cd.warmup()
    best, res = math.inf, None
    for _ in range(repeats):
        target = copy.copy(p)
        t0 = time.perf_counter()
        res = solve(target)
        dt = time.perf_counter() - t0
        best = min(best, dt)
        if dt > 0.5:
            break
    return best, res


def record(fam, cid, p, tol, dt, res, **keys) -> dict:
    """One CSV row of an ``auto`` ablation: the case, ``keys`` (the variant), the recomputed
    error, solved (error and ``res.converged``), the time and ``auto``'s path."""
    err = float(socp_cd.error(p, res.r))
    path = ";".join(f"{x['method']}:{x['iterations']}:{x['error']:.1e}:{x['time']:.4f}"
                    for x in res.info.get("path", []))
    return dict(family=fam, case=cid, dim=p.dim, nc=p.n_contacts, **keys, error=err,
                solved=bool(err <= tol and res.converged), time=dt, path=path)


def size_groups(rows, tiny, small_nc) -> dict:
    """Rows grouped by ``(dim, size band, setting)``: bands ``"1–tiny"`` and
    ``"tiny+1–small_nc"`` contacts, the setting in the rows' ``sweeps`` key."""
    groups = defaultdict(list)
    for r in rows:
        band = f"1–{tiny}" if r["nc"] <= tiny else f"{tiny + 1}–{small_nc}"
        groups[(r["dim"], band, r["sweeps"])].append(r)
    return groups


def write_csv(rows, path) -> None:
    """``rows`` (dicts with the same keys) as a CSV file."""
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def timed_auto(setting, value, p, tol, time_limit, repeats):
    """:func:`min_wall_time` of ``auto`` with its module constant ``setting`` set to ``value``
    (the caller restores it)."""
    setattr(auto, setting, value)
    return min_wall_time(p, lambda t: socp_cd.solve(t, "auto", tol=tol, time_limit=time_limit),
                         repeats)


def sweep_study(its, setting, values, tol, time_limit, repeats_for, csv_path, to_setting=None):
    """Rows of ``auto`` on every item of ``its`` with ``auto.<setting>`` at each of ``values``.

    ``to_setting(value)`` is what the constant is set to (default: the value itself);
    ``repeats_for(problem)`` the runs timed.  JIT warmed on a one-contact problem first; the
    constant is restored; the rows (:func:`record`, key ``sweeps``) go to ``csv_path``.
    """
    convert = to_setting or (lambda v: v)
    default = getattr(auto, setting)
    warm = socp_cd.read_problem(Path(shared_problems_dir()) / "FrictionContact3D_1c.dat")
    rows = []
    try:
        for v in values:
            timed_auto(setting, convert(v), warm, 1e-4, None, 1)
        for fam, cid, p in its:
            for v in values:
                dt, res = timed_auto(setting, convert(v), p, tol, time_limit, repeats_for(p))
                rows.append(record(fam, cid, p, tol, dt, res, sweeps=v))
            print(cid, p.n_contacts, " ".join(f"{r['sweeps']}:{r['error']:.0e}/{r['time']:.4f}s"
                                              for r in rows if r["case"] == cid), flush=True)
    finally:
        setattr(auto, setting, default)
    OUT.mkdir(exist_ok=True)
    write_csv(rows, csv_path)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=("tune", "holdout"), required=True)
    ap.add_argument("--sweeps", type=int, nargs="+", default=[0, 10, 30, 100])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=5.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-contacts", type=int, default=6000)
    ap.add_argument("--sets", nargs="+", choices=("shared", "eval", "reframed", "sim"),
                    default=["shared", "eval", "sim"])
    ap.add_argument("--sim", type=Path, nargs="*", default=None,
                    help="simulation collection folders (default: the split's, see above)")
    ap.add_argument("--tag", default="", help="suffix of the output files")
    args = ap.parse_args(argv)
    its = items(args.split, args.max_contacts, auto.SMALL_NC, args.sets, args.sim)
    print(f"{len(its)} problems", flush=True)
    rows = sweep_study(its, "PROBE_SWEEPS", args.sweeps, args.tol, args.time_limit,
                       lambda p: args.repeats, OUT / f"auto_probe_{args.split}{args.tag}.csv")
    write_report(rows, args)
    return 0


def write_report(rows, args):
    groups = defaultdict(list)
    for r in rows:
        groups[("sim" if r["family"] == "sim" else "eval+shared", r["dim"], r["sweeps"])].append(r)
    lines = [f"# auto's NSGS probe on local problems of more than {auto.SMALL_NC} contacts, "
             f"split `{args.split}` (tol {args.tol:g})", "",
             f"Generated by `validation/auto_probe.py --split {args.split}`: `auto` with at most "
             "*sweeps* NSGS sweeps before Newton (0: no probe, Newton first); a new problem object "
             f"per call, time limit {args.time_limit:g} s, min of {args.repeats} runs (one when a "
             "call takes over 0.5 s); shared 2-core machine, no Siconos in the run.", "",
             "| set | dim | probe sweeps | cases | solved | sgm time (10 ms shift, s) | "
             "median time (s) | time ratio to no probe: median / max |",
             "|---|---|---|---|---|---|---|---|"]
    base = {(r["case"]): r["time"] for r in rows if r["sweeps"] == 0}
    for (fam, dim, s), rs in sorted(groups.items()):
        ratios = [r["time"] / base[r["case"]] for r in rs if r["case"] in base]
        solved = sum(r["solved"] for r in rs)
        rat = (f"{np.median(ratios):.2f} / {max(ratios):.2f}" if ratios else "–")
        lines.append(f"| {fam} | {dim} | {s} | {len(rs)} | {solved} | "
                     f"{shifted_geometric_mean([r['time'] for r in rs], 0.01):.4f} | "
                     f"{np.median([r['time'] for r in rs]):.4f} | {rat} |")
    lost = [(r["case"], r["sweeps"], r["error"]) for r in rows if not r["solved"]
            and any(q["solved"] for q in rows if q["case"] == r["case"] and q["sweeps"] == 0)]
    won = [(r["case"], r["sweeps"], r["error"]) for r in rows if r["solved"]
           and not any(q["solved"] for q in rows if q["case"] == r["case"] and q["sweeps"] == 0)]
    lines += ["", f"Solved without a probe, missed with one: {len(lost)}"]
    lines += [f"- {c} ({s} sweeps): {e:.1e}" for c, s, e in lost]
    lines += ["", f"Missed without a probe, solved with one: {len(won)}"]
    lines += [f"- {c} ({s} sweeps): {e:.1e}" for c, s, e in won]
    (OUT / f"auto_probe_{args.split}{args.tag}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    raise SystemExit(main())

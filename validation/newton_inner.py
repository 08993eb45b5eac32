"""When is a proximal subproblem *solved*?  The Newton method's inner test, old and new (issue #10).

The proximal-point Newton method (``solver="newton"``, ``formulations/newton.md`` §4)
ends an outer iteration when a full Newton step (``t = 1``) cut the subproblem's
residual ``||F_alpha||`` to at most ``INNER_GATE`` times the step's start and either to
at most ``INNER_DECREASE`` times or to an iterate that meets the outer tolerance.
The default is 0.1 and 1e-3 (a nearly exact subproblem, 2-3 Newton steps per outer
iteration); Siconos PROX asks its inner solver for a tenth of the outer error.  This
script runs ``solver="newton"`` with ``policy="prox"`` from ``r = 0`` (tol 1e-8, time
limit 5 s) under each setting on the local exact-Coulomb problems of a split
(``auto_probe.items``: the shared problems on ``tune`` only, the evaluation set's
manufactured and rescaled cases, the simulation collections) and reports per size band
the cases solved, the geometric mean of LU factorizations (+1, -1) and the shifted
geometric mean of the wall time (min of 3 on at most 50 contacts, else 1; a call over
0.5 s is not repeated).

Session 20 chose (0.5, 0.5) on ``--split tune`` (``evalset_sim_small_tune``: 4 more solved,
25-50 % fewer factorizations) and then ran ``--split holdout`` (``evalset_sim_small``) once:
there it won 10 and lost 18 of 394 cases, so the default stayed (0.1, 1e-3)
(``formulations/newton.md`` §4)::

    .venv/bin/python validation/newton_inner.py --split tune --sim evalset_sim_small_tune
    .venv/bin/python validation/newton_inner.py --split holdout --sim evalset_sim_small

``--fresh 4 5 6 7`` runs instead a draw no session had generated before: the manufactured
cases of those seeds on every real operator (both hash splits, no rescaled copies; seeds 0-3
are the evaluation set's), time limit ``--time-limit``; it writes ``newton_inner_fresh``.

Writes ``validation/results/newton_inner_<split>.{csv,md}``.
"""
from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import socp_cd
from socp_cd.bench.evalset import manufactured_cases
from socp_cd.bench.reports import shifted_geometric_mean
from socp_cd.data import shared_problems_dir
from socp_cd.solvers import newton

from auto_probe import items, min_wall_time, write_csv

HERE = Path(__file__).resolve().parent
OUT = HERE / "results"
#: (name, INNER_GATE, INNER_DECREASE)
SETTINGS = (("sessions 9-19 (0.1, 1e-3)", 0.1, 1e-3), ("session 20 (0.5, 0.5)", 0.5, 0.5),
            ("(0.3, 0.3)", 0.3, 0.3))
BANDS = ((1, 10), (11, 50), (51, 400), (401, 10 ** 9))


def band(nc):
    return next(f"{lo}–{hi}" if hi < 10 ** 9 else f"> {lo - 1}" for lo, hi in BANDS
                if nc <= hi)


def run_one(p, gate, decrease, repeats, time_limit=5.0):
    """:func:`auto_probe.min_wall_time` of proximal Newton under ``(gate, decrease)`` (the
    caller restores the module's constants)."""
    newton.INNER_GATE, newton.INNER_DECREASE = gate, decrease
    return min_wall_time(p, lambda t: socp_cd.solve(t, solver="newton", tol=1e-8,
                                                    time_limit=time_limit, policy="prox"),
                         repeats)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=("tune", "holdout"), required=True)
    ap.add_argument("--max-contacts", type=int, default=400)
    ap.add_argument("--sim", nargs="*", default=None)
    ap.add_argument("--fresh", nargs="*", type=int, default=None,
                    help="seeds of a fresh manufactured draw (replaces the split's problems)")
    ap.add_argument("--time-limit", type=float, default=5.0)
    args = ap.parse_args(argv)
    defaults = (newton.INNER_GATE, newton.INNER_DECREASE)
    newton.warmup()
    sims = [HERE / f for f in args.sim] if args.sim else None
    if args.fresh:
        its = [(c.family, c.case_id, c.problem()) for c in manufactured_cases(
                   shared_problems_dir(), seeds=args.fresh, scales=(),
                   max_contacts=args.max_contacts) if not c.is_global]
        its = [x for x in its if float(x[2].mu.max()) > 0.0]
        tag = "fresh"
    else:
        its = items(args.split, args.max_contacts, 0,
                    sets=("shared", "eval") + (("sim",) if sims else ()), sims=sims)
        tag = args.split
    print(f"{len(its)} problems", flush=True)
    rows = []
    try:
        for fam, cid, p in its:
            for name, gate, dec in SETTINGS:
                dt, res = run_one(p, gate, dec, 3 if p.n_contacts <= 50 else 1, args.time_limit)
                rows.append({"family": fam, "case": cid, "nc": p.n_contacts, "dim": p.dim,
                             "setting": name, "solved": bool(res.converged),
                             "error": float(res.error), "time": dt,
                             "iterations": res.iterations,
                             "factorizations": int(res.info.get("factorizations", 0))})
            print(cid, [(r["solved"], r["factorizations"]) for r in rows[-len(SETTINGS):]],
                  flush=True)
    finally:
        newton.INNER_GATE, newton.INNER_DECREASE = defaults
    OUT.mkdir(exist_ok=True)
    write_csv(rows, OUT / f"newton_inner_{tag}.csv")
    groups = defaultdict(list)
    for r in rows:
        groups[(r["dim"], band(r["nc"]), r["setting"])].append(r)
    order = {s[0]: i for i, s in enumerate(SETTINGS)}
    how = (f"--fresh {' '.join(map(str, args.fresh))}" if args.fresh
           else f"--split {args.split}")
    lines = [f"# Newton's proximal subproblem test, `{tag}`", "",
             f"Generated by `validation/newton_inner.py {how}` "
             "(`solver=\"newton\"`, `policy=\"prox\"`, from r = 0, tol 1e-8, time limit "
             f"{args.time_limit:g} s; settings `(INNER_GATE, INNER_DECREASE)`).", "",
             "| dim | contacts | setting | cases | solved | LU factorizations (geo. mean) | "
             "sgm time (0.1 ms shift, s) |", "|---|---|---|---|---|---|---|"]
    for (dim, b, s), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1],
                                                                   order[kv[0][2]])):
        geo = shifted_geometric_mean([r["factorizations"] for r in rs], 1.0)
        lines.append(f"| {dim} | {b} | {s} | {len(rs)} | {sum(r['solved'] for r in rs)} | "
                     f"{geo:.1f} | {shifted_geometric_mean([r['time'] for r in rs], 1e-4):.6f} |")
    by_case = defaultdict(dict)
    for r in rows:
        by_case[r["case"]][r["setting"]] = r
    old, new = SETTINGS[0][0], SETTINGS[1][0]
    lost = [c for c, d in by_case.items() if d[old]["solved"] and not d[new]["solved"]]
    won = [c for c, d in by_case.items() if d[new]["solved"] and not d[old]["solved"]]
    lines += ["", f"{new} against {old}: won {len(won)}, lost {len(lost)}."]
    lines += [f"- lost: {c} ({by_case[c][new]['error']:.1e})" for c in lost]
    lines += [f"- won: {c} (was {by_case[c][old]['error']:.1e})" for c in won]
    (OUT / f"newton_inner_{tag}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""``auto``'s NSGS hand-off on small local problems: when, and how long a Newton trial.

Local exact-Coulomb problems with at most ``auto.SMALL_NC`` contacts start
with NSGS.  Where NSGS converges slowly it ran all its 1 000 sweeps before
Newton started, while Siconos' dense Newton solvers finished the same
problems in a few steps (Rover1040 manufactured: 390 µs against 6.6 µs;
OneObject: 3.8 ms against 0.5 ms).  Session 8's sweep caps
(``auto_small_sweeps.py``) handed NSGS's iterate to the whole Newton chain and
ran NSGS again from the *best* iterate at the end: they lost PerioBox cases.
The hand-off (``formulations/auto.md``, "The hand-off") instead stops NSGS
after ``max(HANDOFF_SWEEPS, HANDOFF_WORK / nnz(W))`` sweeps, tries at most
``TRIAL_STEPS`` plain Newton steps from its iterate (stopped after
``TRIAL_STALL`` steps without a 10 % drop of the error), and when the trial
fails lets NSGS go on from *its own* iterate for the sweeps it has left, so
the trial is all a failed hand-off costs.

Session 12 added the rate prediction: NSGS hands over at the end of any window of
``HANDOFF_PREDICT`` sweeps after which the error's mean rate over the window
predicts that the cap will not reach ``tol`` (0: only at the cap).

This study runs ``auto`` with each setting ``--configs`` (``off`` or
``SWEEPS,STEPS,STALL[,WORK[,PREDICT]]``) on:

``--split tune`` (where the setting is chosen)
    shared/ and the evaluation set's tune cases of at most ``SMALL_NC`` contacts;
``--split holdout`` (run once, to report)
    the evaluation set's holdout cases of that size.

Every call solves a new problem object (a shallow copy, made outside the
timer), tol 1e-8, ``--time-limit`` per call, min of ``--repeats`` wall times
(``--repeats-small`` on at most 10 contacts; one run when a call takes over
0.5 s), JIT warmed.  No Siconos in this run: an ablation of our own portfolio
(``newton_vs_siconos.py`` is the benchmark against Siconos).

Usage::

    .venv/bin/python validation/auto_handoff.py --split tune [--configs off 100,10,3 200,6,2]

Writes ``validation/results/auto_handoff_<split>.{csv,md}``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from socp_cd.bench.reports import shifted_geometric_mean
from socp_cd.solvers import auto

from auto_probe import items, record, timed_auto, write_csv, size_groups

OUT = Path(__file__).resolve().parent / "results"
TINY = 10   #: contacts; problems this small are timed over ``--repeats-small`` runs
KNOBS = ("HANDOFF_SWEEPS", "TRIAL_STEPS", "TRIAL_STALL", "HANDOFF_WORK", "HANDOFF_PREDICT")


def parse(config: str):
    """``"off"`` -> ``(None, steps, stall, work, predict)`` of the defaults;
    ``"S,T,W[,WORK[,PREDICT]]"`` -> ints (``WORK``: ``HANDOFF_WORK``, ``PREDICT``:
    ``HANDOFF_PREDICT``, default the module's)."""
    if config == "off":
        return (None, auto.TRIAL_STEPS, auto.TRIAL_STALL, auto.HANDOFF_WORK, auto.HANDOFF_PREDICT)
    values = [int(x) for x in config.split(",")]
    defaults = (auto.HANDOFF_WORK, auto.HANDOFF_PREDICT)
    return tuple(values) + defaults[len(values) - 3:]


def run(its, configs, tol, time_limit, repeats_for):
    defaults = tuple(getattr(auto, k) for k in KNOBS)
    rows = []
    try:
        for fam, cid, p in its:
            for c in configs:
                values = parse(c)
                for k, v in zip(KNOBS[1:], values[1:]):
                    setattr(auto, k, v)
                dt, res = timed_auto("HANDOFF_SWEEPS", values[0], p, tol, time_limit,
                                     repeats_for(p))
                rows.append(record(fam, cid, p, tol, dt, res, sweeps=c))
            print(cid, p.n_contacts, " ".join(f"{r['sweeps']}:{r['error']:.0e}/{r['time']:.5f}s"
                                              for r in rows if r["case"] == cid), flush=True)
    finally:
        for k, v in zip(KNOBS, defaults):
            setattr(auto, k, v)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=("tune", "holdout"), required=True)
    ap.add_argument("--configs", nargs="+", default=["off", "100,10,3", "100,6,1", "200,6,1",
                                                     "200,6,2"])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--repeats-small", type=int, default=10)
    ap.add_argument("--tag", default="", help="suffix of the output files")
    ap.add_argument("--base", default="off",
                    help="the setting the time ratios and the solved/missed counts refer to")
    args = ap.parse_args(argv)
    if args.configs[0] != "off":
        args.configs = ["off"] + args.configs
    its = items(args.split, auto.SMALL_NC, 0)
    print(f"{len(its)} problems", flush=True)
    # JIT warm: every config once on a small problem
    run(its[:1], args.configs, 1e-4, None, lambda p: 1)
    rows = run(its, args.configs, args.tol, args.time_limit,
               lambda p: args.repeats_small if p.n_contacts <= TINY else args.repeats)
    OUT.mkdir(exist_ok=True)
    write_csv(rows, OUT / f"auto_handoff_{args.split}{args.tag}.csv")
    write_report(rows, args)
    return 0


def write_report(rows, args):
    groups = size_groups(rows, TINY, auto.SMALL_NC)
    lines = [f"# auto's NSGS hand-off on local problems of at most {auto.SMALL_NC} contacts, "
             f"split `{args.split}` (tol {args.tol:g})", "",
             f"Generated by `validation/auto_handoff.py --split {args.split}`: `auto` with each "
             "setting *SWEEPS,STEPS,STALL[,WORK[,PREDICT]]* (`auto.HANDOFF_SWEEPS`, `TRIAL_STEPS`, "
             f"`TRIAL_STALL`, `HANDOFF_WORK`, default {auto.HANDOFF_WORK}, `HANDOFF_PREDICT`, "
             f"default {auto.HANDOFF_PREDICT}; *off*: NSGS's 1 000 "
             "sweeps first, as before the hand-off); a new problem object per call, time limit "
             f"{args.time_limit:g} s, min of {args.repeats} runs ({args.repeats_small} on at most "
             f"{TINY} contacts; one when a call takes over 0.5 s); shared 2-core machine, no "
             "Siconos in the run.", "",
             "| dim | contacts | setting | cases | solved | sgm time (10 ms shift, s) | "
             f"sgm time (0.1 ms shift, s) | total time (s) | time ratio to {args.base}: median / "
             "min / max | "
             "cases > 1.2× / < 0.8× |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    base = {r["case"]: r["time"] for r in rows if r["sweeps"] == args.base}
    order = {c: i for i, c in enumerate(args.configs)}
    for (dim, sz, s), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1],
                                                                     order[kv[0][2]])):
        ratios = [r["time"] / base[r["case"]] for r in rs if r["case"] in base]
        lines.append(f"| {dim} | {sz} | {s} | {len(rs)} | {sum(r['solved'] for r in rs)} | "
                     f"{shifted_geometric_mean([r['time'] for r in rs], 0.01):.5f} | "
                     f"{shifted_geometric_mean([r['time'] for r in rs], 1e-4):.6f} | "
                     f"{sum(r['time'] for r in rs):.3f} | {np.median(ratios):.2f} / "
                     f"{min(ratios):.2f} / {max(ratios):.2f} | "
                     f"{sum(x > 1.2 for x in ratios)} / {sum(x < 0.8 for x in ratios)} |")
    for s in [c for c in args.configs if c != args.base]:
        lost = [r for r in rows if r["sweeps"] == s and not r["solved"]
                and any(q["solved"] for q in rows if q["case"] == r["case"]
                        and q["sweeps"] == args.base)]
        won = [r for r in rows if r["sweeps"] == s and r["solved"]
               and not any(q["solved"] for q in rows if q["case"] == r["case"]
                           and q["sweeps"] == args.base)]
        ranked = sorted((r["time"] / base[r["case"]], r["case"], r["time"]) for r in rows
                        if r["sweeps"] == s and r["case"] in base)
        lines += ["", f"**{s}**: solved by {args.base}, missed with it: {len(lost)}"
                  + "".join(f"; {r['case']} ({r['error']:.1e})" for r in lost)
                  + f". Missed by {args.base}, solved with it: {len(won)}"
                  + "".join(f"; {r['case']}" for r in won)
                  + ". Largest slow-downs: " + ", ".join(f"{c} ×{x:.2f} ({t * 1e3:.2f} ms)"
                                                         for x, c, t in reversed(ranked[-3:]))
                  + ". Largest speed-ups: " + ", ".join(f"{c} ×{x:.2f} ({t * 1e3:.2f} ms)"
                                                        for x, c, t in ranked[:3])]
    (OUT / f"auto_handoff_{args.split}{args.tag}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    raise SystemExit(main())

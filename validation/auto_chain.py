"""``auto``'s chain after NSGS hands over: three rules, each switched on and off (issue #10).

Session 13's rules (tune split: only the first adopted; ``socp_cd.solvers.auto``, ``formulations/auto.md`` "After the hand-off"):

``RETRY_REFUSED``
    a stage whose answer meets ``tol`` by the stages' measure and not by the units guard
    runs once more from it, aiming at the tightened tolerance (what the dispatcher's retry
    does), instead of handing a refused answer to the next methods (BoxesStack1: the
    proximal Newton stage at 2.5e-9 refused, then plain Newton, plain Newton from zero and
    the fixed point ran: 106 ms; Newton again from its answer: 7 steps);
``FAR_NSGS_COLD`` (not adopted)
    on at most ``SMALL_NC`` contacts, Newton starts from ``r = 0`` with the cold proximal
    parameter when NSGS's stages end farther than ``WARM_MAX`` (the far-probe rule of the
    larger problems);
``REST_PREDICT`` (not adopted)
    ``nsgs_rest`` (NSGS going on after a failed trial) stops early when its rate predicts
    that its sweeps will not reach ``tol`` (a window of that many sweeps; 0: off);
``COLD_TRIAL_STEPS``, ``COLD_TRIAL_STALL``
    after the hand-off's first trial fails on a problem the compiled Newton loop takes
    (``m <= newton.COMPILED_LOOP_MAX_M``), plain Newton from ``r = 0`` (Siconos NSN_AC's
    method) for at most that many steps, stopped after that many without a 10 % drop
    (OneObject: plain Newton from zero 17 steps, 0.8 ms; the chain without it 6.2 ms).

``COLD_PROX_STEPS``
    after the cold trial fails too, the proximal Newton method from ``r = 0`` for at most
    that many outer iterations (box stacks with redundant contacts: plain Newton fails
    there, the proximal method converges in ~0.5 ms where the chain took 7-10 ms);
``NEWTON_STALL``
    the stall window of the proximal Newton stages (None: Newton's default, 50).

Session 14's:

``COLD_MAX_M``
    the cold trials run on problems of at most that many unknowns (session 13: 72, where the
    Newton loop is compiled; the held-out 8-box stacks, 30 contacts, m = 90, ran the rest of
    NSGS's 1000 sweeps after a failed trial: 12 ms where Newton alone took 2.5 ms);
``PREDICT_MAX_M``
    the hand-off's rate prediction on problems of at most that many unknowns (session 12: 72);
``MAX_ROUNDS``
    rounds after the order (``validation/auto_rounds.py`` measures them; here 0 in ``base``);
``COLD_ALPHA0``
    ``newton.COLD_ALPHA0``, the Newton method's relative proximal parameter when it starts
    from afar (the default of its ``alpha0`` option; ``auto``'s first Newton stage of larger
    problems and its proximal cold trial).

Session 15's:

``COMPILED_LOOP_MAX_M``
    ``newton.COMPILED_LOOP_MAX_M``: dense local systems of at most that many unknowns run
    the compiled Newton loop (session 13/14: 72, larger ones the Python loop with LAPACK
    through scipy; session 15: every dense system, LAPACK called from the compiled loop
    above 72 unknowns).
``ALT_ALPHA0``
    after the plain stages, the proximal Newton method once more from ``r = 0`` with this
    relative proximal parameter (``"newton_cold_alt"``; None: off).

Session 16's:

``HANDOFF_PREDICT``
    the hand-off's rate-prediction window (sweeps; 20 since session 12; tune: 10 not adopted);
``COMPILED_LU_MAX_ENVELOPE``
    ``newton.COMPILED_LU_MAX_ENVELOPE``: above 72 unknowns Newton's dense LU is the
    written-out one when the envelope of W's pattern fills at most this share of the lower
    triangle (-1: LAPACK above 72, session 15's rule; ``base`` keeps it).

Session 19's:

``TRIAL_STEPS``, ``TRIAL_STALL``
    the hand-off's first Newton trial (plain steps from NSGS's iterate): its step cap (6
    since session 12) and stall window (2); ``base`` keeps them.

Session 20's:

``INNER_GATE``, ``INNER_DECREASE``
    ``newton.INNER_GATE``, ``newton.INNER_DECREASE``: a proximal subproblem of the Newton
    method is solved by a full step that cut its residual to at most the gate times the
    step's start and to at most the decrease times (or met the outer tolerance); 0.1 and
    1e-3 (``base`` too).  0.5 and 0.5 measured in session 20, not adopted
    (``validation/newton_inner.py`` measures the method alone; ``formulations/newton.md`` §4).

Session 22's:

``COLD_PROX_FIRST``
    the hand-off's cold trials in the other order: the proximal method from ``r = 0`` first,
    then plain Newton from ``r = 0`` (False since session 13; tune: no case won or lost, sgm
    unchanged, not adopted: ``results/auto_chain_tune_s22prox.md``);
``MIN_SLOW_START``
    the fixed point does not start for the first time, after another stage, with less than
    this share of the time budget left (0 before session 22; 0.1 adopted:
    ``results/auto_chain_tune_s22slow{,01}.md``, held out ``auto_chain_holdout_s22slow.md``);
``STAGE_SHARE``
    the share of the time left a stage receives (0.5; 0.65 and 0.8 measured, not adopted:
    ``results/auto_chain_tune_s22share.md``).

Session 26's:

``PLAIN_STALL``, ``PLAIN_STALL_LARGE``, ``PLAIN_MAX_ITER``
    the plain Newton stages' stall window (50), the same outside the small local chain only
    (None: ``PLAIN_STALL``) and their step cap (200); 100 and 200 measured for the first two,
    not adopted (``results/auto_chain_tune_s26plain{,large}.md``, ``formulations/auto.md``);
``HANDOFF_SWEEPS``, ``HANDOFF_WORK``
    the hand-off's cap (200 sweeps, 32 000 entry visits); 50 / 8 000 measured with and without
    ``HANDOFF_PREDICT=10``, not adopted (``results/auto_chain_tune_s26handoff.md``).

Session 30's:

``COLD_PLAIN_STALL_LARGE``
    the stall window of ``newton_plain_cold`` alone outside the small local chain (None: as
    ``newton_plain``); 200 adopted (``results/auto_chain_{tune,holdout}_s30cold{1,10}.md``,
    with ``--sets eval reframed``: the ``real-reframed`` copies beside the manufactured cases).

Session 32's:

``SMALL_NC``
    local problems of at most this many contacts take the small chain (NSGS first, the
    hand-off); larger ones the NSGS probe and Newton (100 since session 5, chosen when Newton
    was Python's loop; 10 and 30 measured on 11-100 contacts: ``results/auto_chain_tune_s32smallnc.md``).

Session 33's:

``NEWTON_FIRST_BLOCKS``, ``NEWTON_FIRST_MIN_NC``, ``NEWTON_FIRST_STEPS``, ``NEWTON_FIRST_STALL``
    on local problems of more than that many and at most ``SMALL_NC`` contacts whose ``W``
    stores at least that many blocks per contact, the proximal Newton method first, capped at
    that many outer iterations and stopped after that many without a 10 % drop
    (``"newton_first"``), then the small chain as without it (None: off;
    ``results/auto_chain_tune_s33nfirst.md``; the held-out cases were not run).
``NSGS_OMEGA``, ``NSGS_RELAX_AFTER`` (commit f7562b4 only, reverted after it)
    the NSGS stages of the exact law over-relaxed (NSGS's ``omega``) after that many sweeps
    without it (its ``relax_after``; 1.0: off; ``results/auto_chain_tune_s33omega.md``;
    ``formulations/auto.md``, "Over-relaxed NSGS stages").

Session 41's: ``REDUNDANT_SHARE`` (``formulations/auto.md``, "Redundant contacts: the fixed
point first"; None: off).

Session 43's:

``REDUNDANT_RETRY``
    the stage a ``clarabel_first`` answer the units guard refuses runs next: ``clarabel`` (the
    fixed point once more, until session 43) or ``newton`` (adopted);
``ACCEPT_STOP``
    a Newton stage aiming at a tolerance tightened after a refusal stops at the first iterate
    the chain's judge accepts (adopted with ``REDUNDANT_RETRY=newton``;
    ``results/auto_chain_{tune_s43accept,holdout_s43adopt}.md``, ``formulations/auto.md``,
    "After a refused clarabel_first").

Session 44's:

``CLARABEL_RETRY``
    the same choice after an answer of the chain's own ``clarabel`` stage that the units guard
    refuses: ``clarabel`` (until session 44) or ``newton``.

Session 45's:

``PROBE_CAP``, ``PROBE_PREDICT``
    the NSGS probe of larger problems goes on past ``PROBE_SWEEPS`` up to ``PROBE_CAP``
    sweeps while NSGS's rate over the last ``PROBE_PREDICT`` sweeps predicts that the cap
    reaches ``tol`` (None: off, the probe's 30 sweeps); ``PROBE_MISS_COLD``: a probe that went
    on and missed counts as far (Newton starts afresh).

Session 46's:

``LEMKE_MAX_NC``
    2D local problems of at most this many contacts start with Lemke's method (None: off).

Session 48's:

``SMALL_CLARABEL_EARLY``
    the small local chain runs the Clarabel fixed point right after its first proximal
    Newton stage, before the plain and cold stages (False: after them; not adopted).

Session 50's:

``DRIFT_WINDOW``
    the proximal Newton stages stop after that many outer iterations in a row of null-space
    drift (newton's ``drift_window``), and the fixed point follows such a stop (None: off);
``DRIFT_ANY_SIZE``
    ... at any size (False: in the small local chain only);
``DRIFT_COLD``
    the fixed point after a drift stop starts from ``r = 0`` (False: from the seed).

Session 51's:

``RERUN_TIGHTER``
    a fixed point (``auto.COLD_STAGES``, exact Coulomb law) already run from the same start
    runs again, once, when its earlier answer met a looser stage tolerance than the tightened
    one (False: skipped); ``CLARABEL_RETRY=newton+clarabel`` (and ``REDUNDANT_RETRY``): the
    warm Newton stage, then the fixed point, after a refused fixed point's answer (on top of
    ``base``, where ``RERUN_TIGHTER`` is off, the second is skipped when the seed did not move);
``DRIFT_KEEP_WARM``
    after a drift stop, the order's own (warm) fixed point stays in its place besides the one
    moved next (False: moved).

Session 52's:

``EARLY_COLD_MAX_M``
    after an early hand-off whose trial failed, on problems of more than this many unknowns,
    the cold trials wait for ``nsgs_mid`` and its second trial (None: off); with
    ``PREDICT_MAX_M=150``.
``FP_COLD_AFTER_WARM``
    in the small local chain, a warm fixed point that missed ``tol`` is followed at once by
    the fixed point from ``r = 0`` (when that has not run; False: off).

Each ``--configs`` entry is ``base`` (every rule off: session 12's chain), ``all`` (the
module's defaults), ``now`` (the defaults except for the rules named after it, e.g.
``now,NEWTON_STALL=20``), ``NAME=VALUE[,NAME=VALUE...]`` applied on top of ``base``, or
``solver=NAME``: another solver of ``solve`` with its defaults (``auto``'s knobs as ``now``;
session 32: ``solver=newton`` beside ``now``).  Problems:
local exact-Coulomb problems (``--sets``: shared, eval, reframed) of at most ``--max-contacts``
contacts (and more than
``--min-contacts``: session 28 ran the large manufactured cases alone at 10 s), ``--split tune
(shared/ and the evaluation set's tune cases: where the rules were chosen) or ``holdout``
(run once, to report).  tol 1e-8, ``--time-limit`` per call, min of 3 wall times (10 on at
most 10 contacts; one above 0.5 s), a new problem object per call, JIT warmed.

Usage::

    .venv/bin/python validation/auto_chain.py --split tune [--configs base all RETRY_REFUSED=1]

Writes ``validation/results/auto_chain_<split><--tag>.{csv,md}``.
"""
from __future__ import annotations

import argparse
import csv
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.campaign import warm_up
from socp_cd.bench.evalset import case_split
from socp_cd.bench.reports import shifted_geometric_mean
from socp_cd.bench.tasks import SolverChoice
from socp_cd.solvers import auto, newton

from auto_probe import items, min_wall_time, record, write_csv

OUT = Path(__file__).resolve().parent / "results"
RULES = ("RETRY_REFUSED", "FAR_NSGS_COLD", "REST_PREDICT", "COLD_TRIAL_STEPS", "COLD_TRIAL_STALL",
         "NEWTON_STALL", "COLD_PROX_STEPS", "COLD_MAX_M", "PREDICT_MAX_M", "MAX_ROUNDS",
         "COLD_ALPHA0", "COMPILED_LOOP_MAX_M", "ALT_ALPHA0", "HANDOFF_PREDICT", "COMPILED_LU_MAX_ENVELOPE",
         "TRIAL_STEPS", "TRIAL_STALL", "INNER_GATE", "INNER_DECREASE", "COLD_PROX_FIRST",
         "MIN_SLOW_START", "STAGE_SHARE", "PLAIN_STALL", "PLAIN_STALL_LARGE", "PLAIN_MAX_ITER",
         "HANDOFF_SWEEPS", "HANDOFF_WORK", "COLD_PLAIN_STALL_LARGE", "COLD_SPLIT",
         "SEED_BY_GUARD", "TIGHTEN_FROM_SEED", "SMALL_NC", "NEWTON_FIRST_BLOCKS",
         "NEWTON_FIRST_MIN_NC", "NEWTON_FIRST_STEPS", "NEWTON_FIRST_STALL", "PROX_EARLY", "REDUNDANT_SHARE",
         "LAST_RESORT", "REDUNDANT_RETRY", "ACCEPT_STOP", "CLARABEL_RETRY", "PROBE_CAP",
         "PROBE_PREDICT", "PROBE_MISS_COLD", "LEMKE_MAX_NC", "SMALL_CLARABEL_EARLY",
         "DRIFT_WINDOW", "DRIFT_ANY_SIZE", "DRIFT_COLD", "RERUN_TIGHTER", "DRIFT_KEEP_WARM",
         "EARLY_COLD_MAX_M", "FP_COLD_AFTER_WARM")
#: rules that are constants of another module than auto's
MODULE_OF = {"COLD_ALPHA0": newton, "COMPILED_LOOP_MAX_M": newton,
             "COMPILED_LU_MAX_ENVELOPE": newton, "INNER_GATE": newton, "INNER_DECREASE": newton}
FLOATS = ("COLD_ALPHA0", "ALT_ALPHA0", "COMPILED_LU_MAX_ENVELOPE", "INNER_GATE", "INNER_DECREASE",
          "MIN_SLOW_START", "STAGE_SHARE", "REDUNDANT_SHARE")
BASE = {"RETRY_REFUSED": False, "FAR_NSGS_COLD": False, "REST_PREDICT": 0, "COLD_TRIAL_STEPS": 0,
        "COLD_TRIAL_STALL": 10, "NEWTON_STALL": None, "COLD_PROX_STEPS": 0,
        "COLD_MAX_M": 72, "PREDICT_MAX_M": 72, "MAX_ROUNDS": 0, "COLD_ALPHA0": 1.0,
        "COMPILED_LOOP_MAX_M": 72, "ALT_ALPHA0": None, "HANDOFF_PREDICT": 20,
        "COMPILED_LU_MAX_ENVELOPE": -1.0, "TRIAL_STEPS": 6, "TRIAL_STALL": 2,
        "INNER_GATE": 0.1, "INNER_DECREASE": 1e-3, "COLD_PROX_FIRST": False,
        "MIN_SLOW_START": 0.0, "STAGE_SHARE": 0.5, "PLAIN_STALL": 50, "PLAIN_STALL_LARGE": None,
        "PLAIN_MAX_ITER": 200, "HANDOFF_SWEEPS": 200, "HANDOFF_WORK": 32000,
        "COLD_PLAIN_STALL_LARGE": None, "COLD_SPLIT": False, "SEED_BY_GUARD": False, "TIGHTEN_FROM_SEED": False,
        "SMALL_NC": 100, "NEWTON_FIRST_BLOCKS": None, "NEWTON_FIRST_MIN_NC": 10,
        "NEWTON_FIRST_STEPS": 10, "NEWTON_FIRST_STALL": 2, "PROX_EARLY": False,
        "REDUNDANT_SHARE": None, "LAST_RESORT": False, "REDUNDANT_RETRY": "clarabel",
        "ACCEPT_STOP": False, "CLARABEL_RETRY": "clarabel", "PROBE_CAP": None,
        "PROBE_PREDICT": 15, "PROBE_MISS_COLD": False, "LEMKE_MAX_NC": None,
        "SMALL_CLARABEL_EARLY": False, "DRIFT_WINDOW": None,
        "DRIFT_ANY_SIZE": False, "DRIFT_COLD": False, "RERUN_TIGHTER": False,
        "DRIFT_KEEP_WARM": False, "EARLY_COLD_MAX_M": None,
        "FP_COLD_AFTER_WARM": False}
#: rules whose values are names
STRINGS = ("REDUNDANT_RETRY", "CLARABEL_RETRY")
INTS = ("TRIAL_STEPS", "TRIAL_STALL", "REST_PREDICT", "COLD_TRIAL_STEPS", "COLD_TRIAL_STALL", "NEWTON_STALL", "COLD_PROX_STEPS",
        "COLD_MAX_M", "PREDICT_MAX_M", "MAX_ROUNDS", "COMPILED_LOOP_MAX_M", "HANDOFF_PREDICT",
        "PLAIN_STALL", "PLAIN_STALL_LARGE", "PLAIN_MAX_ITER", "HANDOFF_SWEEPS", "HANDOFF_WORK",
        "COLD_PLAIN_STALL_LARGE", "SMALL_NC", "NEWTON_FIRST_BLOCKS", "NEWTON_FIRST_MIN_NC",
        "NEWTON_FIRST_STEPS", "NEWTON_FIRST_STALL", "PROBE_CAP", "PROBE_PREDICT", "LEMKE_MAX_NC",
        "DRIFT_WINDOW", "EARLY_COLD_MAX_M")
BANDS = ((1, 10), (11, 100), (101, 10 ** 9))


#: the module's defaults, read once at import (run() changes the module's values per setting)
DEFAULTS = {k: getattr(MODULE_OF.get(k, auto), k) for k in RULES}


def settings(config: str) -> dict:
    """The rules' values of a ``--configs`` entry."""
    if config == "all":
        return dict(DEFAULTS)
    out = dict(BASE)
    parts = config.split(",")
    if parts[0] == "now":
        out, parts = dict(DEFAULTS), parts[1:]
    if config != "base":
        for part in parts:
            name, value = part.split("=")
            if name not in RULES:
                raise SystemExit(f"unknown rule {name!r}; one of {RULES}")
            if name in STRINGS and value not in auto.REDUNDANT_RETRIES:
                raise SystemExit(f"{name} must be one of {auto.REDUNDANT_RETRIES}")
            out[name] = (None if value == "None" else value if name in STRINGS
                         else float(value) if name in FLOATS else int(value) if name in INTS
                         else bool(int(value)))
    return out


def run(its, configs, tol, time_limit, repeats_for):
    rows = []
    try:
        for fam, cid, p in its:
            for c in configs:
                solver = c[len("solver="):] if c.startswith("solver=") else "auto"
                for k, v in settings("now" if solver != "auto" else c).items():
                    setattr(MODULE_OF.get(k, auto), k, v)
                dt, res = min_wall_time(p, lambda t: socp_cd.solve(
                    t, solver, tol=tol, time_limit=time_limit), repeats_for(p))
                rows.append(record(fam, cid, p, tol, dt, res, config=c))
            print(cid[-50:], p.n_contacts, " ".join(
                f"{r['config']}:{'ok' if r['solved'] else '--'}/{r['time'] * 1e3:.2f}ms"
                for r in rows if r["case"] == cid), flush=True)
    finally:
        for k, v in DEFAULTS.items():
            setattr(MODULE_OF.get(k, auto), k, v)
    return rows


def band(nc):
    return next(f"{lo}–{hi}" if hi < 10 ** 9 else f"> {lo - 1}" for lo, hi in BANDS if nc <= hi)


def write_report(rows, args):
    base = {r["case"]: r for r in rows if r["config"] == args.configs[0]}
    groups = defaultdict(list)
    for r in rows:
        groups[(r["dim"], band(r["nc"]), r["config"])].append(r)
    order = {c: i for i, c in enumerate(args.configs)}
    lines = [f"# auto's chain after the hand-off: rules on and off, split `{args.split}` "
             f"(tol {args.tol:g})", "",
             f"Generated by `validation/auto_chain.py --split {args.split}` (rules: the module "
             f"docstring; `base` = all off, session 12's chain; `all` = the defaults "
             f"{DEFAULTS}). Local problems of at most "
             f"{args.max_contacts} contacts"
             + (f" and more than {args.min_contacts}" if args.min_contacts else "") +
             f", sets {' '.join(args.sets + (['sim: ' + ' '.join(args.sim)] if args.sim else []))}; a new problem object per call, time limit "
             f"{args.time_limit:g} s, min of 3 wall times (10 on at most 10 contacts, one above "
             "0.5 s); no Siconos in the run. Ratios are to the first setting."
             + ("" if not getattr(args, "from_csv", None) else
                " Reported again (`--from-csv`) from the rows of "
                + ", ".join(f"`{Path(c).name}`" for c in args.from_csv)
                + " whose case is in this split by the current rule (a `real-reframed` copy "
                "in its base case's split)."), "",
             "| dim | contacts | setting | cases | solved | sgm (10 ms shift, s) | "
             "sgm (0.1 ms shift, s) | total (s) | ratio median / min / max | > 1.2× / < 0.8× |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for (dim, b, c), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1],
                                                                   order[kv[0][2]])):
        ratios = [r["time"] / base[r["case"]]["time"] for r in rs]
        lines.append(f"| {dim} | {b} | {c} | {len(rs)} | {sum(r['solved'] for r in rs)} | "
                     f"{shifted_geometric_mean([r['time'] for r in rs], 0.01):.5f} | "
                     f"{shifted_geometric_mean([r['time'] for r in rs], 1e-4):.6f} | "
                     f"{sum(r['time'] for r in rs):.3f} | {np.median(ratios):.2f} / "
                     f"{min(ratios):.2f} / {max(ratios):.2f} | "
                     f"{sum(x > 1.2 for x in ratios)} / {sum(x < 0.8 for x in ratios)} |")
    for c in args.configs[1:]:
        mine = [r for r in rows if r["config"] == c]
        lost = [r for r in mine if not r["solved"] and base[r["case"]]["solved"]]
        won = [r for r in mine if r["solved"] and not base[r["case"]]["solved"]]
        ranked = sorted((r["time"] / base[r["case"]]["time"], r["case"], r["time"]) for r in mine)
        lines += ["", f"**{c}**: lost {len(lost)}" + "".join(
            f"; {r['case']} ({r['error']:.1e})" for r in lost) + f". Won {len(won)}" + "".join(
            f"; {r['case']}" for r in won) + ". Slowest: " + ", ".join(
            f"{n} ×{x:.2f} ({t * 1e3:.2f} ms)" for x, n, t in reversed(ranked[-4:]))
            + ". Fastest: " + ", ".join(f"{n} ×{x:.2f} ({t * 1e3:.2f} ms)"
                                        for x, n, t in ranked[:4])]
    path = OUT / f"auto_chain_{args.split}{args.tag}.md"
    path.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def rows_in_split(paths, split):
    """The rows of earlier CSVs of this script (``auto_chain_<split><tag>.csv``) whose case is in
    ``split`` now: shared problems in tune, simulation dumps in the split of the run they
    come from (the collections are built per split), evaluation-set cases by
    :func:`socp_cd.bench.evalset.case_split`; numbers and flags parsed."""
    rows = []
    for path in paths:
        ran = "tune" if Path(path).name.startswith("auto_chain_tune") else "holdout"
        with open(path, newline="") as fh:
            for r in csv.DictReader(fh):
                fam = r["family"]
                where = ("tune" if fam == "shared" else ran if fam == "sim"
                         else case_split(r["case"]))
                if where != split:
                    continue
                r.update(dim=int(r["dim"]), nc=int(r["nc"]), error=float(r["error"]),
                         time=float(r["time"]), solved=r["solved"] == "True")
                rows.append(r)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=("tune", "holdout"), required=True)
    ap.add_argument("--configs", nargs="+", default=["base", "RETRY_REFUSED=1",
                                                     "FAR_NSGS_COLD=1", "REST_PREDICT=20",
                                                     "all"])
    ap.add_argument("--max-contacts", type=int, default=400)
    ap.add_argument("--min-contacts", type=int, default=0,
                    help="only problems of more contacts than this (e.g. the large misses)")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--sets", nargs="+", default=["shared", "eval"])
    ap.add_argument("--sim", nargs="*", default=None,
                    help="simulation collections (folders under validation/) to add, e.g. "
                         "evalset_sim_small (validation/build_sim_collections.py --small)")
    ap.add_argument("--tag", default="", help="suffix of the output files")
    ap.add_argument("--dim", type=int, choices=(2, 3), default=None,
                    help="only problems of this dimension")
    ap.add_argument("--from-csv", nargs="+", type=Path, default=None,
                    help="no run: the rows of these CSVs (earlier runs of this script) whose "
                         "case is in --split by the evaluation set's current rule, reported "
                         "again (e.g. after a change of the split rule)")
    args = ap.parse_args(argv)
    if args.from_csv:
        rows = rows_in_split(args.from_csv, args.split)
        write_csv(rows, OUT / f"auto_chain_{args.split}{args.tag}.csv")
        write_report(rows, args)
        return 0
    socp_cd.warmup()
    sims = [Path(__file__).resolve().parent / f for f in args.sim] if args.sim else None
    its = items(args.split, args.max_contacts, args.min_contacts,
                sets=tuple(args.sets) + (("sim",) if sims else ()), sims=sims)
    if args.dim is not None:
        its = [it for it in its if it[2].dim == args.dim]
    print(f"{len(its)} problems", flush=True)
    for dim in (2, 3):      # every kernel and stage of auto loaded (the campaign's warm-up)
        warm_up(SolverChoice("auto", "coulomb"), dim)
    run(its[:2], args.configs, 1e-4, None, lambda p: 1)
    rows = run(its, args.configs, args.tol, args.time_limit,
               lambda p: 10 if p.n_contacts <= 10 else 3)
    OUT.mkdir(exist_ok=True)
    write_csv(rows, OUT / f"auto_chain_{args.split}{args.tag}.csv")
    write_report(rows, args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

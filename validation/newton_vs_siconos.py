"""Our solvers against every Siconos 4.4 solver, on shared/ and on problems nobody tuned on.

Problem sets (see :mod:`socp_cd.bench.evalset`):

``shared``
    The real problems of ``shared/data/problems``.
``eval``
    Exact solutions manufactured on the real operators of ``shared/`` and
    their ``q``/``(W, q)`` rescaled copies.  Each case is ``tune`` or
    ``holdout``; the tables report both, side by side, and the targets are
    judged on all of it.  ``--n-eval`` cases per kind are drawn (seeded).
``sim``
    FCLib collections dumped from socp_cd's own simulations (``--sim DIR``,
    every ``*.hdf5`` below it; see ``socp-cd simulate --fclib``).

Every solver's answer is judged by *our* recomputed Siconos error
(:func:`socp_cd.error`); a Siconos run that reports convergence (``info = 0``)
with a recomputed error above ``tol`` is counted as a failure and listed as a
*refuted claim*.

Timing: ours is the wall time of the whole ``socp_cd.solve`` call (argument
checks, the solve, the independent residual), JIT warmed, min over
``--repeats`` runs (``--repeats-small`` for problems of at most 10 contacts);
Siconos' is the driver call alone inside its worker (``time``), min over the
same number of calls made in one process from the same start (the worker's
``repeat``), so that neither side pays a cold first call; both sides stop
repeating once the calls have taken 0.05 s.  A local 3D problem is given to
Siconos with ``W`` dense (up to :data:`DENSE_MAX_M` unknowns) and in its
sparse-block storage, a local 2D one dense and sparse-block, each solver
credited with the better run (the CSV's ``path`` column says which).  Both sides have the
same per-problem ``--time-limit``: an answer counts as solved only when its time is within
it (:data:`BUDGET_SLACK` over it, for either side's stop granularity).  Siconos' worker
kills a task only at ``--time-limit`` plus 0.1 s per repeat (so that the repeats fit), and
until session 42 an answer of one Siconos call of 1.0–1.3 s counted as solved while our
side stopped at the limit; the report counts such runs.  The two sides run interleaved: the problems in chunks of
``--chunk`` (:func:`socp_cd.bench.schedule.interleaved`), each chunk by both sides before the
next, who goes first alternating, so that a slow or fast spell of the machine hits both
alike (until session 27 our side ran over every problem first and Siconos ~30 min later).

Usage::

    .venv/bin/python validation/newton_vs_siconos.py [--quick] [--tol 1e-8]
        [--ours auto newton clarabel nsgs] [--n-eval 80] [--max-contacts 700]
        [--sweep 1e-4 1e-6 1e-8 1e-10] [--sim DIR ...] [--time-limit 5]

Writes ``validation/results/newton_vs_siconos.{csv,md,json}`` and
``newton_vs_siconos_profile.png``.
"""
from __future__ import annotations

import argparse
import copy
import csv
import json
import math
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.evalset import collection_cases, manufactured_cases
from socp_cd.bench.reports import performance_profile, shifted_geometric_mean
from socp_cd.bench.schedule import CHUNK, interleaved
from socp_cd.bench.siconos_peer import SOLVERS as SICONOS_SOLVERS
from socp_cd.bench.siconos_peer import (REPEAT_BUDGET, REPEAT_SECOND_BELOW, family_of,
                                       siconos_available, siconos_batch)
from socp_cd.data import shared_problems_dir


OUT = Path(__file__).resolve().parent / "results"
SGM_SHIFT = 0.01
SMALL = 10          #: contacts; Siconos is repeated on problems this small
#: a local 3D problem goes to Siconos with W both dense (up to this many unknowns) and in
#: its 3x3 sparse-block storage (2D: see :func:`storages`), and each solver is credited with the better of the two
#: (solved first, then faster): the storage moves PROX / NSN_AC up to x40 on small
#: problems (dense fastest), PFP runs on sparse-block storage only, and CSparse (what a
#: problem shipped as arrays used to get, session 10 and before) was never the fastest
DENSE_MAX_M = 2000
#: an answer counts as solved when its time is at most ``time_limit * (1 + BUDGET_SLACK)``:
#: our stages check the clock between iterations (the latest converged answer of ours in
#: sessions 40–41's runs: 1.015 s at a 1 s limit), Siconos' worker between calls
BUDGET_SLACK = 0.02


def storages(item) -> tuple:
    """Siconos storages of ``W`` tried for ``item`` (None: the worker's default).

    Local 2D problems always go dense too (the only storage they had before session
    10; the benchmark's ``--max-contacts`` bounds them), and sparse-block (2x2
    blocks): Siconos' 2D NSGS ran 10x faster on it on FrictionContactProblem00237."""
    if item["kind"] == "local2":
        return ("dense", "sbm")
    if item["kind"] != "local3":
        return (None,)
    return ("dense", "sbm") if item["problem"].m <= DENSE_MAX_M else ("sbm",)


def better(a, b, tol) -> dict:
    """The Siconos record credited of two runs of one solver on one problem."""
    def key(r):
        ok = math.isfinite(r["error"]) and r["error"] <= tol
        return (0, r["time"]) if ok else (1, r["error"] if math.isfinite(r["error"]) else math.inf)
    return a if key(a) <= key(b) else b


def problem_set(args) -> list[dict]:
    """``[{"set", "id", "split", "kind", "nc", "problem"}]`` of the run."""
    data = shared_problems_dir()
    items = []
    sets = set(args.sets)
    for path in sorted(Path(data).iterdir()) if "shared" in sets else ():
        if path.name == "MANIFEST.tsv":
            continue
        p = socp_cd.read_problem(path)
        if p.n_contacts <= args.max_contacts:
            items.append(dict(set="shared", id=path.name, split="shared", kind=family_of(p),
                              nc=p.n_contacts, problem=p))
    rng = np.random.default_rng(args.seed)
    cases = manufactured_cases(data, max_contacts=args.max_contacts) if "eval" in sets else []
    by_kind = defaultdict(list)
    for c in cases:
        if c.is_global:
            by_kind["global3"].append(c)
        else:
            by_kind[f"local{c.dim}"].append(c)
    for kind, cs in sorted(by_kind.items()):
        n = min(len(cs), args.n_eval if kind == "local3" else max(args.n_eval // 3, 1))
        for i in sorted(rng.choice(len(cs), n, replace=False)):
            c = cs[i]
            items.append(dict(set="eval", id=c.case_id, split=c.split, kind=kind, nc=c.n_contacts,
                              problem=c.problem()))
    for folder in args.sim or ():
        tried = [Path(folder), Path(__file__).resolve().parent / folder]   # as given, under validation/
        found = [f for f in tried if f.is_dir() and any(f.rglob("*.hdf5"))]
        if not found:
            raise SystemExit(f"--sim {folder}: no FCLib collection in "
                             f"{' or '.join(map(str, tried))} (run "
                             "validation/build_sim_collections.py first)")
        folder = found[0]
        for sub in sorted({p.parent for p in folder.rglob("*.hdf5")}):
            for c in collection_cases(sub):
                if c.n_contacts <= args.max_contacts:
                    p = c.problem()
                    items.append(dict(set="sim", id=c.case_id, split="holdout", kind=family_of(p),
                                      nc=c.n_contacts, problem=p))
    return items


def run_ours(item, solver, tol, args) -> dict:
    """Min-of-repeats wall time of ``socp_cd.solve``; error of the last run.

    Each call gets a new problem object (a shallow copy of the problem as read,
    made outside the timer), as the Siconos worker builds a new problem per
    call: no per-problem cache (balanced copy, block storage) carries over from one call
    to the next (the problem as read is never solved itself: the warm-up solves copies).
    """
    p = item["problem"]
    best, res, spent = math.inf, None, 0.0
    for k in range(args.repeats_small if item["nc"] <= SMALL else args.repeats):
        if spent > REPEAT_BUDGET and res is not None and not (k == 1
                                                              and spent < REPEAT_SECOND_BELOW):
            break       # (the Siconos worker's rule, its second call included)
        target = copy.copy(p)
        t0 = time.perf_counter()
        try:
            res = socp_cd.solve(target, solver=solver, tol=tol, time_limit=args.time_limit)
        except socp_cd.UnsupportedError:
            return dict(error=math.inf, status="unsupported", time=math.inf, claimed=False,
                        guard=math.inf)
        best = min(best, time.perf_counter() - t0)
        spent += time.perf_counter() - t0
        if not res.converged:          # a failure is not repeated
            break
    return dict(error=float(res.error), status=res.status, time=best, claimed=bool(res.converged),
                guard=float(res.info["guard"]["value"]),      # what solve() judged
                path=";".join(f"{s['method']}:{s['error']:.1e}" for s in res.info.get("path", [])))


def calibration_call(number=500, loops=5) -> float:
    """The machine's speed for our side: the min over ``loops`` loops of ``number`` plain
    calls ``solve(copy, time_limit=1)`` on a manufactured one-contact problem whose ``r = 0``
    is not a solution (µs per call; garbage collection off during the loops), or nan when
    the call fails.  Read before each chunk of the main tolerance's interleaved passes
    (:func:`socp_cd.bench.schedule.interleaved`) and at their end: a reading that moves
    through the run shows a spell of the machine, which the interleaving makes both sides
    share."""
    try:
        from per_call_rounds import per_call_fresh      # (this folder: the same loop)
        from socp_cd.bench.generators import manufactured
        p = manufactured(1, 3, mu=0.5, seed=1)      # (seeds 0, 2: r = 0 solves them)
        for _ in range(200):
            socp_cd.solve(copy.copy(p), time_limit=1.0)
        return per_call_fresh(p, number, loops)
    except Exception:       # (a reading must never cost the run)
        return math.nan


def guard_value(p, r) -> float:
    """The units guard's value of ``r`` (:func:`socp_cd.guard`; ``inf`` when not finite)."""
    if r is None:
        return math.inf
    try:
        with np.errstate(all="ignore"):       # runaway answers (r ~ 1e13 and beyond) overflow
            v = float(socp_cd.guard(p, np.asarray(r, dtype=np.float64))["value"])
    except (socp_cd.SocpCdError, ValueError):  # r not finite, or of the wrong shape
        return math.inf
    return v if math.isfinite(v) else math.inf


def run_siconos(items, solvers_for, tol, args) -> dict:
    """``(item index, solver) -> record`` for every Siconos solver of each item's kind."""
    tasks, keys = [], []
    for k, it in enumerate(items):
        reps = args.repeats_small if it["nc"] <= SMALL else args.repeats
        for s in solvers_for(it["kind"]):
            for storage in storages(it):
                tasks.append({"task": "solve", "problem": it["problem"], "solver": s, "tol": tol,
                              "max_iter": args.siconos_max_iter,
                              "time_limit": args.time_limit + min(0.1 * reps, 2.0),
                              "repeat": reps, "storage": storage})
                keys.append((k, s, storage))
    out: dict = {}
    results = siconos_batch(tasks, timeout=None) if tasks else []
    for (k, s, storage), r in zip(keys, results):
        p = items[k]["problem"]
        err = grd = math.inf
        if r.get("status") == "ok" and r.get("r") is not None:
            rr = np.asarray(r["r"], dtype=np.float64)
            if rr.shape == (p.m,) and np.all(np.isfinite(rr)):
                err = float(socp_cd.error(p, rr))
                grd = guard_value(p, rr)
        claimed = r.get("status") == "ok" and r.get("info") == 0
        t = float(r.get("time") or math.inf) if r.get("status") == "ok" else math.inf
        rec = dict(error=err, status=r.get("status"), time=t, claimed=claimed, guard=grd,
                   path="" if storage is None else f"storage={storage}")
        out[(k, s)] = rec if (k, s) not in out else better(out[(k, s)], rec, tol)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--ours", nargs="+", default=["auto", "newton", "clarabel", "nsgs"])
    ap.add_argument("--siconos", nargs="*", default=None,
                    help="Siconos solver names (default: all of each kind)")
    ap.add_argument("--sets", nargs="+", choices=("shared", "eval", "sim"),
                    default=["shared", "eval", "sim"], help="problem sets of the run (default: all)")
    ap.add_argument("--n-eval", type=int, default=80, help="generated cases drawn (3D local; a third per other kind)")
    ap.add_argument("--max-contacts", type=int, default=700)
    ap.add_argument("--sweep", type=float, nargs="*", default=[1e-4, 1e-6, 1e-10],
                    help="extra tolerances run for ours and Siconos prox/nsn_ac/nsn_fb/nsgs")
    ap.add_argument("--sim", nargs="*", default=None, help="folders of FCLib collections")
    ap.add_argument("--time-limit", type=float, default=None,
                    help="seconds per problem and solver (default 5; with --from-csv the run's, "
                         "read from the JSON beside the CSV)")
    ap.add_argument("--siconos-max-iter", type=int, default=100000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--repeats-small", type=int, default=200,
                    help="repeats on problems of at most SMALL contacts, both sides (stopped after "
                         "REPEAT_BUDGET s of calls): a min of 20 calls of ~20 µs was still 2-3x off "
                         "the min of 2 000")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--chunk", type=int, default=CHUNK,
                    help="problems per chunk of the interleaved passes (each chunk: both sides, "
                         "who goes first alternating)")
    ap.add_argument("--quick", action="store_true", help="a few problems, for a smoke run")
    ap.add_argument("--out", type=Path, default=OUT)
    ap.add_argument("--from-csv", type=Path, default=None,
                    help="rewrite the report and figure from a previous run's CSV (no solving)")
    ap.add_argument("--siconos-from", type=Path, default=None,
                    help="run ours only and judge them against the Siconos rows at --tol of a "
                         "previous run's CSV (the same problems: another tree of ours against "
                         "one Siconos run on the same machine)")
    args = ap.parse_args(argv)
    if args.chunk < 1:
        ap.error(f"--chunk must be at least 1, got {args.chunk}")
    if args.from_csv is not None:
        # the run's summary beside its CSV, read once: the budget its answers are judged
        # against (the run's own) and its calibration readings (the rewritten report keeps them)
        try:
            sibling = json.loads(Path(args.from_csv).with_suffix(".json").read_text())
        except (OSError, ValueError):
            sibling = {}
        sibling = sibling if isinstance(sibling, dict) else {}
        cal = sibling.get("calibration_us")
        cal = cal if isinstance(cal, dict) else {}
        args.calibration = {k: float(v) for k, v in cal.items()
                            if isinstance(v, (int, float))} or None
        if args.time_limit is None:
            try:
                args.time_limit = float(sibling["time_limit"])
            except (KeyError, ValueError, TypeError):
                ap.error("--from-csv: the run's time limit is not recorded beside the CSV (runs "
                         "before session 42, or no readable JSON summary there): give it with "
                         "--time-limit")
    if args.time_limit is None:
        args.time_limit = 5.0
    if args.from_csv is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        write(read_rows(args.from_csv), args, have_sic=True)
        return 0
    if args.quick:
        args.n_eval, args.max_contacts, args.sweep, args.repeats = 6, 60, [], 1
        args.repeats_small = 3
    have_sic = siconos_available() if args.siconos_from is None else False
    items = problem_set(args)
    print(f"{len(items)} problems; Siconos {'available' if have_sic else 'NOT available'}", flush=True)

    # warm every JIT once on a small problem of each kind, and every compiled kernel on tiny
    # problems (socp_cd.warmup; auto reaches the plain loop only when its first Newton
    # stage misses tol: session 11's first run timed its compilation, 3.3 s, on CubeH8)
    socp_cd.warmup()
    for kind in ("local3", "local2", "global3"):
        it = next((i for i in items if i["kind"] == kind), None)
        if it is not None:
            for s in args.ours:
                try:
                    socp_cd.solve(copy.copy(it["problem"]), solver=s, tol=1e-4)   # its caches stay off
                except socp_cd.UnsupportedError:
                    pass

    rows = []
    tols = [args.tol] + [t for t in args.sweep if t != args.tol]
    args.calibration = {}

    def ours(tol, part):
        for k in part:
            it = items[k]
            for s in args.ours:
                rec = run_ours(it, s, tol, args)
                rows.append(dict(tol=tol, set=it["set"], split=it["split"], kind=it["kind"],
                                 problem=it["id"], nc=it["nc"], solver=s, side="ours", **rec))

    def theirs(tol, part):
        if tol == args.tol:
            pick = (lambda kind: args.siconos if args.siconos else SICONOS_SOLVERS[kind])
        else:
            strong = {"local3": ("prox", "nsn_ac", "nsn_fb", "nsgs"), "local2": ("nsgs", "lemke"),
                      "global3": ("prox_wr", "nsgs_wr", "nsn_ac")}
            pick = (lambda kind: strong[kind])
        sub = [items[k] for k in part]
        sic = run_siconos(sub, lambda kind: [s for s in pick(kind) if s in SICONOS_SOLVERS[kind]],
                          tol, args)
        for (j, s), rec in sic.items():
            it = sub[j]
            rows.append(dict(tol=tol, set=it["set"], split=it["split"], kind=it["kind"],
                             problem=it["id"], nc=it["nc"], solver=f"siconos:{s}", side="siconos",
                             **rec))

    for tol in tols:
        t0 = time.time()
        for c, (part, first) in enumerate(interleaved(len(items), args.chunk)):
            if tol == args.tol:
                args.calibration[f"chunk {c} (problems {part[0]}-{part[-1]})"] = calibration_call()
            sides = (ours, theirs) if have_sic else (ours,)
            for side in (sides if first == "ours" else sides[::-1]):     # (first: "peer")
                side(tol, part)
        if tol == args.tol:
            args.calibration["end"] = calibration_call()
        print(f"tol {tol:g} done in {time.time() - t0:.0f} s", flush=True)
    if args.siconos_from is not None:
        ids = {(it["set"], it["id"]) for it in items}
        rows += [r for r in read_rows(args.siconos_from) if r["side"] == "siconos"
                 and r["tol"] == args.tol and (r["set"], r["problem"]) in ids]
        have_sic = True
    args.out.mkdir(parents=True, exist_ok=True)
    write(rows, args, have_sic)
    return 0


def read_rows(path) -> list[dict]:
    """The rows of a previous run's CSV, typed as :func:`write` expects."""
    rows = []
    with open(path, newline="") as fh:
        for r in csv.DictReader(fh):
            r["tol"], r["nc"] = float(r["tol"]), int(r["nc"])
            r["error"], r["time"] = float(r["error"]), float(r["time"])
            r["claimed"] = r["claimed"] == "True"
            r["guard"] = float(r["guard"]) if r.get("guard") not in (None, "") else math.nan
            rows.append(r)
    return rows


def within_tol(r, tol) -> bool:
    """``r``'s recomputed error within ``tol`` (whatever its time)."""
    return math.isfinite(r["error"]) and r["error"] <= tol


def solved(r, tol, time_limit=math.inf) -> bool:
    """:func:`within_tol`, in a time within ``time_limit`` (with :data:`BUDGET_SLACK`)."""
    return within_tol(r, tol) and (time_limit == math.inf
                                   or r["time"] <= time_limit * (1.0 + BUDGET_SLACK))


def past_budget(r, tol, time_limit) -> bool:
    """Within ``tol`` but not in the budget: not :func:`solved`."""
    return within_tol(r, tol) and not solved(r, tol, time_limit)


def guarded(r, tol) -> bool:
    """The units guard's value within ``tol`` (unknown, as in older CSVs: False)."""
    g = r.get("guard", math.nan)
    return isinstance(g, float) and math.isfinite(g) and g <= tol


def rho_table(table, solvers, ksum, key) -> list[str]:
    """Markdown rows of ρ(1, 2, 4, 10) of each of ours against all Siconos solvers in ``table``
    (``problem -> solver -> time``, ``inf`` a failure); stored in ``ksum[solver][key]``."""
    taus = np.array([1.0, 2.0, 4.0, 10.0])
    lines = ["| solver | ρ(1) | ρ(2) | ρ(4) | ρ(10) |", "|---|---|---|---|---|"]
    for s in [s for s in solvers if not s.startswith("siconos:")]:
        sub = {pr: {k: v for k, v in row.items() if k == s or k.startswith("siconos:")}
               for pr, row in table.items()}
        _, rho = performance_profile(sub, taus)
        lines.append(f"| {s} | " + " | ".join(f"{x:.2f}" for x in rho[s]) + " |")
        ksum[s][key] = dict(zip(map(str, taus), map(float, rho[s])))
    return lines


#: contact-count classes of the ρ-by-size table: where the per-call cost decides, the
#: mid-size problems, the large ones
SIZE_CLASSES = ((1, 10), (11, 100), (101, 10 ** 9))


def size_rho_lines(table, kind_rows, solvers) -> list[str]:
    """Markdown: ρ(1, 2, 4, 10) of each of ours against all Siconos solvers, per class of
    :data:`SIZE_CLASSES` (the problems of ``table`` whose contact count falls in it)."""
    nc = {(r["set"], r["split"], r["problem"]): int(r["nc"]) for r in kind_rows}
    lines = ["", "Dolan–Moré ρ(τ) as above, by problem size (contacts):", "",
             "| contacts | problems | " + " | ".join(
                 f"{s} ρ(1) / ρ(2) / ρ(4) / ρ(10)" for s in solvers
                 if not s.startswith("siconos:")) + " |",
             "|---|---|" + "---|" * sum(not s.startswith("siconos:") for s in solvers)]
    taus = np.array([1.0, 2.0, 4.0, 10.0])
    for lo, hi in SIZE_CLASSES:
        sub_table = {pr: row for pr, row in table.items() if lo <= nc[pr] <= hi}
        if not sub_table:
            continue
        cells = []
        for s in [s for s in solvers if not s.startswith("siconos:")]:
            sub = {pr: {k: v for k, v in row.items() if k == s or k.startswith("siconos:")}
                   for pr, row in sub_table.items()}
            _, rho = performance_profile(sub, taus)
            cells.append(" / ".join(f"{x:.2f}" for x in rho[s]))
        label = f"{lo}–{hi}" if hi < 10 ** 9 else f"> {lo - 1}"
        lines.append(f"| {label} | {len(sub_table)} | " + " | ".join(cells) + " |")
    return lines


def write(rows, args, have_sic) -> None:
    """CSV of every run, markdown report, JSON summary and profile figure."""
    stem = args.out / "newton_vs_siconos"
    keys = ["tol", "set", "split", "kind", "problem", "nc", "solver", "side", "error", "guard", "status",
            "claimed", "time", "path"]
    with open(stem.with_suffix(".csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow(r)
    tol, lim = args.tol, args.time_limit
    main_rows = [r for r in rows if r["tol"] == tol]
    lines = [f"# Our solvers vs every Siconos 4.4 solver (tol {tol:g})", "",
             f"Generated by `validation/newton_vs_siconos.py` ({'quick' if args.quick else 'full'} run; "
             f"time limit {args.time_limit:g} s per problem and solver; both sides min of {args.repeats} "
             f"calls, {args.repeats_small} on problems of at most {SMALL} contacts, stopped after "
             f"{REPEAT_BUDGET:g} s of calls; "
             "errors recomputed by `socp_cd.error`; a local 3D problem goes to Siconos with W dense "
             f"(up to {DENSE_MAX_M} unknowns) and in sparse-block storage, a local 2D one dense and "
             "sparse-block, each solver credited with the better run). Sets: `shared` = the real problems; `eval` = exact "
             "solutions manufactured on their operators (tune / holdout split by a hash of the case id; "
             "no parameter was chosen on holdout cases); `sim` = problems dumped from our simulations.", ""]
    if getattr(args, "from_csv", None) is not None:
        lines[-2] += (f" Rewritten from `{Path(args.from_csv).name}` with `--from-csv`: the time "
                      "limit and repeats above are the arguments of that command, which should "
                      "repeat the run's.")
    cal = getattr(args, "calibration", None)    # (--from-csv: the run's readings, main)
    if cal:
        lines[-2] += (" Calibration (the machine's speed on our side, `calibration_call`: a "
                      "one-contact `solve`, µs, read before each chunk of the main tolerance's "
                      "interleaved passes; a "
                      "Siconos side taken from another run with `--siconos-from` is not "
                      "covered): " + ", ".join(f"{k} {v:.2f}" for k, v in cal.items()) + ".")
    summary = {"tol": tol, "time_limit": lim, "kinds": {}, "calibration_us": cal or {}}
    has_guard = any(isinstance(r.get("guard"), float) and not math.isnan(r["guard"]) for r in rows)
    for kind in ("local3", "local2", "global3"):
        kr = [r for r in main_rows if r["kind"] == kind]
        if not kr:
            continue
        probs = sorted({(r["set"], r["split"], r["problem"]) for r in kr})
        solvers = sorted({r["solver"] for r in kr}, key=lambda s: (s.startswith("siconos"), s))
        groups = sorted({(s, sp) for s, sp, _ in probs})
        lines += [f"## {kind}: solved at {tol:g}", "",
                  "| solver | " + " | ".join(f"{s}/{sp} ({sum(1 for x in probs if x[:2] == (s, sp))})"
                                             for s, sp in groups)
                  + " | all | of these, guard too | SGM time [s] | refuted claims |",
                  "|---|" + "---|" * (len(groups) + 4)]
        table = defaultdict(dict)
        for r in kr:
            table[(r["set"], r["split"], r["problem"])][r["solver"]] = r["time"] if solved(r, tol, lim) else math.inf
        ksum = {}
        for s in solvers:
            cells = []
            for g in groups:
                n_ok = sum(1 for r in kr if r["solver"] == s and (r["set"], r["split"]) == g and solved(r, tol, lim))
                cells.append(str(n_ok))
            rs = [r for r in kr if r["solver"] == s]
            n_all = sum(solved(r, tol, lim) for r in rs)
            times = [table[pr].get(s, math.inf) for pr in probs]
            charged = [t if math.isfinite(t) else args.time_limit for t in times]
            sgm = shifted_geometric_mean(charged, SGM_SHIFT)
            refuted = sum(1 for r in rs if r["claimed"] and not within_tol(r, tol))
            n_guard = sum(solved(r, tol, lim) and guarded(r, tol) for r in rs)
            lines.append(f"| {s} | " + " | ".join(cells)
                         + f" | {n_all}/{len(probs)} | {n_guard if has_guard else '–'} | {sgm:.4f} "
                         f"| {refuted} |")
            ksum[s] = dict(solved=n_all, solved_guard_too=n_guard, problems=len(probs), sgm=sgm,
                           refuted=refuted)
        lines += ["", f"*Solved*: Siconos' error (recomputed) within tol, in at most the time limit "
                  f"plus {BUDGET_SLACK:.0%}, the criterion of every column but two (*refuted "
                  "claims*: by the error alone). *Guard too*: also the units guard (`socp_cd.guard`: the same residual in "
                  "balanced units over the velocity scale), which `socp_cd.solve` requires before it "
                  "reports `converged`; our solvers stop only when both hold, Siconos' when its own "
                  "error does (so their times are not for the same accuracy where the guard is "
                  "stricter, on rank-deficient problems with large `r`)."]
        # any-Siconos coverage and what ours miss
        sic = [s for s in solvers if s.startswith("siconos:")]
        if sic:
            any_sic = {pr for pr in probs if any(math.isfinite(table[pr].get(s, math.inf)) for s in sic)}
            lines += ["", f"Solved by at least one Siconos solver: {len(any_sic)}/{len(probs)}."]
            late = [r for r in kr if past_budget(r, tol, lim)]
            if late:
                lines.append(
                    f"Within tol but past the budget ({lim:g} s + {BUDGET_SLACK:.0%}), so not counted: "
                    + ", ".join(f"{r['solver']} on {r['problem']} ({r['time']:.2f} s)"
                                for r in sorted(late, key=lambda r: (r["side"], r["problem"])))
                    + "; by Siconos' solvers alone, problems so lost: "
                    + str(len({(r["set"], r["split"], r["problem"]) for r in late
                               if r["side"] == "siconos"} - any_sic)) + ".")
            for s in [s for s in solvers if not s.startswith("siconos:")]:
                missed = sorted(pr for pr in any_sic if not math.isfinite(table[pr].get(s, math.inf)))
                best = {r["problem"]: r["error"] for r in kr if r["solver"] == s}
                lines.append(f"- `{s}` misses {len(missed)} of them" + (
                    ": " + ", ".join(f"{pr[2]} ({best.get(pr[2], math.inf):.1e})" for pr in missed[:12])
                    + (" …" if len(missed) > 12 else "") if missed else ""))
                ksum[s]["missed_vs_any_siconos"] = len(missed)
            # Dolan–Moré against all Siconos solvers, per ours
            lines += ["", "Dolan–Moré ρ(τ) of each of ours against all Siconos solvers of this kind:", ""]
            lines += rho_table(table, solvers, ksum, "rho")
            # the same at the accuracy solve() certifies: an answer counts only if the guard accepts it
            if has_guard:
                gtable = defaultdict(dict)
                for r in kr:
                    gtable[(r["set"], r["split"], r["problem"])][r["solver"]] = (
                        r["time"] if solved(r, tol, lim) and guarded(r, tol) else math.inf)
                lines += ["", "The same, counting an answer (ours or Siconos') only when the units "
                          "guard accepts it too:", ""]
                lines += rho_table(gtable, solvers, ksum, "rho_guard_too")
            else:       # a CSV of a run made before the guard was recorded
                lines += ["", "(No units-guard values in this CSV: the run predates them.)"]
            lines += size_rho_lines(table, kr, solvers)
        lines.append("")
        summary["kinds"][kind] = ksum
        if kind in FIGURES:
            _figure(table, args.out / FIGURES[kind][0], tol, FIGURES[kind][1])
    # tolerance sweep
    sweep = sorted({r["tol"] for r in rows}, reverse=True)
    if len(sweep) > 1:
        lines += ["## Solved counts per tolerance (all kinds and sets)", "",
                  "| solver | " + " | ".join(f"{t:g}" for t in sweep) + " |", "|---|" + "---|" * len(sweep)]
        for s in sorted({r["solver"] for r in rows if r["tol"] != tol}):
            cells = []
            for t in sweep:
                rs = [r for r in rows if r["solver"] == s and r["tol"] == t]
                cells.append(f"{sum(solved(r, t, lim) for r in rs)}/{len(rs)}" if rs else "–")
            lines.append(f"| {s} | " + " | ".join(cells) + " |")
        lines.append("")
    # one-contact per-call time
    one = [r for r in main_rows if r["nc"] == 1 and r["kind"] == "local3" and solved(r, tol, lim)]
    if one:
        lines += ["## One-contact problems: per-call time [µs] (min of repeated calls, warm, both sides)", "",
                  "| problem | " + " | ".join(sorted({r["solver"] for r in one})) + " |",
                  "|---|" + "---|" * len({r["solver"] for r in one})]
        for pr in sorted({r["problem"] for r in one}):
            cells = []
            for s in sorted({r["solver"] for r in one}):
                t = [r["time"] for r in one if r["problem"] == pr and r["solver"] == s]
                cells.append(f"{1e6 * t[0]:.0f}" if t else "–")
            lines.append(f"| {pr} | " + " | ".join(cells) + " |")
        lines.append("")
    if not have_sic:
        lines.append("Siconos was not available: peer columns are missing.")
    stem.with_suffix(".md").write_text("\n".join(lines) + "\n")
    stem.with_suffix(".json").write_text(json.dumps(summary, indent=1, default=float) + "\n")
    print("\n".join(lines))


#: the performance profiles drawn: kind -> (file, what the title calls the problems)
FIGURES = {"local3": ("newton_vs_siconos_profile.png", "3D local problems"),
           "local2": ("newton_vs_siconos_profile_2d.png", "2D local problems")}


def _figure(table, path, tol, what) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    taus, rho = performance_profile(table)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    ours_colors = {"auto": "black", "newton": "tab:green", "clarabel": "tab:orange", "nsgs": "tab:purple"}
    for s, y in sorted(rho.items(), key=lambda kv: (-kv[1][-1], kv[0])):
        ours = not s.startswith("siconos:")
        style = dict(lw=2.6, ls="-", color=ours_colors.get(s)) if ours else dict(lw=1.0, ls="--", alpha=0.8)
        ax.step(taus, y, where="post", label=s, **style)
    ax.set_xscale("log")
    ax.set_xlim(1, max(taus.max(), 10))
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("τ (time / fastest time)")
    ax.set_ylabel("ρ(τ): fraction of problems")
    ax.set_title(f"{what}, tol {tol:g}: performance profile (ours solid)")
    ax.legend(fontsize=7, ncol=2, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())

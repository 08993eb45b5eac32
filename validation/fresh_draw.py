"""Issue #10's first two targets on a manufactured draw no session has generated before.

The evaluation set's manufactured cases (seeds 0-3 of ``socp_cd.bench.evalset``) have been
run by every session since the rules of ``solver="auto"`` were chosen on their tune half; the
held-out half was run after each choice, so it too has been seen many times.  This script
builds the same families on seeds nobody has drawn (default 30-33: seed ``k`` takes the
mix ``MIXES[k % 4]``, so the four seeds cover the four contact states) on every real
operator of ``shared/``, every ``mu`` of ``evalset.MUS``, no rescaled copies, and checks:

* how many ``auto`` solves at tol (``converged``: Siconos' error and the units guard), one
  call per case on a fresh problem object, ``--time-limit`` seconds (``--large-time-limit``
  above ``--large`` contacts: the budgets of the README's manufactured count);
* with ``--siconos``, whether some Siconos 4.4 solver solves a case ``auto`` misses: every
  solver of the case's family (3D/2D local, global) at the same budget, judged as the
  benchmark judges (our recomputed Siconos error ``<= tol``; the units guard beside it).
  ``--strong-large`` gives the cases above ``--large`` contacts to Siconos' five strongest
  (NSN_AC, NSN_FB, NSN_NM, PROX, ADMM) only.

``--evalset`` runs the evaluation set's own manufactured cases instead (seeds 0-3 and the
rescaled copies: the 620 cases of the README's count, with their tune / held-out split);
``--collections DIR ...`` the step problems of FCLib collections, e.g. the simulation scenes
no session had run (``build_sim_collections.py --fresh``).

Writes ``<out>.csv`` (one row per ``auto`` call), ``<out>_siconos.csv`` and ``<out>.md``
(``--from-csv`` writes the report again from the CSVs)::

    python validation/fresh_draw.py --siconos --strong-large --out results/fresh_draw_s34
    python validation/fresh_draw.py --evalset --siconos --strong-large --out results/manufactured_s34
    python validation/fresh_draw.py --collections evalset_sim_fresh --siconos --out results/sim_fresh_s34
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.reports import emit
from socp_cd.bench.siconos_peer import SOLVERS, family_of, siconos_available
from socp_cd.data import shared_problems_dir

from auto_probe import write_csv
from misses_vs_siconos import siconos_rows

HERE = Path(__file__).resolve().parent
#: Siconos' strongest solvers at 1e-8 (README), for the large cases with ``--strong-large``
STRONG = ("nsn_ac", "nsn_fb", "nsn_nm", "prox", "admm")
BANDS = ((1, 10), (11, 100), (101, 250), (251, 10 ** 9))


def kind_of(p) -> str:
    """``"global"``, ``"local2"`` or ``"local3"``."""
    return "global" if p.is_global else f"local{p.dim}"


def path_text(res) -> str:
    """``method:error;...`` of ``auto``'s stages."""
    return ";".join(f"{s['method']}:{s['error']:.1e}" for s in res.info.get("path", []))


def run_auto(cases, tol, small_limit, large_limit, large) -> list[dict]:
    """One ``auto`` call per case (a fresh problem object each), judged by ``solve``."""
    rows = []
    for i, c in enumerate(cases, 1):
        p = c.problem()
        limit = large_limit if c.n_contacts > large else small_limit
        t0 = time.perf_counter()
        res = socp_cd.solve(p, tol=tol, time_limit=limit)
        wall = time.perf_counter() - t0
        guard = float(res.info.get("guard", {}).get("value", np.inf))
        rows.append({"case": c.case_id, "split": c.split, "kind": kind_of(p), "nc": c.n_contacts,
                     "mu": float(np.max(p.mu)), "time_limit": limit, "status": res.status,
                     "solved": bool(res.converged), "error": float(res.error), "guard": guard,
                     "time": wall, "path": path_text(res)})
        print(f"[{i}/{len(cases)}] {c.case_id} {res.status} err {res.error:.1e} "
              f"guard {guard:.1e} {wall:.3g} s", flush=True)
    return rows


def run_siconos(cases, misses, tol, small_limit, large_limit, large, strong_large):
    """Every Siconos solver of its family (the strong ones above ``large`` contacts with
    ``strong_large``) on each missed case, at ``auto``'s budget."""
    by_id = {c.case_id: c for c in cases}
    rows = []
    for m in misses:
        p = by_id[m["case"]].problem()
        big = p.n_contacts > large
        limit = large_limit if big else small_limit
        names = [n for n in SOLVERS[family_of(p)] if not (strong_large and big) or n in STRONG]
        rows += siconos_rows(m["case"], p, names, tol, limit)
    return rows


def sim_cases(folders, max_contacts=None) -> list:
    """The cases of the FCLib collections in ``folders`` (a collection, or a folder of them;
    paths relative to this script's folder), at most ``max_contacts`` contacts."""
    cases = []
    for folder in folders:
        root = folder if folder.is_absolute() else HERE / folder
        for sub in sorted({f.parent for f in root.rglob("*.hdf5")}):
            cases += [c for c in evalset.collection_cases(sub)
                      if max_contacts is None or c.n_contacts <= max_contacts]
    if not cases:
        raise SystemExit(f"no FCLib collection under {[str(f) for f in folders]}")
    return cases


def read_rows(out):
    """The rows of a run's CSVs (``<out>.csv``, ``<out>_siconos.csv`` when present), typed."""
    def typed(row):
        for key, value in row.items():
            if value in ("True", "False"):
                row[key] = value == "True"
            elif key in ("nc",):
                row[key] = int(value)
            elif key in ("mu", "time_limit", "error", "guard", "time"):
                row[key] = float(value)
        row.setdefault("split", evalset.case_split(row["case"]))
        return row
    with open(out.with_suffix(".csv"), newline="") as fh:
        rows = [typed(r) for r in csv.DictReader(fh)]
    sic = out.with_name(out.name + "_siconos.csv")
    sic_rows = []
    if sic.exists():
        with open(sic, newline="") as fh:
            sic_rows = [typed(r) for r in csv.DictReader(fh)]
    return rows, sic_rows


def report(rows, sic_rows, args, command) -> list[str]:
    """The Markdown report: solved counts by kind and size, the misses, Siconos on them."""
    n = len(rows)
    solved = sum(r["solved"] for r in rows)
    what = ("simulation dumps (" + ", ".join(str(f) for f in args.collections) + ")"
            if args.collections else
            "the evaluation set's manufactured cases (seeds 0-3 and the rescaled copies)"
            if args.evalset else
            f"a fresh manufactured draw (seeds {' '.join(map(str, args.seeds))})")
    how = ("step problems of the scenes' runs (NSGS at 1e-6 inside the simulation; each "
           "problem exact)" if args.collections else
           f"every real operator of shared/"
           f"{f' whose cases contain {args.family!r}' if getattr(args, 'family', '') else ''}, "
           f"μ ∈ {{{', '.join(f'{m:g}' for m in evalset.MUS)}}}, "
           "the mix of seed k = MIXES[k mod 4]")
    by_split = defaultdict(lambda: [0, 0])
    for r in rows:
        by_split[r["split"]][0] += r["solved"]
        by_split[r["split"]][1] += 1
    splits = ", ".join(f"{k} {v[0]} / {v[1]}" for k, v in sorted(by_split.items()))
    lines = [f"# `auto` on {what}, tol {args.tol:g}", "", f"`{command}`", "",
             f"{n} cases ({how}); budget {args.time_limit:g} s, "
             f"{args.large_time_limit:g} s above {args.large} contacts; one call each.", "",
             f"**Solved: {solved} of {n} ({100.0 * solved / max(n, 1):.1f} %)**"
             + (f"; tune / held out by the evaluation set's split: {splits}." if args.evalset
                else "; no parameter of `auto` was chosen on these problems."), "",
             "| kind | contacts | cases | solved | median time [s] |", "|---|---|---|---|---|"]
    groups = defaultdict(list)
    for r in rows:
        band = next(b for b in BANDS if b[0] <= r["nc"] <= b[1])
        groups[(r["kind"], band)].append(r)
    for (kind, band), rs in sorted(groups.items()):
        label = f"{band[0]}–{band[1]}" if band[1] < 10 ** 9 else f"> {band[0] - 1}"
        lines.append(f"| {kind} | {label} | {len(rs)} | {sum(r['solved'] for r in rs)} | "
                     f"{np.median([r['time'] for r in rs]):.2g} |")
    misses = [r for r in rows if not r["solved"]]
    by_case = defaultdict(list)
    for s in sic_rows:
        by_case[s["case"]].append(s)
    lines += ["", "## The misses", "",
              "| case | contacts | `auto` error | guard | status | Siconos solvers that solve it "
              "(error, guard, s) | best Siconos error otherwise |", "|---|---|---|---|---|---|---|"]
    n_sic = n_sic_guard = 0
    for m in sorted(misses, key=lambda r: r["case"]):
        ss = by_case.get(m["case"], [])
        ok = [s for s in ss if s["solved"]]
        n_sic += bool(ok)
        n_sic_guard += any(s["guard_too"] for s in ss)
        best = min(ss, key=lambda s: s["error"]) if ss else None
        who = ((", ".join(f"{s['solver']} ({s['error']:.1e}, {s['guard']:.1e}, {s['time']:.2g})"
                          for s in ok) or "none") if ss else "not run")
        tail = f"{best['error']:.1e} ({best['solver']})" if best else "–"
        lines.append(f"| {m['case']} | {m['nc']} | {m['error']:.1e} | {m['guard']:.1e} | "
                     f"{m['status']} | {who} | {tail} |")
    if not misses:
        lines.append("| none | | | | | | |")
    if sic_rows:
        lines += ["", f"Of the {len(misses)} misses, solved by some Siconos solver "
                  f"by Siconos' error alone: {n_sic}; with the units guard too: {n_sic_guard}."]
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", nargs="+", type=int, default=[30, 31, 32, 33])
    ap.add_argument("--collections", nargs="+", type=Path, default=None,
                    help="FCLib collection folders (or folders of them) instead: simulation "
                         "dumps, e.g. evalset_sim_fresh (build_sim_collections.py --fresh)")
    ap.add_argument("--evalset", action="store_true",
                    help="the evaluation set's own manufactured cases instead (seeds 0-3 and "
                         "the rescaled copies: the 620 cases of the README's count)")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--large", type=int, default=250)
    ap.add_argument("--max-contacts", type=int, default=None,
                    help="leave out operators of more contacts (a quick check)")
    ap.add_argument("--large-time-limit", type=float, default=10.0)
    ap.add_argument("--family", default="",
                    help="only the cases whose id contains this (e.g. Capsules)")
    ap.add_argument("--siconos", action="store_true", help="give auto's misses to Siconos")
    ap.add_argument("--strong-large", action="store_true",
                    help="only Siconos' five strongest solvers on the large misses")
    ap.add_argument("--out", type=Path, required=True, help="output stem (.csv, .md)")
    ap.add_argument("--from-csv", action="store_true",
                    help="write the report from the run's CSVs (<out>.csv, <out>_siconos.csv)")
    args = ap.parse_args(argv)
    out = args.out if args.out.is_absolute() else HERE / args.out
    command = "python validation/fresh_draw.py " + " ".join(
        a for a in (argv if argv is not None else sys.argv[1:]) if a != "--from-csv")
    if args.evalset:
        args.seeds = list(range(4))
    if args.from_csv:
        rows, sic_rows = read_rows(out)
        emit(report(rows, sic_rows, args, command), out.with_suffix(".md"))
        return 0
    if args.siconos and not siconos_available():
        raise SystemExit("Siconos is not available (apt-get install -y python3-siconos)")
    if args.collections:
        cases = sim_cases(args.collections, args.max_contacts)
    elif args.evalset:
        cases = evalset.manufactured_cases(shared_problems_dir(), max_contacts=args.max_contacts)
    else:
        cases = evalset.manufactured_cases(shared_problems_dir(), seeds=args.seeds, scales=(),
                                          max_contacts=args.max_contacts)
    cases = [c for c in cases if args.family in c.case_id]
    socp_cd.warmup()
    rows = run_auto(cases, args.tol, args.time_limit, args.large_time_limit, args.large)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out.with_suffix(".csv"))
    sic_rows = []
    if args.siconos:
        sic_rows = run_siconos(cases, [r for r in rows if not r["solved"]], args.tol,
                               args.time_limit, args.large_time_limit, args.large,
                               args.strong_large)
        if sic_rows:
            write_csv(sic_rows, out.with_name(out.name + "_siconos.csv"))
    emit(report(rows, sic_rows, args, command), out.with_suffix(".md"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Issue #10's "≥ 99 % of the manufactured cases" count from ``auto_chain.py`` runs.

The manufactured set is the evaluation set's ``real-manufactured`` and ``real-scaled``
families (620 cases). A case of at most ``--large`` contacts is counted from a run at 1 s,
a larger one from a run at 10 s (the budget the README's count has used since session 28).
Each run is named ``CSV:CONFIG`` (an ``auto_chain.py`` CSV and the ``config`` column of the
chain to count), so that one count can read a tune run and a held-out run whose chains are
spelled differently::

    python validation/manufactured_count.py \\
        --at1 results/auto_chain_tune_s31seedb1.csv:now,COLD_SPLIT=1,SEED_BY_GUARD=1 \\
              results/auto_chain_holdout_s31adopt1.csv:now \\
        --at10 results/auto_chain_tune_s31seedb10.csv:now,COLD_SPLIT=1,SEED_BY_GUARD=1 \\
               results/auto_chain_holdout_s31adopt10.csv:now

Prints solved / cases per split and the cases not solved with their error. ``auto_chain.py``
runs local problems only: the global cases (and any other case in no run) are an error, or,
with ``--solve-missing``, solved here with this tree's ``auto`` at the budget their size
takes (a fresh problem object, one call each), and counted apart too.
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import Counter
from pathlib import Path

import socp_cd
from socp_cd.bench import evalset
from socp_cd.data import shared_problems_dir

FAMILIES = ("real-manufactured", "real-scaled")


def rows_of(specs):
    """``{case: row}`` of the ``CSV:CONFIG`` runs (a case in two runs: the later wins)."""
    out = {}
    for spec in specs:
        path, _, config = spec.rpartition(":")
        if not config:
            raise SystemExit(f"{spec!r}: expected CSV:CONFIG")
        found = 0
        with open(Path(path)) as f:
            for r in csv.DictReader(f):
                if r["config"] == config and r["family"] in FAMILIES:
                    out[r["case"]] = r
                    found += 1
        if not found:
            raise SystemExit(f"{path}: no manufactured row of config {config!r}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--at1", nargs="+", required=True, help="CSV:CONFIG runs at 1 s")
    ap.add_argument("--at10", nargs="+", required=True, help="CSV:CONFIG runs at 10 s")
    ap.add_argument("--large", type=int, default=250,
                    help="cases of more contacts than this are counted at 10 s")
    ap.add_argument("--solve-missing", action="store_true",
                    help="solve the cases in no run (the global ones) with this tree's auto")
    args = ap.parse_args(argv)
    at1, at10 = rows_of(args.at1), rows_of(args.at10)
    solved, total, missed, absent = Counter(), Counter(), [], []
    for case in evalset.manufactured_cases(shared_problems_dir()):
        cid, nc, split = case.case_id, case.n_contacts, case.split
        row = (at10 if nc > args.large else at1).get(cid)
        if row is None and args.solve_missing:
            p = case.problem()
            budget = 10.0 if nc > args.large else 1.0
            if not absent:          # (the first: JIT and caches warmed outside the budget)
                socp_cd.solve(case.problem(), tol=1e-8, time_limit=budget)
            t0 = time.perf_counter()
            res = socp_cd.solve(p, tol=1e-8, time_limit=budget)
            # (auto_chain.py's record: the recomputed error and the verdict)
            ok = res.converged and socp_cd.error(p, res.r) <= 1e-8
            row = {"solved": str(bool(ok)), "error": res.error}
            absent.append((cid, res.converged, time.perf_counter() - t0))
        elif row is None:
            absent.append((cid, None, None))
            continue
        total[split] += 1
        if row["solved"] == "True":
            solved[split] += 1
        else:
            missed.append((split, cid, nc, float(row["error"])))
    if absent and not args.solve_missing:
        print(f"{len(absent)} cases in no run, e.g. {[a[0] for a in absent[:3]]}",
              file=sys.stderr)
        return 1
    if absent:
        print(f"solved here (in no run): {sum(bool(a[1]) for a in absent)} of {len(absent)}, "
              f"{sum(a[2] for a in absent):.1f} s")
    n, s = sum(total.values()), sum(solved.values())
    print(f"solved {s} of {n} ({100 * s / n:.1f} %): " + ", ".join(
        f"{k} {solved[k]} / {total[k]}" for k in sorted(total)))
    for split, cid, nc, err in sorted(missed):
        print(f"  not solved ({split}): {cid} ({nc} contacts) {err:.1e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

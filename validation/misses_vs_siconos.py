"""Every Siconos solver on the manufactured evaluation-set cases ``auto`` does not solve (issue #10).

Issue #10's first target: ``auto`` solves every problem of shared/ plus the evaluation set
that some Siconos solver solves.  The benchmark (``newton_vs_siconos.py``) checks it on a
seeded draw of the evaluation set; the cases ``auto`` misses on the *whole* manufactured
set are known from ``auto_chain.py`` runs.  This script gives those misses to every
Siconos 4.4 solver of their family (3D or 2D local, global), with the same time limit
``auto`` had, and judges each answer as the benchmark does: our recomputed Siconos error
(``socp_cd.error``) at most ``tol``; the units guard (``socp_cd.guard``), which ``auto``'s
``converged`` needs too, is reported beside it, and counted separately.

The misses are read from ``auto_chain`` CSVs (rows of the manufactured and rescaled
families, ``real-*``, with ``solved`` False for the chosen config; ``--family`` filters by a
substring of the case id)::

    python validation/misses_vs_siconos.py \\
        validation/results/auto_chain_tune_s28large10.csv \\
        validation/results/auto_chain_holdout_s28large10.csv \\
        --family Capsules --time-limit 10 --out validation/results/misses_vs_siconos_s29

Each (case, solver) runs once (a single call, as Siconos' worker runs it, killed at the
time limit), the solvers of one case in one worker; max_iter 1 000 000 so that only the
time limit or the solver's own stop ends a run.
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.siconos_peer import SOLVERS, family_of, siconos_available, siconos_batch
from socp_cd.data import shared_problems_dir

from auto_probe import write_csv


def missed(paths, family, config):
    """``{case_id: (best error, time)}`` of the rows of ``paths`` that ``config`` did not
    solve (first row per case)."""
    out = {}
    for path in paths:
        with open(path, newline="") as fh:
            for row in csv.DictReader(fh):
                if (row["config"] == config and row["solved"] == "False"
                        and row["case"].startswith("real-") and family in row["case"]
                        and row["case"] not in out):
                    out[row["case"]] = (float(row["error"]), float(row["time"]))
    return out


def siconos_rows(cid, p, names, tol, time_limit, extra=None) -> list[dict]:
    """Each Siconos solver of ``names`` on problem ``p`` (case ``cid``) once, in one worker, at
    ``time_limit``, max_iter 1 000 000, judged by our recomputed error (``solved``) and the
    units guard (``guard_too``): one row per solver, ``extra`` (e.g. ``auto``'s error and
    time) after ``case`` and ``nc``; each row printed."""
    tasks = [{"task": "solve", "problem": p, "solver": s, "tol": tol,
              "max_iter": 1_000_000, "time_limit": time_limit} for s in names]
    rows = []
    for s, res in zip(names, siconos_batch(tasks)):
        r = res.get("r")
        ok = res["status"] == "ok" and r is not None and np.all(np.isfinite(r))
        err = float(socp_cd.error(p, r)) if ok else float("inf")
        guard = float(socp_cd.guard(p, r)["value"]) if ok else float("inf")
        rows.append({"case": cid, "nc": p.n_contacts, **(extra or {}), "solver": s,
                     "status": res["status"], "claimed": res.get("info") == 0, "error": err,
                     "guard": guard, "solved": err <= tol, "guard_too": max(err, guard) <= tol,
                     "time": res.get("time", float("inf"))})
        print(f"{cid} {s:8s} {res['status']:10s} err {err:.1e} guard {guard:.1e} "
              f"t {rows[-1]['time']:.3g}", flush=True)
    return rows


def problems(case_ids):
    """``{case_id: problem}`` from the evaluation set (manufactured and rescaled cases)."""
    want = set(case_ids)
    found = {c.case_id: c.problem() for c in evalset.manufactured_cases(shared_problems_dir())
             if c.case_id in want}
    missing = want - set(found)
    if missing:
        raise SystemExit(f"not in the evaluation set: {sorted(missing)}")
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", nargs="+", type=Path, help="auto_chain result CSVs")
    ap.add_argument("--family", default="", help="substring of the case ids to keep")
    ap.add_argument("--config", default="now", help="the auto_chain config whose misses to take")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--solvers", nargs="+", default=None,
                    help="Siconos solver names to run (default: every solver of the family)")
    ap.add_argument("--out", type=Path, required=True, help="output stem (.csv and .md)")
    args = ap.parse_args()
    if not siconos_available():
        raise SystemExit("Siconos is not available (apt-get install -y python3-siconos)")
    miss = missed(args.csv, args.family, args.config)
    if not miss:
        raise SystemExit("no missed case in these CSVs")
    probs = problems(miss)
    rows = []
    for cid in sorted(miss):
        p = probs[cid]
        names = [n for n in SOLVERS[family_of(p)] if args.solvers is None or n in args.solvers]
        rows += siconos_rows(cid, p, names, args.tol, args.time_limit,
                             {"auto_error": miss[cid][0], "auto_time": miss[cid][1]})
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(rows, args.out.with_suffix(".csv"))
    write_md(rows, args, args.out.with_suffix(".md"))


def write_md(rows, args, path) -> None:
    """One line per case: ``auto``'s error (its miss may be the units guard's: error <= tol),
    the Siconos solvers that solve it (error, guard, time), the best Siconos error otherwise;
    the counts by the error alone and with the guard too."""
    lines = [f"# Siconos solvers on the manufactured cases `auto` misses (tol {args.tol:g}, "
             f"{args.time_limit:g} s)", "",
             "`python validation/misses_vs_siconos.py " + " ".join(str(c) for c in args.csv)
             + (f" --family {args.family}" if args.family else "")
             + (f" --solvers {' '.join(args.solvers)}" if args.solvers else "")
             + f" --time-limit {args.time_limit:g}`; solved: our recomputed Siconos error "
             "≤ tol (the benchmark's yardstick), the units guard given beside it.", "",
             "| case | contacts | `auto` error | Siconos solvers that solve it (error, guard, s) "
             "| best Siconos error otherwise |", "|---|---|---|---|---|"]
    by = {}
    for r in rows:
        by.setdefault(r["case"], []).append(r)
    n_solved = n_guard = 0
    for cid, rs in by.items():
        solved = [r for r in rs if r["solved"]]
        n_solved += bool(solved)
        n_guard += any(r["guard_too"] for r in rs)
        best = min(rs, key=lambda r: r["error"])
        lines.append(f"| {cid} | {rs[0]['nc']} | {rs[0]['auto_error']:.1e} | "
                     + (", ".join(f"{r['solver']} ({r['error']:.1e}, {r['guard']:.1e}, "
                                  f"{r['time']:.2g})" for r in solved) or "none")
                     + f" | {best['error']:.1e} ({best['solver']}) |")
    lines += ["", f"{n_solved} of {len(by)} cases solved by some Siconos solver (error <= tol); "
              f"{n_guard} with the units guard <= tol too."]
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()

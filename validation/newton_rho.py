"""``solver="newton"``: one Alart–Curnier parameter per contact (``rho="block"``) or a
split pair (``rho="split"``: ``rho_N = 1/W_NN``, ``rho_T = 1/||W_TT||_2``).

Cases: the local (``local2``/``local3``) ``real-manufactured`` and ``real-scaled``
cases of the evaluation set (``socp_cd.bench.evalset``, files with at most
``--max-contacts`` contacts) of one split, or ``--split capsules``: the
manufactured sliding/sticking/grazing cases on ``Capsules-i125-1213.hdf5`` (the
stalls that motivated the split parameter; whatever their split, reported apart,
not used to choose; with ``--siconos`` also Siconos NSN_AC with three of its rho
strategies, as a reference).  Each case is solved by both strategies back to back
(``tol`` 1e-8, ``--time-limit`` 5 s per call, JIT warmed, one run: the machine is
shared, times are indicative).  Solved = recomputed ``socp_cd.error <= tol``;
the shifted geometric mean (sgm) charges an unsolved case its time limit.

Usage::

    NUMBA_NUM_THREADS=1 .venv/bin/python validation/newton_rho.py --split tune
    NUMBA_NUM_THREADS=1 .venv/bin/python validation/newton_rho.py --split capsules --siconos
    NUMBA_NUM_THREADS=1 .venv/bin/python validation/newton_rho.py --split holdout

Writes ``validation/results/newton_rho_<split>.csv`` and regenerates
``validation/results/newton_rho.md`` from every such csv present.
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.evalset import manufactured_cases
from socp_cd.bench import reports
from socp_cd.bench.reports import variant_comparison_by, variant_disagreements
from socp_cd.data import shared_problems_dir

OUT = Path(__file__).resolve().parent / "results"
STRATEGIES = ("block", "split")
SPLITS = ("tune", "capsules", "holdout")
CAPSULES = "Capsules-i125-1213.hdf5"
FIELDS = ("split", "case", "kind", "nc", "rho", "error", "solved", "time", "status",
          "iterations", "aniso")
#: Siconos NSN_AC rho strategies (``iparam[SICONOS_FRICTION_3D_NSN_RHO_STRATEGY]``);
#: SPECTRAL_NORM is Siconos 4.4's default (one value per contact)
SICONOS_RHO = {"SPECTRAL_NORM": 1, "SPLIT_SPECTRAL_NORM": 3, "CONSTANT": 0}


def select(split, max_contacts):
    """The evaluation cases of ``split`` (local problems only)."""
    cases = [c for c in manufactured_cases(shared_problems_dir(), max_contacts=max_contacts)
             if not c.is_global]
    if split == "capsules":
        return [c for c in cases if c.source == CAPSULES and c.family == "real-manufactured"
                and c.params.get("mix") in ("sliding", "sticking", "grazing")]
    return [c for c in cases if c.split == split]


def anisotropy(p):
    """Median over contacts of ``max(W_NN, ||W_TT||) / min(W_NN, ||W_TT||)``."""
    W = p.W.toarray() if hasattr(p.W, "toarray") else np.asarray(p.W)
    d, nc = p.dim, p.n_contacts
    ratios = []
    for i in range(nc):
        B = W[i * d:(i + 1) * d, i * d:(i + 1) * d]
        a, b = abs(B[0, 0]), np.linalg.norm(B[1:, 1:], 2)
        lo = min(a, b)
        ratios.append(max(a, b) / lo if lo > 0 else np.inf)
    return float(np.median(ratios)) if ratios else 1.0


def run(split, cases, tol, time_limit):
    rows = []
    warm = min(cases, key=lambda c: c.n_contacts).problem()
    for rho in STRATEGIES:
        socp_cd.solve(warm, "newton", tol=1e-4, rho=rho)
    for c in cases:
        p = c.problem()
        aniso = anisotropy(p)
        for rho in STRATEGIES:
            t0 = time.perf_counter()
            res = socp_cd.solve(p, "newton", tol=tol, time_limit=time_limit, rho=rho)
            dt = time.perf_counter() - t0
            err = float(socp_cd.error(p, res.r))
            rows.append(dict(split=split, case=c.case_id, kind=f"local{p.dim}", nc=p.n_contacts,
                             rho=rho, error=err, solved=bool(err <= tol), time=dt,
                             status=res.status, iterations=res.iterations, aniso=aniso))
        print(c.case_id, " ".join(f"{r['rho']}:{r['error']:.1e}/{r['time']:.2f}s"
                                  for r in rows if r["case"] == c.case_id), flush=True)
    return rows


def run_siconos(cases, tol):
    """Siconos NSN_AC per rho strategy: rows ``case, strategy, error, solved``."""
    from socp_cd.bench.siconos_peer import siconos_solve
    rows = []
    for c in cases:
        p = c.problem()
        for name, code in SICONOS_RHO.items():
            res = siconos_solve(p, "nsn_ac", tol=tol, max_iter=1000,
                                iparam={"SICONOS_FRICTION_3D_NSN_RHO_STRATEGY": code})
            err = float(socp_cd.error(p, res["r"]))
            rows.append(dict(case=c.case_id, strategy=name, error=err, solved=err <= tol))
        print(c.case_id, " ".join(f"{r['strategy']}:{r['error']:.1e}" for r in rows
                                  if r["case"] == c.case_id), flush=True)
    return rows


def siconos_lines(path):
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    lines = ["Reference: Siconos 4.4 NSN_AC (its line search, max_iter 1000) on the same "
             "cases, solved (recomputed `socp_cd.error` <= tol) per rho strategy:", "",
             "| case | " + " | ".join(SICONOS_RHO) + " |", "|---" * (len(SICONOS_RHO) + 1) + "|"]
    for cid in dict.fromkeys(r["case"] for r in rows):
        errs = {r["strategy"]: float(r["error"]) for r in rows if r["case"] == cid}
        lines.append(f"| `{cid.split('/')[-1]}` | "
                     + " | ".join(f"{errs[s]:.1e}" for s in SICONOS_RHO) + " |")
    counts = {s: sum(r["solved"] == "True" for r in rows if r["strategy"] == s)
              for s in SICONOS_RHO}
    lines.append("| **solved** | " + " | ".join(str(counts[s]) for s in SICONOS_RHO) + " |")
    return lines


def read_rows(path):
    return reports.read_rows(path, floats=("error", "time", "aniso"), ints=("nc", "iterations"))


def summary(rows, tol, time_limit):
    """Markdown lines: per strategy and kind, solved counts and sgm time; then the
    cases solved by one strategy only."""
    lines = ["| kind | cases | rho | solved | sgm time (s, unsolved = limit) | "
             "sgm time on cases both solve (s) |", "|---|---|---|---|---|---|"]
    for kind, rho, c in variant_comparison_by(rows, "kind", "rho", STRATEGIES, time_limit):
        lines.append(f"| {kind} | {c['cases']} | {rho} | {c['solved']} | "
                     f"{c['sgm']:.4f} | {c['sgm_common']:.4f} ({c['n_common']}) |")
    diff = [(cid, d) for cid, d in variant_disagreements(rows, "rho") if len(d) == 2]
    lines += ["", "Cases solved by one strategy only (error block / split, median "
              "anisotropy max(W_NN, ||W_TT||)/min(...)):", ""]
    if not diff:
        lines.append("- none")
    for cid, d in sorted(diff):
        won = "split" if d["split"]["solved"] else "block"
        lines.append(f"- `{cid}`: {d['block']['error']:.1e} ({d['block']['status']}) / "
                     f"{d['split']['error']:.1e} ({d['split']['status']}), "
                     f"anisotropy {d['block']['aniso']:.1f} — **{won}**")
    return lines


def write_report(tol, time_limit):
    parts = ["# newton: `rho=\"block\"` vs `rho=\"split\"`", "",
             "Generated by `validation/newton_rho.py` (see its docstring). Local "
             "manufactured + scaled cases of the evaluation set, "
             f"tol {tol:g}, time limit {time_limit:g} s per call, one run per case "
             "(shared 2-core machine with other jobs running: times are indicative, "
             "compare the two columns, which ran back to back).", "",
             "`block`: `rho_N = rho_T = sqrt(d)/||W_ii||_F`; `split`: `rho_N = 1/W_NN`, "
             "`rho_T = 1/||W_TT||_2`.", ""]
    for split in SPLITS:
        path = OUT / f"newton_rho_{split}.csv"
        if not path.exists():
            continue
        rows = read_rows(path)
        parts += [f"## {split} ({len(rows) // len(STRATEGIES)} cases)", ""]
        parts += summary(rows, tol, time_limit) + [""]
        sic = OUT / f"newton_rho_{split}_siconos.csv"
        if sic.exists():
            parts += siconos_lines(sic) + [""]
    (OUT / "newton_rho.md").write_text("\n".join(parts))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--split", choices=SPLITS, required=True)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=5.0)
    ap.add_argument("--max-contacts", type=int, default=400)
    ap.add_argument("--siconos", action="store_true",
                    help="also run Siconos NSN_AC per rho strategy on the cases")
    ap.add_argument("--report-only", action="store_true",
                    help="regenerate newton_rho.md from the csv files present")
    args = ap.parse_args(argv)
    if not args.report_only:
        cases = select(args.split, args.max_contacts)
        print(f"{len(cases)} cases", flush=True)
        rows = run(args.split, cases, args.tol, args.time_limit)
        OUT.mkdir(parents=True, exist_ok=True)
        with open(OUT / f"newton_rho_{args.split}.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=FIELDS)
            w.writeheader()
            w.writerows(rows)
        if args.siconos:
            srows = run_siconos(cases, args.tol)
            with open(OUT / f"newton_rho_{args.split}_siconos.csv", "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=("case", "strategy", "error", "solved"))
                w.writeheader()
                w.writerows(srows)
    write_report(args.tol, args.time_limit)
    print((OUT / "newton_rho.md").read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

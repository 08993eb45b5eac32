"""Newton on the natural map (or Fischer–Burmeister's equation) against Alart–Curnier's, case by case.

``solver="newton"`` solves three nonsmooth equations of the law (option ``equation``,
formulations/newton.md §13, §14).  This script gives every case of a split of the evaluation
set (the manufactured and rescaled cases of ``socp_cd.bench.evalset``, seeds 0-3, or a
fresh draw with ``--seeds``; local and global) to each configuration
``equation/policy`` once (``--equations``, default Alart–Curnier and the natural map; the
policies ``prox`` and ``plain``), from ``r = 0``, judged by ``solve`` (Siconos' error and the
units guard), and with ``--siconos`` gives the same cases to Siconos' Newton solvers on the
same equations (NSN_AC, NSN_NM, NSN_FB; local 3D cases) at the same budget::

    python validation/nm_vs_ac.py --split tune --out results/nm_vs_ac_tune
    python validation/nm_vs_ac.py --split holdout --out results/nm_vs_ac_holdout
    python validation/nm_vs_ac.py --split tune --equations alart_curnier fischer_burmeister \
        --out results/fb_vs_ac_tune

Writes ``<out>.csv`` (one row per case and configuration) and ``<out>.md``: solved counts
and the shifted geometric mean of the time (10 ms, failures charged the time limit) per
configuration and family (local 2D, local 3D, global), and the cases one equation solves
and the other does not under the same policy; and ``<out>_profile.png``, the Dolan–Moré
performance profiles of the local 3D cases (the configurations, solved = error and
units guard within ``tol``; Siconos' rows give counts only: its calls here are single, cold,
in the peer's default storage, sparse-block, not the benchmark's timing).  ``--from-csv``
writes the report and the figure again from the run's CSVs.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.reports import emit, performance_profile, shifted_geometric_mean
from socp_cd.data import shared_problems_dir
from auto_probe import write_csv
from fresh_draw import read_rows
from misses_vs_siconos import siconos_rows

HERE = Path(__file__).resolve().parent
#: the configurations: (equation, policy)
POLICIES = ("prox", "plain")
#: each equation as a report names it
SHOWN = {"alart_curnier": "Alart–Curnier", "natural_map": "the natural map",
         "fischer_burmeister": "Fischer–Burmeister's equation"}
#: Siconos' Newton solver on each equation
SICONOS = {"alart_curnier": "nsn_ac", "natural_map": "nsn_nm", "fischer_burmeister": "nsn_fb"}


def family(p) -> str:
    """``"global"``, ``"local2"`` or ``"local3"``."""
    return "global" if p.is_global else f"local{p.dim}"


def run_case(c, p, configs, tol, limit) -> list[dict]:
    """Each configuration on case ``c`` once (a fresh problem object each)."""
    rows = []
    for eq, pol in configs:
        q = c.problem()
        t0 = time.perf_counter()
        res = socp_cd.solve(q, "newton", tol=tol, time_limit=limit, max_iter=10_000,
                            equation=eq, policy=pol)
        wall = time.perf_counter() - t0
        guard = float(res.info.get("guard", {}).get("value", np.inf))
        rows.append({"case": c.case_id, "split": c.split, "family": family(p),
                     "nc": c.n_contacts, "config": f"{eq}/{pol}", "status": res.status,
                     "solved": bool(res.converged), "error": float(res.error), "guard": guard,
                     "time": wall, "time_limit": limit})
    print(f"{c.case_id}: " + " ".join(f"{r['config']}={'Y' if r['solved'] else '-'}"
                                      f"{r['time']:.2g}" for r in rows), flush=True)
    return rows


def report(rows, sic, args, command) -> list[str]:
    what = (f"seeds {' '.join(map(str, args.seeds))}" if args.seeds else f"{args.split} split")
    what += f", cases with {args.family!r}" if args.family else ""
    names = " and on ".join(SHOWN[e] for e in args.equations[::-1])
    lines = [f"# Newton on {names} ({what})", "",
             f"`{command}`; tol {args.tol:g}; one run per case from `r = 0`, "
             f"{args.time_limit:g} s ({args.large_time_limit:g} s above {args.large} "
             "contacts); solved = `solve`'s verdict (Siconos' error and the units guard); "
             "sgm: shifted geometric mean (10 ms) of the wall time, a failure charged its "
             "time limit. Equations other than Alart–Curnier's run the Python Newton loop, "
             "Alart–Curnier's the compiled one on dense systems: on small problems the times "
             "compare the implementations as much as the equations. Figure: "
             f"`{args.out.name}_profile.png` (local 3D, Dolan–Moré over the four "
             "configurations, solved = error and guard).", ""]
    by = defaultdict(list)
    for r in rows:
        by[r["family"], r["config"]].append(r)
    fams = sorted({r["family"] for r in rows})
    configs = [f"{e}/{p}" for e, p in args.configs]
    lines += ["| configuration | " + " | ".join(f"{f}: solved, sgm [s]" for f in fams) + " |",
              "|---|" + "---|" * len(fams)]
    for cfg in configs:
        cells = []
        for f in fams:
            rs = by[f, cfg]
            t = [r["time"] if r["solved"] else r["time_limit"] for r in rs]
            cells.append(f"{sum(r['solved'] for r in rs)} / {len(rs)}, "
                         f"{shifted_geometric_mean(t):.4f}")
        lines.append(f"| `{cfg}` | " + " | ".join(cells) + " |")
    if sic:
        lines += ["", "Siconos on the local 3D cases, same budgets, one call each with the "
                  "peer's default storage (`misses_vs_siconos.siconos_rows`; its times are "
                  "cold single calls, not the benchmark's, so only counts are given): solved "
                  "by our recomputed error / with the units guard too:", ""]
        for s in sorted({r["solver"] for r in sic}):
            rs = [r for r in sic if r["solver"] == s]
            lines.append(f"- {s.upper()}: {sum(r['solved'] for r in rs)} / "
                         f"{sum(r['guard_too'] for r in rs)} of {len(rs)}")
    lines += ["", "Cases one equation solves and the other (Alart–Curnier's) does not, same "
              "policy (error / guard of the one that misses):", ""]
    cases = defaultdict(dict)
    for r in rows:
        cases[r["case"]][r["config"]] = r
    for pol, other in [(p, e) for p in sorted({p for _, p in args.configs})
                       for e in args.equations if e != "alart_curnier"]:
        a, n = f"alart_curnier/{pol}", f"{other}/{pol}"
        if a not in configs or n not in configs:
            continue
        only = {a: [], n: []}
        for cid, cr in cases.items():
            if a in cr and n in cr and cr[a]["solved"] != cr[n]["solved"]:
                win, lose = (a, n) if cr[a]["solved"] else (n, a)
                only[win].append(f"{cid} ({cr[lose]['error']:.1e} / {cr[lose]['guard']:.1e})")
        for cfg, got in only.items():
            lines.append(f"- only `{cfg}` ({len(got)}): " + ("; ".join(got) if got else "none"))
    return lines


def plot_profile(rows, path, title) -> None:
    """Dolan–Moré profiles over the local 3D cases, one per configuration, solved by the
    error and the units guard (a failure: infinite time).  Siconos' rows are left out: their
    times are cold single calls (:func:`report`)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    table = defaultdict(dict)
    for r in rows:
        if r["family"] == "local3":
            table[r["case"]][r["config"]] = r["time"] if r["solved"] else math.inf
    if not table:
        return
    taus, rho = performance_profile(table)
    tmax = max(4.0, float(taus[taus < math.inf][-1]) * 1.5)
    fig, ax = plt.subplots(figsize=(7.0, 4.6))
    for name in sorted(rho):
        x = np.concatenate([taus, [tmax]])
        y = np.concatenate([rho[name], [rho[name][-1]]])
        ax.step(x, y, where="post", label=name, lw=2.0,
                ls="-." if name.startswith("alart") else "-")
    ax.set_xscale("log", base=2)
    ax.set_xlim(1.0, tmax)
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("τ: time within this factor of the fastest")
    ax.set_ylabel("share of problems")
    ax.set_title(f"{title}\n{len(table)} local 3D cases, solved = error and guard <= tol",
                 fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--split", choices=("tune", "holdout", "all"), default="tune")
    ap.add_argument("--seeds", nargs="+", type=int, default=None,
                    help="a fresh draw of the manufactured families on these seeds instead")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--large", type=int, default=250)
    ap.add_argument("--large-time-limit", type=float, default=1.0)
    ap.add_argument("--max-contacts", type=int, default=None)
    ap.add_argument("--family", default="", help="only the cases whose id contains this")
    ap.add_argument("--equations", nargs="+", default=["alart_curnier", "natural_map"],
                    choices=sorted(SICONOS), help="the equations compared (Alart–Curnier "
                    "first: the others are set against it)")
    ap.add_argument("--siconos", action="store_true",
                    help="Siconos' Newton solvers on the same equations, local 3D cases")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--from-csv", action="store_true",
                    help="write the report and the figure from the run's CSVs")
    args = ap.parse_args(argv)
    args.configs = [(e, p) for p in POLICIES for e in args.equations]
    out = args.out if args.out.is_absolute() else HERE / args.out
    command = "python validation/nm_vs_ac.py " + " ".join(
        a for a in (argv if argv is not None else sys.argv[1:]) if a != "--from-csv")
    title = "Newton: " + " vs ".join(SHOWN[e] for e in args.equations) + ", " + (
        f"seeds {' '.join(map(str, args.seeds))}" if args.seeds else f"{args.split} split")
    if args.from_csv:
        rows, sic = read_rows(out)
        emit(report(rows, sic, args, command), out.with_suffix(".md"))
        plot_profile(rows, out.with_name(out.name + "_profile.png"), title)
        return 0
    if args.seeds:
        cases = evalset.manufactured_cases(shared_problems_dir(), seeds=args.seeds, scales=(),
                                          max_contacts=args.max_contacts)
    else:
        cases = evalset.manufactured_cases(shared_problems_dir(),
                                          max_contacts=args.max_contacts)
    if args.split != "all":
        cases = [c for c in cases if c.split == args.split]
    cases = [c for c in cases if args.family in c.case_id]
    socp_cd.warmup()
    rows, sic = [], []
    for c in cases:
        p = c.problem()
        limit = args.large_time_limit if c.n_contacts > args.large else args.time_limit
        rows += run_case(c, p, args.configs, args.tol, limit)
        if args.siconos and not p.is_global and p.dim == 3:
            names = [SICONOS[e] for e in args.equations]
            sic += [dict(r, time_limit=limit)
                    for r in siconos_rows(c.case_id, p, names, args.tol, limit)]
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out.with_suffix(".csv"))
    if sic:
        write_csv(sic, out.with_name(out.name + "_siconos.csv"))
    emit(report(rows, sic, args, command), out.with_suffix(".md"))
    plot_profile(rows, out.with_name(out.name + "_profile.png"), title)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

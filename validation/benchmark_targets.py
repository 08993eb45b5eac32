"""Issue #10's benchmark targets from one run of ``validation/newton_vs_siconos.py``.

Reads the run's CSV (``newton_vs_siconos.csv``) and writes, for the 3D local problems at
``--tol``: problems some Siconos solver solves and whether ``auto`` solves them; ``auto``'s
Dolan–Moré ρ(1) and ρ(4) against all Siconos solvers; the shifted geometric mean (10 ms) of
``auto`` and Siconos PROX over all problems and over the held-out, shared and tune groups;
the problems where ``auto`` takes more than 4× the fastest Siconos solver; and ``auto``
against the fastest Siconos solver on one-contact problems (those whose ``r = 0`` meets
``tol`` — the fastest Siconos solver under 1 µs — apart).  Same criteria as the run's own
report (solved: our recomputed Siconos error within ``tol``, in a time within the run's
limit; a failure charged the time limit in the geometric mean)::

    .venv/bin/python validation/benchmark_targets.py DIR/newton_vs_siconos.csv \\
        --time-limit 1 --out validation/results/benchmark_targets_s27.md
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from newton_vs_siconos import SGM_SHIFT, read_rows, solved  # noqa: E402  (the run's criteria)

from socp_cd.bench.reports import emit, performance_profile, shifted_geometric_mean  # noqa: E402

#: a problem whose fastest Siconos solver returns sooner than this (s) has ``r = 0`` for a
#: solution in the benchmark's draws (the one-contact grazing cases: Siconos stops at its
#: first error check); the one-contact figures set them apart
TRIVIAL = 1e-6


def solved_times(rows, tol, kind="local3", time_limit=math.inf):
    """``(table, nc)`` of a run's ``rows`` (:func:`read_rows`) of ``kind`` at ``tol``:
    ``table[(set, split, problem)][solver]`` the time when solved (:func:`solved`: within
    ``tol`` and the run's ``time_limit``), else inf, and ``nc`` the problems' contact counts."""
    table, nc = defaultdict(dict), {}
    for r in rows:
        if r["tol"] == tol and r["kind"] == kind:
            key = (r["set"], r["split"], r["problem"])
            table[key][r["solver"]] = r["time"] if solved(r, tol, time_limit) else math.inf
            nc[key] = r["nc"]
    return table, nc


def fastest_siconos(row) -> float:
    """The time of the fastest Siconos solver in ``row`` (``solver -> time``, inf: failed)."""
    return min((t for s, t in row.items() if s.startswith("siconos:")), default=math.inf)


#: the groups of the geometric means: held out (evaluation holdout + simulations), shared, tune
GROUPS = {"held out": {("eval", "holdout"), ("sim", "holdout")}, "shared": {("shared", "shared")},
          "tune": {("eval", "tune")}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", type=Path)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0, help="the run's (charged to a failure)")
    ap.add_argument("--label", default=None, help="the run's name in the title (default: the CSV)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    table, nc = solved_times(read_rows(args.csv), args.tol, time_limit=args.time_limit)
    sic = sorted({s for row in table.values() for s in row if s.startswith("siconos:")})
    probs = sorted(table)
    label = args.label or f"`{args.csv}`"
    lines = [f"# Issue #10's targets from {label} (3D local, tol {args.tol:g})", "",
             f"`python validation/benchmark_targets.py {args.csv} --time-limit "
             f"{args.time_limit:g}`; {len(probs)} problems.", ""]
    # every problem a Siconos solver solves
    any_sic = [pr for pr in probs if any(math.isfinite(table[pr].get(s, math.inf)) for s in sic)]
    missed = [pr[2] for pr in any_sic if not math.isfinite(table[pr].get("auto", math.inf))]
    lines.append(f"- solved by some Siconos solver: {len(any_sic)}; by `auto` too: "
                 f"{len(any_sic) - len(missed)}" + (f" (missed: {', '.join(missed)})" if missed else ""))
    # Dolan–Moré against all Siconos solvers
    sub = {pr: {k: v for k, v in row.items() if k == "auto" or k.startswith("siconos:")}
           for pr, row in table.items()}
    _, rho = performance_profile(sub, [1.0, 2.0, 4.0, 10.0])
    lines.append("- `auto` ρ(1) / ρ(2) / ρ(4) / ρ(10): " + " / ".join(f"{x:.2f}" for x in rho["auto"]))
    parts = []
    for name, groups in GROUPS.items():     # (the same profile, on each group's problems)
        _, rho_g = performance_profile({pr: row for pr, row in sub.items() if pr[:2] in groups},
                                       [1.0, 2.0, 4.0, 10.0])
        parts.append(f"{name} ({sum(pr[:2] in groups for pr in sub)}) "
                     + " / ".join(f"{x:.2f}" for x in rho_g["auto"]))
    lines.append("- the same by group: " + "; ".join(parts))
    # shifted geometric means

    def sgm(solver, keys):      # (a failure charged the time limit, as the run's report does)
        times = [table[k].get(solver, math.inf) for k in keys]
        return shifted_geometric_mean([t if math.isfinite(t) else args.time_limit for t in times],
                                      SGM_SHIFT)
    parts = [f"all ({len(probs)}) {sgm('auto', probs):.4f} / {sgm('siconos:prox', probs):.4f}"]
    for name, groups in GROUPS.items():
        keys = [pr for pr in probs if pr[:2] in groups]
        parts.append(f"{name} ({len(keys)}) {sgm('auto', keys):.4f} / "
                     f"{sgm('siconos:prox', keys):.4f}")
    lines.append("- shifted geometric mean (10 ms), `auto` / Siconos PROX [s]: " + "; ".join(parts))
    # beyond 4x the fastest Siconos solver
    beyond, ones, trivial = [], [], []
    for pr in any_sic:
        fastest = fastest_siconos(table[pr])
        ratio = table[pr].get("auto", math.inf) / fastest
        if ratio > 4:
            beyond.append((ratio, pr[2], nc[pr]))
        if nc[pr] == 1:
            (trivial if fastest < TRIVIAL else ones).append(ratio)
    lines.append(f"- beyond 4× the fastest Siconos solver: {len(beyond)} of {len(any_sic)}")
    lines += [f"  - {name} ({n} contacts): ×{ratio:.1f}" for ratio, name, n in sorted(beyond)[::-1]]
    if ones:
        lines.append(f"- one contact, `auto` / fastest Siconos: ×{min(ones):.2f}–{max(ones):.2f} "
                     f"(median ×{statistics.median(ones):.2f}), {sum(r <= 2 for r in ones)} of "
                     f"{len(ones)} within 2×" + (f"; {len(trivial)} with `r = 0` a solution: "
                                                 f"×{min(trivial):.1f}–{max(trivial):.1f}"
                                                 if trivial else ""))
    emit(lines, args.out)


if __name__ == "__main__":
    main()

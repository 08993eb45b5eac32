"""``auto`` against the fastest Siconos solver on one-contact 3D local problems, from benchmark CSVs.

Reads the CSVs of ``validation/newton_vs_siconos.py`` runs restricted to one contact
(``--max-contacts 1``; each run with Siconos in the same run) and writes, per run, the
ratio of ``auto``'s time to the fastest Siconos solver that reaches ``tol`` (by our
recomputed error), and, between the first run and each other, ``auto``'s time ratio::

    .venv/bin/python validation/newton_vs_siconos.py --n-eval 36 --time-limit 1 \\
        --max-contacts 1 --sweep --ours auto nsgs --out /tmp/one
    .venv/bin/python validation/one_contact_table.py A.csv B.csv --out table.md

A problem whose ``r = 0`` meets ``tol`` (the manufactured "grazing" cases on one contact:
the contact is separated at zero gap) is listed apart: Siconos returns it in ~0.3 µs.
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchmark_targets import TRIVIAL, fastest_siconos, solved_times  # noqa: E402
from newton_vs_siconos import read_rows  # noqa: E402  (the run's criteria)

from socp_cd.bench.reports import emit  # noqa: E402


def load(path: Path, tol: float) -> dict:
    """``(set, split, problem) -> {solver: time}`` (inf: not solved) of a run's one-contact 3D
    local problems at ``tol``."""
    table, nc = solved_times(read_rows(path), tol)
    return {k: row for k, row in table.items() if nc[k] == 1}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", nargs="+", type=Path)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    tol = args.tol
    runs = [load(p, tol) for p in args.csv]
    lines = [f"# `auto` against the fastest Siconos solver, one-contact 3D local problems "
             f"(tol {tol:g})", "",
             "`python validation/one_contact_table.py " + " ".join(p.name for p in args.csv)
             + "`; times in µs, each run's Siconos from that run. Trivial: the fastest Siconos "
             f"solver returns in under {TRIVIAL * 1e6:g} µs (in these runs, the one-contact grazing cases, whose "
             "`r = 0` meets `tol`).", "",
             "| run | problems | `auto` min / median / max | fastest Siconos, non-trivial: "
             "min / max | `auto` / fastest Siconos, non-trivial: min / median / max | within 2× | "
             "trivial: count, Siconos min / max, `auto` / Siconos median | `auto` / first run's "
             "(median) | Siconos / first run's (median, non-trivial) |",
             "|---|---|---|---|---|---|---|---|---|"]
    first = runs[0]
    first_sic = {k: fastest_siconos(v) for k, v in first.items()}
    for path, run in zip(args.csv, runs):
        ours = {k: v["auto"] for k, v in run.items() if "auto" in v}    # (inf: not solved)
        ratios, sic, triv, triv_ratio, sic_rel = [], [], [], [], []
        for k, t in ours.items():
            best = fastest_siconos(run[k])
            if best == math.inf:
                continue
            if best < TRIVIAL:
                triv.append(best)
                triv_ratio.append(t / best)
            else:
                ratios.append(t / best)
                sic.append(best)
                if TRIVIAL <= first_sic.get(k, math.inf) < math.inf:
                    sic_rel.append(best / first_sic[k])
        us = sorted(t * 1e6 for t in ours.values())
        rel = [ours[k] / first[k]["auto"] for k in ours if "auto" in first.get(k, {})]

        def med(x, fmt=".2f"):
            return format(statistics.median(x), fmt) if x else "–"

        def span(x, scale=1.0, fmt=".2f"):
            return f"{min(x) * scale:{fmt}} / {max(x) * scale:{fmt}}" if x else "–"
        lines.append(f"| {path.name} | {len(ours)} | {us[0]:.2f} / {med(us)} / {us[-1]:.2f} | "
                     f"{span(sic, 1e6)} | "
                     + (f"{min(ratios):.2f} / {med(ratios)} / {max(ratios):.2f}" if ratios else "–")
                     + f" | {sum(r <= 2 for r in ratios)} of {len(ratios)} | {len(triv)}, "
                     f"{span(triv, 1e6)}, {med(triv_ratio, '.1f')} | {med(rel, '.3f')} | "
                     f"{med(sic_rel, '.3f')} |")
    emit(lines, args.out)


if __name__ == "__main__":
    main()

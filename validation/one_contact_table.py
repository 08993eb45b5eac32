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
import csv
import statistics
from pathlib import Path

from socp_cd.bench.reports import emit


def load(path: Path, tol: str) -> dict:
    """problem -> {(solver, side): (time, error)} of the one-contact 3D local rows at ``tol``."""
    out = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            if r["tol"] != tol or r["nc"] != "1" or r["kind"] != "local3":
                continue
            err = float(r["error"]) if r["error"] else float("inf")
            out.setdefault(r["problem"], {})[(r["solver"], r["side"])] = (float(r["time"]), err)
    return out


def fastest_siconos(rows: dict, tol: float):
    """(solver, time) of the fastest Siconos solver reaching ``tol``, or None."""
    ok = [(t, s) for (s, side), (t, e) in rows.items() if side == "siconos" and e <= tol]
    return min(ok)[::-1] if ok else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", nargs="+", type=Path)
    ap.add_argument("--tol", default="1e-08")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    tol = float(args.tol)
    runs = [load(p, args.tol) for p in args.csv]
    lines = [f"# `auto` against the fastest Siconos solver, one-contact 3D local problems "
             f"(tol {args.tol})", "",
             "`python validation/one_contact_table.py " + " ".join(p.name for p in args.csv)
             + "`; times in µs, each run's Siconos from that run. Trivial: the fastest Siconos "
             "solver returns in under 1 µs (in these runs, the one-contact grazing cases, whose "
             "`r = 0` meets `tol`).", "",
             "| run | problems | `auto` min / median / max | fastest Siconos, non-trivial: "
             "min / max | `auto` / fastest Siconos, non-trivial: min / median / max | within 2× | "
             "trivial: count, Siconos min / max, `auto` / Siconos median | `auto` / first run's "
             "(median) | Siconos / first run's (median, non-trivial) |",
             "|---|---|---|---|---|---|---|---|---|"]
    first = runs[0]
    first_sic = {k: fastest_siconos(v, tol) for k, v in first.items()}
    for path, run in zip(args.csv, runs):
        ours = {k: v[("auto", "ours")][0] for k, v in run.items() if ("auto", "ours") in v}
        ratios, sic, triv, triv_ratio, sic_rel = [], [], [], [], []
        for k, t in ours.items():
            best = fastest_siconos(run[k], tol)
            if best is None:
                continue
            if best[1] < 1e-6:
                triv.append(best[1])
                triv_ratio.append(t / best[1])
            else:
                ratios.append(t / best[1])
                sic.append(best[1])
                if first_sic.get(k) is not None and first_sic[k][1] >= 1e-6:
                    sic_rel.append(best[1] / first_sic[k][1])
        us = sorted(t * 1e6 for t in ours.values())
        rel = [ours[k] / first[k][("auto", "ours")][0] for k in ours
               if ("auto", "ours") in first.get(k, {})]

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

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
             + "`; times in µs, each run's Siconos from that run.", "",
             "| run | problems | trivial (Siconos < 1 µs) | `auto` min / median / max | ratio to the "
             "fastest Siconos, non-trivial: min / median / max | within 2× | `auto` / first run's "
             "(median) |", "|---|---|---|---|---|---|---|"]
    first = runs[0]
    for path, run in zip(args.csv, runs):
        ours = {k: v[("auto", "ours")][0] for k, v in run.items() if ("auto", "ours") in v}
        ratios, trivial = [], 0
        for k, t in ours.items():
            best = fastest_siconos(run[k], tol)
            if best is None:
                continue
            if best[1] < 1e-6:
                trivial += 1
            else:
                ratios.append(t / best[1])
        us = sorted(t * 1e6 for t in ours.values())
        rel = [ours[k] / first[k][("auto", "ours")][0] for k in ours if k in first]
        lines.append(f"| {path.name} | {len(ours)} | {trivial} | {us[0]:.2f} / "
                     f"{statistics.median(us):.2f} / {us[-1]:.2f} | {min(ratios):.2f} / "
                     f"{statistics.median(ratios):.2f} / {max(ratios):.2f} | "
                     f"{sum(r <= 2 for r in ratios)} of {len(ratios)} | "
                     f"{statistics.median(rel):.3f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()

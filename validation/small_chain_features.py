"""Which tune problems of 11–100 contacts `newton` alone solves faster than `auto`, by a cheap feature.

A design study for the small chain's order (formulations/auto.md, "The small chain's size
bound, re-measured", session 32), run on the *tune* split only: it reads an
``auto_chain.py`` run that timed ``now`` (``auto``) and ``solver=newton`` on the same cases,
computes each 3D case's stored ``W`` blocks per contact (``nnzb / n_contacts``, the number of
contacts each contact's row couples to, itself included), and prints, per band of that
feature, how often and by how much ``newton`` alone is faster; then an estimate of a rule
"Newton first where the feature is at least ``--threshold``, the current chain after a failed
Newton": the case's time is ``newton``'s where it solved, ``auto``'s plus ``--penalty``
seconds (the failed Newton run) where it did not. The estimate is optimistic in one way: a
failed Newton run inside the chain would be capped, and its cost is a guess::

    .venv/bin/python validation/auto_chain.py --split tune --configs now solver=newton \\
        solver=nsgs --sets shared eval reframed --sim evalset_sim_small_tune evalset_sim_tune \\
        --min-contacts 10 --max-contacts 100 --time-limit 1 --tag _s32newton
    .venv/bin/python validation/small_chain_features.py \\
        validation/results/auto_chain_tune_s32newton.csv

Prints a Markdown report (``--out`` writes it too).
"""
from __future__ import annotations

import argparse
import csv
import math
import statistics
import sys
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from auto_probe import items  # noqa: E402

from socp_cd.bench.reports import emit, shifted_geometric_mean  # noqa: E402
from socp_cd.solvers.block_storage import csr_to_bsr  # noqa: E402

VAL = Path(__file__).resolve().parent
BANDS = ((1, 2), (2, 4), (4, 6), (6, 9), (9, 10 ** 6))
FAILED = 2.0        # seconds counted for an unsolved case (2x the runs' 1 s budget)


def blocks_per_contact(p) -> float:
    """Stored ``dim x dim`` blocks of ``W`` per contact (NSGS's block storage: its block rows'
    distinct block columns, :func:`~socp_cd.solvers.block_storage.csr_to_bsr`)."""
    indptr, indices, data = p.csr_parts
    bptr = csr_to_bsr(indptr, indices, data, p.dim, p.n_contacts)[0]
    return int(bptr[-1]) / p.n_contacts


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("csv", type=Path)
    ap.add_argument("--threshold", type=float, default=9.0)
    ap.add_argument("--penalty", type=float, nargs="+", default=[0.0, 5e-4, 2e-3])
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    by = defaultdict(dict)
    with open(args.csv) as fh:
        for r in csv.DictReader(fh):
            by[r["case"]][r["config"]] = (float(r["time"]) if r["solved"] == "True" else math.inf)
    its = items("tune", 100, 10, sets=("shared", "eval", "reframed", "sim"),
                sims=[VAL / "evalset_sim_small_tune", VAL / "evalset_sim_tune"])
    cases = [(cid, blocks_per_contact(p), by[cid]["now"], by[cid]["solver=newton"])
             for _, cid, p in its if p.dim == 3 and cid in by
             and {"now", "solver=newton"} <= set(by[cid])]
    lines = [f"# `newton` alone against `auto` by W's blocks per contact (tune, 3D, 11–100 "
             f"contacts, {len(cases)} cases)", "",
             f"`python validation/small_chain_features.py {args.csv.name}`", "",
             "| blocks per contact | cases | `newton` faster | median `newton` / `auto` | "
             "`newton` unsolved |", "|---|---|---|---|---|"]
    for lo, hi in BANDS:
        g = [c for c in cases if lo <= c[1] < hi]
        if not g:
            continue
        ratios = [c[3] / c[2] for c in g if c[2] < math.inf and c[3] < math.inf]
        lines.append(f"| {lo}–{hi if hi < 10 ** 6 else '…'} | {len(g)} | "
                     f"{sum(x < 1 for x in ratios)} | "
                     f"{statistics.median(ratios):.2f} | {sum(c[3] == math.inf for c in g)} |")
    lines += ["", f"Estimate of Newton first at ≥ {args.threshold:g} blocks per contact "
              "(sgm with a 10 ms / 0.1 ms shift; unsolved counted as "
              f"{FAILED:g} s):", "",
              "| failed Newton's cost [s] | sgm now | sgm rule | sgm now (0.1 ms) | "
              "sgm rule (0.1 ms) | faster than ×0.8 | slower than ×1.2 |",
              "|---|---|---|---|---|---|---|"]
    for pen in args.penalty:
        base, rule = [], []
        for _, f, ta, tn in cases:
            tb = ta if ta < math.inf else FAILED
            base.append(tb)
            rule.append((tn if tn < math.inf else tb + pen) if f >= args.threshold else tb)
        lines.append(f"| {pen:g} | {shifted_geometric_mean(base, 0.01):.5f} | "
                     f"{shifted_geometric_mean(rule, 0.01):.5f} | "
                     f"{shifted_geometric_mean(base, 1e-4):.6f} | "
                     f"{shifted_geometric_mean(rule, 1e-4):.6f} | "
                     f"{sum(r < 0.8 * b for r, b in zip(rule, base))} | "
                     f"{sum(r > 1.2 * b for r, b in zip(rule, base))} |")
    emit(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""NSGS alone with over-relaxation after plain first sweeps: sweeps to ``tol`` on the tune split.

Session 33's first measurement for the over-relaxed NSGS stages (``formulations/auto.md``,
"Over-relaxed NSGS stages"): each tune case (3D, local, up to 100 contacts: shared, eval,
reframed and the small tune simulations) is solved by NSGS from ``r = 0`` with ``omega = 1``
for ``--plain`` sweeps, then, unless that met ``tol``, from that iterate with ``omega`` for
the rest of ``--max-iter`` sweeps (two calls through the public API, ``r0``); ``omega = 1``
is one call.  Prints, per band of contacts, the sweeps to ``tol`` relative to ``omega = 1``
(median and geometric mean over the cases both solve) and the cases solved or lost::

    .venv/bin/python validation/nsgs_relaxation.py --out validation/results/nsgs_relaxation_s33.md
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from auto_probe import items  # noqa: E402

import socp_cd  # noqa: E402
from socp_cd.bench.reports import emit  # noqa: E402

VAL = Path(__file__).resolve().parent
OMEGAS = (1.0, 1.2, 1.3, 1.4, 1.5)


def sweeps_to_tol(p, omega, plain, tol, max_iter) -> float:
    """Sweeps NSGS needs to meet ``tol`` (inf: not within ``max_iter``), ``omega`` after
    ``plain`` sweeps without it."""
    if omega == 1.0:
        r = socp_cd.solve(p, "nsgs", tol=tol, max_iter=max_iter)
        return r.iterations if r.converged else math.inf
    r = socp_cd.solve(p, "nsgs", tol=tol, max_iter=plain)
    if r.converged:
        return r.iterations
    r2 = socp_cd.solve(p, "nsgs", tol=tol, omega=omega, max_iter=max_iter - plain, r0=r.r)
    return plain + r2.iterations if r2.converged else math.inf


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plain", type=int, default=10)
    ap.add_argument("--max-iter", type=int, default=1000)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    its = items("tune", 100, 1, sets=("shared", "eval", "reframed", "sim"),
                sims=[VAL / "evalset_sim_small_tune", VAL / "evalset_sim_tune"])
    rows = [(p.n_contacts, [sweeps_to_tol(p, om, args.plain, args.tol, args.max_iter)
                            for om in OMEGAS]) for _, _, p in its if p.dim == 3]
    lines = [f"# NSGS alone, `omega` after {args.plain} plain sweeps (tune, 3D, tol "
             f"{args.tol:g}, at most {args.max_iter} sweeps)", "",
             "`python validation/nsgs_relaxation.py`; sweeps to `tol` relative to "
             "`omega = 1` over the cases both solve.", "",
             "| contacts | cases | `omega` | solved | newly solved / lost | median | geometric "
             "mean | faster than ×0.8 / slower than ×1.2 |", "|---|---|---|---|---|---|---|---|"]
    for lo, hi in ((1, 10), (11, 100)):
        sel = [row for nc, row in rows if lo <= nc <= hi]
        for j, om in enumerate(OMEGAS[1:], start=1):
            both = [r[j] / r[0] for r in sel if math.isfinite(r[0]) and math.isfinite(r[j])]
            won = sum(1 for r in sel if math.isfinite(r[j]) and not math.isfinite(r[0]))
            lost = sum(1 for r in sel if math.isfinite(r[0]) and not math.isfinite(r[j]))
            geo = math.exp(sum(map(math.log, both)) / len(both))
            lines.append(f"| {lo}–{hi} | {len(sel)} | {om:g} | "
                         f"{sum(math.isfinite(r[j]) for r in sel)} | {won} / {lost} | "
                         f"{statistics.median(both):.2f} | {geo:.2f} | "
                         f"{sum(x < 0.8 for x in both)} / {sum(x > 1.2 for x in both)} |")
    emit(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Newton's ``policy="prox_error"`` (Siconos PROX) in the units as written against the balanced units.

``solve`` hands every backend the dispatcher's balanced copy of a local problem.  PROX's
proximal term ``alpha (r - r_k)`` is added to the velocity, so its metric depends on the
units: Siconos runs it on the problem as written.  ``newton.error_prox`` runs it in the
units as written (``written=``, the default through ``solve``); this script compares that
with the same loop in the balanced units (the backend called on the balanced copy, with and
without its record of the units as written), from ``r = 0``, on the capsule-pile cases that
``solver="auto"``'s order leaves unsolved (the manufactured evaluation set's, seeds 0-3,
and the fresh draw's, seeds 30-33, of ``validation/fresh_draw.py``), and with the stall
window off and on::

    python validation/prox_error_units.py --out results/prox_error_units_s34.md
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.reports import emit
from socp_cd.data import shared_problems_dir
from socp_cd.solvers import newton
from socp_cd.solvers.newton import newton_backend
from socp_cd.solvers.scaling import balanced

HERE = Path(__file__).resolve().parent
CASES = (
    "real-manufactured/Capsules-i122-1617.dat/mu0.1-mixed-s32",
    "real-manufactured/Capsules-i122-1617.dat/mu2-mixed-s32",
    "real-manufactured/Capsules-i122-1617.dat/mu2-sliding-s30",
    "real-manufactured/Capsules-i122-1617.dat/mu2-sticking-s33",
    "real-manufactured/Capsules-i125-1213.hdf5/mu2-sliding-s30",
    "real-manufactured/Capsules-i122-1617.dat/mu2-mixed-s0",
    "real-manufactured/Capsules-i122-1617.dat/mu2-sliding-s2",
    "real-manufactured/Capsules-i122-1617.dat/mu1-sliding-s2",
    "real-manufactured/Capsules-i125-1213.hdf5/mu2-sliding-s2",
    "real-scaled/Capsules-i122-1617.dat/Wqx1e+06",
    "real-scaled/Capsules-i122-1617.dat/Wqx1e-06",
)


def run(p, units, stall, limit, tol):
    """``(solved, error, guard, outer iterations, seconds)`` of one run from ``r = 0``."""
    rec = balanced(p)
    # the balanced copy as the dispatcher hands it (its record of the units as written), or
    # a new object with the same data (no record: the loop in the balanced units); the same
    # backend call either way
    copy = rec.problem if units == "written" else rec.problem.with_()
    newton.PROX_BALANCED_FALLBACK = False       # (the written run alone, as measured)
    try:
        t0 = time.perf_counter()
        res = newton_backend(copy, "coulomb", tol=tol, max_iter=1000, policy="prox_error",
                             stall_window=stall, time_limit=limit)
        dt = time.perf_counter() - t0
    finally:
        newton.PROX_BALANCED_FALLBACK = True
    r = rec.a * res.r
    err = float(socp_cd.error(p, r))
    guard = float(socp_cd.guard(p, r)["value"])
    return max(err, guard) <= tol, err, guard, res.iterations, dt


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    data = shared_problems_dir()
    found = {c.case_id: c for c in evalset.manufactured_cases(data)}
    found.update({c.case_id: c for c in evalset.manufactured_cases(
        data, seeds=range(30, 34), scales=())})
    socp_cd.warmup()
    configs = [("written", 0), ("written", 50), ("balanced", 0)]
    lines = [f"# `policy=\"prox_error\"`: units as written vs balanced (tol {args.tol:g}, "
             f"{args.time_limit:g} s, from r = 0)", "",
             "`python validation/prox_error_units.py" + (f" --out {args.out}" if args.out else "")
             + "`. Solved: Siconos' error and the units guard within tol. Each cell: error / "
             "guard, outer iterations, seconds.", "",
             "| case | " + " | ".join(f"{u}, stall {s or 'off'}" for u, s in configs) + " |",
             "|---|" + "---|" * len(configs)]
    wins = [0] * len(configs)
    for cid in CASES:
        p = found[cid].problem()
        cells = []
        for k, (units, stall) in enumerate(configs):
            ok, err, guard, its, dt = run(p, units, stall, args.time_limit, args.tol)
            wins[k] += ok
            cells.append(f"{'**' if ok else ''}{err:.1e} / {guard:.1e}{'**' if ok else ''}, "
                         f"{its}, {dt:.2f}")
            print(cid, units, stall, ok, f"{err:.1e} {guard:.1e} {its} {dt:.2f}", flush=True)
        lines.append(f"| {cid} | " + " | ".join(cells) + " |")
    lines += ["", "Solved: " + ", ".join(f"{u} stall {s or 'off'} {w} of {len(CASES)}"
                                        for (u, s), w in zip(configs, wins)) + "."]
    out = None if args.out is None else (args.out if args.out.is_absolute() else HERE / args.out)
    emit(lines, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

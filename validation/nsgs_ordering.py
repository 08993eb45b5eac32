"""NSGS sweeps to tol in natural, reversed and symmetric (alternating) contact order.

Symmetric Gauss–Seidel (a forward sweep, then a backward one) is a textbook way to speed up
Gauss–Seidel when information must travel both ways through a chain of unknowns, as the
load does through a stack of boxes.  This script counts NSGS's sweeps from ``r = 0`` to
``tol`` (Siconos' error and the units guard) with three orders: the natural one, the
reversed one, and the two alternating (odd sweeps natural, even sweeps reversed).  A sweep
is one call ``solve(p, "nsgs", max_iter=1, r0=r)`` on the problem or on its copy with the
contacts renumbered backwards (``socp_cd.bench.transforms.permuted``), so the iterates are
NSGS's own; on the tune split's 3D local problems of 4-100 contacts::

    python validation/nsgs_ordering.py --out results/nsgs_ordering_s34.md
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.reports import emit
from socp_cd.bench.transforms import permuted

from auto_probe import items

HERE = Path(__file__).resolve().parent
ORDERS = ("natural", "reversed", "symmetric")


def sweeps_to_tol(p, back, order, tol, cap):
    """Sweeps of NSGS from ``r = 0`` until Siconos' error and the units guard are within
    ``tol`` (``inf`` after ``cap``); ``back`` is ``p`` with its contacts numbered backwards."""
    nc, d = p.n_contacts, p.dim
    r = np.zeros(p.m)
    for k in range(1, cap + 1):
        if order == "reversed" or (order == "symmetric" and k % 2 == 0):
            flipped = r.reshape(nc, d)[::-1].ravel().copy()
            res = socp_cd.solve(back, "nsgs", max_iter=1, r0=flipped, tol=1e-30)
            r = res.r.reshape(nc, d)[::-1].ravel().copy()
        else:
            r = socp_cd.solve(p, "nsgs", max_iter=1, r0=r, tol=1e-30).r.copy()
        if max(socp_cd.error(p, r), socp_cd.guard(p, r)["value"]) <= tol:
            return k
    return math.inf


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--cap", type=int, default=400)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    sims = [HERE / "evalset_sim_small_tune", HERE / "evalset_sim_tune"]
    probs = [(cid, p) for _, cid, p in items("tune", 100, 3, sets=("shared", "eval", "sim"),
                                             sims=sims) if p.dim == 3]
    socp_cd.warmup()
    counts = {o: [] for o in ORDERS}
    for cid, p in probs:
        back = permuted(p, np.arange(p.n_contacts)[::-1])
        back = back[0] if isinstance(back, tuple) else back
        for o in ORDERS:
            counts[o].append(sweeps_to_tol(p, back, o, args.tol, args.cap))
        print(cid, p.n_contacts, [counts[o][-1] for o in ORDERS], flush=True)
    both = [i for i in range(len(probs)) if all(math.isfinite(counts[o][i]) for o in ORDERS)]
    lines = [f"# NSGS's sweeps to tol {args.tol:g} by contact order (tune split, 3D, 4-100 "
             f"contacts, cap {args.cap})", "",
             "`python validation/nsgs_ordering.py" + (f" --out {args.out}" if args.out else "")
             + "`", "",
             "| order | solved within the cap | geometric mean of sweeps where all three solve |",
             "|---|---|---|"]
    for o in ORDERS:
        solved = sum(math.isfinite(x) for x in counts[o])
        gm = math.exp(np.mean([math.log(counts[o][i]) for i in both])) if both else math.nan
        lines.append(f"| {o} | {solved} of {len(probs)} | {gm:.1f} ({len(both)} problems) |")
    ratio = [counts["symmetric"][i] / counts["natural"][i] for i in both]
    lines += ["", f"Symmetric over natural, per problem where all three solve: median "
              f"×{np.median(ratio):.2f}, min ×{min(ratio):.2f}, max ×{max(ratio):.2f}."]
    out = None if args.out is None else (args.out if args.out.is_absolute() else HERE / args.out)
    emit(lines, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""NSGS's compiled work on real problems, for interleaved rounds of two source trees.

Prints one line per run: for each problem, the min over repeats (µs) of

* ``sweep``: one NSGS sweep (the difference of 3 and 1 sweeps of
  :func:`socp_cd.solvers.nsgs_kernels.nsgs_loop` from the same start, error
  checks off), divided by the contacts: the per-contact cost of a local solve
  and its free velocity (ns); since session 29 a block-diagonal ``W`` (a sphere
  pile on its floor) has its full error computed after every sweep, so there the
  figure includes it;
* ``nsgs``: a whole ``socp_cd.solve(copy.copy(p), "nsgs", time_limit=1)``,
  the benchmark's call (the copy made before the timer).

Compare two trees in alternating rounds on the same machine (session 10's
README table: three rounds each)::

    for k in 1 2 3; do for d in /tmp/old_tree $PWD; do
        PYTHONPATH=$d python validation/nsgs_kernel_speed.py; done; done

Appends each line, with the tree it ran, to ``validation/results/nsgs_kernel_speed.txt``.
The simulation dumps come from ``validation/build_sim_collections.py``
(``validation/evalset_sim``); a problem whose file is absent is skipped.
"""
from __future__ import annotations

import copy
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench.evalset import collection_cases
from socp_cd.data import shared_problems_dir
from socp_cd.solvers import nsgs_kernels as nk
from socp_cd.solvers.block_storage import csr_to_bsr
from socp_cd.solvers.kernels.cone import LAW_COULOMB
from socp_cd.solvers.kernels.scaling import balance_csr

HERE = Path(__file__).resolve().parent
SHARED = ["Capsules-i122-1617.dat", "OneObject-i1028-138.hdf5.dat", "BoxesStack1-i100000-32.hdf5.dat",
          "LMGC_100_PR_PerioBox-i00361-60-03000.hdf5", "Confeti-ex03-Fc3D-SBM.dat",
          "fc2d_granularflowonwall_00667_00000.dat"]
SIM = ["SpherePile-i00001-301-01350", "SpherePile-i00040-317-00300",
       "Deposit2D1000-i00001-1765-01000"]


def problems():
    """``(label, problem)`` of the shared files and simulation dumps that exist here."""
    out = [(n.split("-")[0].split(".")[0], socp_cd.read_problem(shared_problems_dir() / n))
           for n in SHARED if (shared_problems_dir() / n).exists()]
    sim = HERE / "evalset_sim"
    if sim.is_dir():
        cases = [c for sub in sorted({p.parent for p in sim.rglob("*.hdf5")})
                 for c in collection_cases(sub)]
        for name in SIM:
            hit = [c for c in cases if name in c.case_id]
            if hit:
                out.append((name, hit[0].problem()))
    return out


def sweep_ns(p, repeats=7) -> float:
    """ns per contact of one NSGS sweep on the balanced problem (3 sweeps minus 1, min)."""
    d, nc = p.dim, p.n_contacts
    indptr, indices, data = p.csr_parts
    _, _, data_s, q_s, *_ = balance_csr(indptr, indices, data, p.q, p.mu, d)
    bptr, bcol, blocks, _, diag = csr_to_bsr(indptr, indices, data_s, d, nc)
    rho_n, rho_t, rho_p, _ = nk.local_parameters(diag, blocks)
    W = nk.BlockW(bptr, bcol, blocks, diag)
    law = nk.Law(np.ascontiguousarray(p.mu, dtype=np.float64), np.zeros(nc), LAW_COULOMB)
    local = nk.LocalSolver(0 if d == 2 else 1, rho_n, rho_t, rho_p, 1e-13, 10, 100)
    hist = np.full(1, np.nan)

    def run(n):
        r = np.zeros(p.m)
        t0 = time.perf_counter()
        nk.nsgs_loop(d, W, q_s, law, local, nk.Sweeps(0.0, n, 1.0, False, 0, 0, 0, False, 0, n, -1.0, np.inf), r, hist,
                     nk.no_origin())
        return time.perf_counter() - t0

    run(3)
    best = {n: min(run(n) for _ in range(repeats)) for n in (1, 3)}
    return (best[3] - best[1]) / 2 / nc * 1e9


def solve_us(p, repeats=20) -> float:
    """Min wall time (µs) of the benchmark's NSGS call, a new problem object per call."""
    socp_cd.solve(copy.copy(p), "nsgs", time_limit=1.0)
    best = np.inf
    for _ in range(repeats):
        target = copy.copy(p)
        t0 = time.perf_counter()
        socp_cd.solve(target, "nsgs", time_limit=1.0)
        best = min(best, time.perf_counter() - t0)
    return best * 1e6


def main() -> int:
    parts = [f"{label}:{sweep_ns(p):.0f}ns/{solve_us(p):.0f}us" for label, p in problems()]
    line = f"{Path(socp_cd.__file__).resolve().parents[1]} " + " ".join(parts)
    print(line)
    (HERE / "results").mkdir(exist_ok=True)
    with open(HERE / "results" / "nsgs_kernel_speed.txt", "a") as fh:
        fh.write(line + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

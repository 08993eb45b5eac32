"""Where a one-contact ``solve`` call's time goes, layer by layer (the one-contact target).

Issue #10 asks a one-contact problem to cost at most 2x Siconos' per-call time; Siconos
NSGS solves the sticking copies in 1.83-2.14 us (``results/one_contact_s32``), so a call
would need to take at most ~3.7 us.  This script times, on ``FrictionContact3D_1c``, the
nested layers of a plain ``solve`` (min over loops of many calls, garbage collection off,
``socp_cd.warmup()`` first):

* ``solve(copy)``: the benchmark's call (a new problem object each time, ``time_limit=1``);
* ``auto.plain(copy)``: without the dispatcher's layer;
* the flat kernel's call as ``auto.plain`` makes it (its output array, the entry point);
* the same kernel call on fixed arguments;
* inside the kernel, compiled loops over all its work (``nsgs_route.checked_work``: the
  balancing, the block storage, the sweeps and the checks) and over the set-up pieces that
  allocate their outputs (the balancing, the block storage, the one-contact steps);
* the unboxing of the 24 arguments the flat kernel took until session 33 against a
  10-argument form with its settings packed into one array (two trivial compiled functions
  with those types; the flat kernel takes 11 since session 33).

Prints a Markdown table (``--out`` writes it too)::

    .venv/bin/python validation/per_call_parts.py --out validation/results/per_call_parts_s33.md
"""
from __future__ import annotations

import argparse
import copy
import gc
import time
from pathlib import Path

import numpy as np
from numba import njit, types

import socp_cd
from socp_cd.data import shared_problems_dir
from socp_cd.bench.reports import emit
from socp_cd.solvers import auto, nsgs, nsgs_route
from socp_cd.solvers.block_storage import csr_to_bsr
from socp_cd.solvers.kernels.scaling import balance_csr
from socp_cd.solvers.nsgs_kernels import local_parameters

PROBLEM = "FrictionContact3D_1c.dat"


def per_call(fn, make, number, loops) -> float:
    """µs per call of ``fn(x)`` over ``number`` arguments ``make()`` made outside the timer
    (min over ``loops``)."""
    best = np.inf
    for _ in range(loops):
        args = [make() for _ in range(number)]
        gc.disable()
        try:
            t0 = time.perf_counter()
            for a in args:
                fn(a)
            best = min(best, (time.perf_counter() - t0) / number)
        finally:
            gc.enable()
    return best * 1e6


@njit(cache=True)
def _balance(indptr, indices, data, q, mu, dim, n):
    s = 0.0
    for _ in range(n):
        s += balance_csr(indptr, indices, data, q, mu, dim)[4]
    return s


@njit(cache=True)
def _blocks(indptr, indices, data, dim, nc, n):
    s = 0
    for _ in range(n):
        s += csr_to_bsr(indptr, indices, data, dim, nc)[0][-1]
    return s


@njit(cache=True)
def _steps(indptr, indices, data, dim, nc, n):
    diag, blocks = csr_to_bsr(indptr, indices, data, dim, nc)[4], \
        csr_to_bsr(indptr, indices, data, dim, nc)[2]
    s = 0.0
    for _ in range(n):
        s += local_parameters(diag, blocks)[0][0]
    return s


@njit(cache=True)
def _work(indptr, indices, data, q, mu, tail, vectors, stats, n):
    s = 0
    for _ in range(n):
        stats[:] = 0.0
        s += nsgs_route.checked_work(indptr, indices, data, q, mu, 3, False, 1e-8, 1000, True,
                                     10, 0.5, tail[0], tail[1], tail[2], tail[3], tail[4],
                                     tail[5], tail[6], tail[7], tail[8], tail[9], tail[10],
                                     vectors, stats)
    return s


@njit
def _many(a, b, c, d, e, s1, s2, s3, s4, s5, s6, s7, s8, s9, s10, s11, s12, s13, s14, s15,
          s16, s17, s18, out):
    out[0, 0] = s3
    return 1, 2, 0.5, 0.5, 0.5, 0.5


@njit
def _few(a, b, c, d, e, params, s1, s2, s3, out):
    out[0, 0] = params[3]
    return 1, 2, 0.5, 0.5, 0.5, 0.5


def in_loop_ns(fn, args, n=200000) -> float:
    """ns per iteration of a compiled loop ``fn(*args, n)``."""
    fn(*args, 10)
    t0 = time.perf_counter()
    fn(*args, n)
    return (time.perf_counter() - t0) / n * 1e9


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--number", type=int, default=20000)
    ap.add_argument("--loops", type=int, default=15)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    socp_cd.warmup()
    p0 = socp_cd.read_problem(shared_problems_dir() / PROBLEM)
    for _ in range(1000):
        socp_cd.solve(copy.copy(p0), time_limit=1.0)
    fresh = lambda: copy.copy(p0)           # noqa: E731
    plan = auto.small_plan(3)              # (the plan auto.plain reads)
    indptr, indices, data = p0.csr_parts
    q, mu = p0.q, p0.mu
    m = q.shape[0]
    rows = (3 - (-nsgs_route.N_OUT // m))
    kernel = nsgs_route.flat_entry(indptr, indices)

    def plain_kernel(p):
        ip, ix, dt = p.csr_parts
        out = np.empty((rows, m))
        return kernel(ip, ix, dt, p.q, p.mu, plan[3], False, 1e-8, True, 0.5, out)
    out = np.empty((rows, m))
    # (the tuple form's 11 trailing settings: the compiled loop's call and the 24-argument
    # comparison)
    tail = nsgs_route.prepared(nsgs.route_settings(3), True, plan[2], auto.HANDOFF_PREDICT)
    b, i, f = types.boolean, types.int64, types.float64
    iv, fv = types.Array(types.int32, 1, "C"), types.Array(types.float64, 1, "C")
    many = _many.compile((iv, iv, fv, fv, fv, i, b, f, i, b, i, f, i, f, i, i, f, i, i, b, i, i,
                          i, types.Array(types.float64, 2, "C")))
    few = _few.compile((iv, iv, fv, fv, fv, fv, f, b, f, types.Array(types.float64, 2, "C")))
    ia, fa, params, o2 = np.zeros(2, np.int32), np.zeros(3), np.zeros(18), np.zeros((8, 3))
    n, lp = args.number, args.loops
    rows_out = [
        ("`solve(copy)`, `time_limit=1`", per_call(
            lambda p: socp_cd.solve(p, time_limit=1.0), fresh, n, lp)),
        ("`auto.plain(copy)`", per_call(
            lambda p: auto.plain(p, 1e-8, 1.0, time.perf_counter()), fresh, n, lp)),
        ("the flat kernel's call as `auto.plain` makes it", per_call(plain_kernel, fresh, n, lp)),
        ("the same kernel call, fixed arguments", per_call(
            lambda _: kernel(indptr, indices, data, q, mu, plan[3], False, 1e-8, True, 0.5, out),
            lambda: None, n, lp)),
        ("unboxing 24 arguments (a trivial kernel of the same types)", per_call(
            lambda _: many(ia, ia, fa, fa, fa, 3, False, 1e-8, 1000, True, 10, 0.5, *tail, o2),
            lambda: None, n, lp)),
        ("unboxing 10 arguments (the settings in one array)", per_call(
            lambda _: few(ia, ia, fa, fa, fa, params, 1e-8, True, 0.5, o2), lambda: None, n, lp)),
        ("in the kernel: all its work (`nsgs_route.checked_work`, compiled loop)",
         in_loop_ns(_work, (indptr, indices, data, q, mu, tail, np.empty((3, m)),
                            np.zeros(nsgs_route.N_OUT))) / 1e3),
        ("in the kernel: the balancing (`balance_csr`, compiled loop)",
         in_loop_ns(_balance, (indptr, indices, data, q, mu, 3)) / 1e3),
        ("in the kernel: the block storage (`csr_to_bsr`)",
         in_loop_ns(_blocks, (indptr, indices, data, 3, 1)) / 1e3),
        ("in the kernel: the one-contact steps (`local_parameters`)",
         in_loop_ns(_steps, (indptr, indices, data, 3, 1)) / 1e3),
    ]
    lines = [f"# Where a one-contact call's time goes (`{PROBLEM}`)", "",
             f"`python validation/per_call_parts.py`: µs per call, min over {lp} loops of {n} "
             "calls (the compiled pieces: per iteration of a compiled loop).", "",
             "| layer | µs |", "|---|---|"]
    lines += [f"| {name} | {us:.2f} |" for name, us in rows_out]
    emit(lines, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

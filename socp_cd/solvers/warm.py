"""Load every compiled kernel a solve may reach, before a timed or time-limited call.

The kernels are compiled by numba on their first call and cached on disk
(``__pycache__`` beside the sources): the first call in a process *loads* them
(0.3–1 s in all), the first call after an install or a cache clear *compiles* them
(tens of seconds in all).  Either happens inside whichever call first reaches a kernel,
where no ``time_limit`` check can stop it: in session 33 one ``solver="auto"`` call under
a 1 s budget took 8.4 s right after the cache was cleared, a 38-contact problem that takes
4 ms warm.  :func:`warmup` makes those first calls on tiny problems, once per process, so
that later calls keep their budgets and their timings are the solvers' own.
"""
from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..problem import FrictionContactProblem, GlobalFrictionContactProblem
from . import auto, newton, nsgs, projection
from .registry import solve

#: the stages of ``solver="auto"`` run one by one (its ``methods`` option): the general path
#: of each, on top of the plain calls' compiled routes
AUTO_STAGES = ("lemke", "nsgs", "newton_trial", "newton_trial_cold", "newton_trial_prox", "newton",
               "newton_plain", "newton_plain_cold", "newton_plain_cold_split", "newton_cold_alt",
               "newton_prox_error", "nsgs_probe", "clarabel", "clarabel_first", "clarabel_qp")

_DONE: list = []


def _local(nc, dim, seed):
    """A small local problem with approaching contacts and coupled, well-posed ``W``.  (One
    is enough for every form of the caller's arrays: a problem holds its CSR indices as
    int32 and its arrays writable whatever it was given, so the kernels have one compiled
    version each; ``tests/test_warm.py`` checks int64 indices and read-only data.)"""
    rng = np.random.default_rng(seed)
    m = nc * dim
    A = rng.standard_normal((m, m))
    W = sp.csr_matrix(A @ A.T / m + np.eye(m))
    q = rng.standard_normal(m)
    q[::dim] -= 1.0
    return FrictionContactProblem(W, q, 0.3, dim)


def _sparse(dim, seed):
    """A local problem of more than ``newton.DENSE_MAX_M`` unknowns whose ``W`` couples each
    contact to its neighbours only: the Newton backend's sparse path (the ordering by SuperLU, the
    Jacobian's block kernels, the compiled left-looking LU its pattern takes)."""
    nc = newton.DENSE_MAX_M // dim + 10
    m = nc * dim
    rng = np.random.default_rng(seed)
    band = sp.diags([np.full(m - dim, -0.1), np.full(m, 2.0), np.full(m - dim, -0.1)],
                    [-dim, 0, dim], format="csr")
    q = rng.standard_normal(m)
    q[::dim] -= 1.0
    return FrictionContactProblem(band, q, 0.3, dim)


def warmup(force: bool = False) -> float:
    """Load (or compile) every compiled kernel that :func:`~socp_cd.solve` may reach; returns
    the seconds this call took (0 after the first call in a process, unless ``force``).

    On tiny local problems in 2D and 3D: the plain calls of ``auto``, ``nsgs``, ``newton``
    and ``projection`` (the compiled routes; ``auto``'s Lemke stage in 2D), ``lemke``, with a
    time limit, with ``r0`` and ``max_iter``, Newton's ``history``, each of ``auto``'s stages (:data:`AUTO_STAGES`, at a
    tolerance no stage meets, with and without a time limit); the backends' own warm-ups
    (:func:`socp_cd.solvers.newton.warmup`, ``nsgs``'s, ``projection``'s); a Newton system
    of more than 60 unknowns (it factorizes with one BLAS thread, whose controller is built
    on first use); a sparse one of more than ``newton.DENSE_MAX_M`` unknowns through
    ``newton`` and ``clarabel`` (the sparse LU, the Jacobian's block kernels, the Newton polish
    outside the compiled loop) and ``auto``'s redundancy feature; a global problem through ``auto``, ``newton``, ``clarabel``,
    ``nsgs`` and ``projection``.  What a spread of solves reaches after it is checked by
    ``tests/test_warm.py``; a path outside both (another solver's kernels, an option's) may
    still load or compile on its first call. Call it once before timing solves, or before
    the first call whose ``time_limit`` matters.
    """
    if _DONE and not force:
        return 0.0
    t0 = time.perf_counter()
    newton.warmup()
    nsgs.warmup()
    projection.warmup()
    rng = np.random.default_rng(12345)
    for dim in (2, 3):
        p = _local(3, dim, 12345)
        for name in ("auto", "nsgs", "newton", "projection"):
            solve(p, name)
            solve(p, name, time_limit=5.0)
            solve(p, name, r0=np.ones(p.m), max_iter=3)
        solve(p, "newton", history=True, max_iter=3)
        solve(p, "lemke", "frictionless", time_limit=5.0)
        if dim == 2:
            solve(p, "lemke", time_limit=5.0)   # (auto's plain call above: its compiled route)
        solve(_local(1, dim, 1))   # one contact: the flat kernel's call
        for tol in (1e-6, 1e-30):
            solve(p, "auto", tol=tol, max_iter=3, time_limit=5.0, methods=AUTO_STAGES)
            solve(p, "auto", tol=tol, max_iter=3, methods=AUTO_STAGES)
        solve(_local(25, dim, 12347), "newton", tol=1e-30, max_iter=1)
        # (the Python loop's dense steps, the LU either written out or LAPACK's)
        solve(_local(25, dim, 12347), "newton", policy="prox_error", tol=1e-30, max_iter=1)
        big = _sparse(dim, 12348)
        auto.contact_redundancy(big)      # (auto's feature on problems of more than SMALL_NC contacts)
        solve(big, "newton", tol=1e-30, max_iter=2)
        solve(big, "newton", policy="prox_error", tol=1e-30, max_iter=1)   # (auto's last resort)
        # (Clarabel's Newton polish of a system the compiled loop does not take)
        solve(big, "clarabel", tol=1e-30, max_iter=2)
        H = rng.standard_normal((6, 2 * dim))
        g = GlobalFrictionContactProblem(np.eye(6), H, rng.standard_normal(6),
                                         rng.standard_normal(2 * dim), 0.3, dim)
        for name in ("auto", "newton", "clarabel", "nsgs", "projection"):
            solve(g, name, tol=1e-6, max_iter=3)
    _DONE.append(True)
    return time.perf_counter() - t0


__all__ = ["warmup", "AUTO_STAGES"]

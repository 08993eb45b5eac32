"""``socp_cd.warmup``: after it, the solves a user makes compile nothing more.

The check runs in a fresh interpreter (this process's earlier tests have compiled kernels
already): it records every numba dispatcher of ``socp_cd`` and its compiled signatures after
``warmup()``, solves a spread of problems (sizes, dimensions, laws, time limits, warm starts,
the solvers a user calls), and reports the dispatchers that compiled a new signature, i.e.
would have compiled inside a timed call.
"""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import socp_cd

CHECK = textwrap.dedent('''
    import json, sys
    import numpy as np
    import socp_cd
    from numba.core.registry import CPUDispatcher

    def signatures():
        out = {}
        for name, mod in list(sys.modules.items()):
            if name.startswith("socp_cd"):
                for obj in list(vars(mod).values()):
                    if isinstance(obj, CPUDispatcher):
                        key = obj.py_func.__module__ + "." + obj.py_func.__name__
                        out[key] = len(obj.signatures)
        return out

    first = socp_cd.warmup()
    again = socp_cd.warmup()
    before = signatures()
    from socp_cd.bench.generators import manufactured
    cases = [(1, 3, 0.5, "tree"), (4, 3, 0.5, "redundant"), (30, 3, 1.0, "redundant"),
             (12, 2, 0.5, "redundant"), (150, 3, 0.3, "tree"), (120, 2, 0.3, "tree"),
             (5, 2, 0.5, "redundant")]      # (auto's Lemke stage: 2D, at most LEMKE_MAX_NC)
    for k, (n, d, mu, s) in enumerate(cases):
        p = manufactured(n, d, mu, structure=s, seed=k)
        for tl in (None, 1.0):
            for solver in ("auto", "nsgs", "newton"):
                socp_cd.solve(p, solver, time_limit=tl)
            socp_cd.solve(p, tol=1e-14, time_limit=tl)
        socp_cd.solve(p, r0=np.ones(p.m))
        socp_cd.solve(p, "projection", max_iter=50)
        socp_cd.solve(p, "newton", policy="prox_error", max_iter=3)     # (auto's last resort)
        socp_cd.solve(p, "newton", equation="natural_map", max_iter=3)
        socp_cd.solve(p, "newton", equation="fischer_burmeister", max_iter=3)
        if n <= 12:
            for form in ("associated", "frictionless"):
                socp_cd.solve(p, formulation=form)
            socp_cd.solve(p, "lemke", formulation="frictionless", time_limit=1.0)
            if d == 2:
                socp_cd.solve(p, "lemke", time_limit=1.0)
            socp_cd.solve(p, formulation="tresca", threshold=np.full(n, 0.1))
            socp_cd.solve(p, "nsgs", history=True)
            socp_cd.solve(p, "newton", history=True)
            # CSR indices in int64, and read-only data (a user's buffers; the problem holds
            # them in the kernels' one form, socp_cd.problem.kernel_array)
            W = p.W.copy()
            W.indices, W.indptr = W.indices.astype(np.int64), W.indptr.astype(np.int64)
            wide = socp_cd.FrictionContactProblem(W, p.q, p.mu, d)
            W_ro, q_ro, mu_ro = p.W.copy(), p.q.copy(), p.mu.copy()
            for a in (W_ro.data, q_ro, mu_ro):
                a.flags.writeable = False
            ro = socp_cd.FrictionContactProblem(W_ro, q_ro, mu_ro, d)
            for x in (wide, ro):
                for solver in ("auto", "nsgs", "newton", "projection"):
                    socp_cd.solve(x, solver)
                    socp_cd.solve(x, solver, r0=np.ones(x.m), max_iter=5)
                socp_cd.solve(x, tol=1e-14, time_limit=1.0)
    # a compiled Newton run that meets tol in balanced units only, continued (the shared slider
    # crank's manufactured copy, mu 0.1 mixed: session 44's benchmark compiled the continued
    # run's kernels inside its timed call, 21 s)
    from pathlib import Path
    from socp_cd.bench.evalset import MIXES, manufacture
    from socp_cd.data import shared_problems_dir
    crank = socp_cd.read_problem(Path(shared_problems_dir())
                                 / "FC2D_SliderCrankLagrangian00000.dat")
    continued = socp_cd.solve(manufacture(crank, 0.1, MIXES["mixed"], 0), "newton",
                              time_limit=1.0).info["continued"]
    # Clarabel's Newton polish above the compiled loop's size (a 2D deposit-sized problem)
    big = manufactured(330, 2, 0.3, structure="tree", seed=9)
    socp_cd.solve(big, "clarabel", max_iter=3)
    rng = np.random.default_rng(0)
    for d in (2, 3):
        H = rng.standard_normal((8, 3 * d))
        g = socp_cd.GlobalFrictionContactProblem(np.eye(8), H, rng.standard_normal(8),
                                                 -np.abs(rng.standard_normal(3 * d)), 0.4, d)
        for solver in ("auto", "newton", "nsgs"):
            socp_cd.solve(g, solver)
    after = signatures()
    new = {k: [before.get(k, 0), v] for k, v in after.items() if v != before.get(k, 0)}
    print(json.dumps({"first": first, "again": again, "dispatchers": len(after), "new": new,
                      "continued": len(continued)}))
''')


def test_after_warmup_the_solves_compile_nothing():
    out = subprocess.run([sys.executable, "-c", CHECK], capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["dispatchers"] > 50              # (the check sees socp_cd's kernels)
    assert got["new"] == {}, got["new"]         # nothing compiled inside a later call
    assert got["continued"] >= 1                # (the spread reached a continued Newton run)
    assert got["first"] > 0.0 and got["again"] == 0.0     # once per process


def test_warmup_is_public_and_forced_on_request():
    assert "warmup" in socp_cd.__all__
    socp_cd.warmup()
    assert socp_cd.warmup() == 0.0 and socp_cd.warmup(force=True) > 0.0

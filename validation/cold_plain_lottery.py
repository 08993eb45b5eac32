"""Plain Newton from ``r = 0`` on Capsules-i122: an outcome that rounding decides (issue #10, session 30).

The facts behind ``auto.COLD_PLAIN_STALL_LARGE`` (``formulations/auto.md``, "The cold plain
stage's stall window"), on tune cases only:

1. ``auto`` at 10 s on the manufactured μ = 0.5 mixed case and on 5 copies whose ``q`` is
   multiplied by ``1 + 1e-13 ξ`` (``ξ`` standard normal, seeds 0-4): status, error, and the
   proximal Newton and cold plain stages' errors and steps;
2. ``newton`` with ``policy="plain"``, no stall window, at most 300 steps, from ``r = 0`` on
   that case and on its ``q × 1e-6`` copy, and 3 perturbed copies of each;
3. ``auto`` at 10 s on the μ = 2 sliding case: ``||r||`` and the units guard of its answer.

The chain's constants are the module's (run it on the tree to be described)::

    python validation/cold_plain_lottery.py > validation/results/cold_plain_lottery_s30.md
"""
from __future__ import annotations

import numpy as np

import socp_cd
from socp_cd.bench import evalset
from socp_cd.data import shared_problems_dir
from socp_cd.problem import FrictionContactProblem
from socp_cd.solvers import auto

BASE = "real-manufactured/Capsules-i122-1617.dat/mu0.5-mixed-s0"
SCALED = "real-scaled/Capsules-i122-1617.dat/qx1e-06"
SLIDING = "real-manufactured/Capsules-i122-1617.dat/mu2-sliding-s2"


def perturbed(p, seed):
    """``p`` with ``q (1 + 1e-13 ξ)`` (seed None: ``p`` itself, a new object)."""
    q = p.q if seed is None else p.q * (1 + 1e-13 * np.random.default_rng(seed).standard_normal(p.m))
    return FrictionContactProblem(p.W, q, p.mu, p.dim)


def stage(res, method):
    """``error (steps)`` of the first stage ``method`` of an ``auto`` result, or ``-``."""
    for s in res.info["path"]:
        if s["method"] == method:
            return f"{s['error']:.1e} ({s['iterations']})"
    return "-"


def main() -> int:
    cases = {c.case_id: c for c in evalset.manufactured_cases(shared_problems_dir())
             if c.case_id in (BASE, SCALED, SLIDING)}
    assert all(cases[c].split == "tune" for c in cases)
    base, scaled = cases[BASE].problem(), cases[SCALED].problem()
    socp_cd.solve(perturbed(base, None), time_limit=1.0)          # (JIT and imports)
    print(f"# Plain Newton from r = 0 on Capsules-i122 (tune cases)\n\n"
          f"`python validation/cold_plain_lottery.py`; `auto.COLD_PLAIN_STALL_LARGE = "
          f"{auto.COLD_PLAIN_STALL_LARGE}`.\n")
    print(f"## 1. `auto`, 10 s, `{BASE}` and copies with q x (1 + 1e-13 xi)\n")
    print("| copy | status | error | guard | newton (steps) | newton_plain_cold (steps) |")
    print("|---|---|---|---|---|---|")
    for seed in (None, 0, 1, 2, 3, 4):
        res = socp_cd.solve(perturbed(base, seed), time_limit=10.0)
        print(f"| {'base' if seed is None else f'seed {seed}'} | {res.status} | {res.error:.1e} | "
              f"{res.info['guard']['value']:.1e} | {stage(res, 'newton')} | "
              f"{stage(res, 'newton_plain_cold')} |")
    print("\n## 2. `newton`, policy plain, no stall window, at most 300 steps, from r = 0\n")
    print("| case | copy | status | error | steps |")
    print("|---|---|---|---|---|")
    for name, p in (("mu0.5-mixed-s0", base), ("qx1e-06", scaled)):
        for seed in (None, 10, 11, 12):
            res = socp_cd.solve(perturbed(p, seed), "newton", policy="plain", max_iter=300,
                                stall_window=0, time_limit=10.0)
            print(f"| {name} | {'as is' if seed is None else f'seed {seed}'} | {res.status} | "
                  f"{res.error:.1e} | {res.iterations} |")
    res = socp_cd.solve(cases[SLIDING].problem(), time_limit=10.0)
    print(f"\n## 3. `auto`, 10 s, `{SLIDING}`\n\nstatus {res.status}, error {res.error:.1e}, "
          f"guard {res.info['guard']['value']:.1e}, ||r|| {np.linalg.norm(res.r):.1e}; path: "
          + ", ".join(f"{s['method']} {s['error']:.1e}" for s in res.info["path"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

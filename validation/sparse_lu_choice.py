"""SuperLU or the compiled left-looking LU for the sparse Newton matrices (session 38).

For every local problem whose Newton matrix is sparse (``m > newton.DENSE_ALWAYS_M`` and not
dense enough for the dense LU), two measurements:

1. **per factorization**: the Newton steps of a ``linear_solver="splu"`` run are captured
   (first, middle and last step); each step's matrix, as the Newton path hands it to each LU
   (SuperLU: stored zeros dropped; the left-looking LU: the full block pattern), is
   factorized and solved by SuperLU (``splu`` with
   ``newton.SPLU_OPTIONS``, ordering each matrix: session 38's SuperLU path; since session 39
   SuperLU gets the matrices in the solve's one order instead, measured by
   ``validation/splu_ordering.py``, and the threshold was not re-derived against it) and by
   the left-looking LU
   (:mod:`socp_cd.solvers.kernels.sparse_lu`, the column order computed once on the full
   pattern by :func:`socp_cd.solvers.sparse_lu.column_order`), with its pivot search and as
   a refactorization with the pivots of the previous call (what the Newton steps after the
   first do); min of 5 wall times each, the warm-up call not timed.  Beside them the ordering's multiply-adds per row, the quantity
   :class:`~socp_cd.solvers.sparse_lu.NewtonLU` chooses by
   (``LEFT_LOOKING_MAX_FLOPS_PER_ROW``).
2. **whole solves**: ``solve(p, "newton", tol=1e-8)`` with ``linear_solver="splu"`` and with
   the default (``"auto"``: NewtonLU's choice), min of 3 wall times after a warm-up call
   (where the choice is SuperLU, on the tune problems only: in session 38 the two runs
   differed by the choice's own cost; since session 39 forced SuperLU computes the ordering
   too, so they are the same path).

Split: ``tune`` (the threshold was read off these: shared/'s sparse local problems and the
first 1 000-grain deposit step) and ``holdout`` (the other simulation steps, never looked at
before the threshold was fixed).

    python validation/sparse_lu_choice.py [--quick] [--out validation/results/sparse_lu_choice]
"""
from __future__ import annotations

import argparse
import contextlib
import glob
import os
import sys
import time

import numpy as np
import scipy.sparse.linalg as spla

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import socp_cd  # noqa: E402
from socp_cd.io import read_problem  # noqa: E402
from socp_cd.solvers import newton  # noqa: E402
from socp_cd.solvers import sparse_lu  # noqa: E402

SHARED = os.path.join(os.path.dirname(os.path.dirname(HERE)), "shared", "data", "problems")
TUNE = ["Capsules-i122-1617.dat", "Capsules-i125-1213.hdf5", "KaplasTower-i1061-4.hdf5.dat",
        "Box_Stacks-i0122-82-5.hdf5", "fc2d_granularflowonwall_00667_00000.dat"]


def problem_list(quick: bool):
    items = [("tune", os.path.join(SHARED, f)) for f in TUNE]
    sim = os.path.join(HERE, "evalset_sim")
    dep1 = sorted(glob.glob(os.path.join(sim, "deposit2d-1000", "*.hdf5")))
    if dep1:
        items.append(("tune", dep1[0]))
    held = []
    piles = sorted(glob.glob(os.path.join(sim, "pile3d-300", "*.hdf5")))
    held += piles[1::4][: (2 if quick else 6)]
    held += dep1[1::3][: (2 if quick else 6)]
    dep4 = sorted(glob.glob(os.path.join(sim, "deposit2d-4000", "*.hdf5")))
    held += dep4[::4][:1]
    small = os.path.join(HERE, "evalset_sim_small")
    for kind in ("boxes3d-12",):
        files = [f for f in sorted(glob.glob(os.path.join(small, kind, "*.hdf5")))
                 if int(os.path.basename(f).split("-")[2]) * 3 > newton.DENSE_ALWAYS_M]
        held += files[: (1 if quick else 3)]
    return items + [("holdout", f) for f in held]


def best_of(f, n):
    ts = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)


@contextlib.contextmanager
def sparse_lu_knobs(values):
    """``sparse_lu``'s module knobs set to ``values`` (a mapping) inside the block, restored
    after it."""
    before = {k: getattr(sparse_lu, k) for k in values}
    for k, v in values.items():
        setattr(sparse_lu, k, v)
    try:
        yield
    finally:
        for k, v in before.items():
            setattr(sparse_lu, k, v)


def interleaved_solves(p, variants, repeats):
    """Whole ``solve(p, "newton", tol=1e-8, time_limit=30)`` runs of each variant,
    interleaved: one untimed call per variant, then ``repeats`` rounds of one timed call
    each (the solve alone is timed).

    ``variants``: ``{tag: (solve keyword arguments, sparse_lu knobs)}``.  Returns
    ``{tag: (wall times, the last round's result)}``.
    """
    for kwargs, values in variants.values():
        with sparse_lu_knobs(values):
            socp_cd.solve(p, "newton", tol=1e-8, time_limit=30, **kwargs)
    times = {tag: [] for tag in variants}
    last = {}
    for _ in range(repeats):
        for tag, (kwargs, values) in variants.items():
            with sparse_lu_knobs(values):
                t = time.perf_counter()
                last[tag] = socp_cd.solve(p, "newton", tol=1e-8, time_limit=30, **kwargs)
                times[tag].append(time.perf_counter() - t)
    return {tag: (times[tag], last[tag]) for tag in variants}


def capture(p):
    """The Newton steps of a SuperLU run of ``p``: their Jacobian blocks ``(Dr, Du, alpha)``,
    and its sparse system."""
    steps, systems = [], []
    orig = newton.LocalSystem.direction

    def spy(self, r, Dr, Du, alpha, F, strict=False):
        if not self.compiled and self.kind != "dense":
            steps.append((Dr.copy(), Du.copy(), alpha))
            systems.append(self)
        return orig(self, r, Dr, Du, alpha, F, strict)

    newton.LocalSystem.direction = spy
    try:
        socp_cd.solve(p, "newton", tol=1e-8, linear_solver="splu", time_limit=30)
    finally:
        newton.LocalSystem.direction = orig
    return steps, (systems[0] if systems else None)


def captured(p, choice):
    """``(steps, jac, lu)``: :func:`capture`'s steps, the run's block Jacobian and one
    :class:`~socp_cd.solvers.sparse_lu.NewtonLU` of kind ``choice`` on its full pattern
    (the order computed once, as in a solve); None on the dense path."""
    steps, system = capture(p)
    if not steps:
        return None
    jac = system.jacobian
    return steps, jac, sparse_lu.NewtonLU(jac.indptr, jac.indices, p.m, newton.SPLU_OPTIONS,
                                          choice)


def per_factorization(p):
    """Per captured step: the matrix as the Newton path gives it to each LU (the left-looking
    one: its values on the full block pattern, stored zeros kept; SuperLU: ``current()``,
    stored zeros dropped), factorized and solved by both."""
    got = captured(p, "left_looking")
    if got is None:
        return None, []
    steps, jac, lu = got
    n = p.m
    rows = []
    b = np.random.default_rng(0).standard_normal(n)
    for tag, args in (("first", steps[0]), ("middle", steps[len(steps) // 2]),
                      ("last", steps[-1])):
        jac.values(*args)
        vals = jac.out.reshape(-1).copy()
        J = jac.current()

        def fresh():
            lu.valid = False        # (a factorization with the pivot search)
            return lu.solve(vals, jac.perm, b)

        x_ll = fresh()
        x_su = spla.splu(J, **newton.SPLU_OPTIONS).solve(b)
        t_ll = best_of(fresh, 5)
        lu.solve(vals, jac.perm, b)
        before = lu.refactorizations
        t_re = best_of(lambda: lu.solve(vals, jac.perm, b), 5)     # (refactorizations)
        assert lu.refactorizations == before + 5
        t_su = best_of(lambda: spla.splu(J, **newton.SPLU_OPTIONS).solve(b), 5)
        res = lambda x: float(np.linalg.norm(J @ x - b) / np.linalg.norm(b))  # noqa: E731
        rows.append((tag, J.nnz, t_ll, t_re, t_su, res(x_ll), res(x_su)))
    return lu.flops / n, rows


def whole(p):
    out = {}
    for ls in ("splu", "auto"):
        socp_cd.solve(p, "newton", tol=1e-8, linear_solver=ls, time_limit=30)
        res = []
        t = best_of(lambda: res.append(
            socp_cd.solve(p, "newton", tol=1e-8, linear_solver=ls, time_limit=30)), 3)
        r = res[-1]
        out[ls] = (t, r.status, r.error if hasattr(r, "error") else np.nan,
                   r.info.get("newton_steps"), r.info.get("linear_solver"))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=os.path.join(HERE, "results", "sparse_lu_choice"))
    args = ap.parse_args(argv)
    lines = ["# SuperLU or the compiled left-looking LU for the sparse Newton matrices",
             "", f"Generated by `validation/sparse_lu_choice.py{' --quick' if args.quick else ''}` "
             f"(module docstring: what is timed). Threshold: left-looking when the ordering's "
             f"multiply-adds per row <= {sparse_lu.LEFT_LOOKING_MAX_FLOPS_PER_ROW:g}.", "",
             "## Per factorization (factorize + one solve; min of 5)", "",
             "| split | problem | m | flops/row | choice | matrix | nnz | left-looking (ms) "
             "| its refactorization (ms) | SuperLU (ms) | ratios | residual LL / SuperLU |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    whole_lines = ["", "## Whole Newton solves (tol 1e-8; min of 3)", "",
                   "| split | problem | m | SuperLU (ms) | auto (ms) | ratio | auto's LU | status splu / auto "
                   "| steps splu / auto |", "|---|---|---|---|---|---|---|---|---|"]
    ratios = {"tune": [], "holdout": []}
    for split, path in problem_list(args.quick):
        p = read_problem(path)
        if p.is_global:
            p = p.to_local()    # (newton condenses these: m <= newton.CONDENSE_MAX_M)
        name = os.path.basename(path)
        fpr, rows = per_factorization(p)
        if fpr is None:
            print(name, "no sparse Newton matrix", flush=True)
            continue
        choice = newton.LocalSystem(p, "auto").kind      # (NewtonLU's choice, or "dense")
        for tag, nnz, t_ll, t_re, t_su, r_ll, r_su in rows:
            lines.append(f"| {split} | {name} | {p.m} | {fpr:.0f} | {choice} | {tag} | {nnz} | "
                         f"{t_ll * 1e3:.3f} | {t_re * 1e3:.3f} | {t_su * 1e3:.3f} | "
                         f"{t_ll / t_su:.2f} / {t_re / t_su:.2f} | {r_ll:.1e} / {r_su:.1e} |")
        if choice not in ("splu", "left_looking"):
            print(name, "dense by default: no whole-solve comparison", flush=True)
            continue
        if choice == "splu" and split == "holdout":
            continue    # (SuperLU both ways: the tune ones show the choice's own cost)
        w = whole(p)
        ts, ta = w["splu"][0], w["auto"][0]
        ratios[split].append(ta / ts)
        whole_lines.append(f"| {split} | {name} | {p.m} | {ts * 1e3:.1f} | {ta * 1e3:.1f} | "
                           f"{ta / ts:.2f} | {w['auto'][4]} | {w['splu'][1]} / {w['auto'][1]} | "
                           f"{w['splu'][3]} / {w['auto'][3]} |")
        print(lines[-1], "\n", whole_lines[-1], flush=True)
    summary = ["", "## Summary (whole solves, auto / SuperLU)", ""]
    for split, rs in ratios.items():
        if rs:
            rs = np.array(rs)
            summary.append(f"- {split}: {len(rs)} problems, geometric mean ×{np.exp(np.mean(np.log(rs))):.2f}, "
                           f"min ×{rs.min():.2f}, max ×{rs.max():.2f}")
    text = "\n".join(lines + whole_lines + summary) + "\n"
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out + ".md", "w") as fh:
        fh.write(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Command-line interface: ``socp-cd {info,demo,solve,validate,bench,simulate}``.

``validate``, ``bench`` and ``simulate`` forward their arguments to
:mod:`socp_cd.dynamics.validate`, :mod:`socp_cd.bench.cli` and :mod:`socp_cd.scenes.simulate`.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, tuple):
        return "(" + ", ".join(_fmt(x) for x in v) + ")"
    return str(v)


def cmd_info(args) -> int:
    """Print the properties of problem files and the error of r = 0."""
    import numpy as np

    import socp_cd
    for path in args.files:
        p = socp_cd.read_problem(path)
        print(f"== {path}")
        for k, v in p.summary().items():
            print(f"  {k:16s} {_fmt(v)}")
        print(f"  {'error(r=0)':16s} {socp_cd.error(p, np.zeros(p.m)):.6e}")
    return 0


def cmd_solve(args) -> int:
    """Solve one problem file and print the result."""
    import socp_cd
    p = socp_cd.read_problem(args.file)
    res = socp_cd.solve(p, solver=args.solver, formulation=args.formulation, tol=args.tol,
                        max_iter=args.max_iter, crosscheck=args.crosscheck)
    for k, v in res.summary().items():
        print(f"{k:14s} {_fmt(v)}")
    if "crosscheck" in res.info:
        print(f"{'crosscheck':14s} {res.info['crosscheck']}")
    return 0 if res.converged else 1


def cmd_demo(args) -> int:
    """Load a bundled problem, show its properties, solve it with Clarabel and NSGS."""
    from .data import shared_problems_dir
    from .demo import run_demo
    data = args.data or shared_problems_dir()
    if data is None:
        print("demo: shared problems not found (pass --data DIR or set SOCP_CD_DATA)")
        return 2
    return run_demo(Path(data))


def main(argv=None) -> int:
    """Entry point of the ``socp-cd`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in ("validate", "bench", "simulate"):
        if argv[0] == "validate":
            from .dynamics.validate import main as sub
        elif argv[0] == "simulate":
            from .scenes.simulate import main as sub
        else:
            from .bench.cli import main as sub
        return int(sub(argv[1:]) or 0)
    ap = argparse.ArgumentParser(prog="socp-cd", description=__doc__)
    sp = ap.add_subparsers(dest="cmd", required=True)
    p = sp.add_parser("info", help="properties of problem files")
    p.add_argument("files", nargs="+")
    p.set_defaults(func=cmd_info)
    p = sp.add_parser("demo", help="load, inspect and solve a bundled problem")
    p.add_argument("--data", default=None, help="problem directory (default: the shared set)")
    p.set_defaults(func=cmd_demo)
    p = sp.add_parser("solve", help="solve one problem file")
    p.add_argument("file")
    p.add_argument("--solver", default="nsgs")
    p.add_argument("--formulation", default="coulomb")
    p.add_argument("--tol", type=float, default=1e-8)
    p.add_argument("--max-iter", type=int, default=None)
    p.add_argument("--crosscheck", default=None)
    p.set_defaults(func=cmd_solve)
    sp.add_parser("validate", help="exact-solution validation table (dynamics)")
    sp.add_parser("bench", help="solver comparison campaigns")
    sp.add_parser("simulate", help="run a TOML scene file (docs/scenes.md)")
    args = ap.parse_args(argv)
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())

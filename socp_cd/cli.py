"""Command-line interface: ``socp-cd {info,demo,solve,validate,bench,simulate}``.

``validate``, ``bench`` and ``simulate`` forward their arguments to the
``main(argv)`` of the module named in :data:`FORWARDED`.  Every
subcommand runs through :func:`run`, the one place that turns exceptions into
a one-line message on stderr and an exit code (:data:`EXIT_CODES`).
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
from pathlib import Path

#: Exit codes shared by every subcommand.
EXIT_OK = 0
EXIT_NOT_CONVERGED = 1
EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 3
EXIT_INTERRUPTED = 130

EXIT_CODES = {
    EXIT_OK: "success (solve: converged, residual recomputed)",
    EXIT_NOT_CONVERGED: "solve: ran, but did not reach the tolerance",
    EXIT_BAD_INPUT: "bad input: unreadable or malformed file, invalid option or argument",
    EXIT_INTERNAL: "internal error: a bug or a solver backend failure "
                   "(set SOCP_CD_DEBUG=1 for the traceback)",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C)",
}

#: Environment variable: when set (non-empty), internal errors print their traceback.
DEBUG_ENV = "SOCP_CD_DEBUG"

#: Longest message printed for an error.
MAX_MESSAGE = 1000

EPILOG = "exit codes:\n" + "\n".join(f"  {code:3d}  {text}" for code, text in EXIT_CODES.items())


class UsageError(Exception):
    """Wrong command line (reported with exit code EXIT_BAD_INPUT)."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors become :class:`UsageError` (one line, no usage dump)."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


def exit_code(exc: BaseException) -> int:
    """Exit code of the CLI for an exception raised by a subcommand."""
    from .errors import SocpCdError, SolverError
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    if isinstance(exc, SolverError):
        return EXIT_INTERNAL
    if isinstance(exc, (SocpCdError, UsageError)):
        return EXIT_BAD_INPUT
    return EXIT_INTERNAL


def _one_line(text: str) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE] + "..."


def run(func, *args, prog: str = "socp-cd") -> int:
    """Call a subcommand; map its exceptions to a one-line message and an exit code.

    ``SystemExit`` (``--help``, a forwarded parser) passes through unchanged.
    """
    try:
        return int(func(*args) or 0)
    except SystemExit:
        raise
    except BaseException as exc:  # noqa: BLE001 - the one place that maps errors to codes
        code = exit_code(exc)
        if code == EXIT_INTERRUPTED:
            print(f"{prog}: interrupted", file=sys.stderr)
        elif code == EXIT_BAD_INPUT:
            print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        else:
            if os.environ.get(DEBUG_ENV):
                traceback.print_exc()
            print(f"{prog}: internal error: {type(exc).__name__}: {_one_line(exc)} "
                  f"(set {DEBUG_ENV}=1 for the traceback)", file=sys.stderr)
        return code


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, tuple):
        return "(" + ", ".join(_fmt(x) for x in v) + ")"
    return str(v)


def cmd_info(args) -> int:
    """Print the properties of problem files, the error of r = 0 and the rank method."""
    import socp_cd
    for path in args.files:
        p = socp_cd.read_problem(path)
        print(f"== {path}")
        for k, v in p.summary(tol=args.tol).items():
            print(f"  {k:16s} {_fmt(v)}")
    return EXIT_OK


def cmd_solve(args) -> int:
    """Solve one problem file and print the result."""
    import socp_cd
    p = socp_cd.read_problem(args.file)
    res = socp_cd.solve(p, solver=args.solver, formulation=args.formulation, tol=args.tol,
                        max_iter=args.max_iter, time_limit=args.time_limit,
                        crosscheck=args.crosscheck)
    for k, v in res.summary().items():
        print(f"{k:14s} {_fmt(v)}")
    if "crosscheck" in res.info:
        print(f"{'crosscheck':14s} {res.info['crosscheck']}")
    return EXIT_OK if res.converged else EXIT_NOT_CONVERGED


def cmd_demo(args) -> int:
    """Load a bundled problem, show its properties, solve it with Clarabel and NSGS."""
    from .data import shared_problems_dir
    from .demo import run_demo
    data = args.data or shared_problems_dir()
    if data is None:
        raise UsageError("demo: shared problems not found (pass --data DIR or set SOCP_CD_DATA)")
    return run_demo(Path(data))


#: Subcommands that parse their own arguments: name -> (module with ``main(argv)``, help).
FORWARDED = {
    "validate": ("socp_cd.dynamics.validate", "exact-solution validation table (dynamics)"),
    "bench": ("socp_cd.bench.cli", "solver comparison campaigns"),
    "simulate": ("socp_cd.scenes.simulate", "run a TOML scene file (docs/scenes.md)"),
}


def _forwarded(name: str):
    """Entry point ``main(argv)`` of a subcommand whose parser lives in its own module."""
    return importlib.import_module(FORWARDED[name][0]).main


def build_parser() -> argparse.ArgumentParser:
    """The ``socp-cd`` argument parser (exit codes listed in every ``--help``)."""
    common = dict(epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap = _Parser(prog="socp-cd", description=__doc__.split("\n\n")[0], **common)
    sp = ap.add_subparsers(dest="cmd", required=True)
    p = sp.add_parser("info", help="properties of problem files", **common)
    p.add_argument("files", nargs="+")
    p.add_argument("--tol", type=float, default=1e-8,
                   help="tolerance of the 'trivial' flag: error(r=0) <= tol (default 1e-8)")
    p.set_defaults(func=cmd_info)
    p = sp.add_parser("demo", help="load, inspect and solve a bundled problem", **common)
    p.add_argument("--data", default=None, help="problem directory (default: the shared set)")
    p.set_defaults(func=cmd_demo)
    p = sp.add_parser("solve", help="solve one problem file", **common)
    p.add_argument("file")
    p.add_argument("--solver", default="auto",
                   help="a name of socp_cd.solvers() (default: auto, as socp_cd.solve)")
    p.add_argument("--formulation", default="coulomb")
    p.add_argument("--tol", type=float, default=1e-8)
    p.add_argument("--max-iter", type=int, default=None)
    p.add_argument("--time-limit", type=float, default=None, metavar="SECONDS",
                   help="stop with status time_limit after that many seconds (default: none)")
    p.add_argument("--crosscheck", default=None)
    p.set_defaults(func=cmd_solve)
    for name, (_, text) in FORWARDED.items():
        sp.add_parser(name, help=text, add_help=False)
    return ap


def _dispatch(argv) -> int:
    if argv and argv[0] in FORWARDED:
        return _forwarded(argv[0])(argv[1:])
    args = build_parser().parse_args(argv)
    return args.func(args)


def main(argv=None) -> int:
    """Entry point of the ``socp-cd`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    prog = "socp-cd" + (f" {argv[0]}" if argv and not argv[0].startswith("-") else "")
    return run(_dispatch, argv, prog=prog)


if __name__ == "__main__":
    sys.exit(main())

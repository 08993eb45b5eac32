"""``socp-cd bench``: run a benchmark campaign and write its reports.

Examples
--------
Full comparison on the shared problems (README section)::

    socp-cd bench --preset all

A quick campaign on files with two solvers at one tolerance::

    socp-cd bench Rover1039.dat Capsules-i122-1617.dat --solvers nsgs,clarabel --tol 1e-6

Generated families, the extremes suite, dask::

    socp-cd bench --family manufactured --sizes 1,10,100 --preset mid
    socp-cd bench --suite extremes
    socp-cd bench --preset all --dask            # LocalCluster
    socp-cd bench --preset all --scheduler tcp://host:8786
"""
from __future__ import annotations

import argparse
from pathlib import Path

from .campaign import run_campaign
from .problem_refs import file_problems, generated_problems, shared_problems
from .tasks import PRESETS, default_solvers, parse_solver
from .records import read_records

#: Default output directory (relative to the current directory).
DEFAULT_OUT = Path("validation/results/bench")


def _csv_list(text):
    return [t for t in (text or "").split(",") if t]


def build_parser() -> argparse.ArgumentParser:
    """Argument parser of ``socp-cd bench``."""
    ap = argparse.ArgumentParser(prog="socp-cd bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("problems", nargs="*", help="problem files or directories (default: the shared set)")
    ap.add_argument("--data", default=None, help="directory of problems (default: the shared set)")
    ap.add_argument("--suite", default="bench", choices=("bench", "extremes"),
                    help="'extremes' runs the extremes suite")
    ap.add_argument("--family", action="append", default=[],
                    help="generated family (manufactured, manufactured_psd); repeatable")
    ap.add_argument("--sizes", default="1,10,100", help="contacts of generated problems")
    ap.add_argument("--dims", default="2,3", help="dimensions of generated problems (and extremes)")
    ap.add_argument("--seeds", default="0", help="seeds of generated problems")
    ap.add_argument("--solvers", default="", help="comma-separated specs name[:formulation][,key=value] "
                    "or siconos:NAME (default: every registered Coulomb solver + Siconos peers)")
    ap.add_argument("--no-siconos", action="store_true", help="leave the Siconos peers out")
    ap.add_argument("--preset", default=None,
                    help="low (1e-4) | mid (1e-6) | high (1e-8) | sweep (1e-2..1e-10, every decade) | "
                    "all (1e-2..1e-10 every other decade: the presets + work-precision ends)")
    ap.add_argument("--tol", type=float, action="append", default=[], help="explicit tolerance(s)")
    ap.add_argument("--time-limit", type=float, default=30.0, help="seconds per run (default 30)")
    ap.add_argument("--max-iter", type=int, default=None)
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="output directory for tables and figures")
    ap.add_argument("--csv", default=None, help="records table (default OUT/records.csv)")
    ap.add_argument("--resume", action="store_true", help="skip runs already in the records table")
    ap.add_argument("--report-only", action="store_true", help="only rebuild the reports from the CSV")
    ap.add_argument("--no-report", action="store_true")
    ap.add_argument("--dask", action="store_true", help="run on a dask LocalCluster")
    ap.add_argument("--scheduler", default=None, help="dask scheduler address")
    ap.add_argument("--n-workers", type=int, default=2)
    ap.add_argument("--size", type=int, default=50, help="extremes: contacts of the ordinary cases")
    ap.add_argument("--large", type=int, default=10_000, help="extremes: contacts of the large case (0 skips)")
    ap.add_argument("--large-time-limit", type=float, default=60.0)
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--readme", default=None, metavar="PATH",
                    help="rewrite the comparison table between <!-- bench:begin/end --> markers in PATH")
    return ap


def _solvers(args):
    names = [s for part in args.solvers.split(";") for s in _split_specs(part)]
    if names:
        return [parse_solver(s) for s in names]
    return default_solvers(siconos=not args.no_siconos)


def _split_specs(text: str):
    """Split ``"nsgs,clarabel:associated,omega=2"`` into specs (``k=v`` parts stay attached)."""
    out = []
    for tok in _csv_list(text):
        if "=" in tok and out:
            out[-1] += "," + tok
        else:
            out.append(tok.strip())
    return out


def _problems(args):
    refs = file_problems(args.problems) if args.problems else []
    if args.data:
        refs += file_problems([args.data])
    for fam in args.family:
        refs += generated_problems(fam, [int(s) for s in _csv_list(args.sizes)],
                                     [int(d) for d in _csv_list(args.dims)],
                                     [int(s) for s in _csv_list(args.seeds)])
    if not refs:
        refs = shared_problems()
    return refs


def main(argv=None) -> int:
    """Entry point of ``socp-cd bench`` (returns the exit code)."""
    args = build_parser().parse_args(argv)
    out = Path(args.out)
    dask = args.scheduler or (True if args.dask else None)
    verbose = not args.quiet
    if args.suite == "extremes":
        from .extremes import run_extremes
        ext_out = out if args.out != str(DEFAULT_OUT) else Path("validation/results")
        tol = args.tol[0] if args.tol else PRESETS["mid"]
        recs = run_extremes(_solvers(args), tol, args.time_limit, size=args.size, large=args.large,
                            large_time_limit=args.large_time_limit,
                            dims=tuple(int(d) for d in _csv_list(args.dims)),
                            csv_path=Path(args.csv) if args.csv else ext_out / "extremes.csv",
                            md_path=ext_out / "extremes.md", dask=dask, verbose=verbose)
        print(f"extremes: {len(recs)} runs -> {ext_out / 'extremes.md'}")
        return 0
    csv_path = Path(args.csv) if args.csv else out / "records.csv"
    if not args.report_only:
        refs = _problems(args)
        if not refs:
            print("no problems found (give files, --data, --family, or install the shared set)")
            return 2
        tols = list(args.tol) + ([args.preset] if args.preset else [])
        recs = run_campaign(refs, _solvers(args), tols or None, args.time_limit,
                              max_iter=args.max_iter, csv_path=csv_path, resume=args.resume,
                              dask=dask, n_workers=args.n_workers, verbose=verbose)
        print(f"{len(recs)} runs appended to {csv_path}")
    if not args.no_report:
        from .reports import summary_markdown, write_report
        table = read_records(csv_path)
        if not table:
            print(f"no records in {csv_path}")
            return 1
        files = write_report(table, out)
        print(summary_markdown(table))
        if args.readme:
            from .reports import update_readme
            done = update_readme(args.readme, table)
            print(f"README section {'updated' if done else 'NOT updated (markers missing)'}: {args.readme}")
        for k, v in files.items():
            print(f"{k}: {v}")
    return 0


__all__ = ["main", "build_parser"]

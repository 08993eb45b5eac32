"""Solver comparison studies: campaigns, records, reports, generated problems.

Main entry points
-----------------
run_campaign(problems, solvers, tolerances, time_limit, ...)
    Problems × solvers × tolerances, each run isolated with a time limit,
    one record per run appended to a CSV table (:mod:`.campaign`).
write_report(records, outdir)
    Success rates and shifted geometric means per preset, work–precision
    diagram, Dolan–Moré performance profiles (:mod:`.reports`).
manufactured(n_contacts, dim, mu, ...)
    Problems with a known exact solution (:mod:`.generators`).
run_extremes(...)
    Stability at the extremes (:mod:`.extremes`).
"""
from .campaign import run_campaign, run_one
from .problem_refs import (BUILDERS, ProblemRef, file_problems, generated_problems,
                           register_builder, shared_problems)
from .tasks import (PRESETS, SWEEP, RunTask, SolverChoice, default_solvers, make_tasks,
                    parse_solver, resolve_tolerances, siconos_ready)
from .generators import coulomb_pairs, delassus, generate, manufactured
from .records import FIELDS, append_records, read_records, write_records


def write_report(records, outdir, **kwargs):
    """Write summary.md, work_precision.png, performance_profile.png (see :mod:`.reports`)."""
    from .reports import write_report as _w
    return _w(records, outdir, **kwargs)


def run_extremes(*args, **kwargs):
    """Run the extremes suite (see :func:`socp_cd.bench.extremes.run_extremes`)."""
    from .extremes import run_extremes as _r
    return _r(*args, **kwargs)


__all__ = ["PRESETS", "SWEEP", "ProblemRef", "BUILDERS", "register_builder",
           "resolve_tolerances", "siconos_ready", "RunTask", "SolverChoice", "default_solvers",
           "file_problems", "generated_problems", "make_tasks", "parse_solver", "run_campaign",
           "run_one", "shared_problems", "coulomb_pairs", "delassus", "generate", "manufactured",
           "FIELDS", "append_records", "read_records", "write_records", "write_report",
           "run_extremes"]

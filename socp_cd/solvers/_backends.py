"""Import every backend module so that it registers itself.

Backends whose optional dependency is missing are skipped silently here and
reported by :func:`socp_cd.solvers` simply by their absence.
"""
import importlib

for _mod in ("nsgs", "clarabel_backend", "cvxpy_backend", "proxsuite_backend"):
    try:
        importlib.import_module(f"{__package__}.{_mod}")
    except ModuleNotFoundError as exc:  # a backend module not written yet / optional dep
        if exc.name and (exc.name.endswith(_mod) or exc.name.split(".")[0] in ("clarabel", "cvxpy", "proxsuite", "numba")):
            continue
        raise

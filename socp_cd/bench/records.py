"""Benchmark records: one row per (problem, solver, settings, tolerance) run.

Records are plain dicts with the columns of :data:`FIELDS`, stored in a CSV
table that later campaigns append to.  Two rows describe the same run when
their :data:`KEY` columns agree; on reading (and on appending) the most
recent row wins, so re-running part of a campaign updates it in place.
"""
from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np

#: Column order of the CSV table.
FIELDS = (
    "suite", "problem", "family", "source", "dim", "contacts", "nnz", "solver", "formulation",
    "settings", "tol", "time_limit", "status", "success", "error", "law_error", "time",
    "wall_time", "iterations", "u_error", "r_error", "nan", "message", "timestamp",
)
#: Columns identifying a run (dedupe key).
KEY = ("suite", "problem", "solver", "formulation", "settings", "tol")
#: Columns that depend on the machine load, not on the computation.
TIMING_FIELDS = ("time", "wall_time", "timestamp")
#: Outcomes of a run: the solver statuses plus the campaign's own ones.
RUN_STATUSES = ("converged", "max_iter", "stalled", "numerical_error", "time_limit",
                "rejected", "unsupported", "crashed")

_FLOAT = ("tol", "time_limit", "error", "law_error", "time", "wall_time", "u_error", "r_error")
_INT = ("dim", "contacts", "nnz", "iterations")
_BOOL = ("success", "nan")


def settings_string(options: dict | None) -> str:
    """Canonical text of solver options (sorted JSON; ``""`` when empty)."""
    return json.dumps(options, sort_keys=True, separators=(",", ":")) if options else ""


def key_of(rec: dict) -> tuple:
    """Dedupe key of a record (tolerance compared as a float)."""
    return tuple(float(rec[k]) if k == "tol" else str(rec.get(k, "")) for k in KEY)


def new_record(**values) -> dict:
    """A record with every column of :data:`FIELDS` (missing ones empty/NaN)."""
    rec = {f: "" for f in FIELDS}
    for f in _FLOAT:
        rec[f] = math.nan
    for f in _INT:
        rec[f] = 0
    rec["success"] = False
    rec["nan"] = False
    unknown = set(values) - set(FIELDS)
    if unknown:
        raise KeyError(f"unknown record fields {sorted(unknown)}")
    rec.update(values)
    if rec["status"] and rec["status"] not in RUN_STATUSES:
        raise ValueError(f"invalid run status {rec['status']!r}")
    return rec


def _parse(row: dict) -> dict:
    rec = new_record()
    for f in FIELDS:
        v = row.get(f, "")
        if f in _FLOAT:
            rec[f] = float(v) if v not in ("", None) else math.nan
        elif f in _INT:
            rec[f] = int(float(v)) if v not in ("", None) else 0
        elif f in _BOOL:
            rec[f] = str(v).strip().lower() in ("true", "1")
        else:
            rec[f] = "" if v is None else v
    return rec


def _fmt(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))  # round-trips exactly ("inf", "nan" included)
    if isinstance(v, np.integer):
        return str(int(v))
    return str(v)


def dedupe(records) -> list[dict]:
    """Keep the last record of every key, in order of first appearance."""
    out: dict = {}
    for rec in records:
        k = key_of(rec)
        out.pop(k, None)
        out[k] = rec
    return list(out.values())


def read_records(path) -> list[dict]:
    """Read a records CSV (deduplicated, typed); ``[]`` when the file is missing."""
    path = Path(path)
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return dedupe(_parse(row) for row in csv.DictReader(fh))


def write_records(path, records) -> Path:
    """Write ``records`` (replacing the file) with the :data:`FIELDS` header."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + f".tmp{os.getpid()}")
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        for rec in records:
            w.writerow({f: _fmt(rec.get(f, "")) for f in FIELDS})
    os.replace(tmp, path)
    return path


def append_records(path, records) -> list[dict]:
    """Append ``records`` to the table at ``path``; a new run replaces an old one with the same key.

    Returns
    -------
    list of dict
        The whole deduplicated table after the append.
    """
    table = dedupe(read_records(path) + [dict(r) for r in records])
    write_records(path, table)
    return table


def strip_timing(rec: dict) -> dict:
    """The record without the columns that depend on machine load."""
    return {k: v for k, v in rec.items() if k not in TIMING_FIELDS}


__all__ = ["FIELDS", "KEY", "TIMING_FIELDS", "RUN_STATUSES", "new_record", "settings_string",
           "key_of", "dedupe", "read_records", "write_records", "append_records", "strip_timing"]

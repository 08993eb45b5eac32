"""Stability at the extremes: generated problems at the edges of the data range.

Every case is a manufactured problem (exact solution known, see
:mod:`socp_cd.bench.generators`) pushed to one extreme: friction
coefficients ``0``, ``1e-8``, ``10``, ``1e3``; body mass ratios ``1e6``;
many redundant contacts (rank-deficient ``W``); badly scaled data (entries of
``W`` spanning ``1e-6 .. 1e6``, ``q`` scaled by ``1e4``); grazing contacts
(``r = 0`` and ``û = 0`` at once); zero contacts (must be rejected at
construction with :class:`~socp_cd.InvalidProblemError`); and a large
problem (``10^4`` contacts); and copies of the default problem in other
units (``q`` and ``W, q`` times ``1e±8``), with contacts renumbered or
duplicated, which must get the same answer.  For every solver the suite
records an honest status, the achieved error, and whether anything
non-finite came out.
"""
from __future__ import annotations

import json
import math
from pathlib import Path


from ..errors import UnsupportedError
from .campaign import run_campaign
from .problem_refs import ProblemRef
from .tasks import default_solvers
from .extreme_cases import CASES, COPIES, SHARED_BASES, build

def extreme_problems(size: int = 50, large: int = 10_000, dims=(3,), cases=None, seed: int = 0,
                     shared=()):
    """Problem refs of the suite (``large`` sets the size of the ``"large"`` case; 0 drops it).

    ``shared``: shared problem file names whose ``default`` and :data:`COPIES` are added
    (named ``"<case> (<file stem>, <contacts>)"``); files not found are left out.
    """
    out = []
    for source in shared:
        try:
            n = build("default", source=source).n_contacts
        except UnsupportedError:
            continue
        stem = source.rsplit(".", 1)[0]
        for case in ("default",) + COPIES:
            kw = dict(case=case, n_contacts=0, dim=0, seed=seed, source=source)
            out.append(ProblemRef(f"{case} ({stem}, {n})", "extremes",
                                  generator=json.dumps(kw, sort_keys=True), builder="extremes"))
    for case in (cases or CASES):
        if case == "large" and not large:
            continue
        for dim in ((max(dims),) if case == "large" else dims):   # one large problem (3D)
            n = large if case == "large" else (0 if case == "zero_contacts" else size)
            kw = dict(case=case, n_contacts=int(n), dim=int(dim), seed=seed)
            out.append(ProblemRef(f"{case} ({dim}d, {n})", "extremes",
                                  generator=json.dumps(kw, sort_keys=True), builder="extremes"))
    return out


def run_extremes(solvers=None, tol: float = 1e-6, time_limit: float = 20.0, *, size: int = 50,
                 large: int = 10_000, large_time_limit: float = 60.0, dims=(3,), cases=None,
                 shared=SHARED_BASES, csv_path=None, md_path=None, dask=None,
                 verbose=False) -> list[dict]:
    """Run the extremes suite for every solver and optionally write the tables.

    Parameters
    ----------
    solvers : list, optional
        Solver specs (default: every registered Coulomb solver and the Siconos peers).
    tol : float
        Requested tolerance.
    time_limit, large_time_limit : float
        Seconds per run (the ``"large"`` case gets ``large_time_limit``).
    size, large : int
        Contacts of the ordinary cases and of the ``"large"`` case (0: skip it).
    dims : tuple
    cases : list of str, optional
        Subset of :data:`CASES`.
    shared : sequence of str
        Shared problems (file names) whose ``default`` and :data:`COPIES` also run
        (default :data:`SHARED_BASES`, the problems of issue 14; () for none).
    csv_path, md_path : path, optional
        Where to append the records and write the Markdown table (built from
        the whole CSV table, so runs for other dims/solvers accumulate).
    dask : optional
        As in :func:`~socp_cd.bench.campaign.run_campaign`.

    Returns
    -------
    list of dict
        One record per (case, solver).
    """
    solvers = solvers or default_solvers()
    probs = extreme_problems(size, large, dims, cases, shared=shared)
    small = [p for p in probs if not p.name.startswith("large")]
    big = [p for p in probs if p.name.startswith("large")]
    common = dict(solvers=solvers, tolerances=[tol], suite="extremes", csv_path=csv_path, dask=dask,
                  verbose=verbose)
    recs = run_campaign(small, time_limit=time_limit, **common) if small else []
    if big:
        recs += run_campaign(big, time_limit=large_time_limit, **common)
    if md_path is not None:
        table = recs
        if csv_path is not None:  # the whole suite table, earlier runs included
            from .records import read_records
            table = [r for r in read_records(csv_path) if r["suite"] == "extremes"]
        Path(md_path).parent.mkdir(parents=True, exist_ok=True)
        Path(md_path).write_text(extremes_markdown(table) + "\n")
    return recs


def honest(rec: dict) -> bool:
    """A status is dishonest when it claims convergence but ``error > tol``.

    Under-claiming (a solver stopping with ``max_iter`` although its
    recomputed error is already below ``tol``, which Siconos' own, differently
    normalized stopping test can do) is conservative and counted as honest;
    the record still shows ``success``.
    """
    return not (rec["status"] == "converged" and not rec["success"])


def _cell(rec: dict) -> str:
    st = rec["status"]
    if st in ("rejected", "unsupported"):
        return st
    err = rec["error"]
    e = f"{err:.1e}" if math.isfinite(err) else ("NaN" if rec["nan"] else "—")
    mark = "ok" if rec["success"] else st
    flags = ("" if honest(rec) else " (claimed converged)") + (" NaN!" if rec["nan"] else "")
    return f"{mark} {e}{flags}"


def _copies_summary(records, solvers) -> list[str]:
    """Per solver: on how many copies of ``default`` the outcome (status) is the default's."""
    by = {(r["problem"].split(" ")[0], r["problem"].split(" ")[1], r["solver"]): r for r in records}
    dims = sorted({r["problem"].split(" ")[1] for r in records if r["problem"].startswith("default ")})
    if not dims:
        return []
    out = ["", "## Copies of `default` (same problem in other units, renumbered, duplicated contacts)", "",
           "Per solver: copies (× bases: generated 2D/3D and shared problems) whose outcome equals "
           "the `default` row's; the copies that differ; the largest velocity error "
           "`||u - u*|| / ||u*||` against the exact `u*` over the copies marked `ok` "
           "(generated bases only: the shared problems have no exact solution).",
           "", "| solver | same outcome | differing copies | max u error of `ok` copies |",
           "|---|---:|---|---:|"]
    for s in solvers:
        same, total, diff, uerr = 0, 0, [], []
        for d in dims:
            base = by.get(("default", d, s))
            for c in COPIES:
                r = by.get((c, d, s))
                if base is None or r is None or base["status"] in ("unsupported", "rejected"):
                    continue
                total += 1
                if r["status"] == base["status"]:
                    same += 1
                else:
                    diff.append(f"{c} {d.strip('(,')}: {r['status']}")
                if r["success"] and math.isfinite(r["u_error"]):
                    uerr.append(r["u_error"])
        if total:
            worst = f"{max(uerr):.1e}" if uerr else "—"
            out.append(f"| {s} | {same}/{total} | {'; '.join(diff)} | {worst} |")
    return out


def extremes_markdown(records) -> str:
    """Markdown: case × solver matrix of outcome and achieved error, then the details."""
    cases = list(dict.fromkeys(r["problem"] for r in records))
    solvers = sorted({r["solver"] for r in records})
    cell = {(r["problem"], r["solver"]): r for r in records}
    tol = records[0]["tol"] if records else math.nan
    n_bad = sum(bool(r["nan"]) for r in records)
    n_crash = sum(r["status"] == "crashed" for r in records)
    n_dis = sum(not honest(r) for r in records)
    lines = ["# Extremes suite", "",
             f"Requested tolerance {tol:.0e}; each cell: `ok` (Siconos error recomputed from r <= tol) "
             f"or the solver's status, then the achieved error. Runs: {len(records)}; crashed: {n_crash}; "
             f"runs with NaN/Inf: {n_bad}; over-claimed statuses (solver claimed convergence, "
             f"recomputed error > tol, marked `(claimed converged)`): {n_dis}.", "",
             "| case | " + " | ".join(solvers) + " |", "|---|" + "---|" * len(solvers)]
    for c in cases:
        lines.append(f"| {c} | " + " | ".join(_cell(cell[(c, s)]) if (c, s) in cell else "" for s in solvers) + " |")
    lines += _copies_summary(records, solvers)
    lines += ["", "## Cases", ""]
    for name, (desc, _) in CASES.items():
        lines.append(f"- **{name}**: {desc}")
    lines += ["", "## Details", "", "| case | solver | status | error | time [s] | iterations | u error vs exact | message |",
              "|---|---|---|---:|---:|---:|---:|---|"]
    for r in records:
        lines.append(f"| {r['problem']} | {r['solver']} | {r['status']} | {r['error']:.2e} | {r['time']:.3g} | "
                     f"{r['iterations']} | {r['u_error']:.1e} | {r['message'][:90].replace('|', '/')} |")
    return "\n".join(lines)


__all__ = ["CASES", "COPIES", "SHARED_BASES", "build", "extreme_problems", "run_extremes", "extremes_markdown", "honest"]

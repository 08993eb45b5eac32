"""Clarabel + De Saxcé fixed point against Siconos' ACLM fixed point and NSGS.

For every shared problem: outer iterations, Clarabel (interior-point)
iterations, Newton-polish steps, wall time and Siconos' relative error of our
solution, beside Siconos' own ``fc3d_ACLMFixedPoint`` / ``gfc3d_ACLMFixedPoint``
and NSGS (``fc3d_nsgs``, ``gfc3d_nsgs_wr``, 2D ``fc2d_nsgs``) run through
:mod:`socp_cd.bench.siconos_peer` (one worker subprocess of ``/usr/bin/python3``).
Without Siconos the peer columns stay empty and the report says so.

Usage::

    .venv/bin/python validation/conic_vs_siconos.py [--tol 1e-8] [--only NAME ...]

Writes ``validation/results/conic_vs_siconos.csv`` and ``.md``.
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

from socp_cd.data import shared_problems_dir
from socp_cd.io import read_problem
from socp_cd.residuals import error
from socp_cd.solvers import solve

OUT = Path(__file__).resolve().parent / "results"
SICONOS_TIME_LIMIT = 300.0


def ours(p, tol, repeats=2):
    """Best-of-``repeats`` run of clarabel/coulomb (times exclude imports)."""
    best = None
    for _ in range(repeats):
        res = solve(p, "clarabel", "coulomb", tol=tol)
        if best is None or res.time < best.time:
            best = res
    return best


def peer_tasks(path, p, tol):
    if p.is_global:
        names = ("aclmfp", "nsgs_wr") if p.dim == 3 else ()
    elif p.dim == 3:
        names = ("aclmfp", "nsgs")
    else:
        names = ("nsgs",)
    return [{"task": "solve", "problem": str(path), "solver": s, "tol": tol, "max_iter": 10000,
             "time_limit": SICONOS_TIME_LIMIT} for s in names]


def run_siconos(tasks):
    try:
        from socp_cd.bench.siconos_peer import siconos_available, siconos_batch
    except ImportError as exc:  # bridge not installed
        return None, f"socp_cd.bench.siconos_peer unavailable ({exc})"
    if not siconos_available():
        return None, "Siconos numerics not importable by the peer interpreter"
    return siconos_batch(tasks), ""


def fmt(x, spec=".2e"):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return ""
    return format(x, spec) if isinstance(x, float) else str(x)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--no-siconos", action="store_true")
    ap.add_argument("--reuse-siconos", action="store_true",
                    help="take the Siconos columns from the previous conic_vs_siconos.csv")
    args = ap.parse_args(argv)
    d = shared_problems_dir()
    if d is None:
        print("shared problems not found (set SOCP_CD_DATA)")
        return 1
    files = sorted(x for x in d.iterdir() if x.suffix in (".dat", ".hdf5"))
    if args.only:
        files = [f for f in files if any(o in f.name for o in args.only)]
    solve(read_problem(files[0]), "clarabel", "coulomb", tol=args.tol)  # warm-up: imports
    rows, tasks, owner = [], [], []
    for f in files:
        p = read_problem(f)
        res = ours(p, args.tol)
        row = {
            "problem": f.name, "kind": "global" if p.is_global else "local", "dim": p.dim,
            "contacts": p.n_contacts, "status": res.status,
            "error": error(p, res.r), "outer_it": res.iterations,
            "clarabel_it": res.info.get("inner_iterations"),
            "polish_it": res.info.get("polish_iterations"), "time": res.time,
        }
        rows.append(row)
        print(f"{f.name:45s} {res.status:10s} err={row['error']:.2e} outer={row['outer_it']:3d} "
              f"ipm={row['clarabel_it']:4d} newton={row['polish_it']:3d} t={res.time:.3f}s", flush=True)
        for t in peer_tasks(f, p, args.tol):
            tasks.append(t)
            owner.append((row, t["solver"]))
    note = ""
    if args.no_siconos:
        note = "Siconos not run (--no-siconos)"
    elif args.reuse_siconos:
        prev = {r["problem"]: r for r in csv.DictReader(open(OUT / "conic_vs_siconos.csv"))}
        for row in rows:
            old = prev.get(row["problem"], {})
            for key in COLS[10:]:
                val = old.get(key, "")
                row[key] = (None if val == "" else val if key.endswith("status")
                            else float(val) if key.endswith(("error", "time")) else int(float(val)))
    else:
        t0 = time.perf_counter()
        results, note = run_siconos(tasks)
        if results is not None:
            print(f"Siconos batch: {len(tasks)} tasks in {time.perf_counter() - t0:.1f}s")
            for (row, name), r in zip(owner, results):
                key = "aclmfp" if name == "aclmfp" else "nsgs"
                ok = r.get("status") == "ok"
                err = r.get("error") if ok else None
                if ok and err is None and r.get("r") is not None:   # global: recompute ours
                    p = read_problem(d / row["problem"])
                    err = error(p, np.asarray(r["r"]))
                row[f"{key}_status"] = (("ok" if r.get("info") == 0 else f"info={r.get('info')}")
                                        if ok else r.get("status"))
                row[f"{key}_it"] = r.get("iterations") if ok else None
                row[f"{key}_time"] = r.get("time") if ok else None
                row[f"{key}_error"] = float(err) if err is not None else None
    write(rows, args.tol, note)
    return 0


COLS = ["problem", "kind", "dim", "contacts", "status", "error", "outer_it", "clarabel_it",
        "polish_it", "time", "aclmfp_status", "aclmfp_it", "aclmfp_error", "aclmfp_time",
        "nsgs_status", "nsgs_it", "nsgs_error", "nsgs_time"]


def peer_err(r, key):
    """Peer error cell: the error, or the peer's status when it returned nothing."""
    err = r.get(f"{key}_error")
    if err is None:
        st = r.get(f"{key}_status")
        return "" if st in (None, "ok") else f"({st})"
    return fmt(err)


def write(rows, tol, note):
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "conic_vs_siconos.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, COLS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in COLS})
    reached = [r for r in rows if r["error"] <= tol]
    both = [r for r in rows if r["error"] <= tol and r.get("aclmfp_error") is not None
            and r["aclmfp_error"] <= tol and r.get("aclmfp_time")]
    faster = [r for r in both if r["time"] < r["aclmfp_time"]]
    big = [r for r in both if r["contacts"] >= 20]
    big_faster = [r for r in big if r["time"] < r["aclmfp_time"]]
    peer_fail = [r for r in rows if r["error"] <= tol and r.get("aclmfp_status") not in (None, "ok")]
    lines = [
        "# Clarabel + De Saxcé fixed point vs Siconos",
        "",
        f"Tolerance {tol:g} on Siconos' relative error (recomputed by socp_cd for every solver). "
        "Ours: `solve(p, 'clarabel', 'coulomb')` with default options (Anderson-accelerated "
        "outer loop, fixed inner tolerance min(1e-10, tol/100), semismooth-Newton polish), best of 2 runs. "
        "Siconos: ACLMFP = `fc3d_ACLMFixedPoint` (`gfc3d_ACLMFixedPoint` for global), "
        "NSGS = `fc3d_nsgs` (`gfc3d_nsgs_wr` global, `fc2d_nsgs` 2D), max 10000 iterations, "
        "time = the solver call alone. Machine: 2 shared cores (timings are indicative).",
        "",
        f"**Ours reach {tol:g} on {len(reached)}/{len(rows)} problems.** "
        + (f"Where both converge ({len(both)} problems) ours is faster than Siconos ACLMFP on "
           f"{len(faster)}; total time ours {sum(r['time'] for r in both):.3f}s vs ACLMFP "
           f"{sum(r['aclmfp_time'] for r in both):.3f}s; on the {len(big)} problems with >= 20 "
           f"contacts ours is faster on {len(big_faster)}. "
           f"ACLMFP did not converge (status != ok) on {len(peer_fail)} problems that ours solve."
           if both else ""),
        "",
    ]
    if note:
        lines += [f"> Siconos columns empty: {note}.", ""]
    lines += ["| problem | kind | nc | status | error | outer | IPM it | Newton | time s | "
              "ACLMFP err | ACLMFP it | ACLMFP s | NSGS err | NSGS it | NSGS s |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append("| " + " | ".join([
            r["problem"], f"{r['kind']} {r['dim']}D", str(r["contacts"]), r["status"],
            fmt(r["error"]), str(r["outer_it"]), str(r["clarabel_it"]), str(r["polish_it"]),
            fmt(r["time"], ".3f"), peer_err(r, "aclmfp"), fmt(r.get("aclmfp_it")),
            fmt(r.get("aclmfp_time"), ".3f"), peer_err(r, "nsgs"), fmt(r.get("nsgs_it")),
            fmt(r.get("nsgs_time"), ".3f")]) + " |")
    (OUT / "conic_vs_siconos.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[:8]))


if __name__ == "__main__":
    sys.exit(main())

"""Does a solver's outcome depend on how the same problem is written down? (issue #10)

The ``real-reframed`` family of the evaluation set (:func:`socp_cd.bench.evalset.reframed_cases`)
holds copies of manufactured cases with the contacts renumbered (``order``) or each
contact's tangent basis turned about its normal (``frames``): the same physical problem,
with the base case's exact solution mapped.  This script solves every base case and its
copies with each solver and compares the outcomes:

* solved counts (recomputed Siconos error and units guard ``<= tol``, i.e. the
  dispatcher's ``converged``; for Siconos solvers our recomputed error, and the guard
  beside it) on the bases and on the copies;
* per pair (base, copy): both solved, the base only, the copy only, neither;
* on pairs both solved: the distance between the two velocities, the copy's mapped back
  (``T^T u'``), relative to ``max(||u*||, ||q||)``;
* a figure: each pair's error on the copy against the base's, per solver and reframing.

``--report`` writes the table and the figure again from a CSV, each case in its split by the
evaluation set's current rule.

No parameter was chosen on this family.  Each call runs once on a new problem object, with
the time limit given (default 1 s; outcomes near the limit depend on the machine's load:
run it on a quiet machine, one process)::

    python validation/reframed.py --solvers auto newton nsgs --siconos prox nsn_fb nsgs \\
        --out validation/results/reframed_s30

Writes ``<out>.csv``, ``<out>.md`` and ``<out>.png``.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

import socp_cd
from socp_cd.bench import evalset
from socp_cd.bench.siconos_peer import family_of, siconos_available, siconos_batch
from socp_cd.bench.transforms import contact_map
from socp_cd.data import shared_problems_dir

sys.path.insert(0, str(Path(__file__).resolve().parent))
from auto_probe import write_csv  # noqa: E402


def cases(max_contacts, split):
    """``(bases, copies)``: the ``real-reframed`` cases and the ``real-manufactured`` cases
    they copy, as ``{case_id: EvalCase}``."""
    data = shared_problems_dir()
    copies = {c.case_id: c for c in evalset.reframed_cases(data, max_contacts=max_contacts)
              if split is None or c.split == split}
    want = {c.params["base"] for c in copies.values()}
    bases = {c.case_id: c for c in evalset.manufactured_cases(data, max_contacts=max_contacts)
             if c.case_id in want}
    return bases, copies


def ours(p, solver, tol, time_limit):
    """One ``socp_cd.solve`` call: ``(r, status, seconds)``."""
    t0 = time.perf_counter()
    res = socp_cd.solve(p, solver, tol=tol, time_limit=time_limit)
    return res.r, res.status, time.perf_counter() - t0


def siconos(p, solvers, tol, time_limit):
    """One call of each Siconos solver through the peer (one worker for the case):
    ``[(r or None, status, seconds)]``."""
    tasks = [{"task": "solve", "problem": p, "solver": s, "tol": tol, "max_iter": 1_000_000,
              "time_limit": time_limit} for s in solvers]
    return [(res.get("r"), res["status"], res.get("time", math.inf))
            for res in siconos_batch(tasks)]


def judged(p, r, tol):
    """``(error, guard, solved)`` of an answer (inf when there is none)."""
    if r is None or not np.all(np.isfinite(r)):
        return math.inf, math.inf, False
    err = float(socp_cd.error(p, r))
    g = float(socp_cd.guard(p, r)["value"])
    return err, g, max(err, g) <= tol


def run(bases, copies, solvers, peers, tol, time_limit):
    """One row per (case, solver), each base case followed by its copies (so that a change of
    the machine's load falls on both sides of a pair alike), after one untimed call per solver
    (JIT and imports); each copy row's velocity (``_u``) mapped back to its base's order and
    frames."""
    first = next(iter(bases.values())).problem()
    for s in solvers:
        ours(first, s, tol, time_limit)
    rows = []
    todo = []
    for bid, b in sorted(bases.items()):
        todo.append((bid, b, None))
        todo += [(cid, c, bid) for cid, c in sorted(copies.items()) if c.params["base"] == bid]
    for cid, case, base in todo:
        p = case.problem()
        outcomes = [(s, ours(p, s, tol, time_limit)) for s in solvers]
        peer = [s for s in peers if family_of(p) == "local3" or s == "nsgs"]
        if peer:
            outcomes += [("siconos:" + s, o) for s, o in zip(peer, siconos(p, peer, tol,
                                                                           time_limit))]
        for s, (r, status, dt) in outcomes:
            err, g, ok = judged(p, r, tol)
            u = None if r is None or not np.all(np.isfinite(r)) else p.velocity(r)
            if u is not None and base is not None:
                u = velocity_of_base(case, u)
            rows.append({"case": cid, "base": base or cid, "how": case.params.get("how", "base"),
                         "split": case.split, "file": case.source, "nc": p.n_contacts,
                         "dim": p.dim, "global": p.is_global, "mu": case.params["mu"],
                         "mix": case.params["mix"], "solver": s,
                         "status": status, "error": err, "guard": g, "solved": ok,
                         "u_gap": math.nan, "time": dt,
                         "_u": u,
                         "u_norm": max(float(np.linalg.norm(p.solution.u)),
                                       float(np.linalg.norm(p.q if not p.is_global
                                                            else p.q_local)))})
            print(f"{cid:75s} {rows[-1]['solver']:14s} {status:10s} err {err:.1e} "
                  f"guard {g:.1e} t {dt:.3g}", flush=True)
    return rows


def velocity_of_base(case, u_copy):
    """The copy's velocity in the base case's order and frames, ``T^T u'`` (``T`` rebuilt from
    the copy's draw)."""
    perm, angles = evalset.reframing(case.n_contacts, case.params["how"], case.params["draw"])
    return contact_map(perm, angles, case.dim).T @ u_copy


def pairs(rows):
    """``[(base row, copy row, gap)]`` per solver, ``gap`` the copy row's ``u_gap``."""
    base = {(r["case"], r["solver"]): r for r in rows if r["how"] == "base"}
    out = []
    for r in rows:
        if r["how"] == "base":
            continue
        b = base.get((r["base"], r["solver"]))
        if b is not None:
            out.append((b, r, r["u_gap"]))
    return out


def fill_gaps(rows) -> None:
    """Each copy row's ``u_gap``: ``||T^T u' - u|| / max(||u*||, ||q||)`` against its base row
    when both are solved (else left nan; ``u* = 0`` when every contact sticks or grazes)."""
    for b, c, _ in pairs(rows):
        if b["solved"] and c["solved"]:
            c["u_gap"] = float(np.linalg.norm(c["_u"] - b["_u"]) / max(b["u_norm"], 1e-300))


def write_md(rows, args, path, png) -> None:
    """Counts per solver, reframing and split; the pairs that disagree; the velocity gaps."""
    prs = pairs(rows)
    solvers = list(dict.fromkeys(r["solver"] for r in rows))
    lines = [f"# Outcomes on reframed copies of manufactured cases (tol {args.tol:g}, "
             f"{args.time_limit:g} s)", "",
             "`python validation/reframed.py " + " ".join(sys.argv[1:]) + "`; the "
             "`real-reframed` family (`socp_cd.bench.evalset.reframed_cases`: contacts renumbered, "
             "`order`, or tangent bases turned, `frames`; bases: the manufactured cases of "
             f"mu in {evalset.REFRAMED_MUS}, every seed) of at most {args.max_contacts} contacts"
             + (f", split {args.split}" if args.split else ", both splits")
             + " (a copy in its base case's split)"
             + (" (this table written again from the CSV by `--report`)" if args.report else "")
             + ". Solved: "
             "recomputed Siconos error and units guard <= tol (for Siconos solvers: our "
             "recomputation of their answer). One call per case on a new problem object. "
             "No parameter was chosen on this family.", "",
             "| solver | reframing | split | pairs | both | base only | copy only | neither | "
             "max velocity gap (both solved) |", "|---|---|---|---|---|---|---|---|---|"]
    for s in solvers:
        for how in evalset.REFRAMINGS:
            for split in ("tune", "holdout", "all"):
                sel = [(b, c, g) for b, c, g in prs if b["solver"] == s and c["how"] == how
                       and (split == "all" or c["split"] == split)]
                if not sel:
                    continue
                both = sum(b["solved"] and c["solved"] for b, c, _ in sel)
                bo = sum(b["solved"] and not c["solved"] for b, c, _ in sel)
                co = sum(c["solved"] and not b["solved"] for b, c, _ in sel)
                gaps = [g for _, _, g in sel if not math.isnan(g)]
                lines.append(f"| {s} | {how} | {split} | {len(sel)} | {both} | {bo} | {co} | "
                             f"{len(sel) - both - bo - co} | "
                             + (f"{max(gaps):.1e}" if gaps else "-") + " |")
    lines += ["", "Pairs whose outcomes differ (error / guard of the base and of the copy):", "",
              "| solver | copy | contacts | base | copy |", "|---|---|---|---|---|"]
    for b, c, _ in prs:
        if b["solved"] != c["solved"]:
            lines.append(f"| {c['solver']} | {c['case']} ({c['split']}) | {c['nc']} | "
                         f"{b['error']:.1e} / {b['guard']:.1e} ({b['status']}) | "
                         f"{c['error']:.1e} / {c['guard']:.1e} ({c['status']}) |")
    lines += ["", f"Figure: [{png.name}]({png.name}) (each pair's error on the copy against "
              "the base's; the larger of Siconos' error and the units guard).", ""]
    path.write_text("\n".join(lines) + "\n")


def plot(rows, png, tol) -> None:
    """Per solver: the copy's measure (max of error and guard) against the base's, log-log,
    with the tolerance lines; one marker per reframing."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    prs = pairs(rows)
    solvers = list(dict.fromkeys(r["solver"] for r in rows))
    ncol = min(3, len(solvers))
    nrow = -(-len(solvers) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(max(4.4 * ncol, 5.6), 4.3 * nrow), squeeze=False)
    for ax in axes.flat[len(solvers):]:
        ax.set_visible(False)
    floor = 1e-17
    for ax, s in zip(axes.flat, solvers):
        for how, mk, col in (("order", "o", "tab:blue"), ("frames", "^", "tab:orange")):
            sel = [(b, c) for b, c, _ in prs if b["solver"] == s and c["how"] == how]
            x = [min(max(b["error"], b["guard"], floor), 1.0) for b, _ in sel]
            y = [min(max(c["error"], c["guard"], floor), 1.0) for _, c in sel]
            ax.scatter(x, y, s=14, marker=mk, facecolors="none", edgecolors=col,
                       label=f"{how} ({len(sel)})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.plot([floor, 1], [floor, 1], color="0.7", lw=0.8)
        ax.axvline(tol, color="tab:red", lw=0.8, ls="--")
        ax.axhline(tol, color="tab:red", lw=0.8, ls="--")
        ax.set_xlim(floor, 2)
        ax.set_ylim(floor, 2)
        ax.set_title(s)
        ax.set_xlabel("base case: max(error, guard); no answer: 1")
        ax.set_ylabel("reframed copy: max(error, guard)")
        ax.legend(loc="upper left", fontsize=8)
    fig.suptitle("Same problem, written differently:\noutcome on the copy vs the base "
                 f"(tol {tol:g}, dashed)")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def read_rows(path):
    """The rows of a CSV this script wrote, with their numbers and flags parsed and each case's
    split by the evaluation set's current rule (a copy in its base case's split; the column
    ``u_gap`` nan where the file has none)."""
    import csv
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k in ("error", "guard", "time", "u_gap"):
            r[k] = float(r.get(k, math.nan))
        r["solved"] = r["solved"] == "True"
        r["nc"] = int(r["nc"])
        r["split"] = evalset.case_split(r["case"])
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--solvers", nargs="+", default=["auto"])
    ap.add_argument("--siconos", nargs="*", default=[],
                    help="Siconos solvers to run too (3D local problems; 'nsgs' on every family)")
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--max-contacts", type=int, default=2000)
    ap.add_argument("--split", choices=("tune", "holdout"), default=None)
    ap.add_argument("--out", type=Path, required=True, help="output stem (.csv, .md, .png)")
    ap.add_argument("--report", action="store_true",
                    help="write <out>.md and <out>.png again from <out>.csv (no solve), each "
                         "case in its split by the evaluation set's current rule")
    args = ap.parse_args(argv)
    if args.report:
        rows = read_rows(args.out.with_suffix(".csv"))
        png = args.out.with_suffix(".png")
        plot(rows, png, args.tol)
        write_md(rows, args, args.out.with_suffix(".md"), png)
        return 0
    if args.siconos and not siconos_available():
        raise SystemExit("Siconos is not available (apt-get install -y python3-siconos)")
    bases, copies = cases(args.max_contacts, args.split)
    print(f"{len(bases)} base cases, {len(copies)} copies", flush=True)
    rows = run(bases, copies, args.solvers, args.siconos, args.tol, args.time_limit)
    fill_gaps(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_csv([{k: v for k, v in r.items() if not k.startswith("_") and k != "u_norm"}
               for r in rows], args.out.with_suffix(".csv"))
    png = args.out.with_suffix(".png")
    plot(rows, png, args.tol)
    write_md(rows, args, args.out.with_suffix(".md"), png)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

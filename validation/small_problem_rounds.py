"""Per-call time of ``solve`` on the benchmark's small 3D local problems, tree against tree.

The problems are those of ``validation/newton_vs_siconos.py`` (shared, the evaluation
set's sampled cases, the small simulation collections) with at most ``--max-contacts``
contacts; each call gets a new problem object (a shallow copy made before the timer) and
``time_limit=1``, as in the benchmark, and a problem's time is the min over calls that
stop once they have taken 0.05 s (the benchmark's rule, ``newton_vs_siconos.run_ours``, here
on every size; the record of session 23 was made with at least 3 calls each).  One run writes one CSV per solver::

    python validation/small_problem_rounds.py run --tag NAME [--solvers auto newton]

To compare two trees, run the same command with ``PYTHONPATH`` set to each, in
alternating rounds (the machine drifts by 5-10 % between runs), then::

    python validation/small_problem_rounds.py compare --old TAG1 [TAG2 ...] --new TAG3 [TAG4 ...]

which takes each problem's min over the rounds of each side and writes
``validation/results/small_problem_rounds.md``: geometric means of new / old by size class,
the extremes, and with ``--siconos`` (given to ``run``: NSGS, NSN_AC and NSN_NM, warm
per-call times of the same kind, in the same run) the count of problems beyond 2× and 4×
of the fastest of those three.  CSVs go to ``validation/results/small_rounds/``.
"""
from __future__ import annotations

import argparse
import copy
import csv
import math
import statistics
import sys
from pathlib import Path

import socp_cd

HERE = Path(__file__).resolve().parent
OUT = HERE / "results" / "small_rounds"
sys.path.insert(0, str(HERE))
import newton_vs_siconos as nvs  # noqa: E402  (the benchmark's problem set)

#: Siconos solvers timed with ``--siconos`` (the fastest ones on problems of a few contacts
#: in the session-22 benchmark)
SICONOS = ("nsgs", "nsn_ac", "nsn_nm")
CLASSES = ((1, 10), (11, 50))


def problems(max_contacts):
    """The benchmark's 3D local problems of at most ``max_contacts`` contacts."""
    args = argparse.Namespace(sets=["shared", "eval", "sim"], max_contacts=2000, seed=0,
                              n_eval=36, sim=[str(HERE / "evalset_sim_small")])
    return [it for it in nvs.problem_set(args)
            if it["kind"] == "local3" and it["nc"] <= max_contacts]


def per_call(item, solver) -> tuple[float, str, float]:
    """``(seconds, status, error)``: the benchmark's timed call
    (``newton_vs_siconos.run_ours``, its repeat rule on every size; ``inf`` when not
    converged)."""
    rec = nvs.run_ours(item, solver, 1e-8, _RUN)
    return (rec["time"] if rec["claimed"] else math.inf), rec["status"], rec["error"]


#: ``run_ours``' settings: the benchmark's ``time_limit=1``, and its many-call rule (stop
#: after 0.05 s of calls) on every problem, not only on those of at most 10 contacts
_RUN = argparse.Namespace(time_limit=1.0, repeats=200, repeats_small=200)


def run(args) -> int:
    items = problems(args.max_contacts)
    socp_cd.solvers()
    for it in items[:5]:                # (numba's caches loaded, kernels warm)
        for s in args.solvers:
            socp_cd.solve(copy.copy(it["problem"]), solver=s, time_limit=1.0)
    OUT.mkdir(parents=True, exist_ok=True)
    tree = str(Path(socp_cd.__file__).resolve().parents[1])
    for s in args.solvers:
        path = OUT / f"{args.tag}_{s}.csv"
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["set", "id", "nc", "solver", "time", "status", "error", "tree"])
            for it in items:
                t, st, e = per_call(it, s)
                w.writerow([it["set"], it["id"], it["nc"], s, t, st, e, tree])
        print(f"wrote {path}")
    if args.siconos:
        from socp_cd.bench.siconos_peer import siconos_solve
        path = OUT / f"{args.tag}_siconos.csv"
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["set", "id", "nc", "solver", "time", "status", "error", "tree"])
            for it in items:
                for s in SICONOS:
                    r = siconos_solve(it["problem"], s, tol=1e-8, time_limit=5.0, repeat=200,
                                      storage="dense")
                    ok = r.get("status") == "ok" and r.get("error", math.inf) <= 1e-8
                    w.writerow([it["set"], it["id"], it["nc"], s,
                                r["time"] if ok else math.inf, r.get("status"),
                                r.get("error", math.inf), "siconos"])
        print(f"wrote {path}")
    return 0


def _load(tags, solver):
    """``{(set, id): (nc, min time over the tags' runs)}``."""
    out = {}
    for tag in tags:
        with open(OUT / f"{tag}_{solver}.csv") as fh:
            for r in csv.DictReader(fh):
                k = (r["set"], r["id"])
                nc, t = int(r["nc"]), float(r["time"])
                out[k] = (nc, min(t, out.get(k, (nc, math.inf))[1]))
    return out


def _siconos(tags):
    """``{(set, id): fastest time of the Siconos solvers}`` over the tags' runs."""
    best = {}
    for tag in tags:
        path = OUT / f"{tag}_siconos.csv"
        if path.exists():
            with open(path) as fh:
                for r in csv.DictReader(fh):
                    k = (r["set"], r["id"])
                    best[k] = min(best.get(k, math.inf), float(r["time"]))
    return best


def _geo(xs):
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else math.nan


def compare(args) -> int:
    lines = ["# Small 3D local problems: per-call time, new tree / old tree", "",
             f"`python validation/small_problem_rounds.py compare --old {' '.join(args.old)} "
             f"--new {' '.join(args.new)}` (each problem's min over the rounds of each side; "
             "a new problem object per call, `time_limit=1`).", ""]
    sic = _siconos(args.old + args.new)
    for solver in args.solvers:
        old, new = _load(args.old, solver), _load(args.new, solver)
        keys = [k for k in old if k in new and math.isfinite(old[k][1])
                and math.isfinite(new[k][1])]
        lines += [f"## `{solver}`", "",
                  "| contacts | problems | new / old: geometric mean | median | min | max |",
                  "|---|---|---|---|---|---|"]
        for lo, hi in CLASSES:
            rs = sorted(new[k][1] / old[k][1] for k in keys if lo <= old[k][0] <= hi)
            if rs:
                lines.append(f"| {lo}–{hi} | {len(rs)} | {_geo(rs):.3f} | "
                             f"{statistics.median(rs):.3f} | {rs[0]:.2f} | {rs[-1]:.2f} |")
        lines.append("")
        ranked = sorted(keys, key=lambda k: new[k][1] / old[k][1])
        for title, part in (("Largest speed-ups", ranked[:5]), ("Largest slow-downs",
                                                                 ranked[::-1][:5])):
            lines.append(f"{title}: " + "; ".join(
                f"{k[1]} ({old[k][0]} contacts) {old[k][1] * 1e6:.1f} → {new[k][1] * 1e6:.1f} µs"
                for k in part) + ".")
        if sic:
            both = [k for k in keys if math.isfinite(sic.get(k, math.inf))]
            for name, side in (("old", old), ("new", new)):
                r = [side[k][1] / sic[k] for k in both]
                lines.append(f"{name}: against the fastest of Siconos {', '.join(SICONOS)} on "
                             f"{len(both)} problems: within 1× {sum(x <= 1 for x in r)}, "
                             f"2× {sum(x <= 2 for x in r)}, 4× {sum(x <= 4 for x in r)}; "
                             f"geometric mean ×{_geo(r):.2f}.")
        lines.append("")
    path = HERE / "results" / "small_problem_rounds.md"
    path.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--tag", required=True)
    r.add_argument("--solvers", nargs="+", default=["auto", "newton"])
    r.add_argument("--max-contacts", type=int, default=50)
    r.add_argument("--siconos", action="store_true")
    c = sub.add_parser("compare")
    c.add_argument("--old", nargs="+", required=True)
    c.add_argument("--new", nargs="+", required=True)
    c.add_argument("--solvers", nargs="+", default=["auto", "newton"])
    args = ap.parse_args(argv)
    return run(args) if args.cmd == "run" else compare(args)


if __name__ == "__main__":
    raise SystemExit(main())

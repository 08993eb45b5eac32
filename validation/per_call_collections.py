"""Per-call time of a plain ``solve`` on every small 3D simulation problem, for comparing trees.

``run``: every 3D local problem of at most ``--max-contacts`` contacts in the small
simulation collections (``evalset_sim_small_tune``, the tune split's; ``evalset_sim_small``,
held out), the benchmark's call (``solve(copy.copy(p), time_limit=1.0)``, copies made before
the timer, garbage collection off: ``per_call_rounds.per_call_fresh``), min over 3 loops of
200 calls (30 above 20 contacts), and one more untimed call for its counts;
writes ``{path: [seconds per call, sweeps or iterations, converged, first stage's
iterations]}`` as JSON.  ``compare``: two or more such files of different trees (two rounds
of each, named ``<tree>a.json`` / ``<tree>b.json``, the min taken), against the first tree:
per set, the problems whose first stage's sweep count changed, the others' ratio range and
median, and the noise between a tree's two rounds.  Session 29 (block-diagonal ``W``)::

    for r in a b; do for t in base new; do (cd $t && ../.venv/bin/python \\
        validation/per_call_collections.py run --out /tmp/ab_$t$r.json); done; done
    python validation/per_call_collections.py compare /tmp/ab_base /tmp/ab_new

(each tree its own ``NUMBA_CACHE_DIR``), record: ``results/first_sweep_s29/``.

``run --sets F [F ...] --min-contacts N``: other collections (folders of this directory) and
sizes; a problem whose first call takes ``t`` gets ``clip(PER_LOOP / t, 3, 200)`` calls per
loop (so a 20 ms problem is timed three times a loop).  ``compare`` then reports per folder,
with the shifted geometric mean (10 ms) of each tree.  Session 51 (the Newton system's
pattern kept per problem), record ``results/pattern_cache_s51/``::

    for r in a b; do for t in base new; do PYTHONPATH=$t python validation/per_call_collections.py \
        run --sets evalset_sim_newkinds_fresh3 evalset_sim_kinds_fresh2 --min-contacts 11 \
        --max-contacts 400 --out /tmp/ab_$t$r.json; done; done
"""
from __future__ import annotations

import argparse
import copy
import glob
import json
import math
import statistics
from pathlib import Path

from per_call_rounds import per_call_fresh      # (this folder: the one per-call loop)

HERE = Path(__file__).parent
SETS = {"tune": "evalset_sim_small_tune", "held out": "evalset_sim_small"}
#: seconds of calls per loop for problems slower than a few ms (``run --sets``)
PER_LOOP = 0.03


def run(out: Path, max_contacts: int, folders=None, min_contacts: int = 0) -> None:
    import time
    import socp_cd
    probs = []
    for folder in folders or SETS.values():
        for f in sorted(glob.glob(str(HERE / folder / "*" / "*.hdf5"))):
            p = socp_cd.read_problem(f)
            if p.dim == 3 and not p.is_global and min_contacts <= p.n_contacts <= max_contacts:
                probs.append((str(Path(folder) / Path(f).parent.name / Path(f).name), p))
    if not probs:
        raise SystemExit("no problem: build the collections (build_sim_collections.py --small "
                         "[--tune], or the --sets given)")
    first = {}
    for name, p in probs:
        for _ in range(3):
            t0 = time.perf_counter()
            socp_cd.solve(copy.copy(p), time_limit=1.0)
            first[name] = time.perf_counter() - t0
    rec = {}
    for name, p in probs:
        if folders is None:
            number = 30 if p.n_contacts > 20 else 200
        else:
            number = int(min(200, max(3, PER_LOOP / max(first[name], 1e-9))))
        best = per_call_fresh(p, number, 3) * 1e-6
        r = socp_cd.solve(copy.copy(p), time_limit=1.0)     # (its counts, untimed)
        path = r.info.get("path")
        rec[name] = [best, r.iterations, bool(r.converged), path[0]["iterations"] if path else None]
    out.write_text(json.dumps(rec))


def compare(stems: list[str]) -> None:
    data = {s: [json.loads(Path(f"{s}{r}.json").read_text()) for r in "ab"] for s in stems}
    base = stems[0]
    keys = list(data[base][0])

    def t(s, k):
        return min(d[k][0] for d in data[s])

    folders = list(dict.fromkeys(k.split("/")[0] for k in keys))
    labels = {folder: label for label, folder in SETS.items()}

    def sgm(s, ks):
        return math.exp(sum(math.log(t(s, k) + 0.01) for k in ks) / len(ks)) - 0.01

    for folder in folders:
        label = labels.get(folder, folder)
        ks = [k for k in keys if k.startswith(folder + "/")]
        noise = sorted(data[base][0][k][0] / data[base][1][k][0] for k in ks)
        print(f"{label} ({len(ks)} problems); noise between {base}'s rounds "
              f"x{noise[0]:.2f}-{noise[-1]:.2f}")
        for s in stems[1:]:
            moved = [k for k in ks if data[s][0][k][3] != data[base][0][k][3]]
            rest = [k for k in ks if k not in moved]
            rm = sorted(t(s, k) / t(base, k) for k in moved)
            rr = sorted(t(s, k) / t(base, k) for k in rest)
            line = f"  {s}: first stage's sweeps changed on {len(moved)}"
            if rm:
                line += f" (x{rm[0]:.3f}-{rm[-1]:.3f})"
            if rr:
                line += (f"; the other {len(rr)} x{rr[0]:.3f}-{rr[-1]:.3f}, median "
                         f"x{statistics.median(rr):.3f}")
            conv = sum(data[s][0][k][2] for k in ks)
            print(line + f"; converged {conv} of {len(ks)} ({base}: "
                  f"{sum(data[base][0][k][2] for k in ks)}); sgm (10 ms) {sgm(base, ks):.5f} -> "
                  f"{sgm(s, ks):.5f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("run")
    a.add_argument("--out", type=Path, required=True)
    a.add_argument("--max-contacts", type=int, default=100)
    a.add_argument("--min-contacts", type=int, default=0)
    a.add_argument("--sets", nargs="+", default=None,
                   help="collection folders of this directory (default: the two small ones)")
    b = sub.add_parser("compare")
    b.add_argument("stems", nargs="+", help="JSON stems (<stem>a.json, <stem>b.json), base first")
    args = ap.parse_args()
    if args.cmd == "run":
        run(args.out, args.max_contacts, args.sets, args.min_contacts)
    else:
        compare(args.stems)


if __name__ == "__main__":
    main()

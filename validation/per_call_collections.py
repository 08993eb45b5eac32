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
"""
from __future__ import annotations

import argparse
import copy
import glob
import json
import statistics
from pathlib import Path

from per_call_rounds import per_call_fresh      # (this folder: the one per-call loop)

HERE = Path(__file__).parent
SETS = {"tune": "evalset_sim_small_tune", "held out": "evalset_sim_small"}


def run(out: Path, max_contacts: int) -> None:
    import socp_cd
    probs = []
    for folder in SETS.values():
        for f in sorted(glob.glob(str(HERE / folder / "*" / "*.hdf5"))):
            p = socp_cd.read_problem(f)
            if p.dim == 3 and p.n_contacts <= max_contacts:
                probs.append((str(Path(folder) / Path(f).parent.name / Path(f).name), p))
    if not probs:
        raise SystemExit("no problem: build the collections (build_sim_collections.py --small "
                         "[--tune])")
    for _, p in probs:
        for _ in range(3):
            socp_cd.solve(copy.copy(p), time_limit=1.0)
    rec = {}
    for name, p in probs:
        best = per_call_fresh(p, 30 if p.n_contacts > 20 else 200, 3) * 1e-6
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

    for label, folder in SETS.items():
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
            print(line + f"; converged {conv} of {len(ks)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("run")
    a.add_argument("--out", type=Path, required=True)
    a.add_argument("--max-contacts", type=int, default=100)
    b = sub.add_parser("compare")
    b.add_argument("stems", nargs="+", help="JSON stems (<stem>a.json, <stem>b.json), base first")
    args = ap.parse_args()
    if args.cmd == "run":
        run(args.out, args.max_contacts)
    else:
        compare(args.stems)


if __name__ == "__main__":
    main()

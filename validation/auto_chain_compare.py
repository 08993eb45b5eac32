"""Compare two ``validation/auto_chain.py`` runs case by case (two code trees, one setting each).

``auto_chain.py`` compares settings of one tree in one run; a change that is not a
module constant (session 17: NSGS and ``auto`` stop on the dispatcher's own measure)
is compared by running ``auto_chain.py --configs now`` in each tree (``git worktree
add``, ``PYTHONPATH``) with its own ``--tag``, then::

    python validation/auto_chain_compare.py results/auto_chain_tune_s17base.csv \
        results/auto_chain_tune_s17origin.csv > results/auto_chain_tune_s17_compare.md

Prints, by dimension and size band: cases, solved, shifted geometric means (10 ms and
0.1 ms shifts), totals, the per-case time ratio (second / first: median, min, max, how
many beyond 1.2× and below 0.8×); then the cases won and lost and the eight fastest and
slowest ratios.
"""
from __future__ import annotations

import csv
import math
import sys
from collections import defaultdict
from pathlib import Path


def shifted_gm(xs, shift):
    return math.exp(sum(math.log(x + shift) for x in xs) / len(xs)) - shift


def band(nc):
    return "1–10" if nc <= 10 else "11–100" if nc <= 100 else "> 100"


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print(__doc__)
        return 2
    here = Path(__file__).resolve().parent
    a, b = ({r["case"]: r for r in csv.DictReader(open(here / p if not Path(p).is_absolute()
                                                       else p))} for p in args)
    groups = defaultdict(list)
    for k, x in a.items():
        if k in b:
            groups[(x["dim"], band(int(x["nc"])))].append((x, b[k]))
    out = [f"# `{args[0]}` (first) vs `{args[1]}` (second)", "",
           "| dim | contacts | cases | solved first / second | sgm 10 ms shift (s) | "
           "sgm 0.1 ms shift (s) | total (s) | ratio median / min / max | > 1.2× / < 0.8× |",
           "|---|---|---|---|---|---|---|---|---|"]
    for (dim, bd), v in sorted(groups.items()):
        ta = [float(x["time"]) for x, _ in v]
        tb = [float(y["time"]) for _, y in v]
        rat = sorted(y / x for x, y in zip(ta, tb))
        out.append(f"| {dim} | {bd} | {len(v)} | {sum(x['solved'] == 'True' for x, _ in v)} / "
                   f"{sum(y['solved'] == 'True' for _, y in v)} | {shifted_gm(ta, 0.01):.5f} / "
                   f"{shifted_gm(tb, 0.01):.5f} | {shifted_gm(ta, 1e-4):.6f} / "
                   f"{shifted_gm(tb, 1e-4):.6f} | {sum(ta):.3f} / {sum(tb):.3f} | "
                   f"{rat[len(rat) // 2]:.2f} / {rat[0]:.2f} / {rat[-1]:.2f} | "
                   f"{sum(x > 1.2 for x in rat)} / {sum(x < 0.8 for x in rat)} |")
    common = [k for k in a if k in b]
    lost = [k for k in common if a[k]["solved"] == "True" and b[k]["solved"] != "True"]
    won = [k for k in common if a[k]["solved"] != "True" and b[k]["solved"] == "True"]
    out += ["", f"Lost: {lost or 'none'}. Won: {won or 'none'}.", "",
            "| ratio | case | first (s) | second (s) |", "|---|---|---|---|"]
    ranked = sorted((float(b[k]["time"]) / float(a[k]["time"]), k, float(a[k]["time"]),
                     float(b[k]["time"])) for k in common)
    for x, k, t1, t2 in ranked[:8] + ranked[-8:]:
        out.append(f"| {x:.2f} | {k} | {t1:.3g} | {t2:.3g} |")
    print("\n".join(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

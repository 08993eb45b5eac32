"""What a fresh install compiles: ``socp_cd.warmup()`` with an empty numba cache, per tree.

numba compiles each kernel on its first call and caches it (``cache=True``); after an install
or a cache clear the first calls compile, and that time is the larger part of a clean clone's
``make test``.  A kernel is compiled once per combination of its arguments' numba types, and an
array's type includes its dtype and whether it is read-only, so every form a caller's arrays
may take is one more compiled version.

Each tree is measured in a fresh interpreter whose ``NUMBA_CACHE_DIR`` is a new empty folder
(the project's own cache is neither read nor written): the wall time of ``warmup()``, and for
each ``socp_cd`` dispatcher the number of versions it holds after it and the time spent
compiling it (numba's ``numba:compile`` events; inclusive: a kernel that another calls is
compiled inside the caller's compilation, so the times overlap and do not add up)::

    git worktree add /tmp/base <commit>
    .venv/bin/python validation/compile_cost.py --trees /tmp/base . \\
        --out validation/results/compile_cost_s37.md

One run per tree, one after the other.  On session 37's virtual machine three cold warm-ups
per tree spread over 286-321 s and 163-180 s: compare trees by more than that, or repeat.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

CHILD = r"""
import json, sys, time
from numba.core import event
from numba.core.registry import CPUDispatcher

spent, starts = {}, []

class Listener(event.Listener):
    # (compilations nest, one thread: a stack pairs each end with its start)
    def on_start(self, ev):
        starts.append(time.perf_counter())
    def on_end(self, ev):
        d = ev.data["dispatcher"]
        name = d.py_func.__module__ + "." + d.py_func.__qualname__
        spent[name] = spent.get(name, 0.0) + time.perf_counter() - starts.pop()

event.register("numba:compile", Listener())
t0 = time.perf_counter()
import socp_cd
t1 = time.perf_counter()
socp_cd.warmup()
t2 = time.perf_counter()
versions = {}
for name, mod in list(sys.modules.items()):
    if name.startswith("socp_cd"):
        for obj in list(vars(mod).values()):
            if isinstance(obj, CPUDispatcher) and obj.signatures:
                versions[obj.py_func.__module__ + "." + obj.py_func.__qualname__] = \
                    len(obj.signatures)
print(json.dumps({"import": t1 - t0, "warmup": t2 - t1, "spent": spent,
                  "versions": versions}))
"""


def measure(tree: Path) -> dict:
    """One cold ``warmup()`` of ``tree``'s ``socp_cd`` (its own ``.venv`` python when it has
    one, else this interpreter), in an empty numba cache."""
    python = tree / ".venv" / "bin" / "python"
    python = python if python.exists() else Path(sys.executable)
    with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(tree))
        done = subprocess.run([str(python), "-c", CHILD], cwd=tree, env=env,
                              capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def report(trees, runs, top) -> str:
    names = [str(t) for t in trees]
    lines = ["# A fresh install's compile time: `socp_cd.warmup()` with an empty numba cache", "",
             f"`python validation/compile_cost.py --trees {' '.join(names)}`; one cold run per "
             "tree, in a fresh interpreter with its own empty `NUMBA_CACHE_DIR`.", "",
             "| tree | warmup [s] | import [s] | compiled versions (dispatchers) |",
             "|---|---|---|---|"]
    for name, run in zip(names, runs):
        v = run["versions"]
        lines.append(f"| `{name}` | {run['warmup']:.1f} | {run['import']:.2f} | "
                     f"{sum(v.values())} ({len(v)}) |")
    keys = sorted((k for k in set().union(*(r["spent"] for r in runs))
                   if k.startswith("socp_cd")),
                  key=lambda k: -max(r["spent"].get(k, 0.0) for r in runs))[:top]
    lines += ["", f"The {top} dispatchers that took longest to compile (inclusive seconds, "
              "versions after the warm-up):", "",
              "| kernel | " + " | ".join(f"`{n}`" for n in names) + " |",
              "|---|" + "---|" * len(names)]
    for k in keys:
        cells = [f"{r['spent'].get(k, 0.0):.1f} s, {r['versions'].get(k, 0)}" for r in runs]
        lines.append(f"| `{k.replace('socp_cd.solvers.', '')}` | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trees", nargs="+", type=Path, default=[HERE.parent])
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--out", type=Path, default=None, help="report (.md; a .json beside it)")
    args = ap.parse_args(argv)
    trees = [t.resolve() for t in args.trees]
    runs = []
    for t in trees:
        runs.append(measure(t))
        print(f"{t}: warmup {runs[-1]['warmup']:.1f} s", flush=True)
    text = report(args.trees, runs, args.top)
    print(text)
    if args.out:
        args.out.write_text(text)
        args.out.with_suffix(".json").write_text(json.dumps(
            {str(t): r for t, r in zip(args.trees, runs)}, indent=1))


if __name__ == "__main__":
    main()

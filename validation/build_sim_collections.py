"""Step problems dumped from socp_cd's own simulations, as FCLib collections.

The second half of the evaluation set (:mod:`socp_cd.bench.evalset`): nobody
tuned anything on these.  Each collection is one scene run by
``socp-cd simulate`` with ``--fclib DIR --fclib-every N``; the scene files are
written next to the collections, so a collection says how it was made.

* ``deposit2d-N`` (N = 1 000, 4 000, 10 000): N disks (radii 8–12 mm) at
  random in a box, falling onto the floor: dumps during the collapse (many
  impacts and sliding contacts) and, for 1 000 and 4 000, as the deposit comes
  to rest (dense, rank-deficient W).  10 000 disks: the collapse only.
* ``pile3d-300``: 300 spheres dropped into a heap (``examples/sphere_pile.toml``).

Usage::

    .venv/bin/python validation/build_sim_collections.py [--out DIR] [--quick]

Default output: ``validation/evalset_sim/`` (not committed: regenerate it;
the runs are deterministic).  ``--quick``: 200 disks and 60 spheres, a few
dumps (used by a test).  Writes ``DIR/collections.md`` (contacts and wall
time per collection).

``--small`` builds small 3D collections into ``validation/evalset_sim_small/`` (held out
like the default ones): ``boxes3d-4``, ``boxes3d-8`` and ``boxes3d-12`` (stacks of 4, 8
and 12 boxes sliding down an incline, ``examples/box_stack_incline_above.toml``: 4 redundant
contacts per face, 16, 32 and 48 contacts), ``boxes3d-below-6`` (6 boxes at rest on the
incline, ``examples/box_stack_incline_below.toml``) and ``pile3d-20`` (20 spheres,
``examples/sphere_pile.toml``);
``--small --tune`` other scenes of the same kinds into ``validation/evalset_sim_small_tune/``
(see :func:`small_runs`).

``--small2d`` (session 46) builds small 2D collections into ``validation/evalset_sim_small2d/``
(held out): stacks of 4 and 8 rectangles sliding down the 2D incline
(``examples/box_stack_incline_2d_above.toml``), 6 at rest on it, a talus of 25 hexagons and a
deposit of 40 disks; ``--small2d --tune`` other sizes and seeds into
``validation/evalset_sim_small2d_tune/`` (:data:`SMALL2D_TUNE`), the ones a rule may be chosen on.

``--fresh`` builds scenes of the same kinds that no session had run (session 34) into
``validation/evalset_sim_fresh/`` (see :func:`fresh_runs`): a check of ``auto`` on simulation
dumps after its rules were chosen (``validation/fresh_draw.py --collections``).

``--kinds`` builds scenes of kinds no other collection has (session 41, after every rule of
``auto`` was chosen) into ``validation/evalset_sim_kinds/`` (see :func:`kinds_runs`): a
masonry wall of 3D boxes, a heavy block on light spheres (mass ratio ~1e5), a sphere pile of
two materials (μ 0.02 … 1.5), the Kapla tower of ``examples/``, a 2D hopper discharge and
Moreau's talus of hexagons; ``--kinds --tune`` other sizes and seeds of the same kinds into
``validation/evalset_sim_kinds_tune/``, the ones a rule may be chosen on.
``--kinds-fresh`` (session 42) builds a third draw of the same kinds, with sizes, seeds and
parameters neither of those uses (:data:`KINDS_FRESH`), into
``validation/evalset_sim_kinds_fresh/``: session 41 found its rule's need on ``--kinds`` and
chose it on ``--kinds --tune``, so this draw is the one nothing was looked at on.
``--kinds-fresh2`` (session 43) a fourth draw (:data:`KINDS_FRESH2`) into
``validation/evalset_sim_kinds_fresh2/``: session 43 looked at the third draw's walls before
choosing a rule (``auto.REDUNDANT_RETRY``), so the fourth is the clean check of that rule.

``--new-kinds`` (session 48) builds a fifth draw, of kinds no collection had
(:data:`NEW_KINDS`), into ``validation/evalset_sim_newkinds/``: a heap of 40 boxes and one of 30
irregular polyhedra, both dropped in random orientations (the packing's ``random_orientation``);
a chain of 16 toppling dominoes; a 2D heap of 150 pentagons in a box.  Built after every rule of
``auto`` was chosen and held out: nothing is tuned on them; they check ``auto`` against
Siconos on problems no session had looked at.  Session 48 then looked at that draw (a rule's
need was found there); ``--new-kinds-fresh`` builds a second draw of the same kinds
(:data:`NEW_KINDS_FRESH`: other sizes, seeds and parameters, fixed before the rule was measured)
into ``validation/evalset_sim_newkinds_fresh/``, the held-out check of that rule;
``--new-kinds-fresh2`` (session 50) a third draw (:data:`NEW_KINDS_FRESH2`) into
``validation/evalset_sim_newkinds_fresh2/``, fixed before session 50's drift rule was run on it;
``--new-kinds-fresh3`` (session 50) a fourth (:data:`NEW_KINDS_FRESH3`) into
``validation/evalset_sim_newkinds_fresh3/``, fixed before ``auto.DRIFT_COLD`` was run on it.

``--tune`` builds *other* scenes of the same kinds into
``validation/evalset_sim_tune/`` (1 500 disks with packing seed 11, 250
spheres with seed 2): the simulation problems ``auto``'s rules may be chosen
on, so the collections above stay held out.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from socp_cd.scenes.simulate import simulate

HERE = Path(__file__).resolve().parent
EXAMPLES = HERE.parent / "examples"

DEPOSIT = """\
# {n} disks at random in a box, falling onto the floor (evaluation-set collection).
[scene]
name = "Deposit2D{n}"
dim = 2
mu = 0.3
restitution = 0.0

[simulation]
h = 1e-3
theta = 0.5
steps = {steps}
solver = "nsgs"
tol = 1e-6
max_iter = 2000
record_every = {steps}

[[obstacles]]
shape = "line"
point = [0, 0]
normal = [0, 1]

[[obstacles]]
shape = "line"
point = [0, 0]
normal = [1, 0]

[[obstacles]]
shape = "line"
point = [{width}, 0]
normal = [-1, 0]

[[generate]]
kind = "random_packing"
lo = [0.0, 0.0]
hi = [{width}, {height}]
count = {n}
seed = {seed}
radius_range = [0.008, 0.012]
body = {{ shape = "disk", radius = 0.01, density = 2500.0 }}
"""

#: name -> (grains, steps, dump every)
FULL = {"deposit2d-1000": (1000, 2000, 100), "deposit2d-4000": (4000, 1600, 200),
        "deposit2d-10000": (10000, 300, 100)}
QUICK = {"deposit2d-200": (200, 300, 100)}
#: the tuning scenes (``--tune``): other sizes and packing seeds than FULL's
TUNE = {"deposit2d-tune-1500": (1500, 2000, 100)}
TUNE_DEPOSIT_SEED, TUNE_PILE = 11, (250, 2)          # disks' seed; spheres' count and seed


def deposit_scene(n: int, steps: int, seed: int = 7) -> str:
    """The TOML text of an ``n``-disk deposit (box width ~ 2.2 sqrt(n) diameters)."""
    width = round(0.045 * n ** 0.5, 4)
    area = n * 3.1416 * 0.0102 ** 2 / 0.33          # random sequential placement, 33 % of the box
    return DEPOSIT.format(n=n, steps=steps, width=width, height=round(area / width, 4), seed=seed)

#: ``--kinds-fresh`` (session 42, after session 41's rule was fixed): the same kinds with sizes,
#: seeds and parameters neither ``--kinds`` nor ``--kinds --tune`` uses, so that the rule found
#: on ``--kinds`` and chosen on ``--kinds --tune`` is checked on scenes nobody looked at:
#: name -> (the ``--kinds`` scene, replacements)
KINDS_FRESH = {
    "wall3d-fresh-18": ("wall3d-27", (("rows = 6", "rows = 5"), ("columns = 5", "columns = 4"),
                                      ("mu = 0.6", "mu = 0.4"))),
    "wall3d-fresh-39": ("wall3d-27", (("rows = 6", "rows = 7"), ("columns = 5", "columns = 6"),
                                      ("size = [0.2, 0.1, 0.1]", "size = [0.24, 0.12, 0.08]"))),
    "massratio3d-fresh-80": ("massratio3d-60", (("count = 60", "count = 80"), ("seed = 41", "seed = 81"),
                                                ("density = 2.5e7", "density = 2.5e8"))),
    "mixedmu3d-fresh-120": ("mixedmu3d-160", (("count = 80", "count = 60"), ("seed = 43", "seed = 83"),
                                              ("seed = 47", "seed = 87"))),
    "hopper2d-fresh-300": ("hopper2d-400", (("count = 400", "count = 300"), ("seed = 53", "seed = 93"),
                                            ("opening = 0.12", "opening = 0.1"))),
}

#: ``--kinds-fresh2`` (session 43, after the third draw's walls were looked at): a fourth draw,
#: sizes, seeds and parameters none of the three others uses
KINDS_FRESH2 = {
    "wall3d-fresh2-32": ("wall3d-27", (("rows = 6", "rows = 8"), ("columns = 5", "columns = 4"),
                                       ("mu = 0.6", "mu = 0.5"))),
    "wall3d-fresh2-35": ("wall3d-27", (("rows = 6", "rows = 5"), ("columns = 5", "columns = 7"),
                                       ("size = [0.2, 0.1, 0.1]", "size = [0.18, 0.09, 0.12]"))),
    "massratio3d-fresh2-50": ("massratio3d-60", (("count = 60", "count = 50"),
                                                 ("seed = 41", "seed = 101"),
                                                 ("density = 2.5e7", "density = 5e7"))),
    "mixedmu3d-fresh2-140": ("mixedmu3d-160", (("count = 80", "count = 70"),
                                               ("seed = 43", "seed = 103"),
                                               ("seed = 47", "seed = 107"))),
    "hopper2d-fresh2-350": ("hopper2d-400", (("count = 400", "count = 350"),
                                             ("seed = 53", "seed = 113"),
                                             ("opening = 0.12", "opening = 0.14"))),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=None,
                    help="output directory (default validation/evalset_sim, with --tune "
                         "validation/evalset_sim_tune; --kinds: validation/evalset_sim_kinds, "
                         "with --tune validation/evalset_sim_kinds_tune; --kinds-fresh: "
                         "validation/evalset_sim_kinds_fresh)")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true")
    ap.add_argument("--tune", action="store_true", help="the tuning scenes (see above)")
    mode.add_argument("--small", action="store_true", help="small 3D collections (see above)")
    mode.add_argument("--small2d", action="store_true",
                      help="small 2D collections (session 46, see above)")
    mode.add_argument("--fresh", action="store_true",
                      help="scenes no session had run, for a check after the fact (see above)")
    mode.add_argument("--kinds", action="store_true",
                      help="scene kinds no other collection has (session 41, see above)")
    mode.add_argument("--kinds-fresh", action="store_true",
                      help="the same kinds, sizes and seeds no other collection has (session 42, "
                           "see above)")
    mode.add_argument("--kinds-fresh2", action="store_true",
                      help="a fourth draw of the same kinds (session 43, see above)")
    mode.add_argument("--new-kinds", action="store_true",
                      help="a fifth draw, of kinds no collection had (session 48, see above)")
    mode.add_argument("--new-kinds-fresh", action="store_true",
                      help="a second draw of those kinds (session 48, see above)")
    mode.add_argument("--new-kinds-fresh2", action="store_true",
                      help="a third draw of those kinds (session 50, see above)")
    mode.add_argument("--new-kinds-fresh3", action="store_true",
                      help="a fourth draw of those kinds (session 50, see above)")
    ap.add_argument("--only", nargs="*", default=None)
    args = ap.parse_args(argv)
    if args.tune and (args.fresh or args.kinds_fresh or args.kinds_fresh2 or args.quick
                      or args.new_kinds or args.new_kinds_fresh or args.new_kinds_fresh2
                      or args.new_kinds_fresh3):
        ap.error("--tune goes with the default collections, --small, --small2d or --kinds")
    if args.out is None and args.fresh:
        args.out = HERE / "evalset_sim_fresh"
    if args.out is None and (args.kinds_fresh or args.kinds_fresh2):
        args.out = HERE / ("evalset_sim_kinds_fresh2" if args.kinds_fresh2
                           else "evalset_sim_kinds_fresh")
    new_kinds = (args.new_kinds or args.new_kinds_fresh or args.new_kinds_fresh2
                 or args.new_kinds_fresh3)
    if args.out is None and new_kinds:
        args.out = HERE / ("evalset_sim_newkinds_fresh3" if args.new_kinds_fresh3
                           else "evalset_sim_newkinds_fresh2" if args.new_kinds_fresh2
                           else "evalset_sim_newkinds_fresh" if args.new_kinds_fresh
                           else "evalset_sim_newkinds")
    if args.out is None and args.kinds:
        args.out = HERE / ("evalset_sim_kinds_tune" if args.tune else "evalset_sim_kinds")
    if args.out is None:
        args.out = HERE / ("evalset_sim_small2d_tune" if args.small2d and args.tune
                           else "evalset_sim_small2d" if args.small2d
                           else "evalset_sim_small_tune" if args.small and args.tune
                           else "evalset_sim_tune" if args.tune
                           else "evalset_sim_small" if args.small else "evalset_sim")
    args.out.mkdir(parents=True, exist_ok=True)
    runs = []
    if args.small:
        runs = small_runs(args.out, args.tune)
        return build(runs, args)
    if args.small2d:
        return build(small2d_runs(args.out, args.tune), args)
    if args.fresh:
        return build(fresh_runs(args.out), args)
    if args.kinds:
        return build(kinds_runs(args.out, "tune" if args.tune else "held"), args)
    if args.kinds_fresh or args.kinds_fresh2:
        return build(kinds_runs(args.out, "fresh2" if args.kinds_fresh2 else "fresh"), args)
    if new_kinds:
        return build(new_kinds_runs(args.out, "fresh3" if args.new_kinds_fresh3
                                    else "fresh2" if args.new_kinds_fresh2
                                    else args.new_kinds_fresh), args)
    table = QUICK if args.quick else TUNE if args.tune else FULL
    for name, (n, steps, every) in table.items():
        scene = args.out / f"{name}.toml"
        scene.write_text(deposit_scene(n, steps, TUNE_DEPOSIT_SEED if args.tune else 7))
        runs.append((name, scene, None, every))
    pile = args.out / "pile3d.toml"
    text = (EXAMPLES / "sphere_pile.toml").read_text()
    if args.quick:
        text = text.replace("count = 300", "count = 60")
    if args.tune:
        count, seed = TUNE_PILE
        text = text.replace("count = 300", f"count = {count}").replace("seed = 1", f"seed = {seed}")
    pile.write_text(text)
    pile_name = "pile3d-60" if args.quick else f"pile3d-tune-{TUNE_PILE[0]}" if args.tune else "pile3d-300"
    runs.append((pile_name, pile, 200 if args.quick else None, 50 if args.quick else 150))
    return build(runs, args)


def small_runs(out: Path, tune: bool = False) -> list:
    """The ``--small`` collections: ``(name, scene file, steps, dump every)``: stacks of 4, 8
    and 12 boxes sliding down the incline, 6 boxes at rest on it (below the friction angle), a
    20-sphere pile; with ``tune`` other scenes of the same kinds (``--small --tune``: stacks
    of 5, 6 and 10 boxes, 3 and 7 boxes below the friction angle, a 15-sphere pile with
    another seed), the ones a rule may be chosen on."""
    if tune:
        runs = []
        above = (EXAMPLES / "box_stack_incline_above.toml").read_text()
        below = (EXAMPLES / "box_stack_incline_below.toml").read_text()
        for name, text, count in (("boxes3d-tune-5", above, 5), ("boxes3d-tune-6", above, 6),
                                  ("boxes3d-tune-below-3", below, 3),
                                  # session 14: stacks of more than 72 unknowns (m = 3 nc)
                                  ("boxes3d-tune-10", above, 10),
                                  ("boxes3d-tune-below-7", below, 7)):
            scene = out / f"{name}.toml"
            scene.write_text(text.replace("count = 4", f"count = {count}"))
            runs.append((name, scene, 1000, 50))
        scene = out / "pile3d-tune-15.toml"
        scene.write_text((EXAMPLES / "sphere_pile.toml").read_text()
                         .replace("count = 300", "count = 15").replace("seed = 1", "seed = 5"))
        runs.append(("pile3d-tune-15", scene, None, 100))
        return runs
    runs = []
    stack = (EXAMPLES / "box_stack_incline_above.toml").read_text()
    for count in (4, 8, 12):        # (12: built in session 14, after the rules were chosen)
        scene = out / f"boxes3d-{count}.toml"
        scene.write_text(stack.replace("count = 4", f"count = {count}"))
        runs.append((f"boxes3d-{count}", scene, 1000, 50))
    scene = out / "boxes3d-below-6.toml"
    scene.write_text((EXAMPLES / "box_stack_incline_below.toml").read_text()
                     .replace("count = 4", "count = 6"))
    runs.append(("boxes3d-below-6", scene, 1000, 50))
    scene = out / "pile3d-20.toml"
    scene.write_text((EXAMPLES / "sphere_pile.toml").read_text().replace("count = 300",
                                                                          "count = 20"))
    runs.append(("pile3d-20", scene, None, 100))
    return runs


#: ``--small2d`` (session 46): small 2D scenes, name -> (example or scene, replacements, steps,
#: dump every): stacks of rectangles on the incline sliding and at rest, a talus of hexagons,
#: a deposit of disks; ``--small2d --tune`` (:data:`SMALL2D_TUNE`) other sizes and seeds of the
#: same kinds, the ones a rule may be chosen on
SMALL2D = {
    "boxes2d-4": ("box_stack_incline_2d_above.toml", (), 1000, 50),
    "boxes2d-8": ("box_stack_incline_2d_above.toml", (("count = 4", "count = 8"),), 1000, 50),
    "boxes2d-below-6": ("box_stack_incline_2d_below.toml", (("count = 4", "count = 6"),), 1000, 50),
    "talus2d-small-25": ("talus_2d.toml", (("count = 200", "count = 25"), ("seed = 3", "seed = 5"),
                                           ("hi = [0.9, 2.4]", "hi = [0.5, 0.9]")), 1500, 50),
    "deposit2d-40": ("deposit", (40, 7), 1200, 50),
}
SMALL2D_TUNE = {
    "boxes2d-tune-5": ("box_stack_incline_2d_above.toml", (("count = 4", "count = 5"),), 1000, 50),
    "boxes2d-tune-below-3": ("box_stack_incline_2d_below.toml", (("count = 4", "count = 3"),),
                             1000, 50),
    "talus2d-small-tune-15": ("talus_2d.toml", (("count = 200", "count = 15"),
                                                ("seed = 3", "seed = 13"),
                                                ("hi = [0.9, 2.4]", "hi = [0.5, 0.9]")), 1500, 50),
    "deposit2d-tune-25": ("deposit", (25, 11), 1200, 50),
}
# (added in session 46 after the held-out run showed Lemke's pivot tolerance too small on a
# sliding stack of 4: more stacks, every 25 steps, to choose it on)
SMALL2D_TUNE.update({
    f"boxes2d-tune-{n}": ("box_stack_incline_2d_above.toml", (("count = 4", f"count = {n}"),),
                          1000, 25) for n in (2, 3, 6, 7)})
SMALL2D_TUNE.update({
    f"boxes2d-tune-below-{n}": ("box_stack_incline_2d_below.toml", (("count = 4", f"count = {n}"),),
                                1000, 25) for n in (2, 4, 5)})


def small2d_runs(out: Path, tune: bool = False) -> list:
    """The ``--small2d`` collections (:data:`SMALL2D`, with ``tune`` :data:`SMALL2D_TUNE`):
    ``(name, scene file, steps, dump every)``."""
    runs = []
    for name, (base, swaps, steps, every) in (SMALL2D_TUNE if tune else SMALL2D).items():
        if base == "deposit":
            n, seed = swaps
            text = deposit_scene(n, steps, seed)
        else:
            text = _swapped(name, (EXAMPLES / base).read_text(), swaps)
        scene = out / f"{name}.toml"
        scene.write_text(text)
        runs.append((name, scene, steps, every))
    return runs


def fresh_runs(out: Path) -> list:
    """The ``--fresh`` collections (session 34, after every rule of ``auto`` was chosen): stacks
    of 7 and 9 boxes sliding down the incline, 5 boxes at rest on it, piles of 40 and 120
    spheres and a deposit of 600 disks, with counts and seeds no other collection uses."""
    above = (EXAMPLES / "box_stack_incline_above.toml").read_text()
    below = (EXAMPLES / "box_stack_incline_below.toml").read_text()
    pile = (EXAMPLES / "sphere_pile.toml").read_text()
    runs = []
    for name, text in (("boxes3d-fresh-7", above.replace("count = 4", "count = 7")),
                       ("boxes3d-fresh-9", above.replace("count = 4", "count = 9")),
                       ("boxes3d-fresh-below-5", below.replace("count = 4", "count = 5")),
                       ("pile3d-fresh-40", pile.replace("count = 300", "count = 40")
                        .replace("seed = 1", "seed = 9")),
                       ("pile3d-fresh-120", pile.replace("count = 300", "count = 120")
                        .replace("seed = 1", "seed = 13")),
                       ("deposit2d-fresh-600", deposit_scene(600, 1500, seed=23))):
        scene = out / f"{name}.toml"
        scene.write_text(text)
        every = 100 if name.startswith(("pile", "deposit")) else 50
        runs.append((name, scene, 1000 if name.startswith("boxes") else None, every))
    return runs


KINDS_HEADER = """\
# {what} (validation/build_sim_collections.py --kinds, session 41).
[scene]
name = "{name}"
dim = {dim}
mu = {mu}
restitution = 0.0

[simulation]
h = {h}
theta = 0.5
steps = {steps}
solver = "nsgs"
tol = 1e-6
max_iter = 3000
record_every = 50
"""
FLOOR_3D = """
[[obstacles]]
shape = "plane"
point = [0, 0, 0]
normal = [0, 0, 1]
"""
#: name -> (what, dim, mu, h, steps, dump every, the scene's obstacles and generators)
KINDS = {
    "wall3d-27": ("A masonry wall of 27 boxes in running bond on a rough floor", 3, 0.6, 2e-3,
                  300, 50, FLOOR_3D + """
[[generate]]
kind = "wall"
origin = [0, 0, 0]
rows = 6
columns = 5
body = { shape = "box", size = [0.2, 0.1, 0.1], density = 2000.0 }
"""),
    "massratio3d-60": ("A block of 2.5e7 kg/m3 (mass ratio ~1e5 to a grain) dropped on 60 light "
                       "spheres", 3, 0.5, 2e-3, 800, 50, FLOOR_3D + """mu = 0.8

[[generate]]
kind = "random_packing"
lo = [-0.08, -0.08, 0.02]
hi = [0.08, 0.08, 0.7]
count = 60
seed = 41
radius_range = [0.015, 0.025]
body = { shape = "sphere", radius = 0.02, density = 2500.0 }

[[generate]]
kind = "stack"
base = [0, 0, 0.8]
count = 1
body = { shape = "box", size = [0.12, 0.12, 0.06], density = 2.5e7 }
"""),
    "mixedmu3d-160": ("A pile of 160 spheres of two materials, mu 0.02 (ice) to 1.5 (rubber)",
                      3, 0.5, 2e-3, 800, 50, """
[[materials]]
pair = ["ice", "ice"]
mu = 0.02
[[materials]]
pair = ["rubber", "rubber"]
mu = 1.5
[[materials]]
pair = ["ice", "rubber"]
mu = 0.3
[[materials]]
pair = ["ice", "floor"]
mu = 0.05
[[materials]]
pair = ["rubber", "floor"]
mu = 1.2
""" + FLOOR_3D + """material = "floor"

[[generate]]
kind = "random_packing"
lo = [-0.12, -0.12, 0.05]
hi = [0.12, 0.12, 0.5]
count = 80
seed = 43
radius_range = [0.015, 0.025]
body = { shape = "sphere", radius = 0.02, density = 2500.0, material = "ice" }

[[generate]]
kind = "random_packing"
lo = [-0.12, -0.12, 0.55]
hi = [0.12, 0.12, 1.0]
count = 80
seed = 47
radius_range = [0.015, 0.025]
body = { shape = "sphere", radius = 0.02, density = 2500.0, material = "rubber" }
"""),
    "hopper2d-400": ("A 2D hopper discharging 400 disks", 2, 0.4, 1e-3, 1500, 100, """
[[obstacles]]
shape = "line"
point = [0, -0.6]
normal = [0, 1]

[[generate]]
kind = "hopper"
outlet = [0, 0]
opening = 0.12
count = 400
seed = 53
body = { shape = "disk", radius = 0.01, density = 2000.0 }
"""),
}


#: ``--kinds --tune``: the same kinds, other sizes and seeds (the scenes a rule may be chosen
#: on; ``--kinds`` alone stays held out): name -> (the ``--kinds`` scene, replacements)
KINDS_TUNE = {
    "wall3d-tune-14": ("wall3d-27", (("rows = 6", "rows = 4"), ("columns = 5", "columns = 4"))),
    "wall3d-tune-36": ("wall3d-27", (("rows = 6", "rows = 8"),)),
    "massratio3d-tune-40": ("massratio3d-60", (("count = 60", "count = 40"), ("seed = 41", "seed = 61"),
                                               ("density = 2.5e7", "density = 2.5e6"))),
    "mixedmu3d-tune-100": ("mixedmu3d-160", (("count = 80", "count = 50"), ("seed = 43", "seed = 63"),
                                             ("seed = 47", "seed = 67"))),
    "hopper2d-tune-250": ("hopper2d-400", (("count = 400", "count = 250"), ("seed = 53", "seed = 73"))),
}


#: the draws of :func:`kinds_runs`: ``held`` (``--kinds``), ``tune`` (``--kinds --tune``),
#: ``fresh`` (``--kinds-fresh``), ``fresh2`` (``--kinds-fresh2``)
DRAWS = ("held", "tune", "fresh", "fresh2")
#: the derived draws: draw -> (the table of its scenes, the option that builds it)
DERIVED = {"tune": (KINDS_TUNE, "--kinds --tune, session 41"),
           "fresh": (KINDS_FRESH, "--kinds-fresh, session 42"),
           "fresh2": (KINDS_FRESH2, "--kinds-fresh2, session 43")}
#: each draw's scenes made from ``examples/``: name -> (example file, replacements, steps,
#: dump every)
KINDS_EXAMPLES = {
    "held": {"kapla3d-24": ("kapla_tower.toml", (), 1000, 100),
             "talus2d-200": ("talus_2d.toml", (), 3000, 300)},
    "tune": {"kapla3d-tune-16": ("kapla_tower.toml", (("levels = 12", "levels = 8"),), 1000, 100),
             "kapla3d-tune-32": ("kapla_tower.toml", (("levels = 12", "levels = 16"),), 1000, 100),
             "talus2d-tune-120": ("talus_2d.toml", (("count = 200", "count = 120"),
                                                    ("seed = 3", "seed = 17")), 3000, 300)},
    "fresh": {"kapla3d-fresh-20": ("kapla_tower.toml", (("levels = 12", "levels = 10"),
                                                        ("mu = 0.5", "mu = 0.4")), 1000, 100),
              "talus2d-fresh-160": ("talus_2d.toml", (("count = 200", "count = 160"),
                                                      ("seed = 3", "seed = 29")), 3000, 300)},
    "fresh2": {"kapla3d-fresh2-28": ("kapla_tower.toml", (("levels = 12", "levels = 14"),
                                                          ("mu = 0.5", "mu = 0.45")), 1000, 100),
               "talus2d-fresh2-180": ("talus_2d.toml", (("count = 200", "count = 180"),
                                                        ("seed = 3", "seed = 41")), 3000, 300)},
}


assert "--kinds, session 41" in KINDS_HEADER
NEW_KINDS_HEADER = KINDS_HEADER.replace("--kinds, session 41", "--new-kinds, session 48")


def _dropped(lo, hi, count, seed, body, radius_range=None) -> str:
    """A ``random_packing`` table of ``count`` bodies (``body``: the template's TOML) in random
    orientations in the box ``lo``–``hi``, to be dropped."""
    rr = "" if radius_range is None else f"radius_range = {radius_range}\n"
    return (f'\n[[generate]]\nkind = "random_packing"\nlo = {lo}\nhi = {hi}\ncount = {count}\n'
            f"seed = {seed}\n{rr}random_orientation = true\nbody = {body}\n")


def _lines_2d(*lines) -> str:
    """Fixed 2D lines (``(point, normal)`` pairs) as ``[[obstacles]]`` tables."""
    return "\n".join(f'\n[[obstacles]]\nshape = "line"\npoint = {p}\nnormal = {n}' for p, n in lines) + "\n"


#: ``--new-kinds`` (session 48): name -> (what, dim, mu, h, steps, dump every, the scene's
#: obstacles and generators), as :data:`KINDS`
NEW_KINDS = {
    "boxpile3d-40": ("A heap of 40 boxes (10 x 6 x 4 cm) dropped in random orientations", 3, 0.5,
                     2e-3, 1000, 50, FLOOR_3D + _dropped(
                         [-0.3, -0.3, 0.02], [0.3, 0.3, 1.2], 40, 131,
                         '{ shape = "box", size = [0.1, 0.06, 0.04], density = 700.0 }')),
    "polypile3d-30": ("A heap of 30 irregular convex polyhedra (7 vertices) dropped in random "
                      "orientations", 3, 0.6, 2e-3, 800, 40, FLOOR_3D + _dropped(
                          [-0.12, -0.12, 0.02], [0.12, 0.12, 0.9], 30, 137,
                          '{ shape = "polyhedron", density = 2500.0, vertices = [[0.03, 0.0, 0.0], '
                          '[-0.02, 0.025, 0.0], [-0.015, -0.028, 0.005], [0.0, 0.004, 0.032], '
                          '[0.004, -0.002, -0.027], [0.018, 0.02, 0.015], [-0.01, -0.01, -0.02]] }')),
    "dominoes3d-16": ("A chain of 16 dominoes (2 x 10 x 20 cm, 7.5 cm apart), the first tipped "
                      "at 4 rad/s", 3, 0.4, 1e-3, 1500, 75, FLOOR_3D + """
[[bodies]]
shape = "box"
size = [0.02, 0.1, 0.2]
density = 700.0
position = [-0.075, 0, 0.1]
omega = [0, 4.0, 0]

[[generate]]
kind = "row"
start = [0.0, 0, 0.1]
end = [1.05, 0, 0.1]
count = 15
body = { shape = "box", size = [0.02, 0.1, 0.2], density = 700.0 }
"""),
    "pentagons2d-150": ("A 2D heap of 150 pentagons (circumradius 12-20 mm) in a box, dropped in "
                        "random orientations", 2, 0.5, 1e-3, 1500, 75,
                        _lines_2d(([0, 0], [0, 1]), ([-0.25, 0], [1, 0]), ([0.25, 0], [-1, 0]))
                        + _dropped([-0.25, 0.0], [0.25, 0.6], 150, 139,
                                  '{ shape = "polygon", sides = 5, radius = 0.015, density = 2000.0 }',
                                  radius_range=[0.012, 0.02])),
}


#: ``--new-kinds-fresh`` (session 48): a second draw of the new kinds, other sizes, seeds and
#: parameters, fixed before any rule was measured on the first (which session 48 then looked
#: at): name -> (the ``--new-kinds`` scene, replacements), as :data:`KINDS_FRESH`
NEW_KINDS_FRESH = {
    "boxpile3d-fresh-30": ("boxpile3d-40", (("count = 40", "count = 30"), ("seed = 131", "seed = 151"),
                                            ("size = [0.1, 0.06, 0.04]", "size = [0.12, 0.05, 0.05]"))),
    "polypile3d-fresh-24": ("polypile3d-30", (("count = 30", "count = 24"), ("seed = 137", "seed = 157"),
                                              ("mu = 0.6", "mu = 0.5"))),
    "dominoes3d-fresh-12": ("dominoes3d-16", (("count = 15", "count = 11"),
                                              ("end = [1.05, 0, 0.1]", "end = [0.8, 0, 0.11]"),
                                              ("start = [0.0, 0, 0.1]", "start = [0.0, 0, 0.11]"),
                                              ("position = [-0.075, 0, 0.1]", "position = [-0.08, 0, 0.11]"),
                                              ("size = [0.02, 0.1, 0.2]", "size = [0.025, 0.12, 0.22]"),
                                              ("omega = [0, 4.0, 0]", "omega = [0, 5.0, 0]"),
                                              ("mu = 0.4", "mu = 0.5"))),
    "pentagons2d-fresh-120": ("pentagons2d-150", (("count = 150", "count = 120"),
                                                  ("seed = 139", "seed = 163"))),
}


#: ``--new-kinds-fresh2`` (session 50): a third draw of the new kinds, other sizes, seeds and
#: parameters than the two others, fixed before session 50's drift rule (``auto.DRIFT_WINDOW``,
#: found on the first draw's dominoes) was run on it: two chains of dominoes, a heap of boxes
#: and one of polyhedra (the rule's held-out check beside the second draw)
NEW_KINDS_FRESH2 = {
    "boxpile3d-fresh2-36": ("boxpile3d-40", (("count = 40", "count = 36"), ("seed = 131", "seed = 171"),
                                             ("size = [0.1, 0.06, 0.04]", "size = [0.09, 0.07, 0.035]"))),
    "polypile3d-fresh2-36": ("polypile3d-30", (("count = 30", "count = 36"), ("seed = 137", "seed = 177"),
                                               ("mu = 0.6", "mu = 0.7"))),
    "dominoes3d-fresh2-14": ("dominoes3d-16", (("count = 15", "count = 13"),
                                               ("end = [1.05, 0, 0.1]", "end = [0.84, 0, 0.1]"),
                                               ("omega = [0, 4.0, 0]", "omega = [0, 3.0, 0]"),
                                               ("mu = 0.4", "mu = 0.3"))),
    "dominoes3d-fresh2-20": ("dominoes3d-16", (("count = 15", "count = 19"),
                                               ("end = [1.05, 0, 0.1]", "end = [1.26, 0, 0.1]"),
                                               ("size = [0.02, 0.1, 0.2]", "size = [0.015, 0.08, 0.18]"),
                                               ("start = [0.0, 0, 0.1]", "start = [0.0, 0, 0.09]"),
                                               ("position = [-0.075, 0, 0.1]", "position = [-0.07, 0, 0.09]"),
                                               ("omega = [0, 4.0, 0]", "omega = [0, 4.5, 0]"),
                                               ("mu = 0.4", "mu = 0.6"))),
}


#: ``--new-kinds-fresh3`` (session 50): a fourth draw, fixed before ``auto.DRIFT_COLD`` (found
#: on dominoes steps of the first and the third draw) was run on it
NEW_KINDS_FRESH3 = {
    "boxpile3d-fresh3-44": ("boxpile3d-40", (("count = 40", "count = 44"), ("seed = 131", "seed = 191"),
                                             ("size = [0.1, 0.06, 0.04]", "size = [0.08, 0.06, 0.05]"))),
    "dominoes3d-fresh3-12": ("dominoes3d-16", (("count = 15", "count = 11"),
                                               ("end = [1.05, 0, 0.1]", "end = [0.88, 0, 0.1]"),
                                               ("omega = [0, 4.0, 0]", "omega = [0, 6.0, 0]"),
                                               ("mu = 0.4", "mu = 0.5"))),
    "dominoes3d-fresh3-18": ("dominoes3d-16", (("count = 15", "count = 17"),
                                               ("end = [1.05, 0, 0.1]", "end = [1.02, 0, 0.1]"),
                                               ("size = [0.02, 0.1, 0.2]", "size = [0.025, 0.09, 0.19]"),
                                               ("start = [0.0, 0, 0.1]", "start = [0.0, 0, 0.095]"),
                                               ("position = [-0.075, 0, 0.1]", "position = [-0.065, 0, 0.095]"),
                                               ("omega = [0, 4.0, 0]", "omega = [0, 3.5, 0]"),
                                               ("mu = 0.4", "mu = 0.35"))),
    "dominoes3d-fresh3-24": ("dominoes3d-16", (("count = 15", "count = 23"),
                                               ("end = [1.05, 0, 0.1]", "end = [1.495, 0, 0.1]"),
                                               ("omega = [0, 4.0, 0]", "omega = [0, 5.0, 0]"),
                                               ("mu = 0.4", "mu = 0.45"))),
}


def new_kinds_runs(out: Path, fresh=False) -> list:
    """The ``--new-kinds`` collections (session 48): ``(name, scene file, steps, dump every)``
    of :data:`NEW_KINDS`; with ``fresh`` those of :data:`NEW_KINDS_FRESH`, with ``fresh =
    "fresh2"`` (``"fresh3"``) those of :data:`NEW_KINDS_FRESH2` (:data:`NEW_KINDS_FRESH3`)."""
    scenes = {name: (NEW_KINDS_HEADER.format(what=what, name=name, dim=dim, mu=mu, h=h,
                                             steps=steps) + body, steps, every)
              for name, (what, dim, mu, h, steps, every, body) in NEW_KINDS.items()}
    if fresh == "fresh3":
        scenes = _derived(scenes, NEW_KINDS_FRESH3, "--new-kinds",
                          "--new-kinds-fresh3, session 50")
    elif fresh == "fresh2":
        scenes = _derived(scenes, NEW_KINDS_FRESH2, "--new-kinds",
                          "--new-kinds-fresh2, session 50")
    elif fresh:
        scenes = _derived(scenes, NEW_KINDS_FRESH, "--new-kinds",
                          "--new-kinds-fresh, session 48")
    return _written(out, scenes)


def _swapped(name, text, swaps) -> str:
    """``text`` with each ``(old, new)`` of ``swaps`` replaced (every occurrence; ``old`` must
    occur: a scene that silently kept its base's value would not be the scene named)."""
    for old, new in swaps:
        assert old in text, (name, old)
        text = text.replace(old, new)
    return text


def _written(out: Path, scenes) -> list:
    """Each scene of ``scenes`` (name -> (text, steps, dump every)) written to
    ``out/<name>.toml``: the runs ``(name, scene file, steps, dump every)``."""
    runs = []
    for name, (text, steps, every) in scenes.items():
        scene = out / f"{name}.toml"
        scene.write_text(text)
        runs.append((name, scene, steps, every))
    return runs


def _derived(scenes, table, source, option) -> dict:
    """The scenes of ``table`` (name -> (base scene, replacements)) made from ``scenes`` (name ->
    (text, steps, dump every), the ``source`` draw's): each one's first line says what it is
    made from and by which ``option``, its ``[scene]`` name is its own."""
    derived = {}
    for name, (base, swaps) in table.items():
        text, steps, every = scenes[base]
        head, rest = _swapped(name, text, swaps).split("\n", 1)
        head = (f"# {name}: the {source} scene {base} with "
                + "; ".join(f"{o} -> {n}" for o, n in swaps)
                + f" (validation/build_sim_collections.py {option}).")
        derived[name] = (head + "\n" + rest.replace(f'name = "{base}"', f'name = "{name}"'),
                         steps, every)
    return derived


def kinds_runs(out: Path, draw: str = "held") -> list:
    """The ``--kinds`` collections (session 41): ``(name, scene file, steps, dump every)`` of
    :data:`KINDS` and :data:`KINDS_EXAMPLES` (the Kapla tower of ``examples/``, 1 000 steps,
    and Moreau's talus of 200 hexagons, ``examples/talus_2d.toml``); with ``draw="tune"`` the
    :data:`KINDS_TUNE` scenes, Kapla towers of 8 and 16 levels and a talus of 120 hexagons with
    another seed; with ``draw="fresh"`` the :data:`KINDS_FRESH` scenes, a tower of 10 levels
    (μ 0.4 between planks) and a talus of 160 hexagons with a third seed; with
    ``draw="fresh2"`` the :data:`KINDS_FRESH2` scenes, a tower of 14 levels (μ 0.45) and a
    talus of 180 hexagons with a fourth seed."""
    if draw not in DRAWS:
        raise ValueError(f"draw must be one of {DRAWS}, got {draw!r}")
    scenes = {name: (KINDS_HEADER.format(what=what, name=name, dim=dim, mu=mu, h=h, steps=steps)
                     + body, steps, every)
              for name, (what, dim, mu, h, steps, every, body) in KINDS.items()}
    if draw != "held":
        table, option = DERIVED[draw]
        scenes = _derived(scenes, table, "--kinds", option)
    for name, (example, swaps, steps, every) in KINDS_EXAMPLES[draw].items():
        scenes[name] = (_swapped(name, (EXAMPLES / example).read_text(), swaps), steps, every)
    return _written(out, scenes)


def build(runs, args) -> int:
    """Run each scene of ``runs`` with FCLib dumps and write ``collections.md``."""
    lines = ["# Simulation collections of the evaluation set", "",
             "Generated by `validation/build_sim_collections.py`; NSGS at tol 1e-6 inside the "
             "simulation (the stored solution is that step's answer; the problem itself is exact).", "",
             "| collection | problems | contacts (min–max) | steps | wall time [s] |", "|---|---|---|---|---|"]
    for name, scene, steps, every in runs:
        if args.only and name not in args.only:
            continue
        t0 = time.perf_counter()
        s = simulate(scene, steps=steps, fclib=args.out / name, fclib_every=every, quiet=True)
        wall = time.perf_counter() - t0
        nc = [int(f.name.split("-")[-2]) for f in s["fclib_files"]]
        lines.append(f"| {name} | {len(nc)} | {min(nc, default=0)}–{max(nc, default=0)} | {s['steps']} | {wall:.0f} |")
        print(lines[-1], flush=True)
    index = args.out / "collections.md"
    if args.only and index.exists():          # keep the rows of the collections not rebuilt
        built = {ln.split("|")[1].strip() for ln in lines[6:]}
        lines += [ln for ln in index.read_text().splitlines()
                  if ln.startswith("| ") and not ln.startswith("| collection")
                  and ln.split("|")[1].strip() not in built]
    index.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

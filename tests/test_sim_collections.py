"""validation/build_sim_collections.py's ``--kinds`` scenes (session 41), ``--kinds-fresh``
(session 42) and ``--kinds-fresh2`` (session 43): the four draws apart, every scene a valid
scene file, and the box scenes the redundant-contact problems they are for."""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

import socp_cd
from socp_cd.scenes.simulate import simulate
from socp_cd.solvers import auto


@pytest.fixture()
def script(validation_script):
    return validation_script("build_sim_collections")


def _scene_body(path) -> str:
    """A scene file's text without its comment lines and its ``name``: what makes the scene
    (each draw's files differ in those two by construction)."""
    return "\n".join(ln for ln in Path(path).read_text().splitlines()
                     if not ln.startswith("#") and not ln.startswith("name = "))


def _draws(script, root):
    """``{draw: runs}`` of the draws of the kinds, each written in its own folder."""
    out = {}
    for draw in script.DRAWS:
        (root / draw).mkdir()
        out[draw] = script.kinds_runs(root / draw, draw)
    return out


def test_every_kinds_scene_loads(script, tmp_path):
    from socp_cd.scenes import load_simulation
    runs = [r for rs in _draws(script, tmp_path).values() for r in rs]
    assert len(runs) == 28
    for name, scene, steps, every in runs:
        spec, sim = load_simulation(scene)
        assert len(spec.bodies) > 0 and sim.h > 0 and steps > every > 0, name
        # each scene says which it is (the examples' keep their own names)
        assert spec.name in (name, "KaplaTower", "Talus2D"), (name, spec.name)


def test_the_draws_of_the_kinds_are_apart(script, tmp_path):
    draws = _draws(script, tmp_path)
    assert {d: len(rs) for d, rs in draws.items()} == {"held": 6, "tune": 8, "fresh": 7,
                                                       "fresh2": 7}
    names = [n for rs in draws.values() for n, *_ in rs]
    assert len(set(names)) == len(names)
    texts = {d: {_scene_body(s) for _, s, *_ in rs} for d, rs in draws.items()}
    for a, b in itertools.combinations(draws, 2):
        assert not texts[a] & texts[b], (a, b)                          # no scene in two draws


@pytest.mark.parametrize("name,redundant", [("wall3d-27", True), ("massratio3d-60", False)])
def test_a_box_wall_step_has_redundant_contacts_and_a_sphere_heap_does_not(script, tmp_path,
                                                                           name, redundant):
    _, scene, _, _ = next(r for r in script.kinds_runs(tmp_path) if r[0] == name)
    steps = 1 if redundant else 300         # (the spheres fall first)
    out = simulate(scene, steps=steps, fclib=tmp_path / "dumps", fclib_every=steps, quiet=True)
    problem = socp_cd.read_problem(out["fclib_files"][-1])
    assert problem.n_contacts > 0
    share = auto.contact_redundancy(problem)
    assert (share == 1.0) if redundant else (share < 0.5)


def test_the_new_kinds_load_and_are_apart_from_every_draw(script, tmp_path):
    """``--new-kinds`` and ``--new-kinds-fresh`` (session 48): four valid scenes each, each
    named as its collection, that no other draw holds, their heaps dropped in random
    orientations."""
    from socp_cd.scenes import load_simulation, load_scene_file
    (tmp_path / "new").mkdir()
    (tmp_path / "new_fresh").mkdir()
    first = script.new_kinds_runs(tmp_path / "new")
    fresh = script.new_kinds_runs(tmp_path / "new_fresh", fresh=True)
    assert [n for n, *_ in first] == list(script.NEW_KINDS)
    assert [n for n, *_ in fresh] == list(script.NEW_KINDS_FRESH)
    runs = first + fresh
    for name, scene, steps, every in runs:
        spec, sim = load_simulation(scene)
        assert spec.name == name and len(spec.bodies) > 0 and sim.h > 0 and steps > every > 0
        if "pile" in name or "pentagons" in name:
            turns = {tuple(np.atleast_1d(b["orientation" if spec.dim == 3 else "angle"]))
                     for b in load_scene_file(scene).bodies}
            assert len(turns) == len(spec.bodies), name
    old = {_scene_body(s) for rs in _draws(script, tmp_path).values() for _, s, *_ in rs}
    assert not old & {_scene_body(s) for _, s, *_ in runs}
    assert not {_scene_body(s) for _, s, *_ in first} & {_scene_body(s) for _, s, *_ in fresh}

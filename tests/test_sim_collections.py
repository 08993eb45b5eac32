"""validation/build_sim_collections.py's ``--kinds`` scenes (session 41): held out and tune apart,
every scene a valid scene file, and the box scenes the redundant-contact problems they are for."""
from __future__ import annotations

from pathlib import Path

import pytest

import socp_cd
from socp_cd.scenes.simulate import simulate
from socp_cd.solvers import auto

@pytest.fixture()
def script(validation_script):
    return validation_script("build_sim_collections")


def test_every_kinds_scene_loads(script, tmp_path):
    from socp_cd.scenes import load_simulation
    (tmp_path / "held").mkdir()
    (tmp_path / "tune").mkdir()
    runs = script.kinds_runs(tmp_path / "held") + script.kinds_runs(tmp_path / "tune", tune=True)
    assert len(runs) == 14
    for name, scene, steps, every in runs:
        spec, sim = load_simulation(scene)
        assert len(spec.bodies) > 0 and sim.h > 0 and steps > every > 0, name
        # each scene says which it is (the examples' keep their own names)
        assert spec.name in (name, "KaplaTower", "Talus2D"), (name, spec.name)


def test_kinds_and_their_tune_scenes_are_apart(script, tmp_path):
    (tmp_path / "held").mkdir()
    (tmp_path / "tune").mkdir()
    held = script.kinds_runs(tmp_path / "held")
    tune = script.kinds_runs(tmp_path / "tune", tune=True)
    assert len(held) == 6 and len(tune) == 8
    names = [n for n, *_ in held] + [n for n, *_ in tune]
    assert len(set(names)) == len(names)
    held_texts = {Path(s).read_text() for _, s, *_ in held}
    assert not held_texts & {Path(s).read_text() for _, s, *_ in tune}   # no scene in both


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

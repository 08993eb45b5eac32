"""socp-cd simulate: outputs (HDF5, ParaView, FCLib, PNG), progress bar, examples, Siconos side by side."""
import io
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import socp_cd
from socp_cd.cli import main as cli_main
from socp_cd.dynamics import Trajectory
from socp_cd.scenes import has_boxes, simulate
from socp_cd.scenes.simulate import step_with_problem
from socp_cd.scenes.vtk_output import read_pvd

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
needs_boxes = pytest.mark.skipif(not has_boxes(), reason="socp_cd.dynamics has no Box yet (blocks merge)")

SMALL_2D = """
[scene]
name = "Small2D"
dim = 2
mu = 0.4
[simulation]
h = 2e-3
steps = 6
tol = 1e-10
[[obstacles]]
shape = "line"
[[generate]]
kind = "stack"
base = [0, 0]
count = 3
body = {shape = "box", size = [0.2, 0.1]}
[[bodies]]
shape = "disk"
radius = 0.05
position = [0.4, 0.05]
velocity = [0.5, 0]
"""

SMALL_3D = """
[scene]
name = "Small3D"
dim = 3
mu = 0.3
[simulation]
h = 2e-3
steps = 6
tol = 1e-10
[[obstacles]]
shape = "plane"
[[generate]]
kind = "stack"
base = [0, 0, 0]
count = 2
body = {shape = "sphere", radius = 0.1}
[[bodies]]
shape = "sphere"
radius = 0.05
position = [0.3, 0, 0.05]
velocity = [1, 0, 0]
"""


def _scene(tmp_path, text, name="s.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def _vtk_reader(path):
    vtk = pytest.importorskip("vtk")
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(str(path))
    r.Update()
    return r.GetOutput()


@pytest.mark.parametrize("text, dim", [(SMALL_2D, 2), (SMALL_3D, 3)])
def test_vtk_series_carries_meshes_and_contact_forces(tmp_path, text, dim):
    meshio = pytest.importorskip("meshio")
    out = tmp_path / "vtk"
    s = simulate(_scene(tmp_path, text), vtk=out, every=3, quiet=True)
    traj = s["trajectory"]
    assert len(traj) == 3
    entries = read_pvd(out / f"Small{dim}D.pvd")
    assert sorted({t for t, _, _ in entries}) == pytest.approx(list(traj.t))
    assert all(f.exists() for _, _, f in entries)
    n = traj.meta["n_bodies"]
    last = [f for t, part, f in entries if part in (0, 1) and t == pytest.approx(traj.t[-1])]
    bodies, contacts = (meshio.read(f) for f in last)
    body_ids = np.concatenate(bodies.cell_data["body"])
    assert sorted(set(body_ids.tolist())) == list(range(n))
    if dim == 2:
        assert sum(len(c.data) for c in bodies.cells) == n                    # one polygon per body
    else:
        assert bodies.cells[0].type == "triangle" and len(body_ids) == 80 * n  # icospheres
    fr = traj.frames[-1]
    assert contacts.points.shape == (fr.contacts.n, 3) and fr.contacts.n >= 3
    np.testing.assert_allclose(contacts.points[:, :dim], fr.contacts.point)
    np.testing.assert_allclose(contacts.point_data["normal_force"], fr.contacts.normal_force, rtol=1e-12)
    ft = contacts.point_data["tangential_force"]
    np.testing.assert_allclose(np.einsum("ij,ij->i", ft, contacts.point_data["normal"]), 0, atol=1e-9)
    np.testing.assert_allclose(ft[:, :dim] + contacts.point_data["normal_force"][:, None] * fr.contacts.normal,
                               fr.contacts.force, atol=1e-9)
    assert set(contacts.point_data["status"].tolist()) <= {0, 1, 2, 3}
    # VTK's own XML reader
    try:
        import vtk  # noqa: F401
    except ImportError:
        return
    from vtk.util.numpy_support import vtk_to_numpy
    g = _vtk_reader(last[0])
    assert g.GetNumberOfCells() == len(body_ids)
    np.testing.assert_array_equal(vtk_to_numpy(g.GetCellData().GetArray("body")), body_ids)
    g = _vtk_reader(last[1])
    np.testing.assert_allclose(vtk_to_numpy(g.GetPointData().GetArray("normal_force")), fr.contacts.normal_force,
                               rtol=1e-12)


def test_fclib_dumps_read_back_with_the_recorded_error(tmp_path):
    s = simulate(_scene(tmp_path, SMALL_2D), fclib=tmp_path / "fc", quiet=True)
    files = s["fclib_files"]
    stats = s["trajectory"].stats
    with_contacts = [k + 1 for k, st in enumerate(stats) if st.n_active]
    assert len(files) == len(with_contacts) == 6
    for f, k in zip(files, with_contacts):
        st = stats[k - 1]
        m = re.fullmatch(r"Small2D-i(\d{5})-(\d+)-(\d{5})\.hdf5", f.name)
        assert m and int(m.group(1)) == st.iterations and int(m.group(2)) == st.n_active and int(m.group(3)) == k
        p = socp_cd.read_problem(f)
        assert p.n_contacts == st.n_active and p.dim == 2
        err = socp_cd.error(p, p.solution.r)
        assert err == pytest.approx(st.error, rel=1e-6, abs=1e-15) and err <= 1e-10


def test_step_with_problem_returns_the_solved_problem(tmp_path):
    from socp_cd.scenes import load_simulation
    _, sim = load_simulation(_scene(tmp_path, SMALL_3D))
    for _ in range(3):
        st, prob, res = step_with_problem(sim)
        assert prob.n_contacts == st.n_active
        assert socp_cd.error(prob, res.r) == pytest.approx(st.error, rel=1e-9, abs=1e-15)
        np.testing.assert_allclose(res.r.reshape(-1, 3), sim.last_contacts.r)


def test_trajectory_and_png_outputs(tmp_path):
    for text, dim in ((SMALL_2D, 2), (SMALL_3D, 3)):
        d = tmp_path / f"png{dim}"
        s = simulate(_scene(tmp_path, text), out=tmp_path / f"run{dim}.h5", render=d, every=3, quiet=True)
        tr = Trajectory.load(tmp_path / f"run{dim}.h5")
        assert len(tr) == 3 and len(tr.stats) == 6
        np.testing.assert_allclose(tr.pos[-1], s["trajectory"].pos[-1])
        pngs = sorted(d.glob("*.png"))
        assert [p.name for p in pngs] == [f"Small{dim}D_{k:05d}.png" for k in range(3)]
        import matplotlib.image as mpimg
        img = mpimg.imread(pngs[-1])
        assert img.ndim == 3 and img[..., :3].std() > 0.01         # not a blank canvas


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_only_on_a_terminal_and_not_with_quiet(tmp_path, capsys):
    p = _scene(tmp_path, SMALL_2D)
    tty = _Terminal()
    simulate(p, stream=tty)
    assert "Small2D" in tty.getvalue() and "6/6" in tty.getvalue()
    tty = _Terminal()
    simulate(p, stream=tty, quiet=True)
    assert tty.getvalue() == ""
    pipe = io.StringIO()
    simulate(p, stream=pipe)
    assert pipe.getvalue() == ""
    assert cli_main(["simulate", str(p), "--steps", "2"]) == 0        # pytest's stderr is not a TTY
    cap = capsys.readouterr()
    assert cap.err == "" and "2 steps to t = 0.004" in cap.out
    assert cli_main(["simulate", str(p), "--steps", "2", "--quiet"]) == 0
    assert capsys.readouterr().out == ""


def test_cli_reports_a_bad_scene_file(tmp_path, capsys):
    from socp_cd.cli import EXIT_BAD_INPUT
    p = _scene(tmp_path, SMALL_2D.replace("radius = 0.05", "radius = -0.05"))
    assert cli_main(["simulate", str(p)]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert re.search(r"s.toml: bodies\[0\].radius: must be positive", err)


def test_simulate_solver_overrides_the_files_and_a_bad_name_is_code_2(tmp_path, capsys):
    from socp_cd.cli import EXIT_BAD_INPUT
    p = _scene(tmp_path, SMALL_2D)
    written = [st.solver for st in simulate(p, quiet=True)["trajectory"].stats if st.n_active]
    stats = simulate(p, quiet=True, solver="clarabel")["trajectory"].stats
    ran = [st.solver for st in stats if st.n_active]
    assert ran and set(ran) == {"clarabel"} and "clarabel" not in written
    assert all(st.converged for st in stats)
    assert cli_main(["simulate", str(p), "--solver", "no_such_solver", "--steps", "2"]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "solver" in err and "no_such_solver" in err


# ----------------------------------------------------------------------------- examples
def _example(tmp_path, name):
    dst = tmp_path / f"{name}.toml"
    shutil.copy(EXAMPLES / f"{name}.toml", dst)
    return dst


@pytest.mark.parametrize("name, steps", [("talus_2d", 3), ("sphere_pile", 3)])
def test_granular_examples_run(tmp_path, name, steps):
    s = simulate(_example(tmp_path, name), steps=steps, every=1, quiet=True)
    tr = s["trajectory"]
    assert len(tr) == steps + 1 and np.all(np.isfinite(tr.pos[-1]))
    # bodies start apart and fall under gravity
    assert np.all(tr.pos[-1][:, -1] <= tr.pos[0][:, -1] + 1e-12)
    assert np.mean(tr.pos[-1][:, -1] < tr.pos[0][:, -1]) > 0.9


@pytest.mark.parametrize("side, sign", [("below", -1), ("above", 1)])
def test_2d_box_stack_at_the_friction_angle_plus_minus_2_degrees(tmp_path, side, sign):
    s = simulate(_example(tmp_path, f"box_stack_incline_2d_{side}"), steps=100, quiet=True)
    tr = s["trajectory"]
    a = math.radians(26.56505117707799 + 2 * sign)
    down = np.array([math.cos(a), -math.sin(a)])
    slide = (tr.pos[-1] - tr.pos[0]) @ down
    expected = 0.5 * 9.81 * (math.sin(a) - 0.5 * math.cos(a)) * tr.t[-1] ** 2
    if sign < 0:
        assert np.abs(slide).max() < 1e-6 * abs(expected)            # at rest (sliding would give 1.9 mm)
    else:
        np.testing.assert_allclose(slide, expected, rtol=1e-3)       # slides as one block
    assert s["unconverged"] == 0


@needs_boxes
@pytest.mark.parametrize("name", ["kapla_tower", "box_stack_incline_below", "box_stack_incline_above"])
def test_box_examples_run(tmp_path, name):
    s = simulate(_example(tmp_path, name), steps=3, quiet=True)
    assert np.all(np.isfinite(s["trajectory"].pos[-1])) and s["max_contacts"] > 0


def test_preview_draws_3d_box_scenes_without_the_dynamics(tmp_path):
    out = tmp_path / "kapla.png"
    assert cli_main(["simulate", str(_example(tmp_path, "kapla_tower")), "--preview", str(out)]) == 0
    import matplotlib.image as mpimg
    img = mpimg.imread(out)
    assert img[..., :3].std() > 0.01


# ----------------------------------------------------------------------------- Siconos
@pytest.mark.siconos
def test_sphere_column_agrees_with_siconos_moreau_jean(validation_script):
    from socp_cd.bench.siconos_peer import siconos_available
    if not siconos_available():
        pytest.skip("Siconos not available")
    SCENES = validation_script("siconos_side_by_side").SCENES
    from socp_cd.scenes.siconos_md import run_both
    sc = SCENES["sphere_column"]
    r = run_both(sc["text"], 60, sc["distance"], tol=1e-10)
    assert r.active_ours.max() == 4 and np.array_equal(r.active_ours, r.active_siconos)
    assert r.position_difference().max() < 1e-10 and r.velocity_difference().max() < 1e-8
    assert np.abs(r.pos_ours[-1] - r.pos_ours[0]).max() > 1e-2      # the top sphere moved


def test_fclib_every_dumps_every_nth_step_only(tmp_path):
    s = simulate(_scene(tmp_path, SMALL_2D), fclib=tmp_path / "fc", fclib_every=2, quiet=True)
    steps = [int(re.search(r"-(\d{5})\.hdf5$", f.name).group(1)) for f in s["fclib_files"]]
    assert steps == [2, 4, 6]
    with pytest.raises(socp_cd.SocpCdError, match="fclib_every"):
        simulate(_scene(tmp_path, SMALL_2D), fclib=tmp_path / "fc2", fclib_every=0, quiet=True)

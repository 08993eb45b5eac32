"""``socp-cd simulate SCENE.toml``: run a scene file and write what it asks for.

Outputs (all optional):

* ``--out run.h5`` — the HDF5 trajectory of :class:`socp_cd.dynamics.Trajectory`;
* ``--vtk DIR`` — a ParaView time series (:mod:`socp_cd.scenes.vtk_output`);
* ``--fclib DIR`` — every step's contact problem with the computed solution as an
  FCLib HDF5 file named as the FCLib collections name their dumps (LMGC90/Siconos
  convention ``<Name>-i<iterations:05d>-<contacts>-<step:05d>.hdf5``);
* ``--render DIR`` — PNG frames (2D: :func:`socp_cd.dynamics.render_frame`;
  3D: :class:`socp_cd.scenes.render3d.Renderer3D`).

A tqdm progress bar on stderr shows steps, active contacts, the solver error
and the ratio simulated time / wall time; it is off when stderr is not a
terminal and with ``--quiet``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np


def step_with_problem(sim):
    """Advance ``sim`` by one step and return ``(stats, problem, result)`` of that step.

    ``problem`` (the step's :class:`~socp_cd.problem.FrictionContactProblem`
    or global problem, ``Simulation.last_problem``) and ``result``
    (``Simulation.last_result``) are ``None`` when no contact was active.
    """
    st = sim.step()
    if not st.n_active:
        return st, None, None
    return st, sim.last_problem, sim.last_result


def fclib_name(name: str, step: int, iterations: int, n_contacts: int) -> str:
    """FCLib collection file name of one step's problem.

    FCLib's collections (dumped by LMGC90 and Siconos, e.g.
    ``LMGC_100_PR_PerioBox-i00361-60-03000.hdf5``) are named
    ``<Name>-i<solver iterations, 5 digits>-<number of contacts>-<step, 5 digits>.hdf5``.
    """
    return f"{name}-i{int(iterations):05d}-{int(n_contacts)}-{int(step):05d}.hdf5"


def contact_status(problem, result) -> np.ndarray:
    """:class:`socp_cd.cones.ContactStatus` of each contact of a solved step."""
    from ..cones import classify_contacts

    u = result.u if result.u is not None else problem.velocity(result.r)
    return classify_contacts(result.r, u, problem.mu, problem.dim, tol=max(result.tol, 1e-12))


def _postfix(st, wall: float, t: float) -> dict:
    return {"contacts": st.n_active, "err": f"{st.error:.1e}", "sim/wall": f"{t / max(wall, 1e-9):.3g}"}


def simulate(path, *, steps: int | None = None, out=None, vtk=None, fclib=None, render=None,
             every: int | None = None, fclib_every: int = 1, quiet: bool = False,
             stream=None, solver: str | None = None) -> dict:
    """Run a scene file.

    Parameters
    ----------
    path : str or Path
        TOML scene file (``docs/scenes.md``).
    steps : int, optional
        Number of steps (default ``simulation.steps`` of the file).
    out : path, optional
        HDF5 trajectory.
    vtk, fclib, render : directory, optional
        ParaView series, FCLib step problems, PNG frames.
    every : int, optional
        Record (trajectory, VTK, PNG) one frame every that many steps (default
        ``simulation.record_every``).
    fclib_every : int
        FCLib dumps of every that many steps (those with contacts; default 1:
        every step).
    quiet : bool
        No progress bar.
    stream : file, optional
        Where the progress bar goes (default ``sys.stderr``); shown only when it is a terminal.
    solver : str, optional
        Step solver instead of the file's ``simulation.solver`` (its ``tol`` and
        ``max_iter`` kept).

    Returns
    -------
    dict
        ``steps, t, wall_time, max_contacts, max_error, unconverged, fclib_files,
        frames, trajectory`` (the in-memory :class:`~socp_cd.dynamics.Trajectory`).
    """
    from tqdm import tqdm

    from ..dynamics import Trajectory
    from .builder import load_simulation

    spec, sim = load_simulation(path, solver=solver)
    n_steps = spec.simulation["steps"] if steps is None else int(steps)
    every = spec.simulation["record_every"] if every is None else int(every)
    fclib_every = int(fclib_every)
    if n_steps < 0 or every < 1 or fclib_every < 1:
        from .schema import SceneFileError
        raise SceneFileError(spec.source, "steps" if n_steps < 0 else "every" if every < 1 else "fclib_every",
                             "must be positive")
    stream = sys.stderr if stream is None else stream
    show = not quiet and hasattr(stream, "isatty") and stream.isatty()
    traj = Trajectory.start(sim)
    vtk_series = renderer = None
    bodies, obstacles = sim.scene.bodies, sim.scene.obstacles
    if vtk is not None:
        from .vtk_output import VtkSeries
        vtk_series = VtkSeries(vtk, spec.name, bodies, obstacles, spec.dim)
        vtk_series.write(traj.frames[0])
    if render is not None:
        render = Path(render)
        render.mkdir(parents=True, exist_ok=True)
        renderer = _FrameRenderer(sim, bodies, obstacles, spec.dim)
        renderer.draw(sim, traj.frames[0], render / f"{spec.name}_{0:05d}.png")
    if fclib is not None:
        fclib = Path(fclib)
        fclib.mkdir(parents=True, exist_ok=True)
    fclib_files = []
    max_contacts, max_err, unconverged = 0, 0.0, 0
    t_wall = time.perf_counter()
    t_start = sim.t
    bar = tqdm(total=n_steps, disable=not show, file=stream, desc=spec.name, unit="step", leave=True,
               dynamic_ncols=True)
    try:
        for k in range(1, n_steps + 1):
            st, problem, result = step_with_problem(sim)
            max_contacts = max(max_contacts, st.n_active)
            if problem is not None:
                max_err = max(max_err, float(st.error))
                unconverged += not st.converged
                if fclib is not None and k % fclib_every == 0:
                    from .. import write_fclib
                    f = fclib / fclib_name(spec.name, k, st.iterations, st.n_active)
                    write_fclib(problem, f, solution=result, title=spec.name,
                                description=f"socp_cd simulate {Path(path).name}: step {k}, t = {sim.t:.9g}, "
                                            f"h = {sim.h}, theta = {sim.theta}, solver {st.solver}, "
                                            f"error {st.error:.3e}")
                    fclib_files.append(f)
            if k % every == 0:
                frame = sim.frame()
                traj.append(frame)
                if vtk_series is not None:
                    vtk_series.write(frame, None if problem is None else contact_status(problem, result))
                if renderer is not None:
                    renderer.draw(sim, frame, render / f"{spec.name}_{len(traj) - 1:05d}.png")
            bar.update(1)
            if show:
                bar.set_postfix(_postfix(st, time.perf_counter() - t_wall, sim.t - t_start), refresh=False)
    finally:
        bar.close()
    wall = time.perf_counter() - t_wall
    traj.stats = list(sim.stats)
    if out is not None:
        traj.save(out)
    summary = {"steps": n_steps, "t": sim.t, "wall_time": wall, "max_contacts": max_contacts,
               "max_error": max_err, "unconverged": unconverged, "fclib_files": fclib_files,
               "frames": len(traj), "trajectory": traj}
    return summary


def _spec_object(entry: dict):
    """A light stand-in of a 3D body/obstacle entry for the mesh functions (no dynamics needed)."""
    from types import SimpleNamespace

    keys = ("radius", "size", "vertices", "position", "orientation", "point", "normal")
    return SimpleNamespace(**{k: entry[k] for k in keys if k in entry})


def preview(path, png) -> Path:
    """Render the initial configuration of a scene file to ``png``.

    3D scenes are drawn from the file alone (also boxes and polyhedra, whatever
    ``socp_cd.dynamics`` provides); 2D scenes through the dynamics' renderer.
    """
    from .schema import load_scene_file

    spec = load_scene_file(path)
    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    if spec.dim == 2:
        from .builder import load_simulation
        _, sim = load_simulation(path)
        _FrameRenderer(sim, sim.scene.bodies, sim.scene.obstacles, 2).draw(sim, None, png)
        return png
    from types import SimpleNamespace

    from ..dynamics import ContactFrame
    from .render3d import Renderer3D
    bodies = [_spec_object(b) for b in spec.bodies]
    frame = SimpleNamespace(t=0.0, pos=np.array([b["position"] for b in spec.bodies]),
                            orientation=np.array([b["orientation"] for b in spec.bodies]),
                            contacts=ContactFrame.empty(3))
    r = Renderer3D(bodies, [_spec_object(o) for o in spec.obstacles], frame)
    r.render(frame, png, title=f"{spec.name}: initial state, {len(bodies)} bodies")
    return png


class _FrameRenderer:
    """2D frames through :func:`socp_cd.dynamics.render_frame` with fixed bounds; 3D through mplot3d."""

    def __init__(self, sim, bodies, obstacles, dim: int):
        self.dim, self.bounds, self.r3 = dim, None, None
        if dim == 3:
            from .render3d import Renderer3D
            self.r3 = Renderer3D(bodies, obstacles, sim.frame())

    def draw(self, sim, frame, path) -> None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        if self.r3 is not None:
            self.r3.render(frame, path)
            return
        from ..dynamics import render_frame
        fig = render_frame(sim, None, bounds=self.bounds)
        if self.bounds is None:
            ax = fig.axes[0]
            self.bounds = (*ax.get_xlim(), *ax.get_ylim())
        fig.savefig(path)
        plt.close(fig)


# ----------------------------------------------------------------------------- command line
def build_parser(parser: argparse.ArgumentParser | None = None) -> argparse.ArgumentParser:
    """Arguments of ``socp-cd simulate``."""
    ap = parser or argparse.ArgumentParser(prog="socp-cd simulate", description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", help="TOML scene file (docs/scenes.md)")
    ap.add_argument("--steps", type=int, default=None, help="number of steps (default: the file's simulation.steps)")
    ap.add_argument("--solver", default=None,
                    help="step solver instead of the file's simulation.solver (its tol and max_iter kept)")
    ap.add_argument("--out", default=None, help="HDF5 trajectory file")
    ap.add_argument("--vtk", default=None, metavar="DIR", help="ParaView time series (.pvd + .vtu)")
    ap.add_argument("--fclib", default=None, metavar="DIR", help="every step's problem as an FCLib HDF5 file")
    ap.add_argument("--render", default=None, metavar="DIR", help="PNG frames")
    ap.add_argument("--preview", default=None, metavar="PNG",
                    help="only draw the initial configuration to PNG (no simulation)")
    ap.add_argument("--every", type=int, default=None, help="record one frame every N steps")
    ap.add_argument("--fclib-every", type=int, default=1, metavar="N",
                    help="with --fclib: dump the problem of every N-th step (default 1)")
    ap.add_argument("--quiet", "-q", action="store_true", help="no progress bar, no summary")
    return ap


def main(argv=None) -> int:
    """Entry point of ``socp-cd simulate``; returns 0 (1 when some step did not converge)."""
    args = build_parser().parse_args(argv)
    if args.preview is not None:
        print(f"wrote {preview(args.scene, args.preview)}")
        return 0
    s = simulate(args.scene, steps=args.steps, out=args.out, vtk=args.vtk, fclib=args.fclib,
                 render=args.render, every=args.every, fclib_every=args.fclib_every,
                 quiet=args.quiet, solver=args.solver)
    if not args.quiet:
        print(f"{args.scene}: {s['steps']} steps to t = {s['t']:.6g} in {s['wall_time']:.3g} s wall "
              f"(sim/wall {(s['t'] - s['trajectory'].frames[0].t) / max(s['wall_time'], 1e-9):.3g}); "
              f"max contacts {s['max_contacts']}, max solver error {s['max_error']:.3e}, "
              f"{s['unconverged']} steps not converged")
        for what, val in (("trajectory", args.out), ("ParaView", args.vtk), ("FCLib", args.fclib),
                          ("PNG frames", args.render)):
            if val is not None:
                print(f"  {what}: {val}")
    return 1 if s["unconverged"] else 0


__all__ = ["simulate", "step_with_problem", "fclib_name", "contact_status", "build_parser", "main"]

"""Moreau–Jean contact dynamics of rigid disks, convex polygons (2D), spheres and convex polyhedra (3D).

Typical use::

    from socp_cd.dynamics import Scene, Disk, Polygon, Line, Simulation
    scene = Scene([Disk(0.1, (0, 0.5)), Polygon.box(0.2, 0.1, (0.5, 0.05))],
                  obstacles=[Line((0, 0), (0, 1))], mu=0.3, restitution=0.0)
    sim = Simulation(scene, h=1e-3)          # solver="auto"; or "nsgs", "clarabel"
    traj = sim.run(1000, path="run.h5")                  # Trajectory (HDF5)
    frame = traj.frames[-1]                              # pos, angle, vel, contacts
    frame.contacts.pairs, frame.contacts.force           # global contact data

3D blocks::

    from socp_cd.dynamics import Box, Plane, Scene, Simulation
    boxes = [Box((0.1, 0.1, 0.1), (0, 0, 0.05 + 0.1 * k), material="wood") for k in range(10)]
    scene = Scene(boxes, [Plane(material="steel")], mu=0.5,
                  materials={("wood", "steel"): {"mu": 0.3, "restitution": 0.0}})
    sim = Simulation(scene, h=2e-3)          # post-step projection on by default with polyhedra
    sim.step(); sim.last_problem, sim.last_result   # the step's contact problem and its solution
    state = sim.get_state(); sim.set_state(state)   # kinematics + warm start

See :mod:`socp_cd.dynamics.stepper` for the scheme, :mod:`~.detection` for the
contact conventions (pair ``(i, j)``, ``j = -1`` for obstacles, normal from
``j`` into ``i``), :mod:`~.cases` / :mod:`~.validate` for exact-solution checks.
"""
from .bodies import (Box, ConvexPolyhedron, Disk, FixedBox, FixedDisk, FixedPolygon, FixedPolyhedron, FixedSphere,
                     Force, Line, Plane, Polygon, Sphere, Spring)
from .detection import Contacts, detect
from .frames import ContactFrame, Frame, StepStats
from .overlap import OverlapWarning
from .scene import Scene, System, compile_scene
from .stepper import Simulation
from .trajectory import Trajectory


def render_frame(*args, **kwargs):
    """Draw a 2D frame to PNG (see :func:`socp_cd.dynamics.render.render_frame`)."""
    from .render import render_frame as _r
    return _r(*args, **kwargs)


__all__ = ["Scene", "System", "compile_scene", "Disk", "Polygon", "Sphere", "Box", "ConvexPolyhedron", "Line",
           "Plane", "FixedDisk", "FixedPolygon", "FixedSphere", "FixedBox", "FixedPolyhedron", "OverlapWarning", "Spring", "Force", "Contacts", "detect", "Simulation",
           "StepStats", "Frame", "ContactFrame", "Trajectory", "render_frame"]

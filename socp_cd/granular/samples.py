"""Scenes for the granular experiments, built on the public API of :mod:`socp_cd.dynamics`.

* :func:`biaxial_box_scene` — polydisperse disks in a box closed by two fixed
  lines (left, bottom) and two movable, frictionless, non-rotating wall bodies
  (right, top) pushed by constant forces: a pressure-controlled biaxial cell.
* :func:`talus_scene` — random convex polygons (5–8 sides) raining in a narrow
  column near a vertical wall onto a rough slope made of fixed disks.
* :func:`random_convex_polygon` — the grain generator.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidProblemError

__all__ = ["random_convex_polygon", "BiaxialBox", "biaxial_box_scene", "Talus", "talus_scene", "relax"]


def random_convex_polygon(rng, radius: float, n_min: int = 5, n_max: int = 8,
                          jitter: float = 0.3) -> np.ndarray:
    """Vertices of a random convex polygon inscribed in a circle of ``radius``.

    ``n`` vertices (uniform in ``[n_min, n_max]``) at angles evenly spaced
    plus a random offset of at most ``jitter`` spacing, rotated at random.
    Points on a circle in angular order always form a convex polygon.
    """
    n = int(rng.integers(n_min, n_max + 1))
    step = 2 * np.pi / n
    a = rng.uniform(0, 2 * np.pi) + step * (np.arange(n) + rng.uniform(-jitter, jitter, n))
    return radius * np.c_[np.cos(a), np.sin(a)]


@dataclass
class BiaxialBox:
    """A biaxial cell: the scene plus what the analysis needs to know about it."""

    scene: object
    n_grains: int          #: grains are bodies 0..n_grains-1
    right_wall: int        #: body index of the right wall
    top_wall: int          #: body index of the top wall
    wall_thickness: float
    pressure: tuple        #: (P_x, P_y) applied on the walls (per unit length)


def biaxial_box_scene(n: int = 200, r_min: float = 0.35, r_max: float = 0.65,
                      pressure=(1.0, 2.0), mu: float = 0.3, mu_wall: float = 0.0,
                      wall_mass_factor: float = 2.0,
                      gravity=(0.0, 0.0), seed: int = 0, loose: float = 1.15) -> BiaxialBox:
    """Polydisperse disks in a pressure-controlled biaxial box.

    The grains start on a loose square lattice (cell ``loose * 2 r_max``).
    The left line ``x = 0`` and bottom line ``y = 0`` are fixed; the right and
    top walls are non-rotating rectangles pushed inwards by
    ``P_x * H0`` and ``P_y * W0`` (``H0``, ``W0`` the initial box sizes; the
    load is a force, so the final pressure is ``P * L0 / L``, which the
    analysis recomputes from the actual wall forces).  The moving walls are
    frictionless (so they cannot drift sideways); the fixed lines have friction
    ``mu_wall``.

    Returns
    -------
    BiaxialBox
    """
    from ..dynamics.bodies import Disk, Force, Line, Polygon
    from ..dynamics.scene import Scene
    if n < 4:
        raise InvalidProblemError("n", "need at least 4 grains")
    rng = np.random.default_rng(seed)
    cols = int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    cell = loose * 2 * r_max
    W0, H0 = cols * cell, rows * cell
    radii = rng.uniform(r_min, r_max, n)
    ij = np.array([(k % cols, k // cols) for k in range(n)])
    pos = (ij + 0.5) * cell + rng.uniform(-0.05, 0.05, (n, 2)) * cell
    grains = [Disk(radius=r, position=p, mu=mu) for r, p in zip(radii, pos)]
    m_grains = sum(g.mass for g in grains)
    t = 2 * r_max
    big = 3 * max(W0, H0)
    mw = wall_mass_factor * m_grains / np.sqrt(n)
    right = Polygon.box(t, big, position=(W0 + t / 2, big / 2 - t), mass=mw, fixed_rotation=True, mu=0.0)
    top = Polygon.box(big, t, position=(big / 2 - t, H0 + t / 2), mass=mw, fixed_rotation=True, mu=0.0)
    Px, Py = map(float, pressure)
    forces = [Force(n, lambda _t, f=-Px * H0: (f, 0.0)), Force(n + 1, lambda _t, f=-Py * W0: (0.0, f))]
    scene = Scene(bodies=grains + [right, top],
                  obstacles=[Line((0.0, 0.0), (1.0, 0.0), mu=mu_wall),
                             Line((0.0, 0.0), (0.0, 1.0), mu=mu_wall)],
                  gravity=gravity, mu=mu, restitution=0.0, forces=forces)
    return BiaxialBox(scene=scene, n_grains=n, right_wall=n, top_wall=n + 1,
                      wall_thickness=t, pressure=(Px, Py))


@dataclass
class Talus:
    """A talus scene and its geometry."""

    scene: object
    n_grains: int
    slope_angle: float      #: radians
    bed_radius: float


def talus_scene(n: int = 300, r_mean: float = 0.5, spread: float = 0.3, slope_deg: float = 10.0,
                length: float = 40.0, mu: float = 0.3, column_width: float = 5.0,
                gap: float = 0.3, seed: int = 0) -> Talus:
    """Random convex polygons raining near the left wall onto a rough slope.

    The bed is a row of touching fixed disks (radius ``0.5 r_mean``) along a
    line descending from the left wall at ``slope_deg`` degrees (the heap
    builds against the wall and spreads downslope by avalanches).
    The grains start in a column of width ``column_width`` mean diameters
    against the wall, spaced vertically by ``gap`` diameters, so they arrive
    one layer after another (a crude steady pour).
    """
    from ..dynamics.bodies import FixedDisk, Line, Polygon
    from ..dynamics.scene import Scene
    rng = np.random.default_rng(seed)
    a = np.radians(slope_deg)
    d = 2 * r_mean
    rb = 0.5 * r_mean
    # bed: fixed disks along y = -tan(a) x, from the wall to x = length
    s = np.arange(0.0, length / np.cos(a), 2 * rb)
    bed = [FixedDisk(rb, (si * np.cos(a), -si * np.sin(a)), mu=mu) for si in s]
    radii = r_mean * rng.uniform(1 - spread, 1 + spread, n)
    cw = column_width * d
    per_row = max(1, int(cw // (d * (1 + spread))))
    pitch = cw / per_row
    grains = []
    y0 = 3 * d
    for k, r in enumerate(radii):
        row, col = divmod(k, per_row)
        x = (col + 0.5) * pitch + rng.uniform(-0.1, 0.1) * d
        y = y0 + row * d * (1 + spread) * (1 + gap)
        grains.append(Polygon(random_convex_polygon(rng, r), position=(x, y), mu=mu))
    wall = Line((0.0, 0.0), (1.0, 0.0), mu=mu)
    scene = Scene(bodies=grains, obstacles=[wall] + bed, mu=mu, restitution=0.0)
    return Talus(scene=scene, n_grains=n, slope_angle=a, bed_radius=rb)


def relax(sim, max_steps: int, v_tol: float, bodies=None, min_steps: int = 0,
          check_every: int = 10, callback=None):
    """Step ``sim`` until every body of ``bodies`` moves slower than ``v_tol``.

    Parameters
    ----------
    sim : socp_cd.dynamics.stepper.Simulation
    max_steps : int
    v_tol : float
        Threshold on ``max |v|`` (translational speed) of the selected bodies.
    bodies : index array, optional
        Default: all bodies.
    min_steps : int
        Never stop before that many steps.
    callback : callable, optional
        ``callback(sim, step_index)`` after every step.

    Returns
    -------
    steps : int
        Steps taken.
    prev_vel : ndarray (n, ndof)
        Velocities before the last step (for the inertia term).
    max_speed : float
        Final ``max |v|``.
    """
    d = sim.sys.dim
    sel = slice(None) if bodies is None else np.asarray(bodies)
    prev = sim.sys.vel.copy()
    vmax = np.inf
    for k in range(int(max_steps)):
        prev = sim.sys.vel.copy()
        sim.step()
        if callback is not None:
            callback(sim, k)
        if (k + 1) % check_every == 0 and k + 1 >= min_steps:
            vmax = float(np.linalg.norm(sim.sys.vel[sel, :d], axis=1).max())
            if vmax < v_tol:
                return k + 1, prev, vmax
    vmax = float(np.linalg.norm(sim.sys.vel[sel, :d], axis=1).max())
    return int(max_steps), prev, vmax

"""Scenes for the granular experiments, built on the public API of :mod:`socp_cd.dynamics`.

* :func:`biaxial_box_scene` — polydisperse disks in a box closed by two fixed
  lines (left, bottom) and two movable, frictionless, non-rotating wall bodies
  (right, top) pushed by constant forces: a pressure-controlled biaxial cell.
* :func:`talus_bed`, :class:`TalusGrains`, :func:`feed_batch`,
  :func:`talus_simulation` — random convex polygons (5–8 sides) fed in batches
  near a vertical wall onto a rough slope made of fixed disks; the simulator
  compiles a fixed scene, so each batch rebuilds the simulation from the
  grains' arrays (``validation/talus.py`` runs the loop, with checkpoints).
* :func:`relax` — step until the grains are at rest.
* :func:`random_convex_polygon` — the grain generator.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InvalidProblemError

__all__ = ["random_convex_polygon", "BiaxialBox", "biaxial_box_scene", "Talus", "talus_bed", "TalusGrains",
           "talus_simulation", "feed_batch", "relax"]


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
                      gravity=(0.0, 0.0), seed: int = 0, loose: float = 1.15,
                      shape: str = "disk") -> BiaxialBox:
    """Polydisperse disks (or random convex polygons) in a pressure-controlled biaxial box.

    The grains start on a loose square lattice (cell ``loose * 2 r_max``).
    The left line ``x = 0`` and bottom line ``y = 0`` are fixed; the right and
    top walls are non-rotating rectangles pushed inwards by
    ``P_x * H0`` and ``P_y * W0`` (``H0``, ``W0`` the initial box sizes; the
    load is a force, so the final pressure is ``P * L0 / L``, which the
    analysis recomputes from the actual wall forces).  The moving walls are
    frictionless (so they cannot drift sideways); the fixed lines have friction
    ``mu_wall``.  ``shape="polygon"``: random convex polygons of 5–8 sides
    (:func:`random_convex_polygon`) with circumradii drawn like the disk radii.

    Returns
    -------
    BiaxialBox
    """
    from ..dynamics.bodies import Disk, Force, Line, Polygon
    from ..dynamics.scene import Scene
    if n < 4:
        raise InvalidProblemError("n", "need at least 4 grains")
    if shape not in ("disk", "polygon"):
        raise InvalidProblemError("shape", f"must be 'disk' or 'polygon', got {shape!r}")
    rng = np.random.default_rng(seed)
    cols = int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    cell = loose * 2 * r_max
    W0, H0 = cols * cell, rows * cell
    radii = rng.uniform(r_min, r_max, n)
    ij = np.array([(k % cols, k // cols) for k in range(n)])
    pos = (ij + 0.5) * cell + rng.uniform(-0.05, 0.05, (n, 2)) * cell
    if shape == "disk":
        grains = [Disk(radius=r, position=p, mu=mu) for r, p in zip(radii, pos)]
    else:
        grains = [Polygon(random_convex_polygon(rng, r), position=p, mu=mu) for r, p in zip(radii, pos)]
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
    """A talus: a vertical wall at ``x = 0`` and a rough bed descending from it."""

    obstacles: list         #: the wall line followed by the bed's fixed disks
    slope_angle: float      #: radians
    bed_radius: float
    mu: float
    n_grains: int = 0       #: grains poured so far (bodies 0..n_grains-1)

    def bed_y(self, x):
        """Height of the bed line (through the bed disks' centres) at abscissa ``x``."""
        return -np.tan(self.slope_angle) * np.asarray(x, dtype=float)


def talus_bed(slope_deg: float = 10.0, length: float = 60.0, bed_radius: float = 0.25,
              mu: float = 0.3) -> Talus:
    """The fixed part of the talus: wall ``x = 0`` and touching fixed disks along the slope.

    The bed disks' centres lie on ``y = -tan(slope) x`` for ``0 <= x <= length``.
    """
    from ..dynamics.bodies import FixedDisk, Line
    if not 0 <= slope_deg < 90:
        raise InvalidProblemError("slope_deg", f"must lie in [0, 90), got {slope_deg!r}")
    a = np.radians(slope_deg)
    s = np.arange(0.0, length / np.cos(a), 2 * bed_radius)
    bed = [FixedDisk(bed_radius, (si * np.cos(a), -si * np.sin(a)), mu=mu) for si in s]
    return Talus(obstacles=[Line((0.0, 0.0), (1.0, 0.0), mu=mu)] + bed, slope_angle=a,
                 bed_radius=bed_radius, mu=mu)


@dataclass
class TalusGrains:
    """The poured grains as plain arrays (what a checkpoint stores).

    ``local[k, :nv[k]]`` are the vertices of grain ``k`` in its body frame
    (padding repeats the last vertex); ``vel`` is ``(vx, vy, omega)``.
    """

    local: np.ndarray       #: (n, vmax, 2)
    nv: np.ndarray          #: (n,)
    pos: np.ndarray         #: (n, 2)
    angle: np.ndarray       #: (n,)
    vel: np.ndarray         #: (n, 3)
    mass: np.ndarray        #: (n,)
    inertia: np.ndarray     #: (n,)

    @classmethod
    def empty(cls, vmax: int = 8) -> "TalusGrains":
        z = np.zeros(0)
        return cls(np.zeros((0, vmax, 2)), np.zeros(0, np.int64), np.zeros((0, 2)), z,
                   np.zeros((0, 3)), z, z)

    @classmethod
    def from_simulation(cls, sim) -> "TalusGrains":
        """The polygons of a running simulation (bodies ``0..n-1``)."""
        S = sim.sys
        k = S.poly_of_body
        vmax = S.poly_local.shape[1]
        local = np.zeros((S.n_bodies, max(vmax, 8), 2))
        local[:, :vmax] = S.poly_local[k]
        local[:, vmax:] = S.poly_local[k][:, -1:]
        return cls(local, S.poly_nv[k].astype(np.int64), S.pos.copy(), S.angle.copy(),
                   S.vel.copy(), S.mass.copy(), S.inertia.copy())

    @property
    def n(self) -> int:
        return int(self.pos.shape[0])

    def take(self, keep) -> "TalusGrains":
        """The grains selected by ``keep`` (mask or indices)."""
        return TalusGrains(*(a[keep] for a in (self.local, self.nv, self.pos, self.angle, self.vel,
                                                self.mass, self.inertia)))

    def world(self) -> np.ndarray:
        """World vertices ``(n, vmax, 2)``."""
        c, s = np.cos(self.angle)[:, None], np.sin(self.angle)[:, None]
        L = self.local
        return np.stack([c * L[..., 0] - s * L[..., 1] + self.pos[:, 0, None],
                         s * L[..., 0] + c * L[..., 1] + self.pos[:, 1, None]], axis=-1)


def talus_simulation(talus: Talus, grains: TalusGrains, h: float, sim_kwargs=None):
    """A Simulation of ``grains`` (bodies ``0..n-1``, same order) on the talus bed."""
    from ..dynamics.bodies import Polygon
    from ..dynamics.scene import Scene
    from ..dynamics.stepper import Simulation
    bodies = [Polygon(grains.local[b, :grains.nv[b]], position=grains.pos[b], angle=grains.angle[b],
                      velocity=grains.vel[b, :2], omega=grains.vel[b, 2], mass=grains.mass[b],
                      inertia=grains.inertia[b], mu=talus.mu) for b in range(grains.n)]
    scene = Scene(bodies=bodies, obstacles=talus.obstacles, mu=talus.mu, restitution=0.0)
    return Simulation(scene, h=h, **dict(sim_kwargs or {}))


def feed_batch(talus: Talus, grains: TalusGrains, k: int, rng, *, r_mean: float = 0.5,
               spread: float = 0.3, feed_width: float = 4.0, drop: float = 1.0,
               v0: float = 0.0) -> TalusGrains:
    """``grains`` plus ``k`` new random polygons placed above the heap near the wall.

    The new grains sit on a lattice ``drop`` mean diameters above the highest
    vertex of the feed zone ``0 < x < feed_width`` diameters, falling at speed
    ``v0``.  The caller must let the previous batch land first (otherwise the
    new batch is stacked above a falling one, higher and higher).
    """
    from ..dynamics.bodies import Polygon
    d = 2 * r_mean
    cell = d * (1 + spread) * 1.05
    per_row = max(1, int(feed_width * d // cell))
    top = float(talus.bed_y(0.0)) + talus.bed_radius
    if grains.n:
        V = grains.world()
        feed = V[..., 0].max(axis=1) < feed_width * d + d
        if feed.any():
            top = max(top, float(V[feed, :, 1].max()))
    vmax = grains.local.shape[1]
    new = []
    for m in range(k):
        row, col = divmod(m, per_row)
        x = (col + 0.5) * cell + rng.uniform(-0.05, 0.05) * d
        y = top + drop * d + (row + 0.5) * cell
        r = r_mean * rng.uniform(1 - spread, 1 + spread)
        P = Polygon(random_convex_polygon(rng, r), position=(x, y), mu=talus.mu)
        loc = np.asarray(P.vertices, float)     # re-centred on the centroid by Polygon
        pad = np.empty((vmax, 2))
        pad[:len(loc)] = loc
        pad[len(loc):] = loc[-1]
        new.append((pad, len(loc), np.asarray(P.position, float), float(P.angle), P.mass, P.inertia))
    vel = np.zeros((len(new), 3))
    vel[:, 1] = -abs(float(v0))
    add = TalusGrains(np.array([a[0] for a in new]).reshape(-1, vmax, 2),
                      np.array([a[1] for a in new], np.int64), np.array([a[2] for a in new]).reshape(-1, 2),
                      np.array([a[3] for a in new]), vel,
                      np.array([a[4] for a in new]), np.array([a[5] for a in new]))
    return TalusGrains(*(np.concatenate([a, b]) for a, b in zip(
        (grains.local, grains.nv, grains.pos, grains.angle, grains.vel, grains.mass, grains.inertia),
        (add.local, add.nv, add.pos, add.angle, add.vel, add.mass, add.inertia))))


def relax(sim, max_steps: int, v_tol: float, bodies=None, min_steps: int = 0,
          check_every: int = 10, callback=None):
    """Step ``sim`` until every body of ``bodies`` moves slower than ``v_tol``.

    Parameters
    ----------
    sim : socp_cd.dynamics.stepper.Simulation
    max_steps : int
    v_tol : float
        Threshold on ``max |v|`` (translational speed) of the selected bodies.
    bodies : index array or callable, optional
        Bodies to watch (default all); a callable ``bodies(sim) -> indices``
        is re-evaluated at every check (e.g. to ignore grains leaving the
        sample or contact-free rattlers).
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

    def speed():
        sel = (slice(None) if bodies is None else
               np.asarray(bodies(sim) if callable(bodies) else bodies, dtype=np.int64))
        v = np.linalg.norm(sim.sys.vel[sel, :d], axis=1)
        return float(v.max()) if v.size else 0.0

    prev = sim.sys.vel.copy()
    vmax = np.inf
    for k in range(int(max_steps)):
        prev = sim.sys.vel.copy()
        sim.step()
        if callback is not None:
            callback(sim, k)
        if (k + 1) % check_every == 0 and k + 1 >= min_steps:
            vmax = speed()
            if vmax < v_tol:
                return k + 1, prev, vmax
    return int(max_steps), prev, speed()

"""A declarative scene and its compiled, array-based form.

:class:`Scene` is what users write (lists of bodies, obstacles and loads);
:func:`compile_scene` turns it into :class:`System`, the flat NumPy arrays the
detection, assembly and stepper work on.  Only the machinery a scene uses is
built: a scene of disks has no polygon tables, a 2D scene no 3D frames.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple, Optional, Sequence

import numpy as np

from ..errors import InvalidProblemError
from .bodies import (BODY_TYPES, OBSTACLE_TYPES, Force, Spring)
from .geometry3d import quat_to_matrix
from .hulls import HullTable, pack_hulls


class HalfSpaces(NamedTuple):
    """Fixed half-spaces ``{x : normal·(x - point) >= 0}`` (k rows)."""

    point: np.ndarray
    normal: np.ndarray
    mu: np.ndarray
    e: np.ndarray
    index: np.ndarray      # position in scene.obstacles


class FixedRound(NamedTuple):
    """Fixed disks (2D) / spheres (3D)."""

    center: np.ndarray
    radius: np.ndarray
    mu: np.ndarray
    e: np.ndarray
    index: np.ndarray


class FixedPolygons(NamedTuple):
    """Fixed 2D polygons: padded world vertices, counts, centroids, bounding radii."""

    vertices: np.ndarray
    nv: np.ndarray
    center: np.ndarray
    radius: np.ndarray
    mu: np.ndarray
    e: np.ndarray
    index: np.ndarray


class FixedHulls(NamedTuple):
    """Fixed 3D polyhedra: body-frame table, rotations ``R`` (k, 3, 3), centres (k, 3)."""

    table: HullTable
    rot: np.ndarray
    center: np.ndarray
    mu: np.ndarray
    e: np.ndarray
    index: np.ndarray


@dataclass
class Scene:
    """A rigid-body contact scene.

    Parameters
    ----------
    bodies : list
        :class:`Disk`, :class:`Polygon` (2D) or :class:`Sphere` (3D) objects;
        body ``i`` of contact pairs is ``bodies[i]``.
    obstacles : list
        Fixed :class:`Line`/:class:`Plane` half-spaces and
        :class:`FixedDisk`/:class:`FixedPolygon`/:class:`FixedSphere` grains.
    gravity : sequence, optional
        Gravity vector; defaults to ``(0, -9.81)`` in 2D, ``(0, 0, -9.81)`` in 3D.
    mu : float
        Default Coulomb coefficient of contacts whose members set none.
    restitution : float
        Default Newton restitution coefficient ``e``.
    springs, forces : list
        :class:`Spring` and :class:`Force` loads.
    materials : dict, optional
        Pair table ``{(name_a, name_b): {"mu": float, "restitution": float}}``
        (unordered pairs; either key may be omitted).  A contact whose two
        members both set ``material`` and whose pair is listed takes these
        values; otherwise the minimum of the members' own ``mu`` /
        ``restitution``; otherwise the scene defaults ``mu`` / ``restitution``.
    """

    bodies: list
    obstacles: list = field(default_factory=list)
    gravity: Optional[Sequence[float]] = None
    mu: float = 0.0
    restitution: float = 0.0
    springs: list = field(default_factory=list)
    forces: list = field(default_factory=list)
    materials: dict = field(default_factory=dict)

    @property
    def dim(self) -> int:
        """Space dimension (2 or 3), from the bodies."""
        return self.bodies[0].dim


@dataclass
class System:
    """Array form of a scene (built by :func:`compile_scene`).

    Attributes
    ----------
    dim : int
        Space dimension ``d`` (2 or 3).
    ndof : int
        Velocity unknowns per body (3 in 2D: ``vx, vy, omega``; 6 in 3D).
    n_bodies : int
    pos : ndarray (n, d)
    angle : ndarray (n,)
        Orientation (2D only; zeros in 3D).
    vel : ndarray (n, ndof)
    mass, inertia : ndarray (n,)
    inv_mass_diag : ndarray (n * ndof,)
        Diagonal of ``M^{-1}`` (rotational entries 0 for ``fixed_rotation`` bodies).
        For 3D polyhedra the rotational entries are only ``3 / tr(I)``: their
        exact block ``R I_body⁻¹ Rᵀ`` is :meth:`Simulation.inverse_mass
        <socp_cd.dynamics.stepper.Simulation.inverse_mass>`.
    radius : ndarray (n,)
        Disk/sphere radius, or polygon bounding radius.
    is_poly : ndarray (n,) bool
    poly_local : ndarray (n_poly, vmax, 2), poly_nv : ndarray (n_poly,)
        Body-frame vertices of the polygon bodies (padded), and their counts.
    poly_of_body : ndarray (n,)
        Row in ``poly_local`` (or -1).
    mu_body, e_body : ndarray (n,)
        Material values (NaN when unset).
    halfspaces : (point (k, d), normal (k, d), mu (k,), e (k,), obstacle index (k,))
    fixed_round : (center (k, d), radius (k,), mu, e, obstacle index)
    fixed_poly : FixedPolygons
    orientation : ndarray (n, 4) or None
        Unit quaternions ``(w, x, y, z)`` of 3D bodies (None in 2D).
    inertia_body : ndarray (n, 3, 3) or None
        Body-frame inertia tensors of 3D bodies (spheres: ``I·1``).
    is_hull : ndarray (n,) bool
        3D convex polyhedra (:class:`~socp_cd.dynamics.bodies.ConvexPolyhedron`).
    hulls : HullTable
        Body-frame polyhedra of the hull bodies; ``hull_of_body`` (n,) their rows (or -1).
    fixed_hull : FixedHulls
    mu_obstacle, e_obstacle : ndarray (n_obstacles,)
        Obstacle material values (NaN when unset).
    mat_body, mat_obstacle : ndarray int
        Material name ids (-1: none); ``mat_mu``, ``mat_e`` (K, K) the pair
        table (NaN where the pair or value is not listed); ``material_names``.
    """

    dim: int
    ndof: int
    n_bodies: int
    n_obstacles: int
    pos: np.ndarray
    angle: np.ndarray
    vel: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    inv_mass_diag: np.ndarray
    radius: np.ndarray
    is_poly: np.ndarray
    poly_local: np.ndarray
    poly_nv: np.ndarray
    poly_of_body: np.ndarray
    mu_body: np.ndarray
    e_body: np.ndarray
    halfspaces: tuple
    fixed_round: tuple
    fixed_poly: tuple
    gravity: np.ndarray
    mu_default: float
    e_default: float
    springs: list
    forces: list
    orientation: Optional[np.ndarray] = None
    inertia_body: Optional[np.ndarray] = None
    is_hull: Optional[np.ndarray] = None
    hulls: Optional[HullTable] = None
    hull_of_body: Optional[np.ndarray] = None
    fixed_hull: Optional[FixedHulls] = None
    mu_obstacle: Optional[np.ndarray] = None
    e_obstacle: Optional[np.ndarray] = None
    mat_body: Optional[np.ndarray] = None
    mat_obstacle: Optional[np.ndarray] = None
    mat_mu: Optional[np.ndarray] = None
    mat_e: Optional[np.ndarray] = None
    material_names: tuple = ()

    @property
    def is_round(self) -> np.ndarray:
        """Disks and spheres, (n,) bool."""
        return ~(self.is_poly | self.is_hull)

    @property
    def has_hulls(self) -> bool:
        return bool(self.is_hull.any() or self.fixed_hull.rot.shape[0])

    def rotations(self, orientation=None) -> np.ndarray:
        """Rotation matrices of the 3D bodies, (n, 3, 3)."""
        return quat_to_matrix(self.orientation if orientation is None else orientation)

    @property
    def has_polygons(self) -> bool:
        return bool(self.is_poly.any() or self.fixed_poly[1].size)

    def poly_world(self, pos=None, angle=None) -> np.ndarray:
        """World vertices of the polygon bodies, shape ``(n_poly, vmax, 2)`` (padding repeated)."""
        pos = self.pos if pos is None else pos
        angle = self.angle if angle is None else angle
        idx = np.flatnonzero(self.is_poly)
        if idx.size == 0:
            return np.zeros((0, 1, 2))
        c, s = np.cos(angle[idx]), np.sin(angle[idx])
        L = self.poly_local
        x = c[:, None] * L[..., 0] - s[:, None] * L[..., 1] + pos[idx, 0, None]
        y = s[:, None] * L[..., 0] + c[:, None] * L[..., 1] + pos[idx, 1, None]
        return np.stack([x, y], axis=-1)

    def generalized_velocity(self) -> np.ndarray:
        """Stacked velocity vector ``v`` (length ``n_bodies * ndof``)."""
        return self.vel.reshape(-1).copy()


def _pad_polys(vlist) -> tuple[np.ndarray, np.ndarray]:
    nv = np.array([len(v) for v in vlist], dtype=np.int64)
    vmax = int(nv.max()) if nv.size else 1
    out = np.zeros((len(vlist), vmax, 2))
    for k, v in enumerate(vlist):
        out[k, :len(v)] = v
        out[k, len(v):] = v[-1]
    return out, nv


def _mat(x) -> float:
    return np.nan if x is None else float(x)


def compile_scene(scene: Scene) -> System:
    """Validate a :class:`Scene` and build its :class:`System`.

    Raises
    ------
    InvalidProblemError
        Empty scene, mixed dimensions, unknown object types, bad load indices.
    """
    if not isinstance(scene, Scene):
        raise InvalidProblemError("scene", f"expected a Scene, got {type(scene).__name__}")
    bodies = list(scene.bodies)
    if not bodies:
        raise InvalidProblemError("scene.bodies", "a scene needs at least one body")
    for k, b in enumerate(bodies):
        if not isinstance(b, BODY_TYPES):
            raise InvalidProblemError(f"scene.bodies[{k}]", f"unsupported body type {type(b).__name__}")
    d = bodies[0].dim
    for k, b in enumerate(bodies):
        if b.dim != d:
            raise InvalidProblemError(f"scene.bodies[{k}]", f"is {b.dim}D in a {d}D scene")
    for k, o in enumerate(scene.obstacles):
        if not isinstance(o, OBSTACLE_TYPES):
            raise InvalidProblemError(f"scene.obstacles[{k}]", f"unsupported obstacle type {type(o).__name__}")
        if o.dim != d:
            raise InvalidProblemError(f"scene.obstacles[{k}]", f"is {o.dim}D in a {d}D scene")
    n = len(bodies)
    ndof = 3 if d == 2 else 6
    g = np.zeros(d)
    g[-1] = -9.81
    if scene.gravity is not None:
        g = np.asarray(scene.gravity, dtype=np.float64).reshape(-1)
        if g.shape != (d,) or not np.all(np.isfinite(g)):
            raise InvalidProblemError("scene.gravity", f"must be {d} finite numbers")
    for name, val, lo, hi in (("scene.mu", scene.mu, 0, np.inf), ("scene.restitution", scene.restitution, 0, 1)):
        if not (np.isfinite(val) and lo <= val <= hi):
            raise InvalidProblemError(name, f"must lie in [{lo}, {hi}], got {val!r}")
    pos = np.array([b.position for b in bodies], dtype=np.float64)
    angle = np.zeros(n) if d == 3 else np.array([float(b.angle) for b in bodies])
    vel = np.zeros((n, ndof))
    vel[:, :d] = [b.velocity for b in bodies]
    if d == 2:
        vel[:, 2] = [b.omega for b in bodies]
    else:
        vel[:, 3:] = [b.omega for b in bodies]
    mass = np.array([b.mass for b in bodies])
    is_hull = np.array([b.kind == "hull" for b in bodies])
    orientation = inertia_body = None
    if d == 3:
        orientation = np.array([b.orientation for b in bodies], dtype=np.float64)
        inertia_body = np.array([b.inertia if b.kind == "hull" else b.inertia * np.eye(3) for b in bodies])
        inertia = np.trace(inertia_body, axis1=1, axis2=2) / 3.0
    else:
        inertia = np.array([b.inertia for b in bodies])
    invm = np.zeros((n, ndof))
    invm[:, :d] = (1.0 / mass)[:, None]
    lock = np.array([b.fixed_rotation for b in bodies])
    invm[:, d:] = np.where(lock, 0.0, 1.0 / inertia)[:, None]
    is_poly = np.array([b.kind == "polygon" for b in bodies])
    plist = [b.vertices for b in bodies if b.kind == "polygon"]
    poly_local, poly_nv = _pad_polys(plist) if plist else (np.zeros((0, 1, 2)), np.zeros(0, np.int64))
    poly_of_body = np.full(n, -1, dtype=np.int64)
    poly_of_body[is_poly] = np.arange(is_poly.sum())
    hs = [(k, o) for k, o in enumerate(scene.obstacles) if o.kind == "halfspace"]
    fr = [(k, o) for k, o in enumerate(scene.obstacles) if o.kind == "disk"]
    fp = [(k, o) for k, o in enumerate(scene.obstacles) if o.kind == "polygon"]
    fh = [(k, o) for k, o in enumerate(scene.obstacles) if o.kind == "hull"]
    hull_of_body = np.full(n, -1, dtype=np.int64)
    hull_of_body[is_hull] = np.arange(is_hull.sum())
    hulls = pack_hulls([b.hull for b in bodies if b.kind == "hull"])
    fixed_hull = FixedHulls(pack_hulls([o.hull for _, o in fh]),
                            quat_to_matrix(np.array([o.orientation for _, o in fh]).reshape(-1, 4)),
                            np.array([o.position for _, o in fh]).reshape(-1, 3),
                            np.array([_mat(o.mu) for _, o in fh]), np.array([_mat(o.restitution) for _, o in fh]),
                            np.array([k for k, _ in fh], dtype=np.int64))
    halfspaces = HalfSpaces(np.array([o.point for _, o in hs]).reshape(-1, d),
                  np.array([o.normal for _, o in hs]).reshape(-1, d),
                  np.array([_mat(o.mu) for _, o in hs]), np.array([_mat(o.restitution) for _, o in hs]),
                  np.array([k for k, _ in hs], dtype=np.int64))
    fixed_round = FixedRound(np.array([o.position for _, o in fr]).reshape(-1, d),
                   np.array([o.radius for _, o in fr]),
                   np.array([_mat(o.mu) for _, o in fr]), np.array([_mat(o.restitution) for _, o in fr]),
                   np.array([k for k, _ in fr], dtype=np.int64))
    fpv, fpn = _pad_polys([o.vertices for _, o in fp]) if fp else (np.zeros((0, 1, 2)), np.zeros(0, np.int64))
    fixed_poly = FixedPolygons(fpv, fpn, np.array([o.position for _, o in fp]).reshape(-1, 2),
                  np.array([o.bounding_radius for _, o in fp]),
                  np.array([_mat(o.mu) for _, o in fp]), np.array([_mat(o.restitution) for _, o in fp]),
                  np.array([k for k, _ in fp], dtype=np.int64))
    for k, s in enumerate(scene.springs):
        if not isinstance(s, Spring) or not (0 <= s.body < n):
            raise InvalidProblemError(f"scene.springs[{k}]", "must be a Spring on an existing body")
    for k, f in enumerate(scene.forces):
        if not isinstance(f, Force) or not (0 <= f.body < n):
            raise InvalidProblemError(f"scene.forces[{k}]", "must be a Force on an existing body")
    obst = list(scene.obstacles)
    mats = _material_table(scene, bodies, obst)
    return System(dim=d, ndof=ndof, n_bodies=n, n_obstacles=len(scene.obstacles), pos=pos,
                  angle=angle, vel=vel, mass=mass, inertia=inertia, inv_mass_diag=invm.reshape(-1),
                  radius=np.array([b.bounding_radius for b in bodies]), is_poly=is_poly,
                  poly_local=poly_local, poly_nv=poly_nv, poly_of_body=poly_of_body,
                  mu_body=np.array([_mat(b.mu) for b in bodies]),
                  e_body=np.array([_mat(b.restitution) for b in bodies]),
                  halfspaces=halfspaces, fixed_round=fixed_round, fixed_poly=fixed_poly,
                  gravity=g, mu_default=float(scene.mu), e_default=float(scene.restitution),
                  springs=list(scene.springs), forces=list(scene.forces),
                  orientation=orientation, inertia_body=inertia_body, is_hull=is_hull, hulls=hulls,
                  hull_of_body=hull_of_body, fixed_hull=fixed_hull,
                  mu_obstacle=np.array([_mat(o.mu) for o in obst]),
                  e_obstacle=np.array([_mat(o.restitution) for o in obst]), **mats)


def _material_table(scene, bodies, obstacles) -> dict:
    """Material ids of bodies/obstacles and the (K, K) pair tables (see :class:`Scene`)."""
    if not isinstance(scene.materials, dict):
        raise InvalidProblemError("scene.materials", "must be a dict {(name_a, name_b): {'mu': .., 'restitution': ..}}")
    names = sorted({x.material for x in list(bodies) + list(obstacles) if getattr(x, "material", None)}
                   | {nm for pair in scene.materials for nm in (pair if isinstance(pair, tuple) else ())})
    ids = {nm: k for k, nm in enumerate(names)}
    K = len(names)
    mu = np.full((K, K), np.nan)
    e = np.full((K, K), np.nan)
    for pair, vals in scene.materials.items():
        where = f"scene.materials[{pair!r}]"
        if not (isinstance(pair, tuple) and len(pair) == 2 and all(isinstance(x, str) for x in pair)):
            raise InvalidProblemError(where, "keys must be (name_a, name_b) pairs of strings")
        if not isinstance(vals, dict) or set(vals) - {"mu", "restitution"}:
            raise InvalidProblemError(where, "value must be a dict with keys among 'mu', 'restitution'")
        a, b = ids[pair[0]], ids[pair[1]]
        if "mu" in vals:
            v = float(vals["mu"])
            if not (np.isfinite(v) and v >= 0):
                raise InvalidProblemError(f"{where}['mu']", f"must be >= 0, got {vals['mu']!r}")
            mu[a, b] = mu[b, a] = v
        if "restitution" in vals:
            v = float(vals["restitution"])
            if not (0 <= v <= 1):
                raise InvalidProblemError(f"{where}['restitution']", f"must lie in [0, 1], got {vals['restitution']!r}")
            e[a, b] = e[b, a] = v
    mid = lambda x: ids.get(getattr(x, "material", None), -1)  # noqa: E731
    return {"mat_body": np.array([mid(b) for b in bodies], dtype=np.int64),
            "mat_obstacle": np.array([mid(o) for o in obstacles], dtype=np.int64),
            "mat_mu": mu, "mat_e": e, "material_names": tuple(names)}


__all__ = ["Scene", "System", "compile_scene", "HalfSpaces", "FixedRound", "FixedPolygons", "FixedHulls"]
